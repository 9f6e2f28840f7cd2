// End-to-end tests of `hfrt render` and `hfrt slice`: the binary, a compiled model (through
// tools/hfrt/model_field.cpp) and the image files it writes.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "render/image.h"
#include "tests/malloc_pages.h"

namespace hfrt::render {
namespace {

namespace fs = std::filesystem;

const std::string kHfrt = std::string(HFRT_BINARY_DIR) + "/tools/hfrt/hfrt";

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("hfrt_cli_test_" + std::to_string(getpid()));
  fs::create_directories(d);
  return d;
}

/// Runs `hfrt ARGS`, returns the exit code; stderr goes to *err.
int run_hfrt(const std::string& args, std::string* err = nullptr) {
  fs::path log = temp_dir() / "stderr.txt";
  std::string cmd = kHfrt + " " + args + " 2> " + log.string() + " > /dev/null";
  int status = std::system(cmd.c_str());
  if (err) {
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    *err = ss.str();
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

fs::path write_model(const std::string& name, const std::string& text) {
  fs::path p = temp_dir() / name;
  std::ofstream(p) << text;
  return p;
}

const char* kSphereModel =
    "my_model(x[3], a[1]) {\n"
    "  array c[3];\n"
    "  c = [0, 0, 0];\n"
    "  my_model = hfSphere(x, c, 4);\n"
    "}\n";

TEST(RenderCli, OrthographicSphereCoversItsArea) {
  fs::path model = write_model("sphere.hf", kSphereModel);
  fs::path out = temp_dir() / "sphere.exr";
  std::string err;
  ASSERT_EQ(run_hfrt("render " + model.string() + " -o " + out.string() +
                         " --size 100x100 --ortho 10 --eye 0,0,20 --look-at 0,0,0 --aov depth",
                     &err),
            0)
      << err;
  EXPECT_NE(err.find("root search"), std::string::npos) << err;
  int w, h, c;
  auto img = read_image(out.string(), &w, &h, &c);
  ASSERT_TRUE(img.ok()) << img.error().message;
  ASSERT_EQ(c, 5);  // RGBA + Z
  double covered = 0, worst_depth = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const float* p = &img.value()[(size_t(y) * w + x) * c];
      covered += p[3];
      if (p[3] > 0) {
        double px = -5 + (x + 0.5) * 0.1, py = 5 - (y + 0.5) * 0.1;
        double expected = 20 - std::sqrt(std::max(0.0, 16 - px * px - py * py));
        if (px * px + py * py < 15.5)
          worst_depth = std::max(worst_depth, std::abs(p[4] - expected));
      }
    }
  }
  EXPECT_NEAR(covered * 0.01 / (M_PI * 16), 1.0, 0.01);
  EXPECT_LT(worst_depth, 2e-3);
}

TEST(RenderCli, SameFileForAnyThreadCount) {
  fs::path model = write_model("sphere2.hf", kSphereModel);
  fs::path a = temp_dir() / "t1.png", b = temp_dir() / "t2.png";
  ASSERT_EQ(run_hfrt("render " + model.string() + " -o " + a.string() +
                     " --size 48x40 --spp 4 --threads 1"),
            0);
  ASSERT_EQ(run_hfrt("render " + model.string() + " -o " + b.string() +
                     " --size 48x40 --spp 4 --threads 2"),
            0);
  int w, h, c;
  auto ia = read_image(a.string(), &w, &h, &c);
  auto ib = read_image(b.string(), &w, &h, &c);
  ASSERT_TRUE(ia.ok() && ib.ok());
  EXPECT_EQ(ia.value(), ib.value());
  // Framed by default: the sphere is in the picture, not touching the border.
  size_t fg = 0;
  const auto& v = ia.value();
  for (size_t i = 0; i + 2 < v.size(); i += 3) fg += std::abs(v[i] - v[0]) > 0.02f;
  EXPECT_GT(fg, v.size() / 3 / 10);
}

// `hfrt render` runs with malloc on transparent huge pages where the kernel has them in madvise
// mode (base/memory.h, tools/hfrt/main.cpp), as `hfrt mesh` does; HFRT_MALLOC_HUGEPAGES=0
// turns it off. The picture is the same either way.
TEST(RenderCli, MallocOnHugePagesWhereTheKernelAdvisesThem) {
  const std::string mode = hfrt::testing::thp_mode();
  const char* kDefault = hfrt::testing::kMallocDefaultPagesLine;
  fs::path model = write_model("sphere_pages.hf", kSphereModel);
  fs::path on = temp_dir() / "pages_on.png", off = temp_dir() / "pages_off.png";
  std::string err;
  ASSERT_EQ(
      run_hfrt("render " + model.string() + " -o " + on.string() + " --size 40x32 --stats", &err),
      0)
      << err;
  EXPECT_NE(err.find(hfrt::testing::expected_malloc_line()), std::string::npos)
      << "THP mode '" << mode << "'\n"
      << err;
  ASSERT_EQ(
      std::system(("HFRT_MALLOC_HUGEPAGES=0 " + kHfrt + " render " + model.string() + " -o " +
                   off.string() + " --size 40x32 --stats 2> " + (temp_dir() / "off.txt").string())
                      .c_str()),
      0);
  std::ifstream off_log(temp_dir() / "off.txt");
  std::stringstream off_err;
  off_err << off_log.rdbuf();
  EXPECT_NE(off_err.str().find(kDefault), std::string::npos) << off_err.str();
  int w, h, c;
  auto ia = read_image(on.string(), &w, &h, &c);
  auto ib = read_image(off.string(), &w, &h, &c);
  ASSERT_TRUE(ia.ok() && ib.ok());
  EXPECT_EQ(ia.value(), ib.value());
}

/// A shell 0.01 thick: the sign-change march (step 20/512 = 0.04) steps over it on most rays.
const char* kThinShellModel =
    "my_model(x[3], a[1]) {\n"
    "  array c[3];\n"
    "  c = [0, 0, 0];\n"
    "  my_model = hfSphere(x, c, 5) \\ hfSphere(x, c, 4.99);\n"
    "}\n";

/// Alpha coverage (sum of alpha) of an image file.
double coverage(const fs::path& image, int* w = nullptr, int* h = nullptr) {
  int iw, ih, c;
  auto img = read_image(image.string(), &iw, &ih, &c);
  EXPECT_TRUE(img.ok());
  if (!img.ok()) return 0;
  if (w) *w = iw;
  if (h) *h = ih;
  double covered = 0;
  for (size_t i = 0; i < size_t(iw) * ih; ++i) covered += img.value()[i * c + 3];
  return covered;
}

TEST(RenderCli, ThinShellHasNoHolesWithIntervals) {
  fs::path model = write_model("shell.hf", kThinShellModel);
  fs::path out = temp_dir() / "shell.exr";
  const std::string view = " --size 80x80 --ortho 12 --eye 0,0,20 --look-at 0,0,0 --no-shadows";
  std::string err;
  ASSERT_EQ(run_hfrt("render " + model.string() + " -o " + out.string() + view +
                         " --root interval --stats",
                     &err),
            0)
      << err;
  EXPECT_NE(err.find("root search interval"), std::string::npos) << err;
  // Seen from the front, the shell covers the disk of radius 5: pi 25 / 144 of the view.
  double pixel_area = (12.0 / 80) * (12.0 / 80);
  EXPECT_NEAR(coverage(out) * pixel_area / (M_PI * 25), 1.0, 0.01);
  // The same view with the sign-change march misses most of the shell: the test above can fail.
  fs::path sign = temp_dir() / "shell_sign.exr";
  ASSERT_EQ(
      run_hfrt("render " + model.string() + " -o " + sign.string() + view + " --root sign", &err),
      0)
      << err;
  EXPECT_LT(coverage(sign) * pixel_area / (M_PI * 25), 0.9);
}

TEST(RenderCli, IntervalRenderIsTheSameForAnyThreadCount) {
  fs::path model = write_model("shell2.hf", kThinShellModel);
  fs::path a = temp_dir() / "i1.png", b = temp_dir() / "i2.png";
  std::string err;
  const std::string args = " --size 40x32 --spp 2 --root interval";
  ASSERT_EQ(
      run_hfrt("render " + model.string() + " -o " + a.string() + args + " --threads 1", &err), 0)
      << err;
  ASSERT_EQ(
      run_hfrt("render " + model.string() + " -o " + b.string() + args + " --threads 2", &err), 0)
      << err;
  int w, h, c;
  auto ia = read_image(a.string(), &w, &h, &c);
  auto ib = read_image(b.string(), &w, &h, &c);
  ASSERT_TRUE(ia.ok() && ib.ok());
  EXPECT_EQ(ia.value(), ib.value());
}

TEST(RenderCli, AutoPicksIntervalsUnlessTheyAreLoose) {
  // A ball with a sine ripple is not a polynomial: auto falls back from analytic, says why and
  // where, and takes the interval search (its enclosures are tight).
  fs::path model =
      write_model("sin_sphere.hf",
                  "my_model(x[3], a[1]) {\n"
                  "  my_model = 16 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3] + 0.5 * sin(x[1]);\n"
                  "}\n");
  fs::path out = temp_dir() / "auto.png";
  std::string err;
  ASSERT_EQ(
      run_hfrt("render " + model.string() + " -o " + out.string() + " --size 32x32 --stats", &err),
      0)
      << err;
  EXPECT_NE(err.find("root search interval (auto:"), std::string::npos) << err;
  EXPECT_NE(err.find("interval JIT"), std::string::npos) << err;
  EXPECT_EQ(err.find("no interval culling"), std::string::npos) << err;
  EXPECT_NE(err.find("\nroot: interval\n"), std::string::npos) << err;
  EXPECT_NE(err.find("\nroot fallback: not analytic: 'sin' is not a polynomial at "),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("sin_sphere.hf:2:61"), std::string::npos) << err;
  // The default example's R-function blends have loose enclosures: the march is cheaper.
  fs::path def = fs::path(HFRT_SOURCE_DIR) / "examples" / "default.hf";
  ASSERT_EQ(
      run_hfrt("render " + def.string() + " -o " + out.string() + " --size 32x32 --stats", &err), 0)
      << err;
  EXPECT_NE(err.find("root search sign (auto: loose interval enclosures"), std::string::npos)
      << err;
  EXPECT_NE(err.find("\nroot: sign\n"), std::string::npos) << err;
  EXPECT_NE(err.find("\nroot fallback: not analytic: 'hfBlendUni'"), std::string::npos) << err;
  // Forcing the interval search still works for it.
  ASSERT_EQ(
      run_hfrt("render " + def.string() + " -o " + out.string() + " --size 16x16 --root interval",
               &err),
      0)
      << err;
  EXPECT_NE(err.find("root search interval"), std::string::npos) << err;
}

/// A union (max) of `n` leaves, `leaf(i)` giving leaf i's definition of `t<i>` (one line).
std::string union_model(int n, const std::function<std::string(int)>& leaf) {
  std::string src = "my_model(x[3], a[1]) {\n";
  for (int i = 0; i < n; ++i) {
    src += leaf(i);
    if (i > 0) {
      src += "  u" + std::to_string(i) + " = max(" + (i == 1 ? "t0" : "u" + std::to_string(i - 1)) +
             ", t" + std::to_string(i) + ");\n";
    }
  }
  return src + "  my_model = u" + std::to_string(n - 1) + ";\n}\n";
}

TEST(RenderCli, AutoProbesIntervalsForManyPolynomialLeaves) {
  // From kAutoProbeAnalyticLeaves (16) polynomial leaves, `auto` probes the interval search:
  // 16 spheres have tight enclosures and take it (every ray would solve 16 leaves) ...
  auto sphere = [](int i) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "  dx%d = x[1] - (%.2f); t%d = 0.09 - dx%d*dx%d - x[2]*x[2] - x[3]*x[3];\n", i,
                  -3 + 0.4 * i, i, i, i);
    return std::string(buf);
  };
  fs::path spheres = write_model("spheres16.hf", union_model(16, sphere));
  fs::path out = temp_dir() / "many_leaves.png";
  std::string err;
  ASSERT_EQ(run_hfrt("render " + spheres.string() + " -o " + out.string() + " --size 32x32 --stats",
                     &err),
            0)
      << err;
  EXPECT_NE(err.find("root search interval (auto: interval evaluator, "), std::string::npos) << err;
  EXPECT_NE(err.find("cheaper than solving 16 polynomial leaves per ray; --root analytic forces "
                     "exact roots"),
            std::string::npos)
      << err;
  EXPECT_EQ(err.find("auto probe 0.0 ms"), std::string::npos) << err;  // a probe was made
  // ... 15 do not (no probe) ...
  fs::path fifteen = write_model("spheres15.hf", union_model(15, sphere));
  ASSERT_EQ(run_hfrt("render " + fifteen.string() + " -o " + out.string() + " --size 32x32", &err),
            0)
      << err;
  EXPECT_NE(err.find("root search analytic (auto: analytic: 15 polynomial leaves"),
            std::string::npos)
      << err;
  // ... and 16 quartic tori, whose enclosures are loose, keep the exact roots.
  auto torus = [](int i) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "  p%d = x[1] - (%.2f); q%d = p%d*p%d + x[2]*x[2] + x[3]*x[3] + 0.8; t%d = "
                  "3.2*(p%d*p%d + x[2]*x[2]) - q%d*q%d;\n",
                  i, -3 + 0.4 * i, i, i, i, i, i, i, i, i);
    return std::string(buf);
  };
  fs::path tori = write_model("tori16.hf", union_model(16, torus));
  ASSERT_EQ(run_hfrt("render " + tori.string() + " -o " + out.string() + " --size 32x32", &err), 0)
      << err;
  EXPECT_NE(err.find("root search analytic (auto: analytic: 16 polynomial leaves of degree <= 4; "
                     "loose interval enclosures in a 24x24 probe)"),
            std::string::npos)
      << err;
}

TEST(RenderCli, StatsReportPrunedTapesAndNoPruneTurnsThemOff) {
  // The gear (231 tape instructions) at 256x256: the interval search's boxes go to tapes
  // pruned per tile slab; --no-prune keeps the whole program, with the same image.
  const std::string gear =
      HFRT_CORPUS_DIR "/models/github/alexander-penev__FRep-Designer-Bench/c1_gear.hf";
  fs::path a = temp_dir() / "gear_pruned.png", b = temp_dir() / "gear_full.png";
  std::string err;
  ASSERT_EQ(run_hfrt("render " + gear + " -o " + a.string() +
                         " --size 256x256 --bbox 1.6 --root interval --stats",
                     &err),
            0)
      << err;
  EXPECT_NE(err.find("stats: pruned tapes: "), std::string::npos) << err;
  ASSERT_EQ(run_hfrt("render " + gear + " -o " + b.string() +
                         " --size 256x256 --bbox 1.6 --root interval --stats --no-prune",
                     &err),
            0)
      << err;
  EXPECT_EQ(err.find("pruned tapes"), std::string::npos) << err;
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string png = bytes(a);
  EXPECT_GT(png.size(), 1000u);
  EXPECT_EQ(png, bytes(b));
}

TEST(RenderCli, LargeStraightLineModelsKeepIntervalsOnPrunedTapes) {
  // 400 spheres in a row (~4000 IR instructions: past the interval JIT's limit, so the tape VM
  // evaluates the intervals). `auto` used to render such a model without intervals (framed by
  // sampling); with tapes pruned per tile slab it keeps them, and --no-prune keeps the old way.
  auto sphere = [](int i) {
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  "  dx%d = x[1] - (%.3f); dy%d = x[2] - (%.3f); t%d = 0.01 - dx%d*dx%d - "
                  "dy%d*dy%d - x[3]*x[3];\n",
                  i, -3 + 0.015 * i, i, 0.2 * std::sin(0.3 * i), i, i, i, i, i);
    return std::string(buf);
  };
  fs::path model = write_model("spheres400.hf", union_model(400, sphere));
  fs::path out = temp_dir() / "spheres400.png";
  std::string err;
  ASSERT_EQ(run_hfrt("render " + model.string() + " -o " + out.string() +
                         " --size 96x96 --bbox 4 --stats --no-shadows",
                     &err),
            0)
      << err;
  EXPECT_NE(err.find("interval tape VM"), std::string::npos) << err;
  EXPECT_NE(err.find("(intervals)"), std::string::npos) << err;  // framed by intervals
  EXPECT_NE(err.find("root: interval"), std::string::npos) << err;
  EXPECT_NE(err.find("stats: pruned tapes: "), std::string::npos) << err;
  ASSERT_EQ(run_hfrt("render " + model.string() + " -o " + out.string() +
                         " --size 96x96 --bbox 4 --stats --no-shadows --no-prune",
                     &err),
            0)
      << err;
  EXPECT_NE(err.find("(sampling)"), std::string::npos) << err;
  EXPECT_EQ(err.find("pruned tapes"), std::string::npos) << err;
}

TEST(RenderCli, AutoPicksAnalyticForPolynomialModels) {
  fs::path model = write_model("sphere_auto.hf", kSphereModel);
  fs::path out = temp_dir() / "analytic.png";
  std::string err;
  for (const char* root : {"auto", "analytic"}) {
    ASSERT_EQ(run_hfrt("render " + model.string() + " -o " + out.string() +
                           " --size 32x32 --stats --root " + root,
                       &err),
              0)
        << err;
    EXPECT_NE(err.find("root search analytic"), std::string::npos) << err;
    EXPECT_NE(err.find("\nroot: analytic\n"), std::string::npos) << err;
    EXPECT_EQ(err.find("root fallback"), std::string::npos) << err;
    EXPECT_NE(err.find("analytic candidates:"), std::string::npos) << err;
  }
  // The polynomial examples qualify too.
  for (const char* name : {"analytic_torus", "analytic_csg", "analytic_block"}) {
    fs::path ex = fs::path(HFRT_SOURCE_DIR) / "examples" / (std::string(name) + ".hf");
    ASSERT_EQ(
        run_hfrt("render " + ex.string() + " -o " + out.string() + " --size 24x24 --stats", &err),
        0)
        << err;
    EXPECT_NE(err.find("\nroot: analytic\n"), std::string::npos) << name << ": " << err;
  }
}

TEST(RenderCli, RootAnalyticOnABlendIsALocatedError) {
  fs::path model = write_model("blended.hf",
                               "my_model(x[3], a[1]) {\n"
                               "  array c[3];\n"
                               "  c = [0, 0, 0];\n"
                               "  b = hfSphere(x, c, 3);\n"
                               "  my_model = hfBlendUni(b, hfTorusZ(x, c, 4, 1), 1, 1, 1);\n"
                               "}\n");
  std::string err;
  EXPECT_EQ(run_hfrt("render " + model.string() + " -o " + (temp_dir() / "blend.png").string() +
                         " --root analytic",
                     &err),
            1);
  // file:line:col: error: message, the source line, a caret under the construct, a hint.
  EXPECT_NE(err.find("blended.hf:5:14: error: --root analytic:"), std::string::npos) << err;
  EXPECT_NE(err.find("'hfBlendUni'"), std::string::npos) << err;
  EXPECT_NE(err.find("  my_model = hfBlendUni(b, hfTorusZ"), std::string::npos) << err;
  EXPECT_NE(err.find("\n" + std::string(14, ' ') + "^"), std::string::npos) << err;
  EXPECT_NE(err.find("hint: "), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(temp_dir() / "blend.png"));
}

TEST(RenderCli, DepthGoesToTheZChannelOfTheExr) {
  // Orthographic view of the ball of radius 4 from z = 20: Z = 20 - sqrt(16 - x^2 - y^2) along
  // the pixel-centre rays of the camera contract, +inf off the ball.
  fs::path model = write_model("sphere_z.hf", kSphereModel);
  fs::path out = temp_dir() / "z.exr";
  std::string err;
  ASSERT_EQ(
      run_hfrt(
          "render " + model.string() + " -o " + out.string() +
              " --size 40x40 --ortho 10 --eye 0,0,20 --look-at 0,0,0 --aov depth --root analytic",
          &err),
      0)
      << err;
  int w, h, c;
  auto img = read_image(out.string(), &w, &h, &c);
  ASSERT_TRUE(img.ok());
  ASSERT_EQ(c, 5);  // R G B A Z, in one file
  EXPECT_FALSE(fs::exists(temp_dir() / "z.depth.exr"));
  int checked = 0;
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      double x = ((i + 0.5) / w - 0.5) * 10, y = (0.5 - (j + 0.5) / h) * 10;
      float z = img.value()[(size_t(j) * w + i) * 5 + 4];
      double r2 = x * x + y * y;
      if (r2 < 15.9) {
        EXPECT_NEAR(z, 20 - std::sqrt(16 - r2), 2e-5) << i << "," << j;
        ++checked;
      } else if (r2 > 16.1) {
        EXPECT_TRUE(std::isinf(z) && z > 0) << i << "," << j << " " << z;
      }
    }
  }
  EXPECT_GT(checked, 500);
}

TEST(RenderCli, CompileErrorsExitOneWithDiagnostics) {
  fs::path model =
      write_model("bad.hf", "my_model(x[3], a[1]) {\n  my_model = hfSphere(x, 4);\n}\n");
  std::string err;
  EXPECT_EQ(run_hfrt("render " + model.string() + " -o " + (temp_dir() / "bad.png").string(), &err),
            1);
  EXPECT_NE(err.find("bad.hf:2:"), std::string::npos) << err;
  EXPECT_NE(err.find("error"), std::string::npos) << err;
}

TEST(RenderCli, UsageErrorsExitTwo) {
  fs::path model = write_model("sphere3.hf", kSphereModel);
  std::string out = " -o " + (temp_dir() / "u.png").string();
  std::string err;
  EXPECT_EQ(run_hfrt("render " + model.string() + out + " --size 12", &err), 0);
  EXPECT_EQ(run_hfrt("render " + model.string() + out + " --size 0x5", &err), 2);
  EXPECT_NE(err.find("--size"), std::string::npos);
  EXPECT_EQ(run_hfrt("render " + model.string() + out + " --bbox 1,2,3", &err), 2);
  EXPECT_EQ(run_hfrt("render " + model.string() + out + " --root maybe", &err), 2);
  EXPECT_EQ(run_hfrt("render " + model.string() + out + " --light sun:1,2,3", &err), 2);
  EXPECT_EQ(run_hfrt("render " + model.string() + out + " --eye 1,1,1 --look-at 1,1,1", &err), 2);
  EXPECT_EQ(run_hfrt("render " + model.string() + " -o " + (temp_dir() / "u.nope").string(), &err),
            2);
}

TEST(SliceCli, DiskArea) {
  fs::path model = write_model("sphere4.hf", kSphereModel);
  fs::path out = temp_dir() / "slice.png";
  std::string err;
  ASSERT_EQ(run_hfrt("slice " + model.string() + " -o " + out.string() +
                         " --size 200x100 --bbox -5,-2.5,5,2.5 --z 2",
                     &err),
            0)
      << err;
  int w, h, c;
  auto img = read_image(out.string(), &w, &h, &c);
  ASSERT_TRUE(img.ok());
  ASSERT_EQ(w, 200);
  ASSERT_EQ(h, 100);
  double inside = 0;
  for (float v : img.value()) inside += v > 0.5f;
  // z = 2 slice of a radius-4 ball: a disk of radius sqrt(12), cut by |y| <= 2.5.
  double r = std::sqrt(12.0), yc = 2.5;
  double segment = r * r * std::acos(yc / r) - yc * std::sqrt(r * r - yc * yc);
  double expected = M_PI * r * r - 2 * segment;
  EXPECT_NEAR(inside * 0.05 * 0.05 / expected, 1.0, 0.01);
}

// --- Every corpus model at 64x64 --------------------------------------------------------

/// The corpus's historical_* files: machine-generated stress inputs (1k-14k IR instructions,
/// up to 185 KB) whose scalar JIT compile alone takes 10-20 s here (and the interval JIT much
/// more); too slow for a unit test. Exactly these are left out.
const char* const kTooSlowToRender[] = {"architecture.hf", "hello_world.hf", "involute_gear_2d.hf",
                                        "involute_gear_3d.hf", "prospero.hf"};

/// Models that need options to show a solid, with the reason.
struct CorpusSpecial {
  const char* file;
  const char* args;  ///< extra `hfrt render` options
  bool empty;        ///< the solid is empty: the image must be all background
  const char* why;
};
const CorpusSpecial kCorpusSpecial[] = {
    {"frep_org__hf_objects__ColorSphere.hf", " -a 0,0,0,3", false,
     "centre and radius are the parameters a[1..4]; all zero by default (no solid)"},
    {"stat_auckland__NZSA2022__HF_27_1_block_minus_sphere.hf", "", true,
     "the unit block [-0.5, 0.5]^3 lies inside the unit sphere subtracted from it"},
};

std::vector<std::string> corpus_files(bool too_slow) {
  std::vector<std::string> out;
  fs::path root = fs::path(HFRT_CORPUS_DIR) / "models";
  if (!fs::exists(root)) return out;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.path().extension() != ".hf") continue;
    const bool slow = e.path().string().find("historical_") != std::string::npos;
    if (slow == too_slow) out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::string> corpus_models() {
  return corpus_files(false);
}

TEST(CorpusRenderList, EveryModelButTheListedStressInputs) {
  // 34 models in ../shared/corpus (2026-12): 29 rendered, the 5 historical_* ones left out.
  std::vector<std::string> slow;
  for (const std::string& p : corpus_files(true)) slow.push_back(fs::path(p).filename().string());
  std::sort(slow.begin(), slow.end());
  EXPECT_EQ(slow,
            std::vector<std::string>(std::begin(kTooSlowToRender), std::end(kTooSlowToRender)));
  const std::vector<std::string> models = corpus_models();
  EXPECT_GE(models.size(), 29u) << "the corpus at " << HFRT_CORPUS_DIR;
  for (const CorpusSpecial& s : kCorpusSpecial) {
    EXPECT_EQ(std::count_if(models.begin(), models.end(),
                            [&](const std::string& p) { return fs::path(p).filename() == s.file; }),
              1)
        << s.file;
  }
}

/// Every corpus model renders at 64x64 with its framed camera, and the solid is where the
/// framing puts it: a good share of the image, the border clear, and the covered pixels
/// centred (the camera looks at the centre of the solid's box and fits the box in the view).
class CorpusRender : public ::testing::TestWithParam<std::string> {};

TEST_P(CorpusRender, Renders64WithTheSolidFramed) {
  const std::string file = fs::path(GetParam()).filename().string();
  const CorpusSpecial* special = nullptr;
  for (const CorpusSpecial& s : kCorpusSpecial) {
    if (file == s.file) special = &s;
  }
  fs::path out = temp_dir() / (fs::path(GetParam()).stem().string() + ".exr");
  std::string err;
  ASSERT_EQ(run_hfrt("render '" + GetParam() + "' -o " + out.string() + " --size 64x64" +
                         (special ? special->args : ""),
                     &err),
            0)
      << err;
  int w = 0, h = 0, c = 0;
  auto img = read_image(out.string(), &w, &h, &c);
  fs::remove(out);
  ASSERT_TRUE(img.ok()) << img.error().message;
  ASSERT_EQ(w, 64);
  ASSERT_EQ(h, 64);
  ASSERT_EQ(c, 4);
  size_t covered = 0, border = 0;
  double sx = 0, sy = 0;
  int x0 = w, x1 = -1, y0 = h, y1 = -1;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (img.value()[(size_t(y) * w + x) * 4 + 3] < 0.5f) continue;
      ++covered;
      border += x == 0 || y == 0 || x == w - 1 || y == h - 1;
      sx += x;
      sy += y;
      x0 = std::min(x0, x);
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  }
  if (special && special->empty) {
    EXPECT_EQ(covered, 0u) << file << " should be empty: " << special->why;
    return;
  }
  // Measured over the 29 models: coverage 13-47 %, the centroid within 5.5 pixels of the
  // centre, the covered box's centre within 4 and its sides 21 to 56 pixels.
  const double centre = (w - 1) / 2.0;
  EXPECT_GT(covered, size_t(w * h) / 10) << file << ": the solid is (nearly) missing";
  EXPECT_EQ(border, 0u) << file << ": the solid touches the border";
  if (covered == 0) return;
  EXPECT_NEAR(sx / double(covered), centre, 8) << file << ": centroid off-centre";
  EXPECT_NEAR(sy / double(covered), centre, 8) << file << ": centroid off-centre";
  EXPECT_NEAR((x0 + x1) / 2.0, centre, 6) << file << ": covered box off-centre";
  EXPECT_NEAR((y0 + y1) / 2.0, centre, 6) << file << ": covered box off-centre";
  // The framing fits the solid's box, not the solid: a ball spans half the image.
  const int span_x = x1 - x0 + 1, span_y = y1 - y0 + 1;
  EXPECT_GE(std::max(span_x, span_y), w * 2 / 5) << file << ": the solid is framed too small";
  EXPECT_GE(std::min(span_x, span_y), w / 4) << file << ": the solid is framed too small";
}

INSTANTIATE_TEST_SUITE_P(Corpus, CorpusRender, ::testing::ValuesIn(corpus_models()),
                         [](const auto& info) {
                           std::string n = fs::path(info.param).stem().string();
                           for (char& ch : n)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n + "_" + std::to_string(info.index);
                         });

}  // namespace
}  // namespace hfrt::render
