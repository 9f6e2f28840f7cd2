#pragma once
// The tile loop of the renderers (render/renderer.h, render/tracer.h): square tiles of an
// image, each one unit of work for TBB on a task arena of the asked number of threads, with
// progress after each tile and cancellation between tiles. The tile layout depends only on the
// image and tile size, never on the thread count, which is what keeps both renderers'
// images bit-identical for any number of threads.

#include <atomic>
#include <cstddef>
#include <functional>
#include <vector>

namespace hfrt::render {

/// One tile: its index in row-major tile order and its pixels [x0, x1) x [y0, y1).
struct Tile {
  size_t index = 0;
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

/// How a tile loop ran.
struct TileLoop {
  size_t tiles = 0;
  int threads = 0;         ///< workers used (the request, or all cores for 0)
  bool cancelled = false;  ///< `cancel` was seen set: some tiles were not run
};

/// Runs `fn` once per tile of a width x height image cut into tile_size squares, concurrently
/// on `threads` workers (0: all cores; more than the cores is honoured). `fn` is called from
/// worker threads and must be thread-safe; a worker's scratch state belongs in the caller's
/// thread-specific storage. `progress` (may be empty) gets (tiles done, tiles) after each
/// tile; `cancel` (may be null) is read before each tile.
/// `only` (may be null) restricts the loop to those tile indices (row-major, each < the tile
/// count; a render split across processes gives each its share): progress then counts them.
TileLoop for_each_tile(int width, int height, int tile_size, int threads,
                       const std::function<void(size_t done, size_t total)>& progress,
                       const std::atomic<bool>* cancel, const std::function<void(const Tile&)>& fn,
                       const std::vector<size_t>* only = nullptr);

/// The number of tiles of a width x height image cut into tile_size squares.
size_t tile_count(int width, int height, int tile_size);
/// Tile `index` of that layout.
Tile tile_at(int width, int height, int tile_size, size_t index);
/// Calls fn(pixel index y * width + x) for every pixel of `tiles` (all tiles when null), tile by
/// tile in the order given, row by row inside a tile (the order a tile farm packs pixels in).
void for_each_tile_pixel(int width, int height, int tile_size, const std::vector<size_t>* tiles,
                         const std::function<void(size_t pixel)>& fn);

}  // namespace hfrt::render
