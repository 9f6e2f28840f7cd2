#pragma once
// Trimming regions of Bézier patches (issue 17): closed polylines in a patch's parameter
// square [0,1]^2. A parameter point is kept when it lies inside an odd number of the patch's
// loops (even-odd rule), so one loop keeps its inside and an outer loop with a hole loop keeps
// a ring. Loops may have any orientation, may touch or cross each other (the rule still
// decides), and are closed implicitly (the last point joins the first).
//
// Used by the ray queries (PatchSurface: a Newton root counts only where contains() holds;
// classify() lets the pieces that lie entirely on one side skip the test or the BVH) and by
// the field tessellation (clip(): the kept part of a grid cell, exactly, as triangles).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace hfrt::geom {

/// A point of a patch's parameter square.
struct UV {
  double u = 0, v = 0;
};

/// The kept region of one patch. A default-constructed Trim has no loops: the whole patch is
/// kept (empty() is true).
class Trim {
 public:
  /// How a parameter rectangle lies relative to the kept region.
  enum class Cover : uint8_t { kKept, kRemoved, kPartial };

  Trim() = default;
  /// The region bounded by `loops` (each of at least 3 points, inside [0,1]^2).
  explicit Trim(std::vector<std::vector<UV>> loops);

  /// True when the patch is untrimmed.
  bool empty() const { return loops_.empty(); }
  const std::vector<std::vector<UV>>& loops() const { return loops_; }
  /// The number of loop edges (all loops together).
  size_t num_edges() const { return edges_.size(); }
  /// Heap bytes held (loops, edges, bands).
  size_t memory_bytes() const;

  /// Whether (u, v) is kept: inside an odd number of loops (crossing-number test along +u;
  /// points on a loop edge go to one side or the other by the half-open rule).
  bool contains(double u, double v) const;

  /// kKept or kRemoved when no loop edge meets the rectangle [u0,u1] x [v0,v1] enlarged by
  /// a small margin (1e-9), so contains() is constant over it; kPartial otherwise.
  Cover classify(double u0, double u1, double v0, double v1) const;

  /// Appends the kept part of the rectangle [u0,u1] x [v0,v1] as counter-clockwise triangles
  /// (in (u, v)), exactly up to rounding: a trapezoidal decomposition into slabs at every loop
  /// vertex, every crossing of two edges and of an edge with the rectangle's border, each
  /// trapezoid kept or not by contains() at its centre.
  void clip(double u0, double u1, double v0, double v1, std::vector<std::array<UV, 3>>* out) const;

  /// The border of the kept region within [0,1]^2 as segments (a, b) with the kept region on
  /// their left (counter-clockwise around it, as the untrimmed square's border runs): the
  /// loop edges and the square's sides, split where they cross or touch each other, less the
  /// pieces with the same side left and right (a loop edge inside a region kept on both
  /// sides, a side of the square that is trimmed away) and less repeats (a loop edge along a
  /// side). Each piece's side is decided by contains() at points just left and right of its
  /// middle. What the exact field's boundary curves and closest points of a trimmed patch are
  /// made from (geom/boundary_winding.h). Quadratic in the edges (their crossings).
  std::vector<std::array<UV, 2>> border() const;

  /// Whether a loop edge passes within `eps` of (u, v) (the edges of v's bands): a root of a
  /// winding number's ray there is in doubt, as one near a patch's border is.
  bool near_edge(double u, double v, double eps) const;

 private:
  struct Edge {
    UV a, b;
  };
  std::vector<std::vector<UV>> loops_;
  std::vector<Edge> edges_;
  // Edges by horizontal band of v (kBands bands over [0,1]): the crossing test along +u at
  // height v only looks at the edges of v's band.
  /// The band of height v (clamped to the first and last).
  int band(double v) const {
    return std::clamp(static_cast<int>(std::floor(v * bands_)), 0, bands_ - 1);
  }
  std::vector<uint32_t> band_start_;  // kBands + 1 offsets into band_edges_
  std::vector<uint32_t> band_edges_;
  int bands_ = 0;
};

}  // namespace hfrt::geom
