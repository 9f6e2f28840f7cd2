#pragma once
// The side of a point (generalised winding number >= 1/2) through a grid of cells over a
// surface's bounds, each filled when first asked, so that the renderer's sign samples of open
// meshes and patches (which the crossings of a ray cannot decide) need far fewer winding
// numbers than points.
//   SideGrid (MeshSurface): a point within the distance from its cell's centre to the surface
//   takes the side of the centre; any other point its own winding number.
//   WindingGrid (PatchSurface's exact field): a point takes the centre's winding number plus
//   the facings of the segment between them, within a bound from the boundary curves.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>

#include "base/box.h"

namespace hfrt::geom {

/// The cells of a grid over a surface's bounds grown by a cell: 1/48 of the bounds' largest
/// side each, at most 64 per axis. On a teapot frame 48 asked the fewest winding numbers of
/// 32, 48 and 96 with the images unchanged (96: 1 % fewer instructions, one pixel different,
/// where the lid's gap makes w fractional).
template <typename Cell>
class GridCells {
 public:
  explicit GridCells(const Box& bounds) {
    const float extent = bounds.max_extent();
    h_ = extent > 0 && std::isfinite(extent) ? extent / 48 : 0;
    if (!(h_ > 0 && std::isfinite(1 / h_))) return;
    inv_h_ = 1 / h_;
    lo_ = bounds.lo - Vec3{h_, h_, h_};
    size_ = 1;
    for (int a = 0; a < 3; ++a) {
      n_[a] = std::clamp(int(std::ceil((bounds.hi[a] - bounds.lo[a]) * inv_h_)) + 2, 1, 64);
      size_ *= size_t(n_[a]);
    }
    cells_ = std::make_unique<Cell[]>(size_);  // value-initialised
  }
  float h() const { return h_; }
  /// How far from its cell's centre a point that locate() puts in the cell may be: half the
  /// diagonal of the cell grown by a hundredth of a cell (rounding of the index).
  float reach() const { return 0.5f * std::sqrt(3.0f) * 1.02f * h_; }
  /// p's cell and its centre; false outside the grid (or NaN).
  bool locate(Vec3 p, size_t* index, Vec3* centre) const {
    if (!cells_) return false;
    int c[3];
    for (int a = 0; a < 3; ++a) {
      const float f = (p[a] - lo_[a]) * inv_h_;
      if (!(f >= 0 && f < float(n_[a]))) return false;
      c[a] = std::min(int(f), n_[a] - 1);
    }
    *index = (size_t(c[2]) * n_[1] + c[1]) * n_[0] + c[0];
    *centre = {lo_.x + (float(c[0]) + 0.5f) * h_, lo_.y + (float(c[1]) + 0.5f) * h_,
               lo_.z + (float(c[2]) + 0.5f) * h_};
    return true;
  }
  Cell& cell(size_t index) const { return cells_[index]; }
  size_t memory_bytes() const { return size_ * sizeof(Cell); }

 private:
  Vec3 lo_;
  float h_ = 0, inv_h_ = 0;
  int n_[3] = {0, 0, 0};
  size_t size_ = 0;
  std::unique_ptr<Cell[]> cells_;
};

class SideGrid {
 public:
  explicit SideGrid(const Box& bounds) : cells_(bounds) {}

  /// winding(p) >= 1/2, through p's cell. near(c, r) is the distance from c to the surface
  /// when the surface comes within r of c, +inf otherwise (a lower bound of the distance is
  /// enough); winding(p) the generalised winding number at p. Thread-safe (cells are atomic;
  /// two threads may compute the same cell, with the same result).
  template <typename Near, typename Winding>
  bool inside(Vec3 p, const Near& near, const Winding& winding) const {
    size_t index;
    Vec3 centre;
    // Outside the grid (or NaN): the point's own winding number.
    if (!cells_.locate(p, &index, &centre)) return winding(p) >= 0.5;
    Cell& cell = cells_.cell(index);
    uint8_t state = cell.state.load(std::memory_order_acquire);
    if (state == kUnknown) {
      // Every point the lookup puts in the cell is within reach() of its centre. With no
      // surface in that ball the whole cell has the centre's side (the segment to the centre
      // meets no surface); otherwise the ball of radius d, the centre's distance to the
      // surface, still does (shrunk for the rounding of d) when it is not too small to be
      // worth a winding number.
      const float h = cells_.h();
      const float half_diag = cells_.reach();
      const float d = near(centre, half_diag);
      const bool clear = !(d < half_diag);
      const float r = clear ? half_diag : d * (1.0f - 1e-5f);
      if (clear || r > 0.1f * h) {
        const bool in = winding(centre) >= 0.5;
        if (clear) {
          state = in ? kInside : kOutside;
        } else {
          cell.ball_r2.store(r * r, std::memory_order_relaxed);
          state = in ? kBallInside : kBallOutside;
        }
      } else {
        state = kNear;
      }
      cell.state.store(state, std::memory_order_release);
    }
    switch (state) {
      case kInside:
        return true;
      case kOutside:
        return false;
      case kBallInside:
      case kBallOutside:
        if (length2(p - centre) < cell.ball_r2.load(std::memory_order_relaxed))
          return state == kBallInside;
        break;
      default:
        break;
    }
    return winding(p) >= 0.5;
  }

  /// Heap bytes held.
  size_t memory_bytes() const { return cells_.memory_bytes(); }

 private:
  /// A cell's state: kUnknown until asked, then the side of the cell's centre for the whole
  /// cell (no surface within half its diagonal of the centre), or for the ball around the
  /// centre that holds no surface (its squared radius in ball_r2; kBall* states), or kNear
  /// (the surface passes next to the centre: nothing kept).
  enum : uint8_t {
    kUnknown = 0,
    kNear = 1,
    kInside = 2,
    kOutside = 3,
    kBallInside = 4,
    kBallOutside = 5
  };
  struct Cell {
    std::atomic<uint8_t> state{kUnknown};
    /// Written before its cell's state (release); atomic because two threads may compute the
    /// same cell at once (the same value: relaxed).
    std::atomic<float> ball_r2{0};
  };
  GridCells<Cell> cells_;
};

/// WindingGrid: the side of a point through a grid of cells that keep the winding number w_c
/// at their centre c and a bound d_c on how much w's smooth part changes within the cell
/// (from the boundary curves: zero for a closed surface). Across the surface w jumps by the
/// crossing's facing and is smooth elsewhere, so for p in the cell
///     |w(p) - (w_c + sum of the facings of the segment from c to p)| <= d_c,
/// and when that interval lies on one side of 1/2 the crossings of one short segment decide
/// p (none when p is nearer c than the surface can be), without p's own winding number
/// (PatchSurface: a boundary integral and a ray to infinity). Where d_c is too large (a cell
/// next to a boundary curve), the interval straddles 1/2, or the segment's crossings are in
/// doubt, p's own winding number decides. (Splitting such cells into 4^3 was tried: on the
/// benchmark teapot most of the sub-cells were asked once, and it saved nothing.)
/// The cells cover the bounds (as SideGrid's) and, coarser, the bounds grown by their extent
/// on every side; farther points use their own winding number.
class WindingGrid {
 public:
  explicit WindingGrid(const Box& bounds) : cells_(bounds), outer_(grown(bounds)) {}

  /// winding(q): the winding number at q; smooth_change(c, r): the bound on the change of
  /// w's smooth part within r of c (+inf when unknown); clearance(c, r): a lower bound of the
  /// distance from c to the surface (r when it is at least r); facings(c, p, &sum): the
  /// facings of the crossings of the segment from c to p summed, false when in doubt.
  /// Thread-safe as SideGrid.
  template <typename Winding, typename SmoothChange, typename Clearance, typename Facings>
  bool inside(Vec3 p, const Winding& winding, const SmoothChange& smooth_change,
              const Clearance& clearance, const Facings& facings) const {
    size_t index;
    Vec3 centre;
    const GridCells<Cell>* cells = &cells_;
    if (!cells->locate(p, &index, &centre)) {
      cells = &outer_;
      if (!cells->locate(p, &index, &centre)) return winding(p) >= 0.5;
    }
    Cell& cell = cells->cell(index);
    uint8_t state = cell.state.load(std::memory_order_acquire);
    if (state == kUnknown) {
      // A cell's first point takes its own winding number: a cell asked once (a sweep over
      // a region, as framing's) would pay for its centre's and its bound for nothing.
      uint8_t expected = kUnknown;
      if (cell.state.compare_exchange_strong(expected, kSeen, std::memory_order_acq_rel))
        return winding(p) >= 0.5;
      state = expected;
    }
    if (state == kSeen) {
      // Every point the lookup puts in the cell is within reach() of its centre.
      const float half_diag = cells->reach();
      const float change = smooth_change(centre, half_diag);
      if (change < kMaxChange) {
        cell.w.store(float(winding(centre)), std::memory_order_relaxed);
        cell.change.store(change, std::memory_order_relaxed);
        const float r = clearance(centre, half_diag) * (1.0f - 1e-5f);
        cell.clear_r2.store(r > 0 ? r * r : 0.0f, std::memory_order_relaxed);
        state = kReady;
      } else {
        state = kOwn;
      }
      cell.state.store(state, std::memory_order_release);
    }
    if (state == kReady) {
      int sum = 0;
      const float r2 = cell.clear_r2.load(std::memory_order_relaxed);
      if (length2(p - centre) < r2 || facings(centre, p, &sum)) {
        const double w = double(cell.w.load(std::memory_order_relaxed)) + sum;
        // w_c is exact to ~1e-4 (the quadrature of the boundary's term): a point that close
        // to 1/2 takes its own winding number, as it would without the grid.
        const double margin = double(cell.change.load(std::memory_order_relaxed)) + 2e-4;
        if (w - margin >= 0.5) return true;
        if (w + margin < 0.5) return false;
      }
    }
    return winding(p) >= 0.5;
  }

  size_t memory_bytes() const { return cells_.memory_bytes() + outer_.memory_bytes(); }

 private:
  /// A larger bound leaves little room to decide (w is within 1/2 of 0 or 1 only by it).
  static constexpr float kMaxChange = 0.45f;
  enum : uint8_t { kUnknown = 0, kSeen = 1, kReady = 2, kOwn = 3 };
  struct Cell {
    std::atomic<uint8_t> state{kUnknown};
    /// Written before state (release); atomic because two threads may compute the same cell
    /// at once (the same values: relaxed).
    std::atomic<float> w{0}, change{0}, clear_r2{0};
  };
  static Box grown(const Box& b) {
    const float e = b.max_extent();
    return Box(b.lo - Vec3{e, e, e}, b.hi + Vec3{e, e, e});
  }
  GridCells<Cell> cells_, outer_;
};

/// A grid (SideGrid, WindingGrid) made on the first call of get() (thread-safe; two threads may
/// both make one, one is kept), so that surfaces whose inside() is never asked hold none.
template <typename Grid>
class LazyGrid {
 public:
  LazyGrid() = default;
  LazyGrid(const LazyGrid&) = delete;
  LazyGrid& operator=(const LazyGrid&) = delete;
  ~LazyGrid() { delete grid_.load(std::memory_order_acquire); }

  const Grid& get(const Box& bounds) const {
    if (const Grid* g = grid_.load(std::memory_order_acquire)) return *g;
    auto grid = std::make_unique<Grid>(bounds);
    Grid* expected = nullptr;
    if (grid_.compare_exchange_strong(expected, grid.get(), std::memory_order_acq_rel))
      return *grid.release();
    return *expected;  // another thread's, made at the same time
  }
  /// Heap bytes held (0 before the first get()).
  size_t memory_bytes() const {
    const Grid* g = grid_.load(std::memory_order_acquire);
    return g ? sizeof(Grid) + g->memory_bytes() : 0;
  }

 private:
  mutable std::atomic<Grid*> grid_{nullptr};
};
using LazySideGrid = LazyGrid<SideGrid>;
using LazyWindingGrid = LazyGrid<WindingGrid>;

}  // namespace hfrt::geom
