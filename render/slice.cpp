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

/// The pruned path: blocks larger than this (a side) are subdivided serially, each once,
/// so that the long tapes near the root are evaluated a few times in all rather than once
/// per tile; the blocks of this size are the parallel tasks (64 of them at 1024 x 1024).
constexpr int kTaskSize = 128;

struct SliceThread {
  EvalCounters counters;
  uint64_t by_interval = 0, inside = 0;
  std::vector<float> xs, ys, zs, fs;
  bool has_nan = false;
  Vec3 nan_point;
  // The pruned path: this thread's evaluator, a tape per recursion level (reused), and the
  // tape statistics per level.
  std::unique_ptr<TapeEvaluator> tapes_eval;
  std::vector<std::unique_ptr<FieldTape>> tapes;
  std::vector<uint64_t> tape_count, tape_length;

  FieldTape& tape_at(int level) {
    while (tapes.size() <= size_t(level)) tapes.push_back(tapes_eval->new_tape());
    return *tapes[size_t(level)];
  }
  void count_tape(int level, size_t length) {
    if (tape_count.size() <= size_t(level)) {
      tape_count.resize(size_t(level) + 1, 0);
      tape_length.resize(size_t(level) + 1, 0);
    }
    tape_count[size_t(level)]++;
    tape_length[size_t(level)] += length;
  }
};

/// A block the pruned path hands to a worker: its pixels and a tape valid over it.
struct SliceTask {
  int i0, j0, i1, j1, level;
  std::shared_ptr<const FieldTape> tape;
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

  /// The box of the pixel centres of a block (padded for rounding).
  Box block_box(int i0, int j0, int i1, int j1) const {
    Box box{{std::min(px(i0), px(i1 - 1)), std::min(py(j0), py(j1 - 1)), opt_.z},
            {std::max(px(i0), px(i1 - 1)), std::max(py(j0), py(j1 - 1)), opt_.z}};
    for (int k = 0; k < 3; ++k) {
      float pad = 4e-7f * std::max(std::abs(box.lo[k]), std::abs(box.hi[k])) + 1e-30f;
      box.lo[k] -= pad, box.hi[k] += pad;
    }
    return box;
  }

  /// Fills the block when the interval decides it (all outside or all inside); true then.
  bool settle(const Interval& iv, bool maybe_nan, int i0, int j0, int i1, int j1, SliceThread& st) {
    st.counters.interval_calls++;
    bool outside = iv.hi < 0;
    bool inside = !std::isnan(iv.lo) && iv.lo >= 0 && !maybe_nan;
    if (!outside && !inside) return false;
    fill(i0, j0, i1, j1, inside ? 1 : 0);
    uint64_t n = uint64_t(i1 - i0) * uint64_t(j1 - j0);
    st.by_interval += n;
    if (inside) st.inside += n;
    return true;
  }

  /// Calls visit(i0, j0, i1, j1) for the quarters of a block (halves or itself when a side is
  /// at most kLeafSize), in the order of block().
  template <typename Visit>
  static void split(int i0, int j0, int i1, int j1, Visit visit) {
    int im = (i0 + i1) / 2, jm = (j0 + j1) / 2;
    if (i1 - i0 <= kLeafSize) im = i1;
    if (j1 - j0 <= kLeafSize) jm = j1;
    visit(i0, j0, im, jm);
    if (im < i1) visit(im, j0, i1, jm);
    if (jm < j1) visit(i0, jm, im, j1);
    if (im < i1 && jm < j1) visit(im, jm, i1, j1);
  }

  void block(int i0, int j0, int i1, int j1, SliceThread& st) {
    if (intervals_) {
      bool maybe_nan = false;
      Interval iv = field_.eval_interval(block_box(i0, j0, i1, j1), &maybe_nan);
      if (settle(iv, maybe_nan, i0, j0, i1, j1, st)) return;
      if (i1 - i0 > kLeafSize || j1 - j0 > kLeafSize) {
        split(i0, j0, i1, j1, [&](int a, int b, int c, int d) { block(a, b, c, d, st); });
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
      store(i0, j, i1, j + 1, st);
    }
  }

  /// The pruned path's serial top: blocks above kTaskSize are decided or split here, with a
  /// tape pruned for each; the rest become tasks.
  void plan(int i0, int j0, int i1, int j1, int level, std::shared_ptr<const FieldTape> tape,
            SliceThread& st, std::vector<SliceTask>* tasks) {
    if (i1 - i0 <= kTaskSize && j1 - j0 <= kTaskSize) {
      tasks->push_back({i0, j0, i1, j1, level, std::move(tape)});
      return;
    }
    bool maybe_nan = false;
    Interval iv = st.tapes_eval->eval_interval(*tape, block_box(i0, j0, i1, j1), &maybe_nan);
    if (settle(iv, maybe_nan, i0, j0, i1, j1, st)) return;
    std::shared_ptr<const FieldTape> next = tape;
    std::shared_ptr<FieldTape> child = st.tapes_eval->new_tape();
    if (st.tapes_eval->prune_last(*tape, child.get())) next = std::move(child);
    st.count_tape(level, next->length());
    split(i0, j0, i1, j1,
          [&](int a, int b, int c, int d) { plan(a, b, c, d, level + 1, next, st, tasks); });
  }

  /// block() on tapes: `tape` is valid over the block (pruned for it or a block around it).
  void pruned_block(int i0, int j0, int i1, int j1, int level, const FieldTape& tape,
                    SliceThread& st) {
    TapeEvaluator& ev = *st.tapes_eval;
    bool maybe_nan = false;
    Interval iv = ev.eval_interval(tape, block_box(i0, j0, i1, j1), &maybe_nan);
    if (settle(iv, maybe_nan, i0, j0, i1, j1, st)) return;
    if (i1 - i0 > kLeafSize || j1 - j0 > kLeafSize) {
      FieldTape& child = st.tape_at(level);
      const FieldTape& next = ev.prune_last(tape, &child) ? child : tape;
      st.count_tape(level, next.length());
      split(i0, j0, i1, j1,
            [&](int a, int b, int c, int d) { pruned_block(a, b, c, d, level + 1, next, st); });
      return;
    }
    // A leaf: every pixel in one batch, on the tape of the block around it. (Pruning once
    // more for the leaf costs more than it saves: pruning and register allocation take tens
    // of cycles per instruction, the VM a few per instruction for all 64 pixels.)
    size_t n = size_t(i1 - i0) * size_t(j1 - j0);
    st.xs.resize(n), st.ys.resize(n), st.zs.resize(n), st.fs.resize(n);
    size_t k = 0;
    for (int j = j0; j < j1; ++j) {
      for (int i = i0; i < i1; ++i, ++k) {
        st.xs[k] = px(i);
        st.ys[k] = py(j);
        st.zs[k] = opt_.z;
      }
    }
    ev.eval(tape, n, st.xs.data(), st.ys.data(), st.zs.data(), st.fs.data());
    store(i0, j0, i1, j1, st);
  }

 private:
  /// Stores the values st.fs (row-major over the block) as inside bits, with the counters.
  void store(int i0, int j0, int i1, int j1, SliceThread& st) {
    st.counters.eval_calls++;
    st.counters.eval_points += uint64_t(i1 - i0) * uint64_t(j1 - j0);
    size_t k = 0;
    for (int j = j0; j < j1; ++j) {
      for (int i = i0; i < i1; ++i, ++k) {
        float f = st.fs[k];
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
  std::shared_ptr<const FieldTape> root;
  if (options.use_interval && options.prune && field.has_interval()) root = field.root_tape();
  SliceThread top;  // the pruned path's serial top levels
  if (root) {
    top.tapes_eval = field.tape_evaluator();
    HFRT_CHECK(top.tapes_eval != nullptr);
    std::vector<SliceTask> tasks;
    renderer.plan(0, 0, options.width, options.height, 0, root, top, &tasks);
    if (top.has_nan) nan_tile = 0, nan_point = top.nan_point;
    par::with_threads(threads, [&] {
      par::parallel_for(tasks.size(), 1, [&](size_t begin, size_t end) {
        SliceThread& st = states.local();
        if (!st.tapes_eval) st.tapes_eval = field.tape_evaluator();
        for (size_t ti = begin; ti != end; ++ti) {
          const SliceTask& t = tasks[ti];
          st.has_nan = false;
          renderer.pruned_block(t.i0, t.j0, t.i1, t.j1, t.level, *t.tape, st);
          if (st.has_nan) {
            std::lock_guard<std::mutex> lock(nan_mutex);
            if (ti + 1 < nan_tile) nan_tile = ti + 1, nan_point = st.nan_point;
          }
          size_t d = ++done;
          if (options.progress) options.progress(d, tasks.size());
        }
      });
    });
  } else {
    par::with_threads(threads, [&] {
      par::parallel_for(ntiles, 1, [&](size_t begin, size_t end) {
        SliceThread& st = states.local();
        for (size_t ti = begin; ti != end; ++ti) {
          int tx = int(ti % ntx), ty = int(ti / ntx);
          int i0 = tx * ts, j0 = ty * ts;
          st.has_nan = false;
          renderer.block(i0, j0, std::min(options.width, i0 + ts),
                         std::min(options.height, j0 + ts), st);
          if (st.has_nan) {
            std::lock_guard<std::mutex> lock(nan_mutex);
            if (ti < nan_tile) nan_tile = ti, nan_point = st.nan_point;
          }
          size_t d = ++done;
          if (options.progress) options.progress(d, ntiles);
        }
      });
    });
  }
  SliceStats& s = result.stats;
  s.threads = threads;
  auto merge = [&](SliceThread& st) {
    s.evals += st.counters;
    s.pixels_by_interval += st.by_interval;
    s.pixels_inside += st.inside;
    for (size_t l = 0; l < st.tape_count.size(); ++l) {
      if (s.tapes_by_level.size() <= l) {
        s.tapes_by_level.resize(l + 1, 0);
        s.tape_length_by_level.resize(l + 1, 0);
      }
      s.tapes_by_level[l] += st.tape_count[l];
      s.tape_length_by_level[l] += st.tape_length[l];
    }
  };
  merge(top);
  states.for_each(merge);
  s.pruned = root != nullptr;
  if (root) s.root_tape_length = root->length();
  if (nan_tile != std::numeric_limits<size_t>::max()) {
    s.has_nan_point = true;
    s.nan_point = nan_point;
    s.nan_explanation = field.explain_nan(nan_point);
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace hfrt::render
