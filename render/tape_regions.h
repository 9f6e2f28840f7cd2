#pragma once
// Tapes pruned per region of space for the 3-D renderer (issue 25: "the interval root search of
// every model" on short tapes). A tile's culling bisects its frustum in depth with intervals;
// each slab box that the interval does not decide is also where the interval's min/max choices
// hold, so the tape pruned for it (Field::tape_evaluator, docs/tape_vm.md) is exact for every
// point and box inside it. TapeRegions keeps those (box, tape) pairs for the tile being
// rendered and is itself a Field: an interval over a box that lies inside a registered region
// is evaluated on that region's tape by the tape VM (the gear's 16-pixel slabs keep ~20-40 of
// its 231 instructions), any other box by the field underneath (the interval JIT).

#include <cstdint>
#include <memory>
#include <vector>

#include "render/field.h"

namespace hfrt::render {

/// The regions and tapes of one tile, for one worker thread (not thread-safe: a thread's
/// RootSearcher evaluates through it). Without a root tape (Field::root_tape() null) or with
/// a short one it is a plain view of the field underneath.
class TapeRegions final : public FieldView {
 public:
  /// A region is registered only when its tape is at most this fraction of the root tape's
  /// length: the VM costs ~2.5x the interval JIT per instruction and box (bench/README.md,
  /// hfrt_bench_interval c1_gear: 1.07 ns against ~0.42 ns), so a longer tape is slower than
  /// the JIT's full program.
  static constexpr double kMaxLengthRatio = 0.35;

  /// Programs shorter than this are not pruned: what pruning can save is less than the VM's
  /// costs (one-box passes in the culling, sorting boxes by region). 512x512 renders, 2
  /// threads: s2_csg (20 instructions) 0.059-0.060 s whole program, 0.074-0.078 s pruned
  /// (slab tapes of 4.9); c2_colonnade (206) 0.133-0.145 -> 0.114-0.115 s; c1_gear (231)
  /// 0.098-0.137 -> 0.084-0.098 s without shadows.
  static constexpr size_t kMinRootLength = 64;

  explicit TapeRegions(const Field& base);

  /// Whether the field has tapes (pruning is possible at all).
  bool enabled() const { return root_ != nullptr; }
  /// Forgets the regions (a new tile); the tapes' buffers are kept for reuse.
  void clear();
  /// F's interval over `box` on the tape of region `parent` (-1: the root tape; `box` must lie
  /// inside the parent's box), by the tape VM. When the interval decides nothing about F's
  /// sign (hi >= 0 > lo or NaN possible) the tape is pruned for `box` and, when it got short
  /// enough, registered: the region's index is returned for the children of `box`; otherwise
  /// `parent` (whose tape stays valid in `box`).
  int eval_prune(int parent, const Box& box, Interval* out, bool* maybe_nan);

  /// Statistics: regions registered, and their tapes' total length.
  uint64_t regions_made() const { return regions_made_; }
  uint64_t region_length_sum() const { return region_length_sum_; }
  /// Boxes evaluated on a region's tape / by the field underneath, by eval_intervals.
  uint64_t pruned_boxes() const { return pruned_boxes_; }
  uint64_t full_boxes() const { return full_boxes_; }

  /// Each box inside a registered region is evaluated on the tape of region_of(box) (in one
  /// batch per region); the others by the field underneath. (Every other call goes to
  /// the field underneath: FieldView.)
  void eval_intervals(size_t n, const Box* boxes, Interval* out, bool* maybe_nan) const override;

  /// The region whose tape eval_intervals uses for `b` (an index as eval_prune returns), or
  /// -1: of the usable regions whose box contains `b`, the deepest reached by walking down the
  /// tree of prunes from the top (or from the last answer's node, which usually contains the
  /// next box too) through children that contain `b`. A child's tape is its parent's pruned
  /// further, so the deepest region of a path has the shortest tape of it; boxes of
  /// neighbouring slabs overlap, so another branch might hold a shorter one, which is not
  /// searched (a scan of every region cost 6 % of c1_gear's frame).
  int region_of(const Box& b) const;

 private:
  struct Region {
    Box box;
    const FieldTape* tape;
    size_t length;
    /// The tree of prunes: a region's box lies inside its parent's, and its tape is pruned
    /// from the parent's. first_child / next_sibling link the children (-1: none).
    int first_child = -1, next_sibling = -1;
    /// This region when its tape is short enough to use, else the nearest such ancestor (-1:
    /// none).
    int usable_at = -1;
  };

  std::shared_ptr<const FieldTape> root_;
  std::unique_ptr<TapeEvaluator> ev_;
  size_t root_length_ = 0;
  std::vector<Region> regions_;
  int first_root_ = -1, last_root_ = -1;  ///< the regions pruned from the root tape, a list
  std::vector<int> last_child_;           ///< per region: its last child (appending), -1: none
  size_t usable_count_ = 0;               ///< regions short enough to use
  /// Tapes of this tile's regions, regions_[i].tape == pool_[i]; reused across tiles.
  std::vector<std::unique_ptr<FieldTape>> pool_;
  size_t pool_used_ = 0;
  // eval_intervals scratch: per region the indices of its boxes, gathered boxes and results.
  mutable std::vector<int> which_;
  mutable std::vector<uint32_t> order_;
  mutable std::vector<uint32_t> start_, fill_;
  mutable std::vector<Box> boxes_;
  mutable std::vector<Interval> ivs_;
  mutable std::unique_ptr<bool[]> nan_;
  mutable size_t nan_size_ = 0;
  mutable int last_ = -1;  ///< the deepest node region_of() last reached
  uint64_t regions_made_ = 0, region_length_sum_ = 0;
  mutable uint64_t pruned_boxes_ = 0, full_boxes_ = 0;
};

}  // namespace hfrt::render
