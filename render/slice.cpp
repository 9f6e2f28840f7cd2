#include "render/slice.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>

#include "base/check.h"
#include "base/parallel.h"

namespace hfrt::render {

namespace {

/// Below this many pixels a side, blocks are evaluated point by point (one batch).
constexpr int kLeafSize = 8;

struct SliceThread {
  EvalCounters counters;
  uint64_t by_interval = 0, inside = 0;
  std::vector<float> xs, ys, zs, fs;
  bool has_nan = false;
  Vec3 nan_point;
};

class SliceRenderer {
 public:
  SliceRenderer(const Field& field, const SliceOptions& options, SliceResult* out)
      : field_(field), opt_(options), out_(out) {
    dx_ = (options.x1 - options.x0) / float(options.width);
    dy_ = (options.y1 - options.y0) / float(options.height);
    intervals_ = options.use_interval && field.has_interval();
  }

  float px(int i) const { return opt_.x0 + (float(i) + 0.5f) * dx_; }
  float py(int j) const { return opt_.y1 - (float(j) + 0.5f) * dy_; }

  void block(int i0, int j0, int i1, int j1, SliceThread& st) {
    if (intervals_) {
      // The box of the pixel centres of the block (padded for rounding).
      Box box{{std::min(px(i0), px(i1 - 1)), std::min(py(j0), py(j1 - 1)), opt_.z},
              {std::max(px(i0), px(i1 - 1)), std::max(py(j0), py(j1 - 1)), opt_.z}};
      for (int k = 0; k < 3; ++k) {
        float pad = 4e-7f * std::max(std::abs(box.lo[k]), std::abs(box.hi[k])) + 1e-30f;
        box.lo[k] -= pad, box.hi[k] += pad;
      }
      bool maybe_nan = false;
      Interval iv = field_.eval_interval(box, &maybe_nan);
      st.counters.interval_calls++;
      bool outside = iv.hi < 0;
      bool inside = !std::isnan(iv.lo) && iv.lo >= 0 && !maybe_nan;
      if (outside || inside) {
        fill(i0, j0, i1, j1, inside ? 1 : 0);
        uint64_t n = uint64_t(i1 - i0) * uint64_t(j1 - j0);
        st.by_interval += n;
        if (inside) st.inside += n;
        return;
      }
      if (i1 - i0 > kLeafSize || j1 - j0 > kLeafSize) {
        int im = (i0 + i1) / 2, jm = (j0 + j1) / 2;
        if (i1 - i0 <= kLeafSize) im = i1;
        if (j1 - j0 <= kLeafSize) jm = j1;
        block(i0, j0, im, jm, st);
        if (im < i1) block(im, j0, i1, jm, st);
        if (jm < j1) block(i0, jm, im, j1, st);
        if (im < i1 && jm < j1) block(im, jm, i1, j1, st);
        return;
      }
    }
    // Point evaluation, one batch per block (row by row for large blocks).
    int w = i1 - i0;
    size_t n = size_t(w);
    st.xs.resize(n), st.ys.resize(n), st.zs.resize(n), st.fs.resize(n);
    for (int j = j0; j < j1; ++j) {
      for (int i = i0; i < i1; ++i) {
        st.xs[i - i0] = px(i);
        st.ys[i - i0] = py(j);
        st.zs[i - i0] = opt_.z;
      }
      field_.eval(n, st.xs.data(), st.ys.data(), st.zs.data(), st.fs.data());
      st.counters.eval_calls++;
      st.counters.eval_points += n;
      for (int i = i0; i < i1; ++i) {
        float f = st.fs[i - i0];
        bool in = f >= 0;
        if (std::isnan(f)) {
          st.counters.nan_samples++;
          if (!st.has_nan) st.has_nan = true, st.nan_point = {px(i), py(j), opt_.z};
        }
        out_->inside[size_t(j) * opt_.width + i] = in ? 1 : 0;
        st.inside += in;
      }
    }
  }

 private:
  void fill(int i0, int j0, int i1, int j1, uint8_t v) {
    for (int j = j0; j < j1; ++j) {
      std::fill_n(&out_->inside[size_t(j) * opt_.width + i0], i1 - i0, v);
    }
  }

  const Field& field_;
  const SliceOptions& opt_;
  SliceResult* out_;
  float dx_ = 0, dy_ = 0;
  bool intervals_ = false;
};

}  // namespace

SliceResult render_slice(const Field& field, const SliceOptions& options) {
  HFRT_CHECK(options.width > 0 && options.height > 0 && options.tile_size > 0);
  HFRT_CHECK(options.x1 > options.x0 && options.y1 > options.y0);
  auto start = std::chrono::steady_clock::now();
  SliceResult result;
  result.width = options.width;
  result.height = options.height;
  result.inside.assign(size_t(options.width) * options.height, 0);
  SliceRenderer renderer(field, options, &result);
  const int ts = options.tile_size;
  const int ntx = (options.width + ts - 1) / ts, nty = (options.height + ts - 1) / ts;
  const size_t ntiles = size_t(ntx) * nty;
  std::atomic<size_t> done{0};
  std::mutex nan_mutex;
  size_t nan_tile = std::numeric_limits<size_t>::max();
  Vec3 nan_point;
  par::ThreadLocal<SliceThread> states;
  int threads = options.threads > 0 ? options.threads : par::default_concurrency();
  par::with_threads(threads, [&] {
    par::parallel_for(ntiles, 1, [&](size_t begin, size_t end) {
      SliceThread& st = states.local();
      for (size_t ti = begin; ti != end; ++ti) {
        int tx = int(ti % ntx), ty = int(ti / ntx);
        int i0 = tx * ts, j0 = ty * ts;
        st.has_nan = false;
        renderer.block(i0, j0, std::min(options.width, i0 + ts), std::min(options.height, j0 + ts),
                       st);
        if (st.has_nan) {
          std::lock_guard<std::mutex> lock(nan_mutex);
          if (ti < nan_tile) nan_tile = ti, nan_point = st.nan_point;
        }
        size_t d = ++done;
        if (options.progress) options.progress(d, ntiles);
      }
    });
  });
  SliceStats& s = result.stats;
  s.threads = threads;
  states.for_each([&](SliceThread& st) {
    s.evals += st.counters;
    s.pixels_by_interval += st.by_interval;
    s.pixels_inside += st.inside;
  });
  if (nan_tile != std::numeric_limits<size_t>::max()) {
    s.has_nan_point = true;
    s.nan_point = nan_point;
    s.nan_explanation = field.explain_nan(nan_point);
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace hfrt::render
