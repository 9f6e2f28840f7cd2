#pragma once
// Root search along one ray: the first parameter t in [t0, t1] where F(o + t d) >= 0.
//
// Two strategies, both over the same Field:
//  - sign change: march with a fixed step, evaluating kMarchBatch samples per call of the
//    vectorised evaluator, stop at the first sample inside, and refine the bracketing step
//    (kRefineBatch points per call, most of them around the chord's root) down to the
//    tolerance. Fast, but a feature thinner than the step can fall between two samples.
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
#include <memory>
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
  /// Points per refinement call or round. A tile's marches are refined together
  /// (sign_search_batch), their points packed into the evaluator's 16-lane blocks, so what a
  /// bracket costs is its points, not its calls: 15 per round (one block per bracket, when
  /// each was refined alone) took c1_gear at 512x512 (--bbox 1.6) 5.07M point evaluations,
  /// 7 3.73M, 5 3.56M and 3 3.41M, the last three about 3-5 % faster than 15 in the REPL's
  /// edit -> image. A bracket refined alone (sign_search) takes a call or two more where the
  /// window misses.
  static constexpr int kRefineBatch = 5;
  /// Of them, this many lie eps apart around where the chord between the bracket's ends
  /// crosses 0, the others split the bracket evenly. F is nearly linear across a march step
  /// almost everywhere, so the root is in the window and one round ends the refinement (on
  /// c1_gear at 512x512, no shadows, a window of 8 among 15 points took 4.68M -> 3.03M point
  /// evaluations against evenly spaced points). Where it is not, the bracket still narrows
  /// (kRefineBatch - kRefineWindow + 1)-fold, and the next chord is closer.
  static constexpr int kRefineWindow = 3;

  explicit RootSearcher(const Field& field) : field_(field) {}

  /// Sign-change search. `step` and `eps` are in units of t. With `any_hit` (shadow rays) the
  /// crossing is not refined.
  RootHit sign_search(const Ray& ray, float t0, float t1, float step, float eps, bool any_hit);

  /// One sign_search's request.
  struct MarchRequest {
    Ray ray;
    float t0, t1, step, eps;
    bool any_hit;
  };
  /// out[i] = sign_search(req[i]) for i < n, bit for bit (the same samples, brackets and
  /// refinement points), but the marches share the evaluator's calls: each round evaluates
  /// the next kMarchBatch samples of every march still going in one call, and the
  /// refinement's rounds every open bracket's kRefineBatch points in one. A tile's camera
  /// rays march pieces of a few samples each (c1_gear at 512x512: 303k calls of 4.3 points on
  /// average, one per march), on the 16-lane evaluator mostly empty lanes.
  void sign_search_batch(size_t n, const MarchRequest* req, RootHit* out);

  /// A refinement's bracket: F(ta) = fa < 0 (or NaN), F(tb) = fb >= 0, to narrow to width
  /// <= eps (stuck: float resolution reached first).
  struct Bracket {
    float ta, fa, tb, fb, eps;
    bool stuck = false;
  };

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
  /// kVerifyGrowth away from the root (bisected as usual where not excluded). The pieces of a
  /// ray's proof are evaluated as one batch with the tile's other rays, so fewer, longer pieces
  /// save interval evaluations even where some fail and are bisected: on c1_gear at 512x512
  /// (--bbox 1.6, shadows) growth 3 took 1.318M interval boxes, 5 1.214M, 9 1.152M, 27 1.090M
  /// and one piece (1e6) 1.025M, the same image in each; its REPL edits (hfrt_bench_repl
  /// --modes 1, alternating) ran 93-96 ms with 3 against 87-89 ms with 27 or 1e6; the blend and
  /// s2_csg did not change.
  static constexpr float kVerifyGap = 4;
  static constexpr float kVerifyGrowth = 27;
  /// Shadow rays (any hit) are covered by pieces that start one march step long at their
  /// origin and grow by this factor away from it. A longer piece is proven empty by one
  /// interval as often as not on these models, and an occluder is found by the march of a
  /// piece anyway: 8 instead of 2 takes 4-7 % fewer interval evaluations and 4-5.5 % fewer
  /// instructions for the whole render of s2_csg and c1_gear (s3_blend +0.6 %; callgrind,
  /// 256x256, one thread, the same images); 16 gains nothing more.
  static constexpr float kShadowGrowth = 8;
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
  /// sorts them, evaluates F at the midpoints of the gaps between t0, the candidates and t1
  /// in two calls (the first sample, then the others when it is outside), and reports the
  /// first candidate after which F >= 0, or t0 itself (at_start) when F >= 0 before the first
  /// candidate. A candidate where F only touches 0
  /// (a tangent ray) is not a hit. Shadow rays use it unchanged: there is nothing to refine.
  /// `start_outside`: the caller has proven F < 0 at t0 (the end of a culled slab), so F(t0)
  /// is not evaluated (for a mesh or patch leaf that sample may cost a winding number).
  /// `end_inside`: the caller has proven F >= 0 on a piece of the ray that ends at t1 (a
  /// culling piece proven inside), so the last gap, which reaches into it, is inside without
  /// a sample: a ray that enters a solid once needs no sample at all (the teapot's camera rays:
  /// one winding number each before).
  RootHit analytic_search(const Ray& ray, float t0, float t1, bool start_outside = false,
                          bool end_inside = false);

  /// Batched interval search: the bisection of interval_search for many rays at once. Every
  /// ray has pieces of its range, added front to back or in any order; the pieces of all rays
  /// are evaluated together in rounds (one Field::eval_intervals call per round), and each
  /// round splits what the last one could not exclude. Per ray the answer is what bisect()
  /// would give for the same pieces: the first parameter, in t, of a piece that is inside or
  /// of a leaf that may hold the surface (refined as bisect() refines it); a ray with
  /// `any_hit` stops at the first one found. Pieces behind a ray's best answer so far are
  /// dropped. A ray's interval evaluations count against kIntervalBudget as in
  /// interval_search; past it, its remaining pieces are marched front to back.
  struct BatchRay {
    Ray ray;
    float t_start = 0;  ///< a hit at a piece's start is at_start when it is here
    float eps = 0;      ///< tolerance, in units of t
    float step = 0;     ///< march step (fallback and shadow marches), in units of t
    bool any_hit = false;
    /// The answer when no piece holds a hit (a march's hit that the pieces lie in front of).
    RootHit otherwise;
  };
  void batch_clear();
  /// Adds a ray; returns its index for batch_add_piece and batch_result.
  int batch_add_ray(const BatchRay& ray);
  void batch_add_piece(int ray, float a, float b);
  /// Covers [a, b] with pieces whose lengths grow by `growth` from `first` (at least) away
  /// from the end at b (`from_b`) or at a: the proof pieces in front of a root, or a shadow
  /// ray's pieces leaving the surface.
  void batch_add_growing(int ray, float a, float b, float first, float growth, bool from_b);
  void batch_run();
  const RootHit& batch_result(int ray) const { return batch_rays_[size_t(ray)].result; }

  EvalCounters& counters() { return counters_; }

  /// The first point where a sample had no value, if any was seen since the last reset.
  bool has_nan_point() const { return has_nan_point_; }
  Vec3 nan_point() const { return nan_point_; }
  void reset_nan_point() { has_nan_point_ = false; }

 private:
  /// Evaluates F at o + t_i d for the n parameters in ts_ (fills xs_, ys_, zs_, fs_).
  void eval_params(const Ray& ray, size_t n, size_t first = 0);
  /// F at n points, counted, the first point without a value kept (nan_point()).
  void eval_points(size_t n, const float* x, const float* y, const float* z, float* f);
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
  /// The batched search's state: per ray its request and answer so far, the pieces of the
  /// current and the next round, and the boxes and enclosures of a round.
  struct BatchState : BatchRay {
    RootHit result;
    float best = 0;  ///< the earliest hit found so far (+inf: none)
    int evals = 0;
    bool done = false;
    uint32_t march_round = 0;  ///< the last round in which batch_run queued a march of it
  };
  struct BatchPiece {
    int ray;
    float a, b;
    bool marched;
  };
  /// Records a hit of ray r at t (at_start: F >= 0 at the start of the searched range).
  void batch_hit(BatchState& r, float t, bool at_start);
  std::vector<BatchState> batch_rays_;
  std::vector<BatchPiece> batch_pieces_, batch_next_, batch_live_, batch_over_;
  std::vector<Box> batch_boxes_;
  /// batch_run: per live piece of a round its march in batch_march_req_ (-1: none).
  std::vector<int> batch_march_of_;
  uint32_t batch_round_ = 0;
  std::vector<MarchRequest> batch_march_req_;
  std::vector<RootHit> batch_march_hit_;
  std::vector<Interval> batch_ivs_;
  std::unique_ptr<bool[]> batch_nan_;
  size_t batch_nan_size_ = 0;
  std::vector<double> candidates_;
  /// sign_search_batch's state: the marches still going, the brackets found (and the
  /// request of each), the open ones, and the points of a round (parameter, ray, position, F).
  struct MarchState {
    uint32_t request;
    int64_t next, last;  ///< the next sample to evaluate, the last one
    float prev_t, prev_f;
  };
  /// The points of a round: room for n (bts_, bxs_, bys_, bzs_, bfs_), the positions of
  /// points [first, first + count) on `ray` at their parameters in bts_, and F at the first n
  /// (into bfs_).
  void batch_points_place(size_t n);
  void batch_points_at(size_t first, size_t count, const Ray& ray);
  void eval_batch_points(size_t n);
  std::vector<MarchState> march_;
  std::vector<Bracket> brackets_;
  std::vector<uint32_t> bracket_of_, open_;
  std::vector<float> bts_, bxs_, bys_, bzs_, bfs_;
  bool has_nan_point_ = false;
  Vec3 nan_point_;
  bool plain_bisection_ = false;
};

/// A box enclosing the segment o + t d, t in [a, b], widened for rounding so that every sample
/// point computed as o + t d in float lies inside.
Box segment_box(const Ray& ray, float a, float b);

}  // namespace hfrt::render
