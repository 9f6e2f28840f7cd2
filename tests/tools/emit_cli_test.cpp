// `hfrt emit --pov`: the function alone, the scene (camera vectors, box, size, max_gradient),
// rejected models with their location, usage errors, and — when POV-Ray is installed — that
// POV-Ray parses and renders the scene written. Runs the real binary.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
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

class EmitCliTest : public CliFixture {
 protected:
  EmitCliTest() : CliFixture("hfrt_emit_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("sphere.hf",
          "my_model(x[3], a[1]) { my_model = 1 - (x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }\n");
    write("loop.hf",
          "my_model(x[3], a[1])\n{\n  i = 0; t = 0;\n  while i < 3 loop\n    t = t + x[1]; i = i + "
          "1;\n"
          "  endloop;\n  my_model = t;\n}\n");
    write("torus.hf",
          "torus(x[3], a[1]) { array c[3]; c = [0, 0, 0]; torus = hfTorusY(x, c, 1, 0.3); }\n");
  }
  CliRun emit(const std::string& args) { return hfrt("emit " + args); }
  CliRun run(const std::string& cmdline) { return shell(cmdline); }
};

/// The three numbers of `KEY <a, b, c>` in `text`.
bool vector_of(const std::string& text, const std::string& key, double v[3]) {
  std::smatch m;
  std::regex re(key + " <([-0-9.e+]+), ([-0-9.e+]+), ([-0-9.e+]+)>");
  if (!std::regex_search(text, m, re)) return false;
  for (int i = 0; i < 3; ++i) v[i] = std::stod(m[i + 1]);
  return true;
}

TEST_F(EmitCliTest, FunctionOnlyToStandardOutput) {
  CliRun r = emit("--pov sphere.hf --function-only");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(
      r.out.find(
          "#declare hf_my_model = function(x, y, z) { (1 - (((x * x) + (y * y)) + (z * z))) }"),
      std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("camera"), std::string::npos);
  EXPECT_EQ(r.out.find("#version"), std::string::npos);
}

TEST_F(EmitCliTest, SceneMatchesTheRenderCamera) {
  // Perspective, 35 deg vertical field of view, 64x32: POV-Ray's right and up vectors span
  // the image plane at distance 1 (direction is unit length).
  CliRun r = emit(
      "--pov sphere.hf --eye 0,0,5 --look-at 0,0,0 --size 64x32 --bbox 2 --max-gradient 3 -o "
      "s.pov");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string pov = slurp(dir_ / "s.pov");
  double loc[3], dir[3], right[3], up[3], lo[3];
  ASSERT_TRUE(vector_of(pov, "location", loc)) << pov;
  ASSERT_TRUE(vector_of(pov, "direction", dir)) << pov;
  ASSERT_TRUE(vector_of(pov, "right", right)) << pov;
  ASSERT_TRUE(vector_of(pov, "up", up)) << pov;
  ASSERT_TRUE(vector_of(pov, "box \\{", lo)) << pov;
  EXPECT_NEAR(loc[2], 5, 1e-6);
  EXPECT_NEAR(dir[2], -1, 1e-6);
  const double h = 2 * std::tan(17.5 * M_PI / 180);
  // hfrt is right-handed: looking down -z with y up, screen right is +x.
  EXPECT_NEAR(right[0], 2 * h, 1e-5);
  EXPECT_NEAR(up[1], h, 1e-5);
  EXPECT_NEAR(lo[0], -2, 1e-6);
  EXPECT_NE(pov.find("function { -hf_my_model(x, y, z) }"), std::string::npos) << pov;
  EXPECT_NE(pov.find("max_gradient 3\n"), std::string::npos) << pov;
  EXPECT_NE(pov.find("+W64 +H32"), std::string::npos) << pov;
  EXPECT_NE(pov.find("#version 3.7;"), std::string::npos);
}

TEST_F(EmitCliTest, FramedSceneGetsAGradientEstimate) {
  // |grad (1 - r^2)| = 2r, at most 2 sqrt(3) * 1.5 in the box [-1.5, 1.5]^3; sampled at cell
  // centres and given a 1.2 margin.
  CliRun r = emit("--pov sphere.hf --bbox 1.5 --size 32x32 --transparent-background");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex("max_gradient ([0-9.]+)"))) << r.out;
  const double g = std::stod(m[1]);
  EXPECT_GT(g, 1.0 * 2 * std::sqrt(3.0) * 1.4);
  EXPECT_LT(g, 1.2 * 2 * std::sqrt(3.0) * 1.5 + 1e-3);
  EXPECT_NE(r.out.find("background { rgbt <"), std::string::npos);
  EXPECT_NE(r.out.find("camera {"), std::string::npos);
}

TEST_F(EmitCliTest, LoopIsRejectedWithItsLocation) {
  CliRun r = emit("--pov loop.hf --function-only");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("loop.hf:4:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("while loop"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
}

TEST_F(EmitCliTest, UsageErrors) {
  EXPECT_EQ(emit("sphere.hf").exit_code, 2);                         // no --pov
  EXPECT_EQ(emit("--pov missing.hf --function-only").exit_code, 2);  // unreadable
  EXPECT_EQ(emit("--pov sphere.hf --name 'a b' --function-only").exit_code, 2);
  EXPECT_EQ(emit("--pov sphere.hf --size 0x5").exit_code, 2);
}

TEST_F(EmitCliTest, KeywordObjectNamesArePrefixed) {
  CliRun r = emit("--pov torus.hf --function-only");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("#declare hf_torus = function(x, y, z)"), std::string::npos) << r.out;
  r = emit("--pov torus.hf --function-only --name Ring");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("#declare Ring = function(x, y, z)"), std::string::npos) << r.out;
}

TEST_F(EmitCliTest, PovRayRendersTheScene) {
  // POV-Ray is an independent reference: the set-up installs it (scripts/install-deps.sh), and
  // a missing one fails the test rather than skipping it.
  ASSERT_EQ(std::system("command -v povray > /dev/null 2>&1"), 0)
      << "povray is not installed: run scripts/install-deps.sh";
  CliRun r = emit("--pov torus.hf --eye 0,2,4 --look-at 0,0,0 --bbox 1.5 --size 32x32 -o t.pov");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  CliRun p = run("povray +It.pov +Ot.png +W32 +H32 -D -P +WT1");
  EXPECT_EQ(p.exit_code, 0) << p.err;
  EXPECT_EQ(p.err.find("Parse Error"), std::string::npos) << p.err;
  EXPECT_TRUE(fs::exists(dir_ / "t.png"));
  // The max_gradient estimate is large enough: POV-Ray does not warn of holes.
  EXPECT_EQ(p.err.find("may contain holes"), std::string::npos) << p.err;
}

/// Pixels whose alpha coverage (>= 0.5) differs, as a fraction; -1 when unreadable.
double coverage_difference(const fs::path& a, const fs::path& b) {
  int w[2], h[2], c[2];
  auto ia = render::read_image(a.string(), &w[0], &h[0], &c[0]);
  auto ib = render::read_image(b.string(), &w[1], &h[1], &c[1]);
  if (!ia.ok() || !ib.ok() || w[0] != w[1] || h[0] != h[1] || c[0] != 4 || c[1] != 4) return -1;
  size_t differ = 0, n = size_t(w[0]) * size_t(h[0]), covered = 0;
  for (size_t p = 0; p < n; ++p) {
    bool in_a = ia.value()[p * 4 + 3] >= 0.5f, in_b = ib.value()[p * 4 + 3] >= 0.5f;
    differ += in_a != in_b;
    covered += in_a;
  }
  EXPECT_GT(covered, n / 20) << "the solid should be visible";
  return double(differ) / double(n);
}

TEST_F(EmitCliTest, PovRayAndHfrtSeeTheSameSilhouette) {
  // An asymmetric model (a mirrored camera would move the bump to the other side) with a
  // non-square image and an off-axis camera: the two renders classify the same pixels.
  // POV-Ray is an independent reference: the set-up installs it (scripts/install-deps.sh), and
  // a missing one fails the test rather than skipping it.
  ASSERT_EQ(std::system("command -v povray > /dev/null 2>&1"), 0)
      << "povray is not installed: run scripts/install-deps.sh";
  write("bump.hf",
        "my_model(x[3], a[1]) { array c[3]; c = [0.6, 0.3, 0]; b = hfSphere(x, c, 0.5);"
        " my_model = (0.8 - sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3])) | b; }\n");
  const std::string opts =
      " --size 64x48 --bbox 1.5 --eye 1.2,1.5,3.5 --look-at 0.1,0,0 --light dir:1,1,1 --background "
      "0,0,0";
  CliRun r = emit("--pov bump.hf --transparent-background -o b.pov" + opts);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  CliRun p = run("povray +Ib.pov +Ob.png +W64 +H48 -D -P +UA +WT1");
  ASSERT_EQ(p.exit_code, 0) << p.err;
  CliRun h = run(HFRT_BINARY_DIR "/tools/hfrt/hfrt render bump.hf -o b.exr --threads 1" + opts);
  ASSERT_EQ(h.exit_code, 0) << h.err;
  const double d = coverage_difference(dir_ / "b.exr", dir_ / "b.png");
  EXPECT_GE(d, 0);
  EXPECT_LT(d, 0.01) << "silhouettes differ in " << 100 * d << " % of the pixels";
}

// --- The GPU path (issue 22) -----------------------------------------------------------

TEST_F(EmitCliTest, PtxHasTheKernelsOfTheAbi) {
  CliRun r = emit("--ptx sphere.hf -o sphere.ptx --sm sm_80");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("hfrt: wrote sphere.ptx (PTX for sm_80)"), std::string::npos) << r.err;
  const std::string ptx = slurp(dir_ / "sphere.ptx");
  EXPECT_NE(ptx.find(".target sm_80"), std::string::npos);
  EXPECT_NE(ptx.find(".visible .entry hfrt_eval_f32("), std::string::npos);
  EXPECT_NE(ptx.find(".visible .entry hfrt_render_f32("), std::string::npos);
  EXPECT_NE(ptx.find("object my_model (3 coordinates, 1 parameters a[])"), std::string::npos);
  // A model with a loop too (lane masks become branches on the GPU).
  r = emit("--ptx loop.hf");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find(".entry hfrt_eval_f32("), std::string::npos);
}

TEST_F(EmitCliTest, PtxUsageErrors) {
  CliRun r = emit("--ptx --pov sphere.hf");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("hfrt emit: choose one output language: --pov or --ptx"), std::string::npos)
      << r.err;
  r = emit("sphere.hf");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("choose the output language: --pov or --ptx"), std::string::npos) << r.err;
  r = emit("--ptx sphere.hf --sm 80");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--sm expects a GPU architecture such as sm_60, sm_80 or sm_90 (got '80')"),
            std::string::npos)
      << r.err;
  write("mesh.hf",
        "my_model(x[3], a[1]) { array v[9], t[3]; v = [0,0,0, 1,0,0, 0,1,0]; t = [1, 2, 3]; "
        "my_model = hfTriangles(x, v, t); }\n");
  r = emit("--ptx mesh.hf");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("hfrt emit: mesh.hf: mesh and patch leaves (hfMesh, hfTriangles, "
                       "hfBezier*) are not on the GPU yet"),
            std::string::npos)
      << r.err;
}

TEST_F(EmitCliTest, RenderOnTheDevice) {
  // Without a driver: the reason and what to do, exit 2.
  CliRun r = run("HFRT_LIBCUDA=/nonexistent/libcuda.so.1 " HFRT_BINARY_DIR
                 "/tools/hfrt/hfrt render sphere.hf -o s.png --size 32 --device cuda");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("hfrt: --device cuda: no CUDA driver: cannot load "
                       "/nonexistent/libcuda.so.1"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("install the NVIDIA driver"), std::string::npos) << r.err;
  // The kernels compiled for this CPU: an image, and what ran it.
  r = hfrt("render sphere.hf -o s.exr --size 48 --device cuda-host --stats");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("hfrt: wrote s.exr (48x48, 1 spp, --device cuda-host"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("stats: compile"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir_ / "s.exr"));
  // Usage errors.
  r = hfrt("render sphere.hf -o s.png --device gpu");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--device expects cpu, cuda or cuda-host (got 'gpu')"), std::string::npos)
      << r.err;
  r = hfrt("render sphere.hf -o s.png --device cuda-host --spp 4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("one sample per pixel so far (leave out --spp)"), std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace hfrt::tools
