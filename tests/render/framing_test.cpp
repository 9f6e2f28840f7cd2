#include "render/framing.h"

#include <gtest/gtest.h>

#include "render/renderer.h"
#include "testsupport/analytic_fields.h"

namespace hfrt::render {
namespace {

using testing::SphereField;
using testing::TorusField;

const Box kDefaultBox{{-10, -10, -10}, {10, 10, 10}};

TEST(Framing, ExtentByIntervalsEnclosesTheSolidTightly) {
  SphereField sphere({3, -2, 1}, 2);
  bool by_interval = false;
  Box e = find_extent(sphere, kDefaultBox, 6, &by_interval);
  EXPECT_TRUE(by_interval);
  // Encloses the ball...
  EXPECT_LE(e.lo.x, 1.0f);
  EXPECT_GE(e.hi.x, 5.0f);
  EXPECT_LE(e.lo.y, -4.0f);
  EXPECT_GE(e.hi.y, 0.0f);
  EXPECT_LE(e.lo.z, -1.0f);
  EXPECT_GE(e.hi.z, 3.0f);
  // ... within about one octree cell (20 / 64).
  EXPECT_GT(e.lo.x, 1.0f - 0.32f);
  EXPECT_LT(e.hi.x, 5.0f + 0.32f);
  EXPECT_LT(e.hi.y, 0.0f + 0.32f);
}

TEST(Framing, ExtentBySamplingWithoutIntervals) {
  SphereField sphere({3, -2, 1}, 2);
  sphere.set_has_interval(false);
  bool by_interval = true;
  Box e = find_extent(sphere, kDefaultBox, 6, &by_interval);
  EXPECT_FALSE(by_interval);
  EXPECT_LE(e.lo.x, 1.0f);
  EXPECT_GE(e.hi.x, 5.0f);
  EXPECT_GT(e.lo.x, 1.0f - 0.7f);
  EXPECT_LT(e.hi.x, 5.0f + 0.7f);
}

/// Counts the points asked for their values (eval) and for their sides (eval_sides) apart.
class CountingField final : public Field {
 public:
  explicit CountingField(const Field& f) : f_(f) {}
  void eval(size_t n, const float* x, const float* y, const float* z, float* out) const override {
    points += n;
    f_.eval(n, x, y, z, out);
  }
  void eval_sides(size_t n, const float* x, const float* y, const float* z,
                  float* out) const override {
    sides += n;
    f_.eval(n, x, y, z, out);
  }
  bool has_interval() const override { return f_.has_interval(); }
  Interval eval_interval(const Box& box, bool* maybe_nan) const override {
    return f_.eval_interval(box, maybe_nan);
  }
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f, float* dx,
                     float* dy, float* dz) const override {
    f_.eval_gradient(n, x, y, z, f, dx, dy, dz);
  }
  mutable size_t points = 0, sides = 0;

 private:
  const Field& f_;
};

TEST(Framing, SamplesAskForSidesNotValues) {
  // Framing only compares F with 0, so its samples go through eval_sides (which a mesh or
  // patch leaf answers by a winding number, not a distance query), with and without intervals.
  for (bool intervals : {false, true}) {
    testing::BallsField balls({testing::BallsField::Ball{{3, -2, 1}, 2}});
    balls.set_has_interval(intervals);
    CountingField f(balls);
    const Box e = find_extent(f, kDefaultBox, 6);
    EXPECT_GT(f.sides, 0u);
    EXPECT_EQ(f.points, 0u);
    EXPECT_NEAR(e.lo.x, 1.0f, 0.7f);
    EXPECT_NEAR(e.hi.x, 5.0f, 0.7f);
  }
}

TEST(Framing, SamplingSweepFindsTheSameBoxAsEveryGridPoint) {
  // Regression for the slice sweep of the sampled extent: it must give the box of the inside
  // points of the whole grid (plus one cell); after the interval octree has found a tight box
  // it evaluates far fewer points than the n^3 of the grid.
  using Ball = testing::BallsField::Ball;
  testing::BallsField balls({Ball{{3, -2, 1}, 2}, Ball{{-4, 5, -6}, 1.5}, Ball{{6, 6, 6}, 0.7}});
  balls.set_has_interval(false);
  const int depth = 6, n = (1 << depth) + 1;
  const Vec3 cell = kDefaultBox.size() / float(n - 1);
  Vec3 lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        Vec3 p{i == n - 1 ? kDefaultBox.hi.x : kDefaultBox.lo.x + cell.x * float(i),
               j == n - 1 ? kDefaultBox.hi.y : kDefaultBox.lo.y + cell.y * float(j),
               k == n - 1 ? kDefaultBox.hi.z : kDefaultBox.lo.z + cell.z * float(k)};
        float f;
        balls.eval(1, &p.x, &p.y, &p.z, &f);
        if (f >= 0) lo = vmin(lo, p), hi = vmax(hi, p);
      }
    }
  }
  Box want{vmax(lo - cell, kDefaultBox.lo), vmin(hi + cell, kDefaultBox.hi)};
  CountingField counted(balls);
  Box got = find_extent(counted, kDefaultBox, depth);
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(got.lo[a], want.lo[a]) << "axis " << a;
    EXPECT_EQ(got.hi[a], want.hi[a]) << "axis " << a;
  }
  testing::BallsField ball({Ball{{3, -2, 1}, 2}});
  CountingField counted_ball(ball);
  Box e = find_extent(counted_ball, kDefaultBox, depth);
  EXPECT_LE(e.lo.x, 1.0f);
  EXPECT_GE(e.hi.x, 5.0f);
  EXPECT_LT(counted_ball.sides, size_t(n) * n * n / 2);  // measured: a third
  EXPECT_EQ(counted_ball.points, 0u);                    // the sweep asks for sides only
}

TEST(Framing, EmptyModelFallsBackToTheBox) {
  SphereField nothing({50, 50, 50}, 1);
  Box e = find_extent(nothing, kDefaultBox);
  EXPECT_EQ(e.lo.x, -10);
  EXPECT_EQ(e.hi.z, 10);
}

TEST(Framing, ProvenExtentHoldsEveryInsidePointAndCostsBatches) {
  // A torus lying in the xz plane: a flat solid, whose faces in y an octree reaches last.
  TorusField torus(2.5, 0.4);
  const Box box{{-4, -4, -4}, {4, 4, 4}};
  const Box e = proven_extent(torus, box, 6, 200000);
  // Every point where F >= 0 lies inside (a grid through the torus).
  int inside = 0;
  for (int i = 0; i <= 64; ++i) {
    for (int j = 0; j <= 16; ++j) {
      for (int k = 0; k <= 64; ++k) {
        const Vec3 p{-3.0f + 6.0f * float(i) / 64, -0.5f + 1.0f * float(j) / 16,
                     -3.0f + 6.0f * float(k) / 64};
        if (torus.value(p.x, p.y, p.z) < 0) continue;
        ++inside;
        EXPECT_TRUE(e.contains(p)) << p.x << " " << p.y << " " << p.z;
      }
    }
  }
  EXPECT_GT(inside, 1000);
  // Within two cells (8 / 64) of the torus' box [-2.9, 2.9] x [-0.4, 0.4] x [-2.9, 2.9].
  EXPECT_LT(e.hi.x, 2.9f + 0.25f);
  EXPECT_GT(e.lo.z, -2.9f - 0.25f);
  EXPECT_LT(e.hi.y, 0.4f + 0.25f);
  // One batch of the interval evaluator per level (7 levels).
  EXPECT_LE(torus.interval_batches.load(), 7);
}

TEST(Framing, ProvenExtentStopsALevelEarlyAtItsBudget) {
  TorusField torus(2.5, 0.4);
  const Box box{{-4, -4, -4}, {4, 4, 4}};
  const Box full = proven_extent(torus, box, 6, 200000);
  const Box capped = proven_extent(torus, box, 6, 600);
  // Looser, but still holding the full depth's box (and so the solid).
  EXPECT_TRUE(capped.contains(full.lo) && capped.contains(full.hi));
  EXPECT_GT(capped.hi.y, full.hi.y);
  EXPECT_LE(torus.interval_batches.load(), 7 + 6);
}

TEST(Framing, ProvenExtentOfNothingIsEmpty) {
  SphereField nothing({50, 50, 50}, 1);
  EXPECT_TRUE(proven_extent(nothing, kDefaultBox, 6, 4096).empty());
}

TEST(Framing, DefaultCameraFitsTheSolidInTheFrame) {
  SphereField sphere({3, -2, 1}, 2);
  Box e = find_extent(sphere, kDefaultBox);
  RenderOptions o;
  o.width = 96;
  o.height = 64;
  o.camera = resolve_camera({}, e, float(o.width) / float(o.height));
  o.shadows = false;
  EXPECT_EQ(o.camera.kind, Camera::Kind::kPerspective);
  // Three-quarter view: from the right, above and in front.
  Vec3 dir = o.camera.eye - o.camera.look_at;
  EXPECT_GT(dir.x, 0);
  EXPECT_GT(dir.y, 0);
  EXPECT_GT(dir.z, 0);
  RenderResult res = render(sphere, o);
  // Visible, not touching the border, and filling a fair part of the frame.
  size_t covered = 0, border = 0;
  for (int y = 0; y < o.height; ++y) {
    for (int x = 0; x < o.width; ++x) {
      bool hit = res.image.alpha[size_t(y) * o.width + x] > 0;
      covered += hit;
      if (hit && (x == 0 || y == 0 || x == o.width - 1 || y == o.height - 1)) ++border;
    }
  }
  EXPECT_EQ(border, 0u);
  EXPECT_GT(covered, size_t(o.width * o.height) / 10);
}

TEST(Framing, UserPartsOfTheCameraAreKept) {
  Box e{{-1, -1, -1}, {1, 1, 1}};
  CameraRequest req;
  req.eye = Vec3{0, 0, 9};
  req.fov_deg = 20;
  Camera c = resolve_camera(req, e, 1.0f);
  EXPECT_EQ(c.eye.z, 9);
  EXPECT_EQ(c.look_at.x, 0);
  EXPECT_EQ(c.fov_deg, 20);
  req = {};
  req.look_at = Vec3{5, 5, 5};
  req.ortho_width = 4;
  c = resolve_camera(req, e, 1.0f);
  EXPECT_EQ(c.kind, Camera::Kind::kOrthographic);
  EXPECT_EQ(c.ortho_width, 4);
  EXPECT_EQ(c.look_at.y, 5);
  EXPECT_GT(length(c.eye - c.look_at), 1.0f);
}

}  // namespace
}  // namespace hfrt::render
