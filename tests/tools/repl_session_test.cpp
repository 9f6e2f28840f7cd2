// `hfrt repl`: the Session driven directly (definitions, :load, :eval, :render, errors), and
// the command in script mode (stdin not a terminal) as a subprocess.
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

#include "render/image.h"
#include "tools/hfrt/session.h"

namespace hfrt::tools {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("hfrt_repl_test_" + std::to_string(getpid()));
  fs::create_directories(d);
  return d;
}

SessionResult feed_all(Session& s, const std::string& text) {
  std::istringstream in(text);
  std::string line;
  SessionResult last;
  bool got = false;
  while (std::getline(in, line)) {
    auto r = s.feed_line(line);
    if (r) {
      last = *r;
      got = true;
    }
  }
  EXPECT_TRUE(got) << "no complete input in: " << text;
  return last;
}

double eval_value(Session& s, const std::string& point) {
  SessionResult r = s.run(":eval " + point);
  EXPECT_TRUE(r.ok) << r.err;
  return std::strtod(r.out.c_str(), nullptr);
}

TEST(ReplSession, BraceDelta) {
  EXPECT_EQ(brace_delta("f(x[3], a[1]) {"), 1);
  EXPECT_EQ(brace_delta("} -- { in a comment"), -1);
  EXPECT_EQ(brace_delta("{ }"), 0);
}

TEST(ReplSession, MultiLineDefinitionThenEval) {
  Session s;
  EXPECT_FALSE(s.feed_line("ball(x[3], a[1])"));
  EXPECT_FALSE(s.feed_line("{"));
  EXPECT_TRUE(s.pending());
  auto r = s.feed_line("  ball = 4 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3];");
  EXPECT_FALSE(r);
  r = s.feed_line("}");
  ASSERT_TRUE(r);
  EXPECT_TRUE(r->ok) << r->err;
  EXPECT_FALSE(s.pending());
  EXPECT_EQ(s.current(), "ball");
  // 4 - 1 - 4 - 0.25 = -1.25, printed with %.17g as `hfrt eval` does, then s[] (every
  // object has s[1], 0 when not written).
  SessionResult e = s.run(":eval 1 2 0.5");
  ASSERT_TRUE(e.ok) << e.err;
  EXPECT_EQ(e.out, "-1.25 0\n");
  EXPECT_EQ(s.run(":eval 0.1 0 0").out, "3.9900000000000002 0\n");
}

TEST(ReplSession, ErroneousDefinitionKeepsPreviousModel) {
  Session s;
  ASSERT_TRUE(feed_all(s, "m(x[3], a[1]) { m = 1 - x[1]; }").ok);
  EXPECT_DOUBLE_EQ(eval_value(s, "3 0 0"), -2);
  // A syntax error on the second typed line: a located diagnostic, nothing changes.
  SessionResult bad = feed_all(s, "m(x[3], a[1]) {\n  m = 2 - ;\n}");
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.err.find("<input>:2:"), std::string::npos) << bad.err;
  EXPECT_EQ(s.current(), "m");
  EXPECT_DOUBLE_EQ(eval_value(s, "3 0 0"), -2);
  // The corrected definition replaces it in place.
  ASSERT_TRUE(feed_all(s, "m(x[3], a[1]) {\n  m = 2 - x[1];\n}").ok);
  EXPECT_DOUBLE_EQ(eval_value(s, "3 0 0"), -1);
  EXPECT_EQ(s.objects().size(), 1u);
}

TEST(ReplSession, ObjectsCallEarlierObjectsAndCacheCompiles) {
  Session s;
  ASSERT_TRUE(s.run("base(x[3], a[1]) { base = 1 - x[1]; }").ok);
  SessionResult r = s.run("top(x[3], a[1]) { v = base(x, a); top = 10 * v; }");
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_EQ(s.current(), "top");
  EXPECT_DOUBLE_EQ(eval_value(s, "0.5 0 0"), 5);
  // Replacing base in place changes top (defined later) too.
  ASSERT_TRUE(s.run("base(x[3], a[1]) { base = 2 - x[1]; }").ok);
  ASSERT_TRUE(s.run("top(x[3], a[1]) { v = base(x, a); top = 10 * v; }").ok);
  EXPECT_DOUBLE_EQ(eval_value(s, "0.5 0 0"), 15);
  ASSERT_EQ(s.objects().size(), 2u);
  EXPECT_EQ(s.objects()[0].first, "base");
  // Evaluating again compiles nothing: the model is cached by its source text.
  int before = s.compiles();
  eval_value(s, "1 0 0");
  EXPECT_EQ(s.compiles(), before);
}

TEST(ReplSession, EvalWithParametersAndErrors) {
  Session s;
  ASSERT_TRUE(s.run("p(x[3], a[2]) { p = a[1] + a[2] * x[1]; }").ok);
  EXPECT_DOUBLE_EQ(eval_value(s, "2 0 0 1 3"), 7);
  EXPECT_DOUBLE_EQ(eval_value(s, "2 0 0"), 0);  // parameters are not remembered
  EXPECT_FALSE(s.run(":eval 1 zz 0").ok);
  EXPECT_FALSE(s.run(":eval 1").ok);
  EXPECT_FALSE(s.run(":nonsense").ok);
}

TEST(ReplSession, LoadPicksMyModel) {
  Session s;
  fs::path dir = temp_dir();
  fs::path file = dir / "two.hf";
  std::ofstream(file) << "-- two objects\nmy_model(x[3], a[1])\n{\n  my_model = 3 - x[1];\n}\n\n"
                         "other(x[3], a[1]) { other = -7; }\n";
  SessionResult r = s.run(":load " + file.string());
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_EQ(s.current(), "my_model");
  EXPECT_EQ(s.objects().size(), 2u);
  EXPECT_DOUBLE_EQ(eval_value(s, "1 0 0"), 2);
  EXPECT_FALSE(s.run(":load " + (dir / "missing.hf").string()).ok);
  EXPECT_EQ(s.current(), "my_model");
  fs::remove_all(dir);
}

TEST(ReplSession, RenderRemembersOptions) {
  Session s;
  fs::path dir = temp_dir();
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 4 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  std::string out1 = (dir / "a.png").string();
  SessionResult r = s.run(":render " + out1 + " --size 64x48 --bbox -3,-3,-3,3,3,3 --spp 1");
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_TRUE(r.rendered);
  ASSERT_NE(s.last_image(), nullptr);
  EXPECT_EQ(s.last_image()->width, 64);
  EXPECT_EQ(s.last_image()->height, 48);
  // The sphere is in the middle of the picture: the centre pixel hits, a corner does not.
  const render::Image& img = *s.last_image();
  EXPECT_GT(img.alpha[size_t(24) * 64 + 32], 0.5f);
  EXPECT_EQ(img.alpha[0], 0.0f);
  ASSERT_TRUE(fs::exists(out1));
  EXPECT_GT(fs::file_size(out1), 0u);

  // A bad option changes nothing.
  EXPECT_FALSE(s.run(":render " + out1 + " --size 0x1").ok);
  EXPECT_EQ(s.render_settings().options.width, 64);

  // A new definition, then `:render OUT` reuses size and box.
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  std::string out2 = (dir / "b.png").string();
  r = s.run(":render " + out2);
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_EQ(s.last_image()->width, 64);
  EXPECT_EQ(s.last_image()->height, 48);
  ASSERT_TRUE(fs::exists(out2));
  // :set changes one option for the next render.
  ASSERT_TRUE(s.run(":set size 32x32").ok);
  EXPECT_FALSE(s.run(":set size banana").ok);
  r = s.run(":render " + out2);
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_EQ(s.last_image()->width, 32);
  EXPECT_NE(s.run(":show").out.find("size 32x32"), std::string::npos);
  fs::remove_all(dir);
}

TEST(ReplSession, AnsiPreview) {
  render::Image img;
  img.resize(4, 4);
  for (float& v : img.rgb) v = 1.0f;
  std::string p = ansi_preview(img, 80);
  // 4x4 pixels: 2 text rows of 4 half blocks each.
  size_t blocks = 0;
  for (size_t i = p.find("\xe2\x96\x80"); i != std::string::npos; i = p.find("\xe2\x96\x80", i + 1)) ++blocks;
  EXPECT_EQ(blocks, 8u);
  EXPECT_NE(p.find("38;2;255;255;255"), std::string::npos);
}

// --- The command, as a subprocess ----------------------------------------------------------

struct RunResult {
  int code = -1;
  std::string out;
};

RunResult run_hfrt(const std::string& script, const std::string& env = "") {
  fs::path dir = temp_dir();
  fs::path in = dir / "script.txt", out = dir / "out.txt";
  std::ofstream(in) << script;
  std::string cmd = env + " '" HFRT_BINARY_DIR "/tools/hfrt/hfrt' repl < '" + in.string() + "' > '" +
                    out.string() + "' 2>/dev/null";
  int status = std::system(cmd.c_str());
  RunResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream f(out);
  std::stringstream ss;
  ss << f.rdbuf();
  r.out = ss.str();
  return r;
}

TEST(ReplScript, SuccessfulScriptExitsZero) {
  RunResult r = run_hfrt("ball(x[3], a[1])\n{\n  ball = 4 - x[1]*x[1];\n}\n:eval 1 0 0\n:eval 3 0 0\n");
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out, "defined ball\n3 0\n-5 0\n");
}

TEST(ReplScript, FailedCommandExitsNonZeroButGoesOn) {
  RunResult r = run_hfrt("m(x[3], a[1]) { m = 1; }\nm(x[3], a[1]) { m = 1 + ; }\n:eval 0 0 0\n");
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.out, "defined m\n1 0\n");
  // Input that ends inside a definition is an error too.
  EXPECT_EQ(run_hfrt("m(x[3], a[1]) {\n m = 1;\n").code, 1);
}

}  // namespace
}  // namespace hfrt::tools
