// Time in scenes (issue 24), against closed forms: a sphere moved by x[4] (a metamorphosis
// model) and one moved by keyed translate land where their formulas put them in every frame; a
// keyed parameter (the radius) gives the area of its interpolated value; motion blur of a
// sphere crossing the image gives the coverage profile the shutter predicts; a render of a
// subset of tiles (what one MPI rank does) is bit-identical to the full render on those tiles.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "app/scene_job.h"
#include "render/tiles.h"
#include "scene/scene_file.h"

namespace hfrt::app {
namespace {

// An orthographic camera 8 units wide over 128 x 32 pixels: pixel (x, y) has its centre at
// world ((x + 0.5) / 16 - 4, 1 - (y + 0.5) / 16).
const char* const kCamera = R"toml(
[camera]
eye = [0, 0, 10]
look_at = [0, 0, 0]
ortho = 8
[render]
size = [128, 32]
background = [0, 0, 0]
)toml";

// x[4] moves the unit sphere from x = -2 (time 0) to x = 2 (time 1).
const char* const kMoving = R"toml(
[[object]]
source = "my_model(x[4], a[1]) { cx = -2 + 4 * x[4]; my_model = 1 - (x[1] - cx)^2 - x[2]^2 - x[3]^2; }"
bbox = [-4, -2, -2, 4, 2, 2]
)toml";

scene::SceneDesc parse(const std::string& text) {
  scene::SceneDesc d;
  scene::SceneError err;
  EXPECT_TRUE(scene::parse_scene(text, "/tmp/hfrt_scene_time_test.toml", &d, &err)) << err.render();
  return d;
}

std::unique_ptr<PreparedScene> prepare(const scene::SceneDesc& d, SceneJobResult* res,
                                       SceneOverrides ov = {}) {
  ov.threads = 2;
  auto p = PreparedScene::prepare(d, ov, res);
  EXPECT_TRUE(p) << res->error;
  return p;
}

double world_x(int x) {
  return (x + 0.5) / 16.0 - 4.0;
}

/// The mean world x of the covered pixels of row y, and how many there are.
double row_centre(const render::Image& img, int y, int* count) {
  double sum = 0;
  *count = 0;
  for (int x = 0; x < img.width; ++x) {
    if (img.alpha[size_t(y) * img.width + x] > 0.5f) {
      sum += world_x(x);
      ++*count;
    }
  }
  return *count ? sum / *count : NAN;
}

TEST(SceneTime, MovingSphereLandsWhereTheClosedFormPutsItInEveryFrame) {
  for (const char* root : {"analytic", "interval", "sign"}) {
    scene::SceneDesc d = parse(std::string(kCamera) + "root = \"" + root +
                               "\"\n[animation]\nframes = 5\nend = 1\n" + kMoving);
    SceneJobResult res;
    auto p = prepare(d, &res);
    ASSERT_TRUE(p);
    EXPECT_EQ(res.compilations, 1u);
    for (int f = 0; f < 5; ++f) {
      const double t = d.animation.frame_time(f);
      render::TraceResult out;
      SceneJobResult r = p->render(t, nullptr, nullptr, &out);
      ASSERT_EQ(r.status, SceneJobStatus::kOk) << r.error;
      EXPECT_EQ(r.time, t);
      int n = 0;
      const double cx = row_centre(out.image, 16, &n);
      // The chord of the unit sphere through y = 1 - 16.5/16 covers 2 units: 32 pixels.
      EXPECT_NEAR(n, 32, 1) << root << " frame " << f;
      EXPECT_NEAR(cx, -2 + 4 * t, 1.0 / 16) << root << " frame " << f;
    }
  }
}

TEST(SceneTime, KeyedTranslateAndKeyedRadius) {
  // A sphere of radius sqrt(a[1]) keyed from 0.25 to 1 (radius 0.5 to 1) and moved by keyed
  // translate from x = -2 to x = 2, with keys at times 0 and 2 (frames at 0, 1, 2).
  scene::SceneDesc d = parse(std::string(kCamera) + R"toml(spp = 16
[animation]
frames = 3
end = 2
[[object]]
source = "my_model(x[3], a[1]) { my_model = a[1] - x[1]^2 - x[2]^2 - x[3]^2; }"
params = [{ keys = [[0, 0.25], [2, 1.0]] }]
translate = [{ keys = [[0, -2], [2, 2]] }, 0, 0]
bbox = [-1.5, -1.5, -1.5, 1.5, 1.5, 1.5]
)toml");
  SceneJobResult res;
  auto p = prepare(d, &res);
  ASSERT_TRUE(p);
  for (int f = 0; f < 3; ++f) {
    const double t = d.animation.frame_time(f);
    render::TraceResult out;
    ASSERT_EQ(p->render(t, nullptr, nullptr, &out).status, SceneJobStatus::kOk);
    const double a = 0.25 + 0.75 * t / 2;  // the keyed parameter
    const double cx = -2 + 2 * t;          // the keyed translate
    double covered = 0, sx = 0;
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 128; ++x) {
        const float al = out.image.alpha[size_t(y) * 128 + x];
        covered += al;
        sx += al * world_x(x);
      }
    // Area pi r^2 = pi a in world units, 256 pixels per unit^2.
    EXPECT_NEAR(covered / 256, M_PI * a, 0.03 * M_PI * a) << "frame " << f;
    EXPECT_NEAR(sx / covered, cx, 0.02) << "frame " << f;
  }
}

TEST(SceneTime, MotionBlurCoverageFollowsTheShutter) {
  // Frame time 0, shutter 0.5: the centre sweeps x = -2 .. 0 at constant speed, so a point x of
  // the centre row is covered for length([x - 1, x + 1] n [-2, 0]) / 2 of the shutter.
  scene::SceneDesc d =
      parse(std::string(kCamera) + "spp = 16\n[animation]\nframes = 2\nend = 1\nshutter = 0.5\n" +
            kMoving);
  SceneJobResult res;
  auto p = prepare(d, &res);
  ASSERT_TRUE(p);
  render::TraceResult out;
  SceneJobResult r = p->render(0.0, nullptr, nullptr, &out);
  ASSERT_EQ(r.status, SceneJobStatus::kOk) << r.error;
  EXPECT_EQ(r.passes, 16);
  double worst = 0, total = 0;
  for (int x = 0; x < 128; ++x) {
    const double wx = world_x(x);
    const double half = std::sqrt(1 - std::pow(1 - 16.5 / 16, 2));  // chord at the row's y
    const double expect = std::max(0.0, std::min(wx + half, 0.0) - std::max(wx - half, -2.0)) / 2.0;
    const double got = out.image.alpha[16 * 128 + x];
    worst = std::max(worst, std::abs(got - expect));
    total += std::abs(got - expect);
  }
  // 16 stratified times: each pixel's coverage is within a stratum or two of the closed form,
  // and the profile as a whole much closer.
  EXPECT_LT(worst, 2.0 / 16 + 0.01);
  EXPECT_LT(total / 128, 0.02);
  // Without a shutter the same frame is sharp: the same total coverage (the chord), but only
  // the two edge pixels partly covered (antialiasing), where the blur has a ramp on each side.
  scene::SceneDesc still = d;
  still.animation.shutter = 0;
  SceneJobResult res2;
  auto q = prepare(still, &res2);
  render::TraceResult sharp;
  ASSERT_EQ(q->render(0.0, nullptr, nullptr, &sharp).status, SceneJobStatus::kOk);
  int partial_sharp = 0, partial_blur = 0;
  double sum_sharp = 0, sum_blur = 0;
  for (int x = 0; x < 128; ++x) {
    const float a = sharp.image.alpha[16 * 128 + x], b = out.image.alpha[16 * 128 + x];
    partial_sharp += a > 0 && a < 1;
    partial_blur += b > 0 && b < 1;
    sum_sharp += a;
    sum_blur += b;
  }
  EXPECT_LE(partial_sharp, 2);
  EXPECT_GE(partial_blur, 60);  // two ramps of 2 units (32 pixels) each, less the plateau's end
  EXPECT_NEAR(sum_sharp, 32, 0.5);
  EXPECT_NEAR(sum_blur, 32, 0.5);
}

TEST(SceneTime, TileSubsetIsBitIdenticalToTheFullRender) {
  for (const char* blur : {"0", "0.25"}) {
    scene::SceneDesc d =
        parse(std::string(kCamera) + "spp = 4\n[animation]\nframes = 2\nend = 1\n" +
              "shutter = " + blur + "\n" + kMoving);
    SceneJobResult res;
    auto p = prepare(d, &res);
    ASSERT_TRUE(p);
    render::TraceResult full, part;
    ASSERT_EQ(p->render(0.4, nullptr, nullptr, &full).status, SceneJobStatus::kOk);
    const std::vector<size_t> tiles = {1, 3, 6, 9, 14};
    ASSERT_EQ(p->render(0.4, nullptr, nullptr, &part, &tiles).status, SceneJobStatus::kOk);
    const render::TraceOptions& o = p->options();
    size_t compared = 0;
    for (size_t ti : tiles) {
      const render::Tile t = render::tile_at(o.width, o.height, o.tile_size, ti);
      for (int y = t.y0; y < t.y1; ++y)
        for (int x = t.x0; x < t.x1; ++x) {
          const size_t i = size_t(y) * o.width + x;
          ASSERT_EQ(full.image.rgb[3 * i], part.image.rgb[3 * i]) << blur;
          ASSERT_EQ(full.image.rgb[3 * i + 1], part.image.rgb[3 * i + 1]);
          ASSERT_EQ(full.image.alpha[i], part.image.alpha[i]);
          ASSERT_EQ(full.image.depth[i], part.image.depth[i]);
          ++compared;
        }
    }
    EXPECT_EQ(compared, tiles.size() * 16 * 16);
  }
}

}  // namespace
}  // namespace hfrt::app
