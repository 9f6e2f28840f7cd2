#include "render/tape_regions.h"

#include <algorithm>
#include <cmath>

#include "render/depth_cull.h"

namespace hfrt::render {

TapeCells::TapeCells(const Field& field, const Box& bounds) : root_(field.root_tape()) {
  if (!root_ || root_->length() < TapeRegions::kMinRootLength || bounds.empty()) {
    root_.reset();
    return;
  }
  // The finest cells' size is side / 2^kLevels; the grid is half of it (a power of two
  // times grid_ for every level, so that boundaries are exact integer multiples).
  const float side = bounds.max_extent();
  if (!(side > 0) || !std::isfinite(side)) {
    root_.reset();
    return;
  }
  const float g = side * (1.0f / float(2 << kLevels));
  grid_ = {g, g, g};
  origin_ = bounds.center() - Vec3{0.5f * side, 0.5f * side, 0.5f * side};
  for (int level = 1; level <= kLevels; ++level) {
    const size_t n = size_t(1) << level;
    cells_[level - 1] = std::make_unique<std::atomic<const FieldTape*>[]>(n * n * n);
  }
}

Box TapeCells::cell_box(int level, const int idx[3]) const {
  // Cell i of `level` spans [i s, (i + 1) s] with s = 2^(kLevels + 1 - level) grid_; grown by
  // s / 2: [(2i - 1) u, (2i + 3) u] grid_ with u = s / (2 grid_).
  const int u = 1 << (kLevels - level);
  Box b;
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = origin_[a] + float((2 * idx[a] - 1) * u) * grid_[a];
    b.hi[a] = origin_[a] + float((2 * idx[a] + 3) * u) * grid_[a];
  }
  return b;
}

const FieldTape& TapeCells::tape_for(const Box& box, TapeEvaluator& ev) {
  // The deepest level whose cell under the box's centre holds the box.
  int level = kLevels, idx[3] = {0, 0, 0};
  for (; level >= 1; --level) {
    const int n = 1 << level;
    for (int a = 0; a < 3; ++a) {
      const float s = float(2 << (kLevels - level)) * grid_[a];
      const float c = 0.5f * (box.lo[a] + box.hi[a]) - origin_[a];
      const float f = std::floor(c / s);
      idx[a] = f < 0 ? 0 : f >= float(n - 1) ? n - 1 : int(f);
    }
    if (cell_box(level, idx).contains(box)) break;
  }
  const FieldTape* tape = root_.get();
  // Down from level 1 to it through the cell's ancestors (each holding it), making the missing.
  for (int l = 1; l <= level; ++l) {
    const int n = 1 << l, shift = level - l;
    const int at[3] = {idx[0] >> shift, idx[1] >> shift, idx[2] >> shift};
    std::atomic<const FieldTape*>& slot = cells_[l - 1][(size_t(at[2]) * n + at[1]) * n + at[0]];
    const FieldTape* t = slot.load(std::memory_order_acquire);
    if (!t) {
      // Made without a lock (a thread waiting for another's cell idled: c1_gear's frame took
      // longer with the cells than without under one mutex); when two threads make the same
      // cell at once, the first to publish wins and the other's copy is dropped.
      bool maybe_nan = false;
      ev.eval_interval(*tape, cell_box(l, at), &maybe_nan);
      std::unique_ptr<FieldTape> child = ev.new_tape();
      const FieldTape* made = ev.prune_last(*tape, child.get()) ? child.get() : tape;
      const FieldTape* expected = nullptr;
      if (slot.compare_exchange_strong(expected, made, std::memory_order_acq_rel,
                                       std::memory_order_acquire)) {
        t = made;
        if (made == child.get()) {
          ++cells_made_;
          cell_length_sum_ += made->length();
          std::lock_guard<std::mutex> lock(mutex_);
          owned_.push_back(std::move(child));
        }
      } else {
        t = expected;
      }
    }
    tape = t;
  }
  return *tape;
}

TapeRegions::TapeRegions(const Field& base, TapeCells* cells)
    : FieldView(base), root_(base.root_tape()), cells_(cells) {
  if (root_ && root_->length() >= kMinRootLength) ev_ = base.tape_evaluator();
  if (!ev_) {
    root_.reset();
    cells_ = nullptr;
    return;
  }
  if (cells_ && !cells_->enabled()) cells_ = nullptr;
  root_length_ = root_->length();
}

void TapeRegions::clear() {
  regions_.clear();
  last_child_.clear();
  first_root_ = last_root_ = -1;
  usable_count_ = 0;
  pool_used_ = 0;
  last_ = -1;
}

int TapeRegions::eval_prune(int parent, const Box& box, Interval* out, bool* maybe_nan) {
  const FieldTape& tape = parent >= 0 ? *regions_[size_t(parent)].tape
                          : cells_    ? cells_->tape_for(box, *ev_)
                                      : *root_;
  *out = ev_->eval_interval(tape, box, maybe_nan);
  // A box the interval decides (empty or inside) is not searched: nothing to prune for.
  const SlabTest verdict = slab_verdict(*out, *maybe_nan, false);
  if (verdict.empty || verdict.inside) return parent;
  if (pool_used_ == pool_.size()) pool_.push_back(ev_->new_tape());
  const FieldTape* child = pool_[pool_used_].get();
  if (ev_->prune_last(tape, pool_[pool_used_].get())) {
    ++pool_used_;
  } else if (parent < 0 && &tape != root_.get()) {
    // Nothing more decided than in the cell: the cell's tape is the box's.
    child = &tape;
  } else {
    return parent;
  }
  const size_t len = child->length();
  // A tape too long to beat the JIT still serves as the parent of its children's prunes;
  // region_of() walks through it and answers its nearest usable ancestor.
  const bool usable = double(len) <= kMaxLengthRatio * double(root_length_);
  const int self = int(regions_.size());
  Region r{box, child, len};
  r.usable_at = usable ? self : (parent >= 0 ? regions_[size_t(parent)].usable_at : -1);
  regions_.push_back(r);
  last_child_.push_back(-1);
  // Append to the parent's children (or the roots), keeping them in the culling's order.
  int& tail = parent >= 0 ? last_child_[size_t(parent)] : last_root_;
  if (tail >= 0) {
    regions_[size_t(tail)].next_sibling = self;
  } else if (parent >= 0) {
    regions_[size_t(parent)].first_child = self;
  } else {
    first_root_ = self;
  }
  tail = self;
  if (usable) {
    ++usable_count_;
    ++regions_made_;
    region_length_sum_ += len;
  }
  return self;
}

namespace {

/// r.contains(b) for a non-empty b (as every searched box is), with the six comparisons
/// combined without branches: region_of makes about three such tests per box, and their
/// outcomes are hard to predict (with Box::contains' short-circuit branches it was 5-6 % of
/// c1_gear's frame).
inline bool holds(const Box& r, const Box& b) {
  return (r.lo.x <= b.lo.x) & (r.lo.y <= b.lo.y) & (r.lo.z <= b.lo.z) & (b.hi.x <= r.hi.x) &
         (b.hi.y <= r.hi.y) & (b.hi.z <= r.hi.z);
}

}  // namespace

int TapeRegions::region_of(const Box& b) const {
  // Start from the last answer's node when it holds the box (consecutive boxes are usually
  // pieces of one ray or of neighbouring rays), else from the top.
  int node = -1;
  if (last_ >= 0 && holds(regions_[size_t(last_)].box, b)) node = last_;
  for (;;) {
    int c = node >= 0 ? regions_[size_t(node)].first_child : first_root_;
    while (c >= 0 && !holds(regions_[size_t(c)].box, b)) c = regions_[size_t(c)].next_sibling;
    if (c < 0) break;
    node = c;
  }
  last_ = node;
  return node >= 0 ? regions_[size_t(node)].usable_at : -1;
}

void TapeRegions::eval_intervals(size_t n, const Box* boxes, Interval* out, bool* maybe_nan) const {
  if (n == 0) return;
  if (usable_count_ == 0) {
    full_boxes_ += n;
    base().eval_intervals(n, boxes, out, maybe_nan);
    return;
  }
  // Bucket the boxes by region (bucket 0: none), counting sort.
  const size_t nb = regions_.size() + 1;
  which_.resize(n);
  start_.assign(nb + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    which_[i] = region_of(boxes[i]) + 1;
    ++start_[size_t(which_[i]) + 1];
  }
  for (size_t k = 0; k < nb; ++k) start_[k + 1] += start_[k];
  const size_t w0 = size_t(which_[0]);
  if (start_[w0 + 1] - start_[w0] == n) {
    // Every box in one bucket: no gathering.
    if (w0 == 0) {
      full_boxes_ += n;
      base().eval_intervals(n, boxes, out, maybe_nan);
    } else {
      pruned_boxes_ += n;
      ev_->eval_intervals(*regions_[w0 - 1].tape, n, boxes, out, maybe_nan);
    }
    return;
  }
  order_.resize(n);
  fill_.assign(start_.begin(), start_.end() - 1);
  for (size_t i = 0; i < n; ++i) order_[fill_[size_t(which_[i])]++] = uint32_t(i);
  boxes_.resize(n);
  ivs_.resize(n);
  if (nan_size_ < n) {
    nan_size_ = std::max(n, 2 * nan_size_);
    nan_.reset(new bool[nan_size_]);
  }
  for (size_t i = 0; i < n; ++i) boxes_[i] = boxes[order_[i]];
  for (size_t k = 0; k < nb; ++k) {
    const size_t a = start_[k], m = start_[k + 1] - a;
    if (m == 0) continue;
    if (k == 0) {
      full_boxes_ += m;
      base().eval_intervals(m, &boxes_[a], &ivs_[a], &nan_[a]);
    } else {
      pruned_boxes_ += m;
      ev_->eval_intervals(*regions_[k - 1].tape, m, &boxes_[a], &ivs_[a], &nan_[a]);
    }
  }
  for (size_t i = 0; i < n; ++i) {
    out[order_[i]] = ivs_[i];
    maybe_nan[order_[i]] = nan_[i];
  }
}

}  // namespace hfrt::render
