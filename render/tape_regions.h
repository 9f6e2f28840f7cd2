#pragma once
// Tapes pruned per region of space for the 3-D renderer (issue 25: "the interval root search of
// every model" on short tapes). A tile's culling bisects its frustum in depth with intervals;
// each slab box that the interval does not decide is also where the interval's min/max choices
// hold, so the tape pruned for it (Field::tape_evaluator, docs/tape_vm.md) is exact for every
// point and box inside it. TapeRegions keeps those (box, tape) pairs for the tile being
// rendered and is itself a Field: an interval over a box that lies inside a registered region
// is evaluated on that region's tape by the tape VM (the gear's 16-pixel slabs keep ~20-40 of
// its 231 instructions), any other box by the field underneath (the interval JIT).

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "render/field.h"

namespace hfrt::render {

/// Tapes pruned for the cells of a loose octree over the solid's extent, made on first use and
/// shared by the worker threads of one render: where a tile's culling starts pruning, its
/// first slab is evaluated on the tape of the smallest cell holding it instead of the whole
/// program. That one-box pass of the VM costs in proportion to the tape,
/// and each tile paid it on the whole program for every first slab (c1_gear: ~4900 one-box
/// passes of 231 instructions per 512x512 frame, 71 % of the culling's VM work). Pruning is
/// exact for every box inside the cell, so the slab's interval, and with it the image, is
/// the same.
///
/// The cells are cubes over the cube around `bounds` (the solid's framed extent,
/// RenderOptions::solid_extent, or the render box when it is unknown). The render box is often far
/// larger than the solid (the default -10..10 around a gear 3 wide), and a thin solid's box is
/// flat: cells over either held few slabs (c1_gear at its default box: 23 cells of 222
/// instructions). Level L (1..kLevels) has 2^L cells per axis of size s = side / 2^L; a cell's
/// loose box is its cell grown by s/2 on each side, so that every box at most s/2 wide whose centre
/// is inside the cell lies in it. Cell boundaries are multiples of a grid of s_kLevels / 2, so a
/// loose box lies inside its parent's in float arithmetic too, and its tape is pruned from the
/// parent's.
class TapeCells {
 public:
  static constexpr int kLevels = 4;

  /// Cells over the cube around `bounds` for the root tape of `field` (none when the field has
  /// no tape or one too short to prune: TapeRegions::kMinRootLength).
  TapeCells(const Field& field, const Box& bounds);

  bool enabled() const { return root_ != nullptr; }
  /// The tape of the deepest cell whose loose box contains `box` (the root tape when none
  /// does). A cell missing on the way down is made with `ev`, the calling thread's evaluator,
  /// whose remembered decisions (for prune_last) it overwrites. Thread-safe.
  const FieldTape& tape_for(const Box& box, TapeEvaluator& ev);

  /// Statistics: cells whose tape was pruned, and those tapes' total length.
  uint64_t cells_made() const { return cells_made_.load(); }
  uint64_t cell_length_sum() const { return cell_length_sum_.load(); }

 private:
  /// The loose box of cell (i, j, k) of `level`.
  Box cell_box(int level, const int idx[3]) const;

  std::shared_ptr<const FieldTape> root_;
  Vec3 origin_, grid_;  ///< cell boundaries are origin_ + m grid_ for integers m
  /// Per level 1..kLevels (index level - 1): the cells' tapes, null until made (a cell whose
  /// box decided nothing holds its parent's tape).
  std::unique_ptr<std::atomic<const FieldTape*>[]> cells_[kLevels];
  std::mutex mutex_;  ///< guards owned_
  std::vector<std::unique_ptr<FieldTape>> owned_;
  std::atomic<uint64_t> cells_made_{0}, cell_length_sum_{0};
};

/// The regions and tapes of one tile, for one worker thread (not thread-safe: a thread's
/// RootSearcher evaluates through it). Without a root tape (Field::root_tape() null) or with
/// a short one it is a plain view of the field underneath.
class TapeRegions final : public FieldView {
 public:
  /// A region is registered only when its tape is at most this fraction of the root tape's
  /// length: the VM costs more than the interval JIT per instruction and box (bench/README.md,
  /// hfrt_bench_interval c1_gear: 1.07 ns against ~0.42 ns when this was chosen), so a longer
  /// tape is slower than the JIT's full program. With the VM at 0.57 ns (2026-12-07), 0.5
  /// and 0.65 were no faster on c1_gear and c2_colonnade (512x512, --bbox 1.6, medians of 6).
  static constexpr double kMaxLengthRatio = 0.35;

  /// Programs shorter than this are not pruned: what pruning can save is less than the VM's
  /// costs (one-box passes in the culling, sorting boxes by region). 512x512 renders, 2
  /// threads: s2_csg (20 instructions) 0.059-0.060 s whole program, 0.074-0.078 s pruned
  /// (slab tapes of 4.9); c2_colonnade (206) 0.133-0.145 -> 0.114-0.115 s; c1_gear (231)
  /// 0.098-0.137 -> 0.084-0.098 s without shadows.
  static constexpr size_t kMinRootLength = 64;

  /// `cells`: the render's shared cell tapes, where a first prune (parent -1) starts (null:
  /// from the root tape).
  explicit TapeRegions(const Field& base, TapeCells* cells = nullptr);

  /// Whether the field has tapes (pruning is possible at all).
  bool enabled() const { return root_ != nullptr; }
  /// Forgets the regions (a new tile); the tapes' buffers are kept for reuse.
  void clear();
  /// F's interval over `box` on the tape of region `parent` (-1: the root tape, or the tape of
  /// the smallest cell holding `box`; `box` must lie inside the parent's box), by the tape VM. When
  /// the interval decides nothing about F's sign (hi >= 0 > lo or NaN possible) the tape is pruned
  /// for `box` and, when it got short enough, registered: the region's index is returned for the
  /// children of `box`; otherwise `parent` (whose tape stays valid in `box`).
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
  TapeCells* cells_ = nullptr;
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
