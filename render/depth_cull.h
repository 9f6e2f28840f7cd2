#pragma once
// The depth bisection that the renderers' culling shares (render/renderer.cpp: a tile's camera
// rays and a tile's shadow-ray bundles; render/tracer.cpp: a tile's camera rays per scene
// object): a range of depths is cut front to back into pieces whose boxes an interval test
// judges, so that the per-ray root searches skip what is empty for every ray of the bundle.

#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "render/field.h"
#include "render/tape_regions.h"

namespace hfrt::render {

/// One piece [a, b] of a depth range under bisection, `level` halvings deep.
struct DepthPiece {
  float a, b;
  int level;
  int node = -1;  ///< the caller's tag of the piece's parent (SlabTest::node), -1 at the top
};

/// What a culling test found in the box of the depths [a, b] of a ray bundle.
struct SlabTest {
  bool empty = false;   ///< proven to hold no surface (F < 0 there, or outside the box): dropped
  bool inside = false;  ///< proven inside the solid: kept without being split further
  /// Inside, and every ray of the bundle crosses this piece inside the box: nothing behind it
  /// can be seen, so the bisection stops after keeping it. (A piece the box clipped does not
  /// hide: a ray passing it outside the box meets the solid's cap later.)
  bool hides = false;
  /// A tag the test gives the piece's children (e.g. the tape pruned for this piece's box,
  /// render/tape_regions.h); -1 when none.
  int node = -1;
};

/// A camera culling's verdict from an enclosure `iv` of F over a piece's box (`maybe_nan`:
/// F may have no value there): empty where F < 0, inside where F >= 0 with no NaN possible,
/// and hiding what lies behind when also `unclipped` (every ray of the bundle crosses the
/// piece inside the box it was clipped to).
inline SlabTest slab_verdict(const Interval& iv, bool maybe_nan, bool unclipped) {
  SlabTest s;
  s.empty = iv.hi < 0;
  s.inside = !std::isnan(iv.lo) && iv.lo >= 0 && !maybe_nan;
  s.hides = s.inside && unclipped;
  return s;
}

/// slab_verdict() of F's interval over `box` (one more count in `*interval_calls`).
inline SlabTest interval_slab_test(const Field& field, const Box& box, bool unclipped,
                                   uint64_t* interval_calls) {
  bool maybe_nan = false;
  const Interval iv = field.eval_interval(box, &maybe_nan);
  ++*interval_calls;
  return slab_verdict(iv, maybe_nan, unclipped);
}

/// The same verdict from the tape of culling node `parent` (TapeRegions::eval_prune, -1: the
/// root tape), with SlabTest::node set to the node whose tape the piece's children and the
/// searches inside its box use.
inline SlabTest pruned_slab_test(TapeRegions& regions, int parent, const Box& box, bool unclipped,
                                 uint64_t* interval_calls) {
  bool maybe_nan = false;
  Interval iv;
  const int node = regions.eval_prune(parent, box, &iv, &maybe_nan);
  ++*interval_calls;
  SlabTest s = slab_verdict(iv, maybe_nan, unclipped);
  s.node = node;
  return s;
}

/// Bisects [t0, t1] front to back. Each piece is judged by `test(a, b)` or `test(a, b, node)`
/// (a SlabTest; `node` is the parent's SlabTest::node, -1 for [t0, t1]); a piece
/// that is not empty and not inside is halved while it is longer than `width(b)` and less than
/// 20 halvings deep; every other non-empty piece goes to `keep(a, b, test)`, in increasing
/// depth, with its SlabTest (whether it was proven inside). The walk ends after a piece that
/// hides what lies behind it. `stack` is the caller's scratch.
template <typename Test, typename Width, typename Keep>
void bisect_depths(float t0, float t1, std::vector<DepthPiece>* stack, Test&& test, Width&& width,
                   Keep&& keep) {
  stack->clear();
  stack->push_back({t0, t1, 0});
  while (!stack->empty()) {
    const DepthPiece p = stack->back();
    stack->pop_back();
    SlabTest s;
    if constexpr (std::is_invocable_v<Test&, float, float, int>) {
      s = test(p.a, p.b, p.node);
    } else {
      s = test(p.a, p.b);
    }
    if (s.empty) continue;
    if (!s.inside && p.level < 20 && (p.b - p.a) > width(p.b)) {
      const float mid = p.a + (p.b - p.a) * 0.5f;
      if (mid > p.a && mid < p.b) {
        stack->push_back({mid, p.b, p.level + 1, s.node});
        stack->push_back({p.a, mid, p.level + 1, s.node});
        continue;
      }
    }
    keep(p.a, p.b, s);
    if (s.hides) break;
  }
}

}  // namespace hfrt::render
