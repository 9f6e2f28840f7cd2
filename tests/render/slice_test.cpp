#include "render/slice.h"

#include <gtest/gtest.h>

#include <cmath>

#include "testsupport/analytic_fields.h"

namespace hfrt::render {
namespace {

using testing::SphereField;

TEST(Slice, DiskAreaAndIntervalFill) {
  // The z = 1 slice of a ball of radius 3 is a disk of radius sqrt(8).
  SphereField ball({0, 0, 0}, 3);
  SliceOptions o;
  o.width = o.height = 256;
  o.x0 = o.y0 = -4;
  o.x1 = o.y1 = 4;
  o.z = 1;
  SliceResult res = render_slice(ball, o);
  double pixel = (8.0 / 256) * (8.0 / 256);
  EXPECT_NEAR(double(res.stats.pixels_inside) * pixel / (M_PI * 8), 1.0, 0.005);
  // Intervals settle most pixels without a point evaluation.
  EXPECT_GT(res.stats.pixels_by_interval, uint64_t(256 * 256) / 2);
  EXPECT_LT(res.stats.evals.eval_points, uint64_t(256 * 256) / 2);
  // Every pixel agrees with the point test at its centre.
  size_t wrong = 0, inside = 0;
  for (int j = 0; j < o.height; ++j) {
    for (int i = 0; i < o.width; ++i) {
      float x = o.x0 + (i + 0.5f) * (o.x1 - o.x0) / o.width;
      float y = o.y1 - (j + 0.5f) * (o.y1 - o.y0) / o.height;
      bool expected = ball.value(x, y, o.z) >= 0;
      bool got = res.inside[size_t(j) * o.width + i] != 0;
      wrong += expected != got;
      inside += got;
    }
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(inside, res.stats.pixels_inside);
}

TEST(Slice, OffCentreDiskIsWhereItShouldBe) {
  SphereField ball({2, 1, 0}, 1);
  SliceOptions o;
  o.width = 100;
  o.height = 50;
  o.x0 = 0, o.x1 = 4, o.y0 = 0, o.y1 = 2;
  SliceResult res = render_slice(ball, o);
  // Centre (2, 1) is pixel (50, 25); y grows upwards, so (2, 1.8) is row 5.
  EXPECT_EQ(res.inside[25 * 100 + 50], 1);
  EXPECT_EQ(res.inside[5 * 100 + 50], 1);
  EXPECT_EQ(res.inside[25 * 100 + 5], 0);
  EXPECT_EQ(res.inside[1 * 100 + 95], 0);
}

TEST(Slice, SameResultWithAndWithoutIntervalsAndThreads) {
  testing::TorusField torus(4, 1.5);
  SliceOptions o;
  o.width = o.height = 200;
  o.z = 0.5f;
  o.threads = 1;
  SliceResult a = render_slice(torus, o);
  o.threads = 2;
  o.use_interval = false;
  SliceResult b = render_slice(torus, o);
  EXPECT_EQ(b.stats.evals.interval_calls, 0u);
  EXPECT_EQ(a.inside, b.inside);
  EXPECT_GT(a.stats.pixels_inside, 1000u);
}

}  // namespace
}  // namespace hfrt::render
