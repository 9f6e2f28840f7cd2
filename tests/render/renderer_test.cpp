#include "render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "tests/render/box_coverage.h"
#include "testsupport/analytic_fields.h"

namespace hfrt::render {
namespace {

using testing::ShellField;
using testing::SphereField;
using testing::TorusField;

/// An orthographic camera looking down -z from z = 20 with a view `width` wide.
RenderOptions ortho_options(int size, float width) {
  RenderOptions o;
  o.width = o.height = size;
  o.camera.kind = Camera::Kind::kOrthographic;
  o.camera.eye = {0, 0, 20};
  o.camera.look_at = {0, 0, 0};
  o.camera.ortho_width = width;
  o.shadows = false;
  return o;
}

size_t covered_pixels(const Image& img) {
  size_t n = 0;
  for (float a : img.alpha) n += a > 0;
  return n;
}

class SphereOrtho : public ::testing::TestWithParam<RootMode> {};

TEST_P(SphereOrtho, AreaDepthAndNormalsMatchTheAnalyticSphere) {
  const double r = 3;
  SphereField sphere({0, 0, 0}, r);
  RenderOptions o = ortho_options(400, 8);
  o.root = GetParam();
  RenderResult res = render(sphere, o);
  const Image& img = res.image;
  // auto picks the analytic search: the sphere lists its ray candidates.
  RootMode expected_mode = GetParam() == RootMode::kAuto ? RootMode::kAnalytic : GetParam();
  EXPECT_EQ(res.stats.root_used, expected_mode);

  // Area: pixels covered times pixel area vs pi r^2, within 0.5 %.
  double pixel_area = (8.0 / 400) * (8.0 / 400);
  double area = double(covered_pixels(img)) * pixel_area;
  EXPECT_NEAR(area / (M_PI * r * r), 1.0, 0.005);

  // Depth (exact to 1e-4 of the box size) and normals (the normalised analytic gradient) at
  // every hit pixel, from the same rays the renderer used.
  CameraFrame frame(o.camera, o.width, o.height);
  const double box = o.bbox.max_extent();
  double worst_depth = 0, worst_normal = 0;
  for (int y = 0; y < o.height; ++y) {
    for (int x = 0; x < o.width; ++x) {
      size_t i = size_t(y) * o.width + x;
      Ray ray = frame.ray(x + 0.5f, y + 0.5f);
      double rho2 = double(ray.o.x) * ray.o.x + double(ray.o.y) * ray.o.y;
      if (img.alpha[i] == 0) {
        // A miss is allowed only within a hair of the silhouette.
        EXPECT_GT(rho2, (r - 1e-3) * (r - 1e-3)) << x << "," << y;
        continue;
      }
      ASSERT_LE(rho2, (r + 1e-3) * (r + 1e-3)) << x << "," << y;
      double expected = 20 - std::sqrt(std::max(0.0, r * r - rho2));
      worst_depth = std::max(worst_depth, std::abs(img.depth[i] - expected));
      // Analytic outward normal at the rendered hit point.
      Vec3 p = ray.o + ray.d * img.depth[i];
      Vec3 n = normalize(p);
      for (int k = 0; k < 3; ++k) {
        worst_normal = std::max(worst_normal, double(std::abs(img.normal[3 * i + k] - n[k])));
      }
    }
  }
  EXPECT_LE(worst_depth, 1e-4 * box);
  EXPECT_LE(worst_normal, 1e-4);
}

INSTANTIATE_TEST_SUITE_P(Roots, SphereOrtho,
                         ::testing::Values(RootMode::kSign, RootMode::kInterval, RootMode::kAuto,
                                           RootMode::kAnalytic),
                         [](const auto& info) { return std::string(root_mode_name(info.param)); });

TEST(Renderer, SignModeWithoutIntervalsStillFindsTheSphere) {
  SphereField sphere({0, 0, 0}, 3);
  sphere.set_has_interval(false);
  sphere.set_has_ray_candidates(false);
  RenderOptions o = ortho_options(200, 8);
  RenderResult res = render(sphere, o);
  EXPECT_EQ(res.stats.root_used, RootMode::kSign);
  EXPECT_EQ(sphere.interval_calls.load(), 0);
  double area = double(covered_pixels(res.image)) * (8.0 / 200) * (8.0 / 200);
  EXPECT_NEAR(area / (M_PI * 9), 1.0, 0.01);
}

/// Pixels whose ray passes well inside the outer sphere but which were not hit.
size_t shell_holes(const RenderResult& res, const RenderOptions& o, double r) {
  CameraFrame frame(o.camera, o.width, o.height);
  size_t holes = 0;
  for (int y = 0; y < o.height; ++y) {
    for (int x = 0; x < o.width; ++x) {
      Ray ray = frame.ray(x + 0.5f, y + 0.5f);
      double rho2 = double(ray.o.x) * ray.o.x + double(ray.o.y) * ray.o.y;
      if (rho2 < (r - 1e-3) * (r - 1e-3) && res.image.alpha[size_t(y) * o.width + x] == 0) ++holes;
    }
  }
  return holes;
}

TEST(Renderer, ThinShellHasNoHolesWithIntervalRoot) {
  const double r = 5;
  ShellField shell(r, 0.01);
  RenderOptions o = ortho_options(160, 12);
  o.root = RootMode::kInterval;
  RenderResult res = render(shell, o);
  EXPECT_EQ(shell_holes(res, o, r), 0u);
  EXPECT_GT(covered_pixels(res.image), 100u);

  // The same shell with a coarse sign-change step does have holes: the check can fail.
  o.root = RootMode::kSign;
  o.step = 0.5f;
  RenderResult coarse = render(shell, o);
  EXPECT_GT(shell_holes(coarse, o, r), 100u);
}

TEST(Renderer, ThinShellPerspectiveWithShadowsHasNoHoles) {
  const double r = 5;
  ShellField shell(r, 0.01);
  RenderOptions o;
  o.width = o.height = 96;
  o.camera.eye = {0, 0, 25};
  o.camera.look_at = {0, 0, 0};
  o.camera.fov_deg = 30;
  o.root = RootMode::kInterval;
  RenderResult res = render(shell, o);
  CameraFrame frame(o.camera, o.width, o.height);
  size_t holes = 0;
  for (int y = 0; y < o.height; ++y) {
    for (int x = 0; x < o.width; ++x) {
      Ray ray = frame.ray(x + 0.5f, y + 0.5f);
      // Distance from the centre to the ray's line.
      Vec3 d = normalize(ray.d);
      Vec3 c = -ray.o;
      double dist = length(c - d * dot(c, d));
      if (dist < r - 1e-2 && res.image.alpha[size_t(y) * o.width + x] == 0) ++holes;
    }
  }
  EXPECT_EQ(holes, 0u);
}

// The pruned march (RenderOptions::interval_pruned_march, the default: depths bisected front
// to back before the march visits what is left) and the march over every depth find the same
// first hits. Balls seen in perspective, with a march step wider than the smallest ball, so
// that the proof and not the march finds it: the coverage is the same pixel for pixel, the
// depths agree to the tolerance, and the small ball is there (the march alone misses it).
TEST(Renderer, PrunedMarchFindsWhatTheFullMarchFinds) {
  using testing::BallsField;
  BallsField balls({{{0, 0, 0}, 2.0}, {{1.2, 1.2, 2.6}, 0.06}, {{-2.4, 0.4, 1}, 0.6}});
  RenderOptions o;
  o.width = o.height = 160;
  o.camera.eye = {0, 0, 12};
  o.camera.look_at = {0, 0, 0};
  o.camera.fov_deg = 35;
  o.bbox = Box{{-4, -4, -4}, {4, 4, 4}};
  o.root = RootMode::kInterval;
  o.step = 0.15f;  // the pieces the march visits: 32 steps, 4.8 (a third of the depth range)
  RenderResult pruned = render(balls, o);
  EXPECT_EQ(pruned.stats.root_used, RootMode::kInterval);
  o.interval_pruned_march = false;
  RenderResult full = render(balls, o);
  size_t covered = 0, small_ball = 0;
  double worst = 0;
  CameraFrame frame(o.camera, o.width, o.height);
  for (size_t i = 0; i < pruned.image.alpha.size(); ++i) {
    ASSERT_EQ(pruned.image.alpha[i], full.image.alpha[i]) << "pixel " << i;
    if (pruned.image.alpha[i] == 0) continue;
    ++covered;
    worst = std::max(worst, double(std::abs(pruned.image.depth[i] - full.image.depth[i])));
    const Ray ray = frame.ray(float(i % size_t(o.width)) + 0.5f, float(i / size_t(o.width)) + 0.5f);
    const Vec3 p = ray.o + normalize(ray.d) * pruned.image.depth[i];  // depth: the distance
    small_ball += length(p - Vec3{1.2f, 1.2f, 2.6f}) < 0.07f;
  }
  EXPECT_GT(covered, 2000u);
  EXPECT_GE(small_ball, 4u);
  EXPECT_LE(worst, 1e-4 * o.bbox.max_extent());
  // The march alone, at this step, misses part of the small ball: the check can fail.
  o.root = RootMode::kSign;
  RenderResult sign = render(balls, o);
  size_t sign_covered = 0;
  for (float a : sign.image.alpha) sign_covered += a > 0;
  EXPECT_LT(sign_covered, covered);
}

TEST(Renderer, SameImageForAnyThreadCount) {
  TorusField torus(4, 1.5);
  RenderOptions o;
  o.width = 80;
  o.height = 64;
  o.camera.eye = {6, 9, 14};
  o.camera.look_at = {0, 0, 0};
  o.spp = 4;
  o.tile_size = 8;
  for (RootMode mode : {RootMode::kSign, RootMode::kInterval}) {
    o.root = mode;
    o.threads = 1;
    RenderResult a = render(torus, o);
    o.threads = 2;
    RenderResult b = render(torus, o);
    o.threads = 3;
    RenderResult c = render(torus, o);
    ASSERT_GT(covered_pixels(a.image), 500u);
    EXPECT_EQ(a.stats.threads, 1);
    EXPECT_EQ(b.stats.threads, 2);
    for (const RenderResult* other : {&b, &c}) {
      ASSERT_EQ(a.image.rgb.size(), other->image.rgb.size());
      EXPECT_EQ(0,
                std::memcmp(a.image.rgb.data(), other->image.rgb.data(), a.image.rgb.size() * 4));
      EXPECT_EQ(0, std::memcmp(a.image.depth.data(), other->image.depth.data(),
                               a.image.depth.size() * 4));
      EXPECT_EQ(0, std::memcmp(a.image.normal.data(), other->image.normal.data(),
                               a.image.normal.size() * 4));
      EXPECT_EQ(a.stats.evals.eval_points, other->stats.evals.eval_points);
    }
  }
}

TEST(Renderer, TileCullingSkipsEmptySpaceWithoutChangingCoverage) {
  SphereField sphere({2, 1, 0}, 1.5);
  RenderOptions o = ortho_options(128, 16);
  o.root = RootMode::kSign;
  o.tile_culling = true;
  RenderResult culled = render(sphere, o);
  o.tile_culling = false;
  RenderResult full = render(sphere, o);
  EXPECT_GT(culled.stats.tiles_empty, culled.stats.tiles / 2);
  EXPECT_EQ(full.stats.tiles_empty, 0u);
  EXPECT_LT(culled.stats.evals.eval_points, full.stats.evals.eval_points / 4);
  size_t differ = 0;
  for (size_t i = 0; i < culled.image.alpha.size(); ++i)
    differ += culled.image.alpha[i] != full.image.alpha[i];
  EXPECT_LE(differ, 2u);
  EXPECT_EQ(covered_pixels(culled.image), covered_pixels(full.image));
}

TEST(Renderer, SupersamplingGivesFractionalCoverageOnTheSilhouette) {
  SphereField sphere({0, 0, 0}, 3);
  RenderOptions o = ortho_options(64, 8);
  o.spp = 9;
  RenderResult res = render(sphere, o);
  size_t partial = 0;
  double sum = 0;
  for (float a : res.image.alpha) {
    partial += a > 0 && a < 1;
    sum += a;
  }
  EXPECT_GT(partial, 20u);
  double area = sum * (8.0 / 64) * (8.0 / 64);
  EXPECT_NEAR(area / (M_PI * 9), 1.0, 0.01);
  // Deterministic seeds: rendering again gives the same bits.
  RenderResult again = render(sphere, o);
  EXPECT_EQ(0, std::memcmp(res.image.rgb.data(), again.image.rgb.data(), res.image.rgb.size() * 4));
}

TEST(Renderer, ColourComesFromAttributes) {
  testing::ColouredSphereField sphere({0, 0, 0}, 3);
  RenderOptions o = ortho_options(64, 8);
  RenderResult res = render(sphere, o);
  // A pixel on the right half is red-ish, one on the left blue-ish.
  size_t right = size_t(32) * 64 + 44, left = size_t(32) * 64 + 20;
  ASSERT_GT(res.image.alpha[right], 0);
  ASSERT_GT(res.image.alpha[left], 0);
  EXPECT_GT(res.image.rgb[3 * right], 3 * res.image.rgb[3 * right + 2]);
  EXPECT_GT(res.image.rgb[3 * left + 2], 3 * res.image.rgb[3 * left]);
  EXPECT_GT(res.stats.evals.attribute_calls, 0u);
}

TEST(Renderer, BackgroundAndShadows) {
  // A small ball above a big one, lit from straight above, seen from the side: the top of the
  // big ball, right under the small one, is in its shadow.
  testing::BallsField balls({{{0, -4, 0}, 4.0}, {{0, 2.5f, 0}, 1.0}});
  RenderOptions o = ortho_options(64, 10);
  o.lights = {{Light::Kind::kDirectional, {0, 1, 0}, {1, 1, 1}}};
  o.background = {0.5f, 0.25f, 0.125f};
  o.shadows = true;
  RenderResult lit = render(balls, o);
  o.shadows = false;
  RenderResult unshadowed = render(balls, o);
  // Corner pixel: the background exactly.
  EXPECT_EQ(lit.image.rgb[0], 0.5f);
  EXPECT_EQ(lit.image.rgb[1], 0.25f);
  EXPECT_EQ(lit.image.rgb[2], 0.125f);
  // Pixel (32, 32) sees the big ball at about (0.08, -0.08, 0.79): shadowed by the small ball.
  size_t under = size_t(32) * 64 + 32;
  ASSERT_EQ(lit.image.alpha[under], 1);
  EXPECT_LT(lit.image.rgb[3 * under], 0.5f * unshadowed.image.rgb[3 * under]);
  // Pixel (10, 48) sees the big ball's left flank at (-3.36, -2.58, 1.64): lit in both.
  size_t flank = size_t(48) * 64 + 10;
  ASSERT_EQ(lit.image.alpha[flank], 1);
  EXPECT_EQ(lit.image.rgb[3 * flank], unshadowed.image.rgb[3 * flank]);
  EXPECT_GT(lit.stats.shadow_rays, 0u);
  EXPECT_EQ(unshadowed.stats.shadow_rays, 0u);
}

TEST(Renderer, ShadowCullingKeepsTheShadows) {
  // The scene above lit from behind, so that the shadow faces the camera. With tile culling,
  // the interval search's shadow rays are searched only inside the box where intervals have
  // not proven the solid absent (a box of 20 around balls 8 wide), and the sign-change
  // search's are culled as a bundle per tile first. The shadow must be the same as without
  // any culling (pixels in shadow: darker than half the unshadowed shade).
  testing::BallsField balls({{{0, -4, 0}, 4.0}, {{0, 2.5f, 0}, 1.0}});
  for (RootMode root : {RootMode::kInterval, RootMode::kSign}) {
    SCOPED_TRACE(root_mode_name(root));
    RenderOptions o = ortho_options(128, 10);
    o.lights = {{Light::Kind::kDirectional, {0, 1, -0.3f}, {1, 1, 1}}};
    o.root = root;
    o.shadows = false;
    RenderResult unshadowed = render(balls, o);
    o.shadows = true;
    RenderResult culled = render(balls, o);
    o.tile_culling = false;
    RenderResult full = render(balls, o);
    auto in_shadow = [&](const RenderResult& r) {
      size_t n = 0;
      for (size_t i = 0; i < r.image.alpha.size(); ++i) {
        n += r.image.alpha[i] > 0 && r.image.rgb[3 * i] < 0.5f * unshadowed.image.rgb[3 * i];
      }
      return n;
    };
    size_t a = in_shadow(culled), b = in_shadow(full);
    EXPECT_GT(b, 50u);
    EXPECT_NEAR(double(a), double(b), 0.02 * double(b));
    if (root == RootMode::kInterval) {
      EXPECT_LT(culled.stats.evals.interval_calls, full.stats.evals.interval_calls);
    } else {
      EXPECT_LT(culled.stats.evals.eval_points, full.stats.evals.eval_points);
    }
  }
}

TEST(Renderer, NanSamplesAreCountedAndExplained) {
  testing::HalfNanSphereField f({0, 0, 0}, 3);
  RenderOptions o = ortho_options(64, 8);
  o.root = RootMode::kSign;
  RenderResult res = render(f, o);
  EXPECT_GT(res.stats.evals.nan_samples, 0u);
  ASSERT_TRUE(res.stats.has_nan_point);
  EXPECT_GT(res.stats.nan_point.x, 0);
  EXPECT_EQ(res.stats.nan_explanation, "sqrt of a negative (test)");
  // NaN counts as outside: the right half is empty, the left half is there.
  size_t right = size_t(32) * 64 + 44, left = size_t(32) * 64 + 20;
  EXPECT_EQ(res.image.alpha[right], 0);
  EXPECT_EQ(res.image.alpha[left], 1);
}

TEST(Renderer, BoxClipsTheSolidWithAFlatCap) {
  // A ball larger than the box: what is seen is the box face, with its normal.
  SphereField big({0, 0, 0}, 30);
  RenderOptions o = ortho_options(32, 8);
  RenderResult res = render(big, o);
  size_t c = size_t(16) * 32 + 16;
  ASSERT_EQ(res.image.alpha[c], 1);
  EXPECT_NEAR(res.image.depth[c], 10, 1e-5);  // the face z = 10 seen from z = 20
  EXPECT_EQ(res.image.normal[3 * c + 2], 1.0f);
}

TEST(Renderer, BoxCapsSeenInPerspectiveHaveNoHoles) {
  // Regression (found on the gallery's 'Infinity' by bench/peers/povray: tile-sized holes in
  // its caps): a shell larger than the box (outer radius 30, hollow of radius 5 at the centre)
  // fills the box's faces, so every camera ray that meets the box hits its cap, and the
  // hollow keeps the culling from taking the whole depth range at once. A tile's depth slab that is
  // inside the solid where it overlaps the box used to end the tile's culling ("every ray is inside
  // by now"), although rays of the tile that enter the box later had not reached the solid yet:
  // their caps were lost.
  for (RootMode mode : {RootMode::kSign, RootMode::kInterval, RootMode::kAnalytic}) {
    ShellField big(30, 25);
    RenderOptions o;
    o.width = o.height = 96;
    o.camera.eye = {30.5f, 24.8f, 43.6f};
    o.camera.look_at = {0, 0, 0};
    o.camera.fov_deg = 35;
    o.shadows = false;
    o.root = mode;
    RenderResult res = render(big, o);
    const hfrt::testing::BoxCoverage c = hfrt::testing::box_coverage(o.camera, o.bbox, res.image);
    EXPECT_GT(c.meets, 2000u);
    EXPECT_EQ(c.wrong, 0u) << "root mode " << int(mode);
  }
}

TEST(Renderer, ProgressIsReportedForEveryTile) {
  SphereField sphere({0, 0, 0}, 3);
  RenderOptions o = ortho_options(64, 8);
  o.tile_size = 16;
  std::atomic<size_t> calls{0}, last_total{0};
  o.progress = [&](size_t, size_t total) {
    calls++;
    last_total = total;
  };
  render(sphere, o);
  EXPECT_EQ(calls.load(), 16u);
  EXPECT_EQ(last_total.load(), 16u);
}

}  // namespace
}  // namespace hfrt::render
