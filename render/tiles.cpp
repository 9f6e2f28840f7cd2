#include "render/tiles.h"

#include <algorithm>

#include "base/check.h"
#include "base/parallel.h"

namespace hfrt::render {

size_t tile_count(int width, int height, int tile_size) {
  const int ntx = (width + tile_size - 1) / tile_size, nty = (height + tile_size - 1) / tile_size;
  return size_t(ntx) * size_t(nty);
}

Tile tile_at(int width, int height, int tile_size, size_t index) {
  const int ts = tile_size;
  const int ntx = (width + ts - 1) / ts;
  Tile t;
  t.index = index;
  t.x0 = int(index % size_t(ntx)) * ts;
  t.y0 = int(index / size_t(ntx)) * ts;
  t.x1 = std::min(width, t.x0 + ts);
  t.y1 = std::min(height, t.y0 + ts);
  return t;
}

void for_each_tile_pixel(int width, int height, int tile_size, const std::vector<size_t>* tiles,
                         const std::function<void(size_t pixel)>& fn) {
  const size_t n = tiles ? tiles->size() : tile_count(width, height, tile_size);
  for (size_t k = 0; k < n; ++k) {
    const Tile t = tile_at(width, height, tile_size, tiles ? (*tiles)[k] : k);
    for (int y = t.y0; y < t.y1; ++y)
      for (int x = t.x0; x < t.x1; ++x) fn(size_t(y) * size_t(width) + size_t(x));
  }
}

TileLoop for_each_tile(int width, int height, int tile_size, int threads,
                       const std::function<void(size_t done, size_t total)>& progress,
                       const std::atomic<bool>* cancel, const std::function<void(const Tile&)>& fn,
                       const std::vector<size_t>* only) {
  const size_t all = tile_count(width, height, tile_size);
  TileLoop loop;
  loop.tiles = only ? only->size() : all;
  loop.threads = threads > 0 ? threads : par::default_concurrency();
  std::atomic<size_t> done{0};
  std::atomic<bool> cancelled{false};
  par::with_threads(loop.threads, [&] {
    par::parallel_for(loop.tiles, 1, [&](size_t begin, size_t end) {
      for (size_t k = begin; k != end; ++k) {
        if (cancel && cancel->load(std::memory_order_relaxed)) {
          cancelled.store(true, std::memory_order_relaxed);
          return;
        }
        const size_t ti = only ? (*only)[k] : k;
        HFRT_CHECK(ti < all);
        fn(tile_at(width, height, tile_size, ti));
        size_t d = ++done;
        if (progress) progress(d, loop.tiles);
      }
    });
  });
  loop.cancelled = cancelled.load();
  return loop;
}

}  // namespace hfrt::render
