// Scene files on the command line: `hfrt check scene.toml` (summary or one located error, and
// the exit code) and `hfrt emit --pov scene.toml` (every object, material, light and camera
// setting written; POV-Ray renders it, with absorption and placement checked against closed
// forms on POV-Ray's own image). Runs the real binary.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "render/image.h"
#include "tests/tools/cli_fixture.h"

namespace hfrt::tools {
namespace {

namespace fs = std::filesystem;

using testing::CliFixture;
using testing::CliRun;
using testing::slurp;

class SceneCliTest : public CliFixture {
 protected:
  SceneCliTest() : CliFixture("hfrt_scene_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("ball.hf",
          "ball(x[3], a[1]) { ball = a[1]*a[1] - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n");
  }
  CliRun hfrt_run(const std::string& args) { return hfrt(args); }
};

// A scene with every kind of light and the materials of the issue's examples.
const char* const kScene = R"toml([camera]
eye = [0, 1, -8]
look_at = [0, 0, 0]
fov = 30
aperture = 0.05
focus_distance = 7.5

[render]
size = [64, 48]
spp = 8
max_depth = 4
background = [0.1, 0.1, 0.12]

[[light]]
kind = "sphere"
position = [4, 6, -4]
radius = 0.5
samples = 16
intensity = 0.8

[[light]]
kind = "directional"
direction = [0, 1, 0]
color = [0.5, 0.5, 1]

[[light]]
position = [-3, 3, -3]

[material.glass]
ambient = 0
diffuse = 0
specular = 0.5
shininess = 50
transmit = 1
ior = 1.45
fresnel = true
absorb = [0.25, 0.5, 1]

[material.mirror]
color = [0.9, 0.9, 0.9]
diffuse = 0.5
reflect = 0.5

[[object]]
file = "ball.hf"
params = [1]
bbox = [-1.5, -1.5, -1.5, 1.5, 1.5, 1.5]
material = "glass"
scale = 0.5
rotate = [10, 20, 30]
translate = [1, 0, 0]

[[object]]
file = "ball.hf"
params = [1]
bbox = [-1.5, -1.5, -1.5, 1.5, 1.5, 1.5]
translate = [-1, 0, 0]

[[object]]
source = """
slab(x[3], a[1]) { slab = 0.01 - x[2]*x[2]; }
"""
bbox = [-5, -0.2, -5, 5, 0.2, 5]
translate = [0, -1, 0]
material = "mirror"
)toml";

TEST_F(SceneCliTest, CheckPrintsASummary) {
  write("s.toml", kScene);
  CliRun r = hfrt_run("check s.toml");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out,
            "s.toml: 3 objects, 3 lights, 2 materials; perspective camera with depth of field; "
            "64x48, 8 spp, depth 4\n");
  EXPECT_EQ(r.err, "");
}

TEST_F(SceneCliTest, CheckPrintsTheLocatedError) {
  write("bad.toml", "[render]\nspp = 2\n\n[[object]]\nfile = \"ball.hf\"\nmaterial = \"glas\"\n");
  CliRun r = hfrt_run("check bad.toml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err,
            "bad.toml:6:12: error: unknown material \"glas\"\n"
            " material = \"glas\"\n"
            "            ^~~~~~\n"
            "hint: the scene defines no materials: add a [material.glas] table, or leave "
            "material out for the default look\n");
}

TEST_F(SceneCliTest, CheckRunsTheFrontEndOnEveryModel) {
  write("bad.toml",
        "[[object]]\nfile = \"ball.hf\"\nname = \"blub\"\n\n[[object]]\nsource = \"\"\"\n"
        "b(x[3], a[1]) {\n  b = 1 - nosuch;\n}\n\"\"\"\n");
  CliRun r = hfrt_run("check bad.toml");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err,
            "bad.toml:3:8: error: no object named 'blub' in ball.hf\n"
            "hint: the objects are: ball\n"
            "bad.toml:8:11: error: 'nosuch' is used but never assigned\n"
            "   b = 1 - nosuch;\n"
            "           ^~~~~~\n"
            "hint: assign it before this point (nosuch = ...;) or check the spelling\n");
}

TEST_F(SceneCliTest, CheckOfAMissingSceneIsAnEnvironmentError) {
  CliRun r = hfrt_run("check nothere.toml");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nothere.toml"), std::string::npos) << r.err;
}

TEST_F(SceneCliTest, CheckMixesScenesAndModels) {
  write("s.toml", kScene);
  CliRun r = hfrt_run("check ball.hf s.toml");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("s.toml: 3 objects"), std::string::npos) << r.out;
}

/// The text of the n-th (0-based) `isosurface { ... }` block (blocks end at a line "}").
std::string isosurface(const std::string& pov, int n) {
  size_t at = 0;
  for (int i = 0; i <= n; ++i) {
    at = pov.find("\nisosurface {", at + 1);
    if (at == std::string::npos) return "";
  }
  return pov.substr(at + 1, pov.find("\n}\n", at) - at);
}

TEST_F(SceneCliTest, EmitWritesEveryObjectMaterialLightAndCameraSetting) {
  write("s.toml", kScene);
  CliRun r = hfrt_run("emit --pov s.toml -o s.pov");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string pov = slurp(dir_ / "s.pov");
  // Two objects share ball.hf with the same parameter: one function.
  EXPECT_NE(pov.find("#declare hf_ball = function"), std::string::npos) << pov;
  EXPECT_NE(pov.find("#declare hf_slab = function"), std::string::npos) << pov;
  EXPECT_EQ(pov.find("hf_ball_2"), std::string::npos) << pov;
  EXPECT_NE(pov.find("max_trace_level 5\n"), std::string::npos) << pov;
  // The camera: POV-Ray's lens disc has radius aperture / 4.
  EXPECT_NE(pov.find("  aperture 0.2\n  focal_point <0, 0.06973952, -0.5579162>\n"
                     "  blur_samples 8\n  variance 0\n"),
            std::string::npos)
      << pov;
  // Lights: a circular area light of diameter 2 r with 4 x 4 samples, a parallel light, a
  // point light; colours times intensity.
  EXPECT_NE(pov.find("  <4, 6, -4> color rgb <0.8, 0.8, 0.8>\n"
                     "  area_light <1, 0, 0>, <0, 1, 0>, 4, 4\n  circular orient\n"),
            std::string::npos)
      << pov;
  EXPECT_NE(pov.find(" color rgb <0.5, 0.5, 1>\n  parallel point_at "), std::string::npos) << pov;
  EXPECT_NE(pov.find("  <-3, 3, -3> color rgb <1, 1, 1>\n}"), std::string::npos) << pov;
  EXPECT_NE(pov.find("background { rgb <0.1, 0.1, 0.12> }"), std::string::npos) << pov;

  const std::string glass = isosurface(pov, 0);
  EXPECT_NE(glass.find("function { -hf_ball(x, y, z) }"), std::string::npos) << glass;
  EXPECT_NE(glass.find("contained_by { box { <-1.5, -1.5, -1.5>, <1.5, 1.5, 1.5> } }"),
            std::string::npos)
      << glass;
  EXPECT_NE(glass.find("pigment { rgbt <0.78, 0.76, 0.7, 1> }"),
            std::string::npos)
      << glass;
  EXPECT_NE(glass.find("specular 0.5 roughness 0.02\n"), std::string::npos) << glass;
  EXPECT_NE(glass.find("reflection { 0, 1 fresnel on }\n      conserve_energy\n"),
            std::string::npos)
      << glass;
  // exp(-(1 - fade_color) d / fade_distance) = exp(-absorb d).
  EXPECT_NE(glass.find("interior {\n    ior 1.45\n    fade_power 1001\n    fade_distance 1\n"
                       "    fade_color rgb <0.75, 0.5, 0>\n  }\n"),
            std::string::npos)
      << glass;
  // Scale, then rotate about x, y, z, then translate.
  EXPECT_NE(glass.find("  scale 0.5\n  rotate <10, 0, 0>\n  rotate <0, 20, 0>\n"
                       "  rotate <0, 0, 30>\n  translate <1, 0, 0>\n"),
            std::string::npos)
      << glass;

  const std::string plain = isosurface(pov, 1);
  EXPECT_NE(plain.find("function { -hf_ball(x, y, z) }"), std::string::npos) << plain;
  EXPECT_NE(plain.find("ambient 0.12 diffuse 1\n"), std::string::npos) << plain;
  EXPECT_EQ(plain.find("interior"), std::string::npos) << plain;
  EXPECT_EQ(plain.find("reflection"), std::string::npos) << plain;

  const std::string mirror = isosurface(pov, 2);
  EXPECT_NE(mirror.find("function { -hf_slab(x, y, z) }"), std::string::npos) << mirror;
  EXPECT_NE(mirror.find("pigment { rgbt <0.9, 0.9, 0.9, 0> }"),
            std::string::npos)
      << mirror;
  EXPECT_NE(mirror.find("reflection { 0.5 }"), std::string::npos) << mirror;
  EXPECT_NE(mirror.find("  translate <0, -1, 0>\n"), std::string::npos) << mirror;
  EXPECT_EQ(mirror.find("rotate"), std::string::npos) << mirror;
}

TEST_F(SceneCliTest, EmitRejectsRenderOptionsForScenes) {
  write("s.toml", kScene);
  CliRun r = hfrt_run("emit --pov s.toml --eye 1,2,3 -o s.pov");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err,
            "hfrt emit: --eye does not apply to a scene file: set it in the scene (see "
            "docs/scenes.md)\n");
  EXPECT_FALSE(fs::exists(dir_ / "s.pov"));
}

// --size, --spp and --max-depth replace the scene's values, as for `hfrt render scene.toml`.
TEST_F(SceneCliTest, EmitTakesSizeSppAndDepthOverTheScenes) {
  write("s.toml", kScene);
  CliRun r = hfrt_run("emit --pov s.toml --size 32x24 --spp 4 --max-depth 2 -o s.pov");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string pov = slurp(dir_ / "s.pov");
  EXPECT_NE(pov.find("render with  povray +W32 +H24\n"), std::string::npos) << pov;
  EXPECT_NE(pov.find("blur_samples 4"), std::string::npos) << pov;  // the scene has a lens
  EXPECT_NE(pov.find("max_trace_level 3"), std::string::npos) << pov;
}

TEST_F(SceneCliTest, EmitOfABadSceneIsOneLocatedError) {
  write("bad.toml", "[render]\nspp = 0\n\n[[object]]\nfile = \"ball.hf\"\n");
  CliRun r = hfrt_run("emit --pov bad.toml -o s.pov");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err,
            "bad.toml:2:7: error: [render] spp must be at least 1, not 0\n"
            " spp = 0\n"
            "       ^\n");
}

TEST_F(SceneCliTest, InlineSourceErrorsAreLocatedInTheSceneFile) {
  write("bad.toml",
        "[render]\nspp = 2\n\n[[object]]\nsource = \"\"\"\nb(x[3], a[1]) {\n  b = 1 - "
        "nosuch;\n}\n\"\"\"\n");
  CliRun r = hfrt_run("emit --pov bad.toml -o s.pov");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.rfind("bad.toml:7:11: error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("nosuch"), std::string::npos) << r.err;
}

/// The image's channels as floats (POV-Ray writes linear 16-bit PNG with File_Gamma=1.0).
std::vector<float> read_pixels(const fs::path& p, int* w, int* h, int* c) {
  auto img = render::read_image(p.string(), w, h, c);
  EXPECT_TRUE(img.ok()) << p;
  return img.ok() ? img.value() : std::vector<float>{};
}

TEST_F(SceneCliTest, PovRayTransmitsExpOfMinusAbsorbTimesThickness) {
  // A slab 1 thick (the solid |z| < 1 capped by its box at |z| = 0.5) with ior 1 in front of
  // a white background: every pixel is exp(-absorb * 1), on POV-Ray's own image.
  // POV-Ray is an independent reference: the set-up installs it (scripts/install-deps.sh), and
  // a missing one fails the test rather than skipping it.
  ASSERT_EQ(std::system("command -v povray > /dev/null 2>&1"), 0)
      << "povray is not installed: run scripts/install-deps.sh";
  write("slab.toml",
        "[camera]\neye = [0, 0, 10]\nlook_at = [0, 0, 0]\northo = 2\n\n[render]\nsize = [8, 8]\n"
        "background = [1, 1, 1]\n\n[material.ink]\nambient = 0\ndiffuse = 0\nspecular = 0\n"
        "transmit = 1\nior = 1\nabsorb = [0.2, 0.7, 1.5]\n\n[[object]]\n"
        "source = \"slab(x[3], a[1]) { slab = 1 - x[3]*x[3]; }\"\n"
        "bbox = [-5, -5, -0.5, 5, 5, 0.5]\nmaterial = \"ink\"\n");
  CliRun r = hfrt_run("emit --pov slab.toml -o slab.pov");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  CliRun p = shell("povray +Islab.pov +Oslab.png +W8 +H8 -D -P +FN16 File_Gamma=1.0 +WT1");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  int w = 0, h = 0, c = 0;
  std::vector<float> px = read_pixels(dir_ / "slab.png", &w, &h, &c);
  ASSERT_EQ(w, 8);
  ASSERT_EQ(h, 8);
  ASSERT_GE(c, 3);
  const double absorb[3] = {0.2, 0.7, 1.5};
  for (int i = 0; i < w * h; ++i) {
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(px[size_t(i) * c + k], std::exp(-absorb[k]), 2e-4) << "pixel " << i << " " << k;
    }
  }
}

TEST_F(SceneCliTest, PovRayPlacesObjectsScaledRotatedThenTranslated) {
  // A ball of radius 0.25 at model point (1, 0, 0), scaled by 2 (radius 0.5 at (2, 0, 0)),
  // rotated 90 degrees about z (to (0, 2, 0)), translated by (1, 0, 0): centre (1, 2, 0). Seen
  // from (0, 0, 10) with a vertical field of view of 40 degrees on 64 x 64 pixels, its centre
  // projects to pixel (32 + 32 t, 32 - 64 t) with t = 1 / (10 tan 20 deg). Another order of
  // the steps, or the other sense of rotation, puts it elsewhere.
  ASSERT_EQ(std::system("command -v povray > /dev/null 2>&1"), 0)
      << "povray is not installed: run scripts/install-deps.sh";
  write("place.toml",
        "[camera]\neye = [0, 0, 10]\nlook_at = [0, 0, 0]\nfov = 40\n\n[render]\nsize = [64, 64]\n"
        "\n[[object]]\nsource = \"b(x[3], a[1]) { b = 0.0625 - (x[1]-1)*(x[1]-1) - x[2]*x[2] - "
        "x[3]*x[3]; }\"\nbbox = [0, -1, -1, 2, 1, 1]\nscale = 2\nrotate = [0, 0, 90]\n"
        "translate = [1, 0, 0]\n");
  CliRun r = hfrt_run("emit --pov place.toml --transparent-background -o place.pov");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  CliRun p = shell("povray +Iplace.pov +Oplace.png +W64 +H64 -D -P +UA +WT1");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  int w = 0, h = 0, c = 0;
  std::vector<float> px = read_pixels(dir_ / "place.png", &w, &h, &c);
  ASSERT_EQ(c, 4);
  double sx = 0, sy = 0, n = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (px[(size_t(y) * w + x) * 4 + 3] < 0.5f) continue;
      sx += x + 0.5;
      sy += y + 0.5;
      n += 1;
    }
  const double t = 1 / (10 * std::tan(20 * M_PI / 180));
  // The disc of radius 0.5 at depth 10 covers about pi (0.5 * 32 t)^2 pixels.
  const double r_px = 0.5 * 32 * t;
  ASSERT_GT(n, 0.7 * M_PI * r_px * r_px);
  EXPECT_LT(n, 1.3 * M_PI * r_px * r_px);
  EXPECT_NEAR(sx / n, 32 + 32 * t, 0.5);
  EXPECT_NEAR(sy / n, 32 - 64 * t, 0.5);
}

TEST_F(SceneCliTest, PovRayRendersTheWholeScene) {
  ASSERT_EQ(std::system("command -v povray > /dev/null 2>&1"), 0)
      << "povray is not installed: run scripts/install-deps.sh";
  write("s.toml", kScene);
  CliRun r = hfrt_run("emit --pov s.toml --transparent-background -o s.pov");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  CliRun p = shell("povray +Is.pov +Os.png +W64 +H48 -D -P +UA +WT1");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_EQ(p.err.find("Parse Error"), std::string::npos) << p.err;
  EXPECT_EQ(p.err.find("may contain holes"), std::string::npos) << p.err;
  int w = 0, h = 0, c = 0;
  std::vector<float> px = read_pixels(dir_ / "s.png", &w, &h, &c);
  ASSERT_EQ(c, 4);
  // The plain ball is solid and lit. Its centre (-1, 0, 0), seen from (0, 1, -8) towards the
  // origin, lies right of the image centre (x grows to the left in this view).
  size_t covered = 0;
  for (int i = 0; i < w * h; ++i) covered += px[size_t(i) * 4 + 3] >= 0.5f;
  EXPECT_GT(covered, size_t(w * h) / 4) << "floor and balls should cover much of the image";
  bool ball_seen = false;
  for (int x = w / 2; x < w; ++x) {
    const float* q = &px[(size_t(h / 2) * w + x) * 4];
    ball_seen |= q[3] >= 0.99f && q[0] + q[1] + q[2] > 0.1f;
  }
  EXPECT_TRUE(ball_seen);
}

}  // namespace
}  // namespace hfrt::tools
