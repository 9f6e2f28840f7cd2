#include "render/root_search.h"

#include <gtest/gtest.h>

#include <cmath>

#include "testsupport/analytic_fields.h"

namespace hfrt::render {
namespace {

using testing::ShellField;
using testing::SphereField;

TEST(RootSearch, SignChangeFindsSphereToTolerance) {
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  Ray ray{{0.5f, 1.0f, 20}, {0, 0, -1}};
  RootHit h = s.sign_search(ray, 0, 40, 0.05f, 1e-5f, false);
  ASSERT_TRUE(h.hit);
  EXPECT_FALSE(h.at_start);
  double expected = 20 - std::sqrt(9.0 - 0.25 - 1.0);
  EXPECT_NEAR(h.t, expected, 2e-5);
  // Several samples per call: far fewer calls than samples.
  EXPECT_GT(s.counters().eval_points, 4 * s.counters().eval_calls);
}

TEST(RootSearch, RefinementFollowsTheChordToTheRoot) {
  // F = 3 - |p| is nearly linear across one march step: the chord's root is close to F's, and
  // closer with each narrower bracket, so a few calls of kRefineBatch (5) points past the
  // march reach the tolerance. Five evenly spaced points per call (6-fold narrower) would take
  // five from 0.05 down to 1e-5.
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  Ray ray{{0.5f, 1.0f, 20}, {0, 0, -1}};
  RootHit h = s.sign_search(ray, 16, 40, 0.05f, 1e-5f, false);  // one march call: 24 steps
  ASSERT_TRUE(h.hit);
  EXPECT_NEAR(h.t, 20 - std::sqrt(9.0 - 0.25 - 1.0), 2e-5);
  EXPECT_LE(s.counters().eval_calls, 1u + 3u);
}

/// F = 1000 in front of the plane z = 1 and -1 behind it (the ray comes from z > 1): a jump,
/// where the chord between two samples points far from the crossing.
class StepField : public testing::AnalyticField {
 public:
  double value(double, double, double z) const override { return z > 1 ? -1 : 1000; }
  Vec3 gradient(double, double, double) const override { return {0, 0, 0}; }
  Interval interval(const Box& b) const override {
    return {b.hi.z > 1 ? -1.0f : 1000.0f, b.lo.z > 1 ? -1.0f : 1000.0f};
  }
};

TEST(RootSearch, RefinementNarrowsEvenWhereTheChordIsFarFromTheRoot) {
  StepField step;
  RootSearcher s(step);
  Ray ray{{0, 0, 10}, {0, 0, -1}};
  RootHit h = s.sign_search(ray, 0, 20, 0.1f, 1e-5f, false);  // the jump at t = 9
  ASSERT_TRUE(h.hit);
  EXPECT_GE(h.t, 9 - 1e-5);
  EXPECT_LE(h.t, 9 + 1e-5);
  // The bracket still narrows 3-fold per call (the two evenly spaced points of five): nine
  // calls from 0.1 down to 1e-5 (3^9 > 10^4), after the three of the march.
  EXPECT_LE(s.counters().eval_calls, 3u + 9u);
}

TEST(RootSearch, IntervalFindsSphereToTolerance) {
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  Ray ray{{0.5f, 1.0f, 20}, {0, 0, -1}};
  RootHit h = s.interval_search(ray, 0, 40, 1e-5f, 0.05f, false);
  ASSERT_TRUE(h.hit);
  double expected = 20 - std::sqrt(9.0 - 0.25 - 1.0);
  EXPECT_NEAR(h.t, expected, 2e-5);
  EXPECT_GT(s.counters().interval_calls, 0u);
}

TEST(RootSearch, MissReportsNoHit) {
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  Ray ray{{3.5f, 0, 20}, {0, 0, -1}};
  EXPECT_FALSE(s.sign_search(ray, 0, 40, 0.05f, 1e-5f, false).hit);
  EXPECT_FALSE(s.interval_search(ray, 0, 40, 1e-5f, 0.05f, false).hit);
}

TEST(RootSearch, StartInsideIsReportedAtStart) {
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  Ray ray{{0, 0, 1}, {0, 0, -1}};
  RootHit a = s.sign_search(ray, 0, 10, 0.05f, 1e-5f, false);
  RootHit b = s.interval_search(ray, 0, 10, 1e-5f, 0.05f, false);
  ASSERT_TRUE(a.hit && b.hit);
  EXPECT_TRUE(a.at_start);
  EXPECT_TRUE(b.at_start);
  EXPECT_EQ(a.t, 0);
  EXPECT_EQ(b.t, 0);
}

TEST(RootSearch, ThinShellMissedByCoarseStepFoundByIntervals) {
  // Shell 0.01 thick; a step of 0.3 jumps over it for most offsets.
  ShellField shell(5, 0.01);
  RootSearcher s(shell);
  int sign_hits = 0, interval_hits = 0;
  for (int i = 0; i < 50; ++i) {
    Ray ray{{0.01f * float(i), 0.3f, 20}, {0, 0, -1}};
    sign_hits += s.sign_search(ray, 0, 40, 0.3f, 1e-5f, false).hit;
    RootHit h = s.interval_search(ray, 0, 40, 1e-5f, 0.3f, false);
    interval_hits += h.hit;
    if (h.hit) {
      double rho2 = double(ray.o.x) * ray.o.x + 0.09;
      EXPECT_NEAR(h.t, 20 - std::sqrt(25 - rho2), 1e-4);
    }
  }
  EXPECT_EQ(interval_hits, 50);
  EXPECT_LT(sign_hits, 50);  // the coarse march does miss it: the test can tell them apart
}

/// A thin shell (radius 5, 0.01 thick) around a solid ball of radius 2: F = max(shell, ball).
class ShellAroundBall final : public testing::AnalyticField {
 public:
  double value(double x, double y, double z) const override {
    return std::max(shell_.value(x, y, z), ball_.value(x, y, z));
  }
  Vec3 gradient(double x, double y, double z) const override {
    return shell_.value(x, y, z) > ball_.value(x, y, z) ? shell_.gradient(x, y, z)
                                                        : ball_.gradient(x, y, z);
  }
  Interval interval(const Box& b) const override {
    Interval s = shell_.interval(b), c = ball_.interval(b);
    return {std::max(s.lo, c.lo), std::max(s.hi, c.hi)};
  }

 private:
  ShellField shell_{5, 0.01};
  SphereField ball_{{0, 0, 0}, 2};
};

TEST(RootSearch, BatchedMarchesGiveSignSearchesAnswersBitForBit) {
  // Rays missing everything, crossing the thin shell (which steps of 0.3 may step over) and
  // the ball, starting inside, ranges of one sample, of none (t0 > t1) and without a step;
  // camera-like and any-hit, with several calls' worth of samples (kMarchBatch each).
  ShellAroundBall f;
  RootSearcher batched(f), one(f);
  std::vector<RootSearcher::MarchRequest> req;
  for (int i = 0; i < 60; ++i) {
    const float x = 0.1f * float(i), step = i % 3 == 0 ? 0.3f : 0.05f;
    req.push_back({{{x, 0.3f, 20}, {0, 0, -1}}, 0, 40, step, 1e-5f, i % 4 == 1});
    req.push_back({{{x, -0.2f, 20}, {0, 0, -1}}, 12.5f + 0.01f * float(i), 40, step, 1e-5f, false});
  }
  req.push_back({{{0, 0, 1}, {0, 0, -1}}, 0, 4, 0.1f, 1e-5f, false});     // starts inside the ball
  req.push_back({{{0, 0, 20}, {0, 0, -1}}, 18, 18, 0.1f, 1e-5f, false});  // one sample
  req.push_back({{{0, 0, 20}, {0, 0, -1}}, 19, 18, 0.1f, 1e-5f, false});  // empty range
  req.push_back({{{0, 0, 20}, {0, 0, -1}}, 0, 40, 0, 1e-5f, false});      // no step
  std::vector<RootHit> got(req.size());
  batched.sign_search_batch(req.size(), req.data(), got.data());
  int hits = 0;
  for (size_t i = 0; i < req.size(); ++i) {
    const RootSearcher::MarchRequest& q = req[i];
    const RootHit want = one.sign_search(q.ray, q.t0, q.t1, q.step, q.eps, q.any_hit);
    ASSERT_EQ(got[i].hit, want.hit) << i;
    EXPECT_EQ(got[i].t, want.t) << i;
    EXPECT_EQ(got[i].at_start, want.at_start) << i;
    hits += want.hit;
  }
  EXPECT_GT(hits, 60);
  EXPECT_TRUE(got[req.size() - 4].at_start);
  // The same samples in far fewer calls: a round per kMarchBatch samples, then a few rounds of
  // refinement, instead of one call per march and per refinement step.
  EXPECT_EQ(batched.counters().eval_points, one.counters().eval_points);
  EXPECT_LT(batched.counters().eval_calls * 10, one.counters().eval_calls);
}

TEST(RootSearch, IntervalMarchFirstStillFindsAThinShellInFrontOfASolid) {
  // The march (step 0.3) steps over the shell and finds the ball; the intervals over what lies
  // before the ball must still find the shell, as the plain bisection does.
  ShellAroundBall f;
  RootSearcher fast(f), plain(f);
  plain.set_plain_bisection(true);
  for (int i = 0; i < 50; ++i) {
    Ray ray{{0.01f * float(i), 0.3f, 20}, {0, 0, -1}};
    RootHit a = fast.interval_search(ray, 0, 40, 1e-5f, 0.3f, false);
    RootHit b = plain.interval_search(ray, 0, 40, 1e-5f, 0.3f, false);
    ASSERT_TRUE(a.hit && b.hit);
    double rho2 = double(ray.o.x) * ray.o.x + 0.09;
    EXPECT_NEAR(a.t, 20 - std::sqrt(25 - rho2), 1e-4);
    EXPECT_NEAR(a.t, b.t, 1e-4);
  }
}

TEST(RootSearch, IntervalMarchFirstAgreesWithBisectionWithFewerIntervals) {
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher fast(sphere), plain(sphere);
  plain.set_plain_bisection(true);
  for (int i = 0; i < 40; ++i) {
    Ray ray{{0.07f * float(i), 0.5f, 20}, {0, 0, -1}};
    RootHit a = fast.interval_search(ray, 0, 40, 1e-5f, 0.05f, false);
    RootHit b = plain.interval_search(ray, 0, 40, 1e-5f, 0.05f, false);
    ASSERT_EQ(a.hit, b.hit) << i;
    if (a.hit) {
      EXPECT_NEAR(a.t, b.t, 1e-4) << i;
    }
  }
  EXPECT_LT(fast.counters().interval_calls, plain.counters().interval_calls);
}

/// Batched search of `rays` over [t0, t1] (one piece each, or the shadow rays' growing pieces
/// with any_hit), as the renderer batches a tile.
std::vector<RootHit> batch_search(RootSearcher& s, const std::vector<Ray>& rays, float t0, float t1,
                                  float eps, float step, bool any_hit) {
  s.batch_clear();
  std::vector<int> index;
  for (const Ray& ray : rays) {
    RootSearcher::BatchRay br;
    br.ray = ray;
    br.t_start = t0;
    br.eps = eps;
    br.step = step;
    br.any_hit = any_hit;
    int r = s.batch_add_ray(br);
    if (any_hit) {
      s.batch_add_growing(r, t0, t1, step, 2, false);
    } else {
      s.batch_add_piece(r, t0, t1);
    }
    index.push_back(r);
  }
  s.batch_run();
  std::vector<RootHit> out;
  for (int r : index) out.push_back(s.batch_result(r));
  return out;
}

TEST(RootSearch, BatchedBisectionGivesTheSameHitsAsOneRayAtATime) {
  // Rays that miss everything, cross only the thin shell (which a march of 0.3 steps over),
  // or cross the shell and then the ball; one that starts inside the shell's wall.
  ShellAroundBall f;
  RootSearcher batched(f), plain(f);
  plain.set_plain_bisection(true);
  std::vector<Ray> rays;
  for (int i = 0; i < 64; ++i) rays.push_back({{0.09f * float(i), 0.3f, 20}, {0, 0, -1}});
  rays.push_back({{0, 0, 5.0f}, {0, 0, -1}});
  std::vector<RootHit> got = batch_search(batched, rays, 0, 40, 1e-5f, 0.3f, false);
  int hits = 0, misses = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    RootHit want = plain.interval_search(rays[i], 0, 40, 1e-5f, 0.3f, false);
    ASSERT_EQ(got[i].hit, want.hit) << i;
    EXPECT_EQ(got[i].t, want.t) << i;
    EXPECT_EQ(got[i].at_start, want.at_start) << i;
    (want.hit ? hits : misses)++;
  }
  EXPECT_GT(hits, 40);
  EXPECT_GT(misses, 5);
  EXPECT_TRUE(got.back().at_start);
  // The batch asks for its boxes a round at a time: a few dozen calls for thousands of boxes.
  EXPECT_GT(batched.counters().interval_calls, 1000u);
  EXPECT_LT(f.interval_batches.load(), 100);
}

TEST(RootSearch, BatchedAnyHitAgreesWithTheShadowSearch) {
  // Shadow-like rays leaving the ball's surface outwards: every one must cross the thin shell.
  // Rays leaving the shell's outside into empty space must not.
  ShellAroundBall f;
  RootSearcher batched(f), one(f);
  std::vector<Ray> out_of_ball, out_of_shell;
  for (int i = 0; i < 40; ++i) {
    float a = 0.157f * float(i);
    Vec3 d{std::cos(a), std::sin(a) * 0.6f, std::sin(a) * 0.8f};
    out_of_ball.push_back({d * 2.001f, d});
    out_of_shell.push_back({d * 5.02f, d});
  }
  for (const auto* rays : {&out_of_ball, &out_of_shell}) {
    std::vector<RootHit> got = batch_search(batched, *rays, 0, 20, 1e-5f, 0.3f, true);
    for (size_t i = 0; i < rays->size(); ++i) {
      RootHit want = one.interval_search((*rays)[i], 0, 20, 1e-5f, 0.3f, true);
      ASSERT_EQ(got[i].hit, want.hit) << i;
      EXPECT_EQ(got[i].hit, rays == &out_of_ball) << i;
      if (got[i].hit) {
        EXPECT_NEAR(got[i].t, 3.0f, 0.35f) << i;  // at the shell, within a march step
      }
    }
  }
}

/// A ball whose interval evaluator knows nothing ([-1e30, 1e30] everywhere).
class BallWithUselessIntervals final : public testing::AnalyticField {
 public:
  double value(double x, double y, double z) const override { return ball_.value(x, y, z); }
  Vec3 gradient(double x, double y, double z) const override { return ball_.gradient(x, y, z); }
  Interval interval(const Box&) const override { return {-1e30f, 1e30f}; }

 private:
  SphereField ball_{{0, 0, 0}, 2};
};

TEST(RootSearch, BatchedRaysOutOfBudgetFinishByMarching) {
  // eps far below what the bisection reaches within its budget, with enclosures that never
  // exclude anything: every ray runs out of budget and marches its remaining pieces.
  BallWithUselessIntervals f;
  RootSearcher batched(f);
  std::vector<Ray> rays = {
      {{0, 0, 10}, {0, 0, -1}}, {{1.5f, 0, 10}, {0, 0, -1}}, {{2.5f, 0, 10}, {0, 0, -1}}};
  std::vector<RootHit> got = batch_search(batched, rays, 0, 20, 1e-30f, 0.01f, false);
  EXPECT_EQ(batched.counters().interval_fallbacks, 3u);
  EXPECT_LE(batched.counters().interval_calls, 3u * RootSearcher::kIntervalBudget);
  for (size_t i = 0; i < rays.size(); ++i) {
    ASSERT_EQ(got[i].hit, i < 2) << i;
    if (got[i].hit) {
      double rho = rays[i].o.x;
      EXPECT_NEAR(got[i].t, 10 - std::sqrt(4 - rho * rho), 1e-3) << i;
    }
  }
}

TEST(RootSearch, TangentTouchIsFound) {
  // A ray that grazes the ball at exactly one point (F <= 0 on the whole ray, = 0 once).
  SphereField sphere({0, 0, 0}, 2);
  RootSearcher s(sphere);
  Ray ray{{2, 0, 10}, {0, 0, -1}};
  RootHit h = s.interval_search(ray, 0, 20, 1e-4f, 0.1f, false);
  ASSERT_TRUE(h.hit);
  EXPECT_NEAR(h.t, 10, 1e-2);
}

TEST(RootSearch, AnyHitStopsWithoutRefining) {
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher a(sphere), b(sphere);
  Ray ray{{0, 0, 20}, {0, 0, -1}};
  ASSERT_TRUE(a.sign_search(ray, 0, 40, 0.05f, 1e-6f, true).hit);
  ASSERT_TRUE(b.sign_search(ray, 0, 40, 0.05f, 1e-6f, false).hit);
  EXPECT_LT(a.counters().eval_calls, b.counters().eval_calls);
}

TEST(RootSearch, NanSamplesCountAsOutsideAndAreRecorded) {
  testing::HalfNanSphereField f({0, 0, 0}, 3);
  RootSearcher s(f);
  Ray right{{1, 0, 20}, {0, 0, -1}};  // x > 0: F has no value anywhere on this ray
  EXPECT_FALSE(s.sign_search(right, 0, 40, 0.1f, 1e-5f, false).hit);
  EXPECT_GT(s.counters().nan_samples, 0u);
  ASSERT_TRUE(s.has_nan_point());
  EXPECT_EQ(s.nan_point().x, 1);
  Ray left{{-1, 0, 20}, {0, 0, -1}};
  EXPECT_TRUE(s.sign_search(left, 0, 40, 0.1f, 1e-5f, false).hit);
}

TEST(RootSearch, AnalyticFindsSphereExactly) {
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  Ray ray{{0.5f, 1.0f, 20}, {0, 0, -1}};
  RootHit h = s.analytic_search(ray, 0, 40);
  ASSERT_TRUE(h.hit);
  EXPECT_FALSE(h.at_start);
  EXPECT_NEAR(h.t, 20 - std::sqrt(9.0 - 0.25 - 1.0), 2e-6);
  // One candidate call; F at t0 (outside), then the gaps between the two roots and t1.
  EXPECT_EQ(s.counters().candidate_calls, 1u);
  EXPECT_EQ(s.counters().candidates, 2u);
  EXPECT_EQ(s.counters().eval_calls, 2u);
  EXPECT_EQ(s.counters().eval_points, 3u);
}

TEST(RootSearch, AnalyticStartKnownOutsideSkipsOneSample) {
  // The renderer passes start_outside when t0 ends a culled slab: the same hit (and the same
  // misses), one F sample fewer per call; a ray with no candidate then evaluates nothing.
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  Ray ray{{0.5f, 1.0f, 20}, {0, 0, -1}};
  const RootHit full = s.analytic_search(ray, 0, 40);
  const uint64_t before = s.counters().eval_points;
  const RootHit skip = s.analytic_search(ray, 0, 40, true);
  EXPECT_EQ(s.counters().eval_points - before, 1u);  // the first gap decides: not t0
  ASSERT_TRUE(full.hit && skip.hit);
  EXPECT_EQ(full.t, skip.t);
  EXPECT_FALSE(skip.at_start);
  const uint64_t calls = s.counters().eval_calls;
  EXPECT_FALSE(s.analytic_search({{5, 0, 20}, {0, 0, -1}}, 0, 40, true).hit);
  EXPECT_EQ(s.counters().eval_calls, calls);
}

TEST(RootSearch, AnalyticEndKnownInsideSkipsTheLastGap) {
  // The renderer passes end_inside when the tile's last culling piece was proven inside: the
  // gap reaching t1 is inside without a sample. A ray entering once then needs none at all.
  SphereField sphere({0, 0, 0}, 3);
  RootSearcher s(sphere);
  const Ray ray{{0.5f, 1.0f, 20}, {0, 0, -1}};
  const float t_in = 20 - std::sqrt(9.0f - 0.25f - 1.0f);
  const RootHit full = s.analytic_search(ray, 0, 19);  // ends inside the ball
  uint64_t before = s.counters().eval_points;
  const RootHit both = s.analytic_search(ray, 0, 19, true, true);
  EXPECT_EQ(s.counters().eval_points, before);
  ASSERT_TRUE(full.hit && both.hit);
  EXPECT_EQ(full.t, both.t);
  EXPECT_NEAR(both.t, t_in, 2e-6);
  EXPECT_FALSE(both.at_start);
  // t0 not known outside: only gap 0 is sampled.
  before = s.counters().eval_points;
  const RootHit end = s.analytic_search(ray, 0, 19, false, true);
  EXPECT_EQ(s.counters().eval_points - before, 1u);
  EXPECT_EQ(end.t, full.t);
  // No candidate in an inside range: a hit at its start, without a sample.
  before = s.counters().eval_points;
  const RootHit in = s.analytic_search(ray, 18, 19, false, true);
  EXPECT_TRUE(in.hit && in.at_start);
  EXPECT_EQ(in.t, 18);
  EXPECT_EQ(s.counters().eval_points, before);
  // Two candidates (through the ball) and the range ending past it: the gaps are sampled.
  const RootHit through = s.analytic_search(ray, 0, 40, true, false);
  ASSERT_TRUE(through.hit);
  EXPECT_EQ(through.t, full.t);
}

TEST(RootSearch, AnalyticMissStartInsideAndTangent) {
  SphereField sphere({0, 0, 0}, 2);
  RootSearcher s(sphere);
  EXPECT_FALSE(s.analytic_search({{3, 0, 20}, {0, 0, -1}}, 0, 40).hit);
  RootHit in = s.analytic_search({{0, 0, 1}, {0, 0, -1}}, 0, 10);
  ASSERT_TRUE(in.hit);
  EXPECT_TRUE(in.at_start);
  EXPECT_EQ(in.t, 0);
  // Range ending before the surface: no hit; starting past the near root, inside: at start.
  EXPECT_FALSE(s.analytic_search({{0, 0, 20}, {0, 0, -1}}, 0, 17).hit);
  RootHit mid = s.analytic_search({{0, 0, 20}, {0, 0, -1}}, 19, 30);
  EXPECT_TRUE(mid.hit && mid.at_start);
  // A ray touching the ball at one point is not a hit (F < 0 on both sides of the double root).
  EXPECT_FALSE(s.analytic_search({{2, 0, 10}, {0, 0, -1}}, 0, 20).hit);
}

TEST(RootSearch, AnalyticNeverMissesAThinShell) {
  // Shell 0.001 thick: every ray through it is hit at the outer sphere, to float precision.
  ShellField shell(5, 0.001);
  RootSearcher s(shell);
  for (int i = 0; i < 200; ++i) {
    Ray ray{{0.0249f * float(i), 0.3f, 20}, {0, 0, -1}};
    RootHit h = s.analytic_search(ray, 0, 40);
    ASSERT_TRUE(h.hit) << i;
    double rho2 = double(ray.o.x) * ray.o.x + 0.09;
    EXPECT_NEAR(h.t, 20 - std::sqrt(25 - rho2), 1e-5) << i;
  }
}

TEST(RootSearch, SegmentBoxEnclosesSamples) {
  Ray ray{{1.1f, -3.3f, 7.7f}, {0.3f, 0.77f, -1.9f}};
  Box b = segment_box(ray, 0.25f, 9.5f);
  for (int i = 0; i <= 1000; ++i) {
    float t = 0.25f + (9.5f - 0.25f) * float(i) / 1000.0f;
    ASSERT_TRUE(b.contains(ray.o + ray.d * t)) << t;
  }
}

}  // namespace
}  // namespace hfrt::render
