#pragma once
// Root search along one ray: the first parameter t in [t0, t1] where F(o + t d) >= 0.
//
// Two strategies, both over the same Field:
//  - sign change: march with a fixed step, evaluating kMarchBatch samples per call of the
//    vectorised evaluator, stop at the first sample inside, and refine the bracketing step by
//    repeated sectioning (kRefineBatch points per call) down to the tolerance. Fast, but a
//    feature thinner than the step can fall between two samples.
//  - interval: recursive bisection of [t0, t1]; a piece whose interval excludes 0 is skipped,
//    one that straddles 0 is split, down to the tolerance. A piece that still straddles at the
//    tolerance counts as a hit even when no sample inside it is >= 0: that is what keeps thin
//    shells and tangent touches from being missed (at worst a hit is reported within about
//    the tolerance of the true surface). Camera rays march to the first sample inside first
//    (point samples are far cheaper than interval evaluations) and bisect only the pieces
//    before it, which grow away from it; shadow rays march each short piece before bisecting it.
//  - analytic: the Field lists every parameter where F may change sign on the ray (the real
//    roots of its polynomial leaves, Field::ray_candidates); F is evaluated once between
//    consecutive candidates, and the hit is the first candidate after which F >= 0. Exact to
//    the precision of the roots, no step or tolerance, and thin parts cannot be missed.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "render/camera.h"
#include "render/field.h"

namespace hfrt::render {

/// Evaluator calls made by the renderer, by kind (summed over threads for --stats).
struct EvalCounters {
  uint64_t eval_calls = 0, eval_points = 0;
  uint64_t interval_calls = 0;
  uint64_t gradient_calls = 0, gradient_points = 0;
  uint64_t attribute_calls = 0, attribute_points = 0;
  /// Point samples where F had no value (counted as outside).
  uint64_t nan_samples = 0;
  /// Interval searches that ran out of budget and finished with the sign-change march.
  uint64_t interval_fallbacks = 0;
  /// Analytic search: calls of Field::ray_candidates() and candidates they returned.
  uint64_t candidate_calls = 0, candidates = 0;

  EvalCounters& operator+=(const EvalCounters& o);
};

/// The outcome of one search.
struct RootHit {
  bool hit = false;
  float t = 0;
  /// True when F was already >= 0 at the start of the searched range (no crossing found).
  bool at_start = false;
};

/// Per-thread searcher: owns its scratch buffers and counters; holds a reference to the shared
/// (thread-safe) Field.
class RootSearcher {
 public:
  static constexpr int kMarchBatch = 32;
  static constexpr int kRefineBatch = 7;

  explicit RootSearcher(const Field& field) : field_(field) {}

  /// Sign-change search. `step` and `eps` are in units of t. With `any_hit` (shadow rays) the
  /// crossing is not refined.
  RootHit sign_search(const Ray& ray, float t0, float t1, float step, float eps, bool any_hit);

  /// Interval search (needs field.has_interval()): the first t where the interval enclosure of
  /// F over a piece of length <= `eps` (units of t) still reaches 0, so that no feature thinner
  /// than the march step is missed. Without `any_hit` it marches (`fallback_step`) to the first
  /// sample inside, refines it, and bisects only what lies before it (see kVerifyGap); with
  /// `any_hit` (shadow rays) it bisects pieces growing away from t0 and marches each piece of at
  /// most kPrunedSpan steps once before bisecting it further. A ray that
  /// needs more than kIntervalBudget interval evaluations (an evaluator whose enclosures stay
  /// wide, e.g. [-inf, inf] after a division) finishes its remaining pieces with the sign-change
  /// march at `fallback_step`, so that no ray costs unbounded time; such rays are counted.
  RootHit interval_search(const Ray& ray, float t0, float t1, float eps, float fallback_step,
                          bool any_hit);
  static constexpr int kIntervalBudget = 4096;
  /// The primary search marches to the first sample inside, refines it, then proves with
  /// intervals that [t0, root - kVerifyGap eps] holds no surface, covered by pieces growing by
  /// kVerifyGrowth away from the root (bisected as usual where not excluded).
  static constexpr float kVerifyGap = 4;
  static constexpr float kVerifyGrowth = 3;
  /// With `on`, interval_search without any_hit is the plain bisection of [t0, t1] (no march
  /// first): what RenderOptions::interval_march_first = false asks for.
  void set_plain_bisection(bool on) { plain_bisection_ = on; }

  /// Sign-change search that first drops pieces of [t0, t1] whose interval is below 0, marching
  /// only pieces of at most kPrunedSpan steps that may hold the surface. For rays that no
  /// per-tile culling covers (shadow rays) when the field has intervals but the user asked for
  /// the sign-change search.
  RootHit pruned_sign_search(const Ray& ray, float t0, float t1, float step, float eps,
                             bool any_hit);
  static constexpr int kPrunedSpan = 32;

  /// Analytic search (needs field.has_ray_candidates()): gathers the candidates in [t0, t1],
  /// sorts them, evaluates F at t0 and at the midpoints between consecutive candidates (and
  /// between the last one and t1) in one batch call, and reports the first candidate after
  /// which F >= 0, or t0 itself (at_start) when F(t0) >= 0. A candidate where F only touches 0
  /// (a tangent ray) is not a hit. Shadow rays use it unchanged: there is nothing to refine.
  RootHit analytic_search(const Ray& ray, float t0, float t1);

  EvalCounters& counters() { return counters_; }

  /// The first point where a sample had no value, if any was seen since the last reset.
  bool has_nan_point() const { return has_nan_point_; }
  Vec3 nan_point() const { return nan_point_; }
  void reset_nan_point() { has_nan_point_ = false; }

 private:
  /// Evaluates F at o + t_i d for the n parameters in ts_ (fills xs_, ys_, zs_, fs_).
  void eval_params(const Ray& ray, size_t n);
  /// Refines a bracket (F(ta) < 0 or NaN, F(tb) >= 0) to width <= eps.
  float refine(const Ray& ray, float ta, float fa, float tb, float fb, float eps);

  const Field& field_;
  EvalCounters counters_;
  std::vector<float> ts_, xs_, ys_, zs_, fs_;
  struct Piece {
    float a, b;
    bool marched;  // a shadow ray's piece (or its parent) already marched without a hit
  };
  /// The bisection of interval_search over the pieces on stack_ (the front one on top), front
  /// to back; at_start is relative to t0. Counts interval evaluations against `*budget`.
  RootHit bisect(const Ray& ray, float t0, float eps, float fallback_step, bool any_hit,
                 int* budget);
  std::vector<Piece> stack_;
  std::vector<double> candidates_;
  bool has_nan_point_ = false;
  Vec3 nan_point_;
  bool plain_bisection_ = false;
};

/// A box enclosing the segment o + t d, t in [a, b], widened for rounding so that every sample
/// point computed as o + t d in float lies inside.
Box segment_box(const Ray& ray, float a, float b);

}  // namespace hfrt::render
