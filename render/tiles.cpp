#include "render/tiles.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>

namespace hfrt::render {

TileLoop for_each_tile(int width, int height, int tile_size, int threads,
                       const std::function<void(size_t done, size_t total)>& progress,
                       const std::atomic<bool>* cancel,
                       const std::function<void(const Tile&)>& fn) {
  const int ts = tile_size;
  const int ntx = (width + ts - 1) / ts, nty = (height + ts - 1) / ts;
  TileLoop loop;
  loop.tiles = size_t(ntx) * nty;
  loop.threads = threads > 0 ? threads : tbb::info::default_concurrency();
  std::atomic<size_t> done{0};
  std::atomic<bool> cancelled{false};
  // TBB caps workers at the core count unless told otherwise; --threads N means N.
  tbb::global_control allow(tbb::global_control::max_allowed_parallelism,
                            std::max<size_t>(loop.threads, tbb::info::default_concurrency()));
  tbb::task_arena arena(loop.threads);
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, loop.tiles, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t ti = r.begin(); ti != r.end(); ++ti) {
                          if (cancel && cancel->load(std::memory_order_relaxed)) {
                            cancelled.store(true, std::memory_order_relaxed);
                            return;
                          }
                          Tile t;
                          t.index = ti;
                          t.x0 = int(ti % ntx) * ts;
                          t.y0 = int(ti / ntx) * ts;
                          t.x1 = std::min(width, t.x0 + ts);
                          t.y1 = std::min(height, t.y0 + ts);
                          fn(t);
                          size_t d = ++done;
                          if (progress) progress(d, loop.tiles);
                        }
                      });
  });
  loop.cancelled = cancelled.load();
  return loop;
}

}  // namespace hfrt::render
