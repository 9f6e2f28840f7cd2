// `hfrt eval` as scripts use it: output format, backends, precisions, errors, exit codes.
// Runs the real binary with stdin/stdout/stderr redirected to files.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/tools/cli_fixture.h"

namespace hfrt::tools {
namespace {

namespace fs = std::filesystem;

using testing::CliFixture;
using testing::CliRun;
using testing::slurp;

class EvalCliTest : public CliFixture {
 protected:
  EvalCliTest() : CliFixture("hfrt_eval_cli") {}
  void SetUp() override {
    CliFixture::SetUp();
    write("m.hf",
          "my_model(x[3], a[2], s[2])\n"
          "{\n"
          "  d = x[1] - a[1];\n"
          "  s[1] = x[2] * 2;\n"
          "  s[2] = a[2];\n"
          "  my_model = 1 / d - x[3];\n"
          "}\n"
          "other(x[2], a[1])\n"
          "{\n"
          "  other = x[1] + 10 * x[2];\n"
          "}\n");
  }
  CliRun run(const std::string& args, const std::string& input) {
    return hfrt("eval " + args, input);
  }
};

TEST_F(EvalCliTest, OneLinePerPointWithSValues) {
  // Missing coordinates are 0, extra ones ignored, blank and '#' lines skipped.
  CliRun r = run("m.hf -a 0,7", "0.5 0.25\n2 0 1\n\n# comment\n1 2 3 4 5\n");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "2 0.5 7\n-0.5 0 7\n-2 4 7\n");
  EXPECT_EQ(r.err, "");
}

TEST_F(EvalCliTest, SeventeenSignificantDigits) {
  CliRun r = run("m.hf", "3 0 0.1\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  char want[64];
  std::snprintf(want, sizeof want, "%.17g 0 0\n", 1.0 / 3.0 - 0.1);
  EXPECT_EQ(r.out, want);
}

TEST_F(EvalCliTest, RuntimeErrorMessageWithLocationOnBothBackends) {
  // 1 / d with d = 0: the '/' is on line 6, column 16.
  for (const char* backend : {"jit", "interp"}) {
    CliRun r = run(std::string("m.hf --backend ") + backend, "0.5 0.25\n0 0 0\n2 0 0\n");
    EXPECT_EQ(r.exit_code, 0) << backend << ": " << r.err;
    EXPECT_EQ(r.out, "2 0.5 0\nnan Division by zero (line 6 pos 16)\n0.5 0 0\n") << backend;
  }
}

TEST_F(EvalCliTest, ObjectSelection) {
  CliRun r = run("m.hf --object other", "1 2\n");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "21 0\n");  // an object without s reports one s of 0, as the original
  CliRun bad = run("m.hf --object nope", "1\n");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("no object named 'nope'"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("my_model, other"), std::string::npos) << bad.err;
}

TEST_F(EvalCliTest, CompileErrorsGoToStderrWithExitOne) {
  write("bad.hf", "my_model(x[3], a[1]) { my_model = x[1] +* 2; }\n");
  CliRun r = run("bad.hf", "1 2 3\n");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_NE(r.err.find("bad.hf:1:41: error"), std::string::npos) << r.err;
}

TEST_F(EvalCliTest, UsageAndInputErrors) {
  CliRun missing = run("nofile.hf", "");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("nofile.hf"), std::string::npos);
  CliRun garbage = run("m.hf", "1 abc\n");
  EXPECT_EQ(garbage.exit_code, 2);
  EXPECT_NE(garbage.err.find("line 1: cannot read 'abc'"), std::string::npos) << garbage.err;
  CliRun bad_params = run("m.hf -a 1,x", "1\n");
  EXPECT_EQ(bad_params.exit_code, 2);
  CliRun bad_backend = run("m.hf --backend gpu", "1\n");
  EXPECT_NE(bad_backend.exit_code, 0);
}

TEST_F(EvalCliTest, JitAndInterpreterPrintTheSameTextForManyPoints) {
  // More points than one JIT block (4096), with errors sprinkled in.
  write("w.hf",
        "my_model(x[3], a[1], s[1])\n{\n"
        "  r = sqrt(x[1]*x[1] + x[2]*x[2]);\n"
        "  i = 0; t = 0;\n"
        "  while (i < 5) loop\n"
        "    if (x[3] > i) then t = t + sin(r * i); else t = t - cos(x[3] * i); endif;\n"
        "    i = i + 1;\n"
        "  endloop;\n"
        "  s[1] = t;\n"
        "  my_model = t / (x[1] - 1) + log(x[2] + 2);\n}\n");
  std::string input;
  for (int i = 0; i < 5000; ++i) {
    char line[96];
    std::snprintf(line, sizeof line, "%d %.6f %.6f\n", i % 3, std::sin(i * 0.37) * 3,
                  std::cos(i * 0.11) * 6);
    input += line;
  }
  CliRun jit = run("w.hf", input);
  CliRun interp = run("w.hf --backend interp", input);
  ASSERT_EQ(jit.exit_code, 0) << jit.err;
  ASSERT_EQ(interp.exit_code, 0) << interp.err;
  EXPECT_EQ(std::count(jit.out.begin(), jit.out.end(), '\n'), 5000);
  EXPECT_NE(jit.out.find("nan Division by zero"), std::string::npos);
  EXPECT_NE(jit.out.find("nan Logarithm of non-positive value"), std::string::npos);
  EXPECT_EQ(jit.out, interp.out);
}

TEST_F(EvalCliTest, SinglePrecisionIsClose) {
  CliRun r = run("m.hf --precision f32", "3 0 0.1\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  double v = std::strtod(r.out.c_str(), nullptr);
  EXPECT_NEAR(v, 1.0 / 3.0 - 0.1, 1e-6);
  EXPECT_NE(v, 1.0 / 3.0 - 0.1);  // really computed in float
}

TEST_F(EvalCliTest, StatsGoToStderr) {
  CliRun r = run("m.hf --stats", "0.5 0.25\n");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_EQ(r.out, "2 0.5 0\n");
  EXPECT_NE(r.err.find("stats: jit f64:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("codegen"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hfrt::tools

namespace hfrt::tools {
namespace {

// ---- limits on hostile input (docs/limits.md) ------------------------------------------------

TEST_F(EvalCliTest, LoopLimitIsAnOptionAndEndlessLoopsAreNaNWithTheirLocation) {
  write("loop.hf",
        "my_model(x[3], a[1])\n{\n  i = 0;\n  while i < x[1] loop i = i + 1; endloop;\n"
        "  my_model = i;\n}\n");
  for (const char* backend : {"jit", "interp"}) {
    CliRun r = hfrt(std::string("eval loop.hf --max-loop-iterations 5 --backend ") + backend,
                    "5 0 0\n6 0 0\n");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.out, "5 0\nnan Loop iteration limit exceeded (line 4 pos 3)\n") << backend;
  }
  CliRun bad = hfrt("eval loop.hf --max-loop-iterations 0");
  EXPECT_EQ(bad.exit_code, 2) << bad.err;  // a usage error
  EXPECT_NE(bad.err.find("--max-loop-iterations: Value 0 not in range 1 to 16777216"),
            std::string::npos)
      << bad.err;
}

// --max-exact-curves below the teapot's 16 open border curves: its field goes through the
// tessellation, whose values near the surface are off by up to its measured error (~2e-3);
// the default is the exact field. 0 is out of range.
TEST_F(EvalCliTest, MaxExactCurvesPicksTheTessellatedPatchField) {
  const std::string teapot = std::string(HFRT_SOURCE_DIR) + "/examples/teapot.hf";
  const std::string points = "1.5 1.0 0.4\n0.5 2.0 0.3\n-1.2 0.8 -0.9\n";
  CliRun exact = run(teapot, points), tessellated = run(teapot + " --max-exact-curves 8", points);
  ASSERT_EQ(exact.exit_code, 0) << exact.err;
  ASSERT_EQ(tessellated.exit_code, 0) << tessellated.err;
  std::istringstream a(exact.out), b(tessellated.out);
  double fa, fb, sa, sb, most = 0;
  int n = 0;
  while (a >> fa >> sa && b >> fb >> sb) most = std::max(most, std::abs(fa - fb)), ++n;
  EXPECT_EQ(n, 3);
  EXPECT_GT(most, 1e-6);
  EXPECT_LT(most, 3e-3);
  CliRun bad = run(teapot + " --max-exact-curves 0", points);
  EXPECT_EQ(bad.exit_code, 2) << bad.err;  // a usage error
  EXPECT_NE(bad.err.find("--max-exact-curves: Value 0 not in range 1 to"), std::string::npos)
      << bad.err;
}

TEST_F(EvalCliTest, HugeArrayAndDevZeroMeshAreLocatedErrors) {
  write("arr.hf", "my_model(x[3], a[1])\n{\n  array v[1000000000];\n  my_model = 1;\n}\n");
  CliRun r = hfrt("eval arr.hf");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("arr.hf:3:11: error: array size 1000000000 is more than the limit of 8192 "
                       "elements"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("hint: raise the limit with --max-array-size N"), std::string::npos);
  EXPECT_EQ(hfrt("eval arr.hf --max-array-size 999999999").exit_code, 1);

  write("zero.hf", "my_model(x[3], a[1])\n{\n  my_model = hfMesh(x, \"/dev/zero\");\n}\n");
  CliRun z = hfrt("eval zero.hf");
  EXPECT_EQ(z.exit_code, 1);
  EXPECT_NE(z.err.find("zero.hf:3:14: error: hfMesh: /dev/zero: is not a regular file"),
            std::string::npos)
      << z.err;
}

}  // namespace
}  // namespace hfrt::tools
