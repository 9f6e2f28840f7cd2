// `hfrt eval --interval` and `hfrt eval --gradient` as scripts use them: output format, known
// values, both backends printing the same text, errors and exit codes. Runs the real binary.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

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

/// The numbers of one output line (and whether it ends with the ` nan` flag).
std::vector<double> numbers(const std::string& line, bool* nan_flag = nullptr) {
  std::istringstream in(line);
  std::vector<double> out;
  std::string word;
  if (nan_flag) *nan_flag = false;
  while (in >> word) {
    if (word == "nan") {
      out.push_back(std::nan(""));
      if (nan_flag) *nan_flag = true;
    } else {
      out.push_back(std::strtod(word.c_str(), nullptr));
    }
  }
  return out;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string l;
  while (std::getline(in, l)) out.push_back(l);
  return out;
}

class EvalDomainsCliTest : public CliFixture {
 protected:
  EvalDomainsCliTest() : CliFixture("hfrt_eval_domains") {}
  void SetUp() override {
    CliFixture::SetUp();
    // F = 16 - |x|^2: over [0,1]^3 exactly [13, 16]; gradient -2x.
    write("sphere.hf",
          "my_model(x[3], a[1]) {\n  array c[3];\n  c = [0, 0, 0];\n"
          "  my_model = hfSphere(x, c, 4);\n}\n");
    // No value where x[1] < 0 (sqrt) or x[2] = 0 (division).
    write("partial.hf", "my_model(x[3], a[1]) {\n  my_model = sqrt(x[1]) + 1 / x[2];\n}\n");
  }
  CliRun run(const std::string& args, const std::string& input) {
    return hfrt("eval " + args, input);
  }
};

TEST_F(EvalDomainsCliTest, IntervalOfAKnownSphereBox) {
  CliRun r = run("--interval sphere.hf", "0 1 0 1 0 1\n# comment\n\n5 6 -1 1 0 0\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> out = lines(r.out);
  ASSERT_EQ(out.size(), 2u) << r.out;
  bool nan_flag = true;
  std::vector<double> a = numbers(out[0], &nan_flag);
  ASSERT_EQ(a.size(), 2u) << out[0];
  EXPECT_FALSE(nan_flag);
  // Sound (outward rounded) and tight.
  EXPECT_LE(a[0], 13.0);
  EXPECT_GE(a[1], 16.0);
  EXPECT_NEAR(a[0], 13.0, 1e-9);
  EXPECT_NEAR(a[1], 16.0, 1e-9);
  // x in [5, 6], y in [-1, 1], z = 0: 16 - [25, 37].
  std::vector<double> b = numbers(out[1]);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_NEAR(b[0], -21.0, 1e-9);
  EXPECT_NEAR(b[1], -9.0, 1e-9);
  EXPECT_LE(b[0], -21.0);
  EXPECT_GE(b[1], -9.0);
}

TEST_F(EvalDomainsCliTest, IntervalPrintsSeventeenDigitsAndTheNanFlag) {
  CliRun r = run("--interval partial.hf", "1 4 1 2\n-1 1 1 2\n1 4 -1 1\n0.25 0.25 2 2\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> out = lines(r.out);
  ASSERT_EQ(out.size(), 4u) << r.out;
  bool nan_flag = false;
  numbers(out[0], &nan_flag);
  EXPECT_FALSE(nan_flag) << out[0];
  numbers(out[1], &nan_flag);  // sqrt of negative x[1]
  EXPECT_TRUE(nan_flag) << out[1];
  EXPECT_EQ(out[1].substr(out[1].size() - 4), " nan");
  numbers(out[2], &nan_flag);  // x[2] may be 0
  EXPECT_TRUE(nan_flag) << out[2];
  // A point box: sqrt(0.25) + 1/2 = 1, printed with %.17g (one ulp of widening at most).
  std::vector<double> p = numbers(out[3], &nan_flag);
  EXPECT_FALSE(nan_flag);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_LE(p[0], 1.0);
  EXPECT_GE(p[1], 1.0);
  EXPECT_LT(p[1] - p[0], 1e-15);
  char want[64];
  std::snprintf(want, sizeof want, "%.17g %.17g", p[0], p[1]);
  EXPECT_EQ(out[3], want);
}

TEST_F(EvalDomainsCliTest, MissingPairsArePoints) {
  // "2" is x = [2, 2]; y and z missing: the point 0.
  CliRun r = run("--interval sphere.hf", "2\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::vector<double> v = numbers(r.out);
  ASSERT_EQ(v.size(), 2u);
  EXPECT_LE(v[0], 12.0);
  EXPECT_GE(v[1], 12.0);
  EXPECT_LT(v[1] - v[0], 1e-12);
}

TEST_F(EvalDomainsCliTest, BothBackendsPrintTheSameIntervalsAndGradients) {
  std::string boxes, points;
  for (int i = 0; i < 300; ++i) {
    char line[160];
    double x = std::sin(i * 0.7) * 4, y = std::cos(i * 0.3) * 4, z = std::sin(i * 0.11) * 3;
    double w = 0.001 * (i % 50);
    std::snprintf(line, sizeof line, "%.6f %.6f %.6f %.6f %.6f %.6f\n", x, x + w, y, y + 2 * w, z,
                  z + w);
    boxes += line;
    std::snprintf(line, sizeof line, "%.6f %.6f %.6f\n", x, y, z);
    points += line;
  }
  for (const char* model : {"sphere.hf", "partial.hf"}) {
    CliRun a = run(std::string("--interval ") + model, boxes);
    CliRun b = run(std::string("--interval --backend interp ") + model, boxes);
    ASSERT_EQ(a.exit_code, 0) << a.err;
    EXPECT_EQ(lines(a.out).size(), 300u);
    EXPECT_EQ(a.out, b.out) << model;
    CliRun g = run(std::string("--gradient ") + model, points);
    CliRun h = run(std::string("--gradient --backend interp ") + model, points);
    ASSERT_EQ(g.exit_code, 0) << g.err;
    EXPECT_EQ(lines(g.out).size(), 300u);
    EXPECT_EQ(g.out, h.out) << model;
  }
}

TEST_F(EvalDomainsCliTest, GradientOfASphere) {
  for (const char* backend : {"jit", "interp"}) {
    CliRun r = run(std::string("--gradient --backend ") + backend + " sphere.hf", "1 2 0.5\n3\n");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    // F = 16 - |x|^2, grad = -2x: exact in binary.
    EXPECT_EQ(r.out, "10.75 -2 -4 -1\n7 -6 0 0\n") << backend;
  }
  CliRun f32 = run("--gradient --precision f32 sphere.hf", "0.1 0.2 0.3\n");
  ASSERT_EQ(f32.exit_code, 0) << f32.err;
  std::vector<double> v = numbers(f32.out);
  ASSERT_EQ(v.size(), 4u);
  EXPECT_NEAR(v[0], 16 - 0.14, 1e-5);
  EXPECT_NEAR(v[1], -0.2, 1e-6);
  EXPECT_NEAR(v[3], -0.6, 1e-6);
  EXPECT_NE(v[1], -0.2);  // really computed in float
}

TEST_F(EvalDomainsCliTest, GradientWithoutValueIsAllNan) {
  CliRun r = run("--gradient partial.hf", "4 2 0\n-1 2 0\n4 0 0\n");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "2.5 0.25 -0.25 0\nnan nan nan nan\nnan nan nan nan\n");
}

TEST_F(EvalDomainsCliTest, UsageAndInputErrors) {
  CliRun reversed = run("--interval sphere.hf", "0 1 0 1 0 1\n0 1 3 2 0 1\n");
  EXPECT_EQ(reversed.exit_code, 2);
  EXPECT_EQ(reversed.out, "");  // nothing printed before the whole input is checked
  EXPECT_NE(reversed.err.find("box 2, coordinate 2"), std::string::npos) << reversed.err;
  CliRun garbage = run("--gradient sphere.hf", "1 x 2\n");
  EXPECT_EQ(garbage.exit_code, 2);
  EXPECT_NE(garbage.err.find("cannot read 'x'"), std::string::npos) << garbage.err;
  CliRun both = run("--interval --gradient sphere.hf", "1\n");
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("exclude each other"), std::string::npos) << both.err;
  CliRun f32 = run("--interval --precision f32 sphere.hf", "1\n");
  EXPECT_EQ(f32.exit_code, 2);
  write("bad.hf", "my_model(x[3], a[1]) { my_model = x[1] +; }\n");
  CliRun bad = run("--interval bad.hf", "1\n");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("bad.hf:1:"), std::string::npos) << bad.err;
  CliRun missing = run("--gradient nofile.hf", "1\n");
  EXPECT_EQ(missing.exit_code, 2);
}

TEST_F(EvalDomainsCliTest, StatsNameTheEngine) {
  CliRun jit = run("--interval --stats sphere.hf", "0 1\n");
  ASSERT_EQ(jit.exit_code, 0) << jit.err;
  EXPECT_NE(jit.err.find("engine jit"), std::string::npos) << jit.err;
  EXPECT_NE(jit.err.find("interval jit:"), std::string::npos) << jit.err;
  CliRun interp = run("--gradient --stats --backend interp sphere.hf", "0 1\n");
  ASSERT_EQ(interp.exit_code, 0) << interp.err;
  EXPECT_NE(interp.err.find("engine interpreter"), std::string::npos) << interp.err;
}

}  // namespace
}  // namespace hfrt::tools
