// `hfrt repl`: the Session driven directly (definitions, :load, :eval, :render, errors), and
// the command in script mode (stdin not a terminal) as a subprocess.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "lang/objects.h"
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
  EXPECT_EQ(lang::brace_delta("f(x[3], a[1]) {"), 1);
  EXPECT_EQ(lang::brace_delta("} -- { in a comment"), -1);
  EXPECT_EQ(lang::brace_delta("{ }"), 0);
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

// `:set time T` (issue 24): x[4] of the model, a number for the cached model (no recompile),
// restored after the render like -a.
TEST(ReplSession, TimeMovesAnAnimatedModel) {
  Session s;
  fs::path dir = temp_dir();
  ASSERT_TRUE(
      s.run("m(x[4], a[1]) { m = 1 - (x[1] - (-2 + 4 * x[4]))^2 - x[2]*x[2] - x[3]*x[3]; }").ok);
  const std::string out = (dir / "t.png").string();
  for (double t : {0.0, 0.75}) {
    ASSERT_TRUE(s.run(":set time " + std::to_string(t)).ok);
    SessionResult r = s.run(":render " + out +
                            " --size 64x16 --ortho 8 --eye 0,0,10 --look-at 0,0,0 "
                            "--bbox -4,-2,-2,4,2,2");
    ASSERT_TRUE(r.ok) << r.err;
    const render::Image& img = *s.last_image();
    double sum = 0, n = 0;
    for (int x = 0; x < 64; ++x) {
      const float a = img.alpha[size_t(8 * 64 + x)];
      sum += a * ((x + 0.5) / 8 - 4);
      n += a;
    }
    EXPECT_NEAR(sum / n, -2 + 4 * t, 0.07) << t;
  }
  EXPECT_FALSE(s.run(":set time later").ok);
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

TEST(ReplSession, RendersAMeshLeafWithTheAnalyticSearch) {
  // A mesh leaf in CSG with a ball renders through the session with the analytic search (the
  // session prepares it as `hfrt render` does: app::ModelField::prepare_render).
  Session s;
  fs::path dir = temp_dir();
  ASSERT_TRUE(s.run("my_model(x[3], a[1]) {\n"
                    "  array v[24], t[36], c[3];\n"
                    "  v = [-1,-1,-1, 1,-1,-1, 1,1,-1, -1,1,-1, -1,-1,1, 1,-1,1, 1,1,1, -1,1,1];\n"
                    "  t = [1,3,2, 1,4,3, 5,6,7, 5,7,8, 1,2,6, 1,6,5, 4,8,7, 4,7,3, 1,5,8, 1,8,4,"
                    " 2,3,7, 2,7,6];\n"
                    "  c = [1, 1, 1];\n"
                    "  my_model = hfTriangles(x, v, t) \\ hfSphere(x, c, 0.8);\n"
                    "}")
                  .ok);
  EXPECT_GT(eval_value(s, "0 0 0"), 0.0);        // inside the cube, outside the ball
  EXPECT_LT(eval_value(s, "0.9 0.9 0.9"), 0.0);  // cut away by the sphere
  std::string out = (dir / "mesh.png").string();
  SessionResult r = s.run(":render " + out + " --size 48x48 --bbox -2,-2,-2,2,2,2 --stats");
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_NE((r.out + r.err).find("root: analytic"), std::string::npos) << r.out << r.err;
  const render::Image& img = *s.last_image();
  EXPECT_GT(img.alpha[size_t(24) * 48 + 24], 0.5f);  // the cube is in the middle
  EXPECT_EQ(img.alpha[0], 0.0f);
  fs::remove_all(dir);
}

TEST(ReplSession, AnsiPreview) {
  render::Image img;
  img.resize(4, 4);
  for (float& v : img.rgb) v = 1.0f;
  std::string p = ansi_preview(img, 80);
  // 4x4 pixels: 2 text rows of 4 half blocks each.
  size_t blocks = 0;
  for (size_t i = p.find("\xe2\x96\x80"); i != std::string::npos; i = p.find("\xe2\x96\x80", i + 1))
    ++blocks;
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
  std::string cmd = env + " '" HFRT_BINARY_DIR "/tools/hfrt/hfrt' repl < '" + in.string() +
                    "' > '" + out.string() + "' 2>/dev/null";
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
  RunResult r =
      run_hfrt("ball(x[3], a[1])\n{\n  ball = 4 - x[1]*x[1];\n}\n:eval 1 0 0\n:eval 3 0 0\n");
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

// --- :set takes every option of `hfrt render`, with its validation --------------------------

/// Sums the coverage (alpha) of the last image: how much of the picture the solid fills.
double coverage(const Session& s) {
  const render::Image* img = s.last_image();
  if (!img) return -1;
  double sum = 0;
  for (float a : img->alpha) sum += a;
  return sum / double(img->alpha.size());
}

TEST(ReplSet, EveryRenderOptionIsAccepted) {
  Session s;
  // One valid value for each option of `hfrt render` (all of them: the list is the parser's).
  const std::map<std::string, std::string> values = {{"size", "40x30"},
                                                     {"bbox", "-3,-3,-3,3,3,3"},
                                                     {"eye", "5,4,3"},
                                                     {"look-at", "0,0,0"},
                                                     {"up", "0,0,1"},
                                                     {"fov", "40"},
                                                     {"ortho", "4"},
                                                     {"root", "sign"},
                                                     {"spp", "2"},
                                                     {"threads", "1"},
                                                     {"a", "1,2"},
                                                     {"object", "ball"},
                                                     {"light", "dir:1,1,1"},
                                                     {"step", "0.01"},
                                                     {"epsilon", "0.001"},
                                                     {"aov", "depth,normal"},
                                                     {"background", "0,0,0"},
                                                     {"no-shadows", "on"},
                                                     {"no-prune", "on"},
                                                     {"backend", "interp"},
                                                     {"stats", "on"},
                                                     {"max-depth", "3"},
                                                     {"time", "0.25"}};
  for (const std::string& name : render_option_names()) {
    auto it = values.find(name);
    ASSERT_NE(it, values.end()) << "no test value for --" << name;
    SessionResult r = s.run(":set " + name + " " + it->second);
    EXPECT_TRUE(r.ok) << name << ": " << r.err;
  }
  const RenderCli& cli = s.render_cli();
  const SessionRenderSettings& st = s.render_settings();
  EXPECT_EQ(st.options.width, 40);
  EXPECT_EQ(st.options.height, 30);
  EXPECT_EQ(st.options.bbox.hi.x, 3);
  EXPECT_EQ(st.options.root, render::RootMode::kSign);
  EXPECT_EQ(st.options.spp, 2);
  EXPECT_EQ(st.options.threads, 1);
  ASSERT_EQ(st.options.lights.size(), 1u);
  EXPECT_EQ(st.options.lights[0].kind, render::Light::Kind::kDirectional);
  EXPECT_FLOAT_EQ(st.options.step, 0.01f);
  EXPECT_FALSE(st.options.shadows);
  EXPECT_EQ(st.options.background.x, 0);
  ASSERT_TRUE(st.camera.eye && st.camera.ortho_width && st.camera.up);
  EXPECT_EQ(st.camera.eye->x, 5);
  EXPECT_EQ(*st.camera.ortho_width, 4);
  EXPECT_EQ(cli.model.params, "1,2");
  EXPECT_EQ(cli.model.object, "ball");
  EXPECT_EQ(cli.model.backend, "interp");
  EXPECT_EQ(cli.aov, "depth,normal");
  EXPECT_TRUE(cli.stats);
  EXPECT_EQ(cli.max_depth, 3);
  EXPECT_EQ(cli.model.time, "0.25");
  // `default` restores one option; the first REPL's spellings still work.
  ASSERT_TRUE(s.run(":set size default").ok);
  EXPECT_EQ(s.render_settings().options.width, 512);
  ASSERT_TRUE(s.run(":set eye auto").ok);
  EXPECT_FALSE(s.render_settings().camera.eye);
  ASSERT_TRUE(s.run(":set ortho off").ok);
  EXPECT_FALSE(s.render_settings().camera.ortho_width);
  ASSERT_TRUE(s.run(":set shadows on").ok);
  EXPECT_TRUE(s.render_settings().options.shadows);
  ASSERT_TRUE(s.run(":set --no-shadows on").ok);
  EXPECT_FALSE(s.render_settings().options.shadows);
  // Several lights at once; a later :set replaces them.
  ASSERT_TRUE(s.run(":set light dir:0,1,0 point:0,5,0,2").ok);
  EXPECT_EQ(s.render_settings().options.lights.size(), 2u);
  ASSERT_TRUE(s.run(":set light point:1,1,1").ok);
  ASSERT_EQ(s.render_settings().options.lights.size(), 1u);
  EXPECT_EQ(s.render_settings().options.lights[0].kind, render::Light::Kind::kPoint);
}

/// `hfrt render` with extra options on a small sphere; returns the exit code, stderr in `err`.
int render_cli_error(const std::string& options, std::string* err) {
  fs::path dir = temp_dir();
  fs::path model = dir / "cli_sphere.hf";
  std::ofstream(model)
      << "my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n";
  fs::path errf = dir / "cli_err.txt";
  std::string cmd = "'" HFRT_BINARY_DIR "/tools/hfrt/hfrt' render '" + model.string() + "' -o '" +
                    (dir / "cli.png").string() + "' " + options + " 2> '" + errf.string() + "'";
  int status = std::system(cmd.c_str());
  std::ifstream f(errf);
  std::stringstream ss;
  ss << f.rdbuf();
  *err = ss.str();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(ReplSet, BadValuesFailWithTheCommandLinesMessages) {
  Session s;
  ASSERT_TRUE(s.run(":set size 64x48").ok);
  // Each bad value: :set fails, changes nothing, and says what `hfrt render` says (after its
  // "hfrt render: " prefix, the session's is "hfrt: ").
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"size", "0x5"},        {"bbox", "1,2,3"}, {"bbox", "1,1,1,0,2,2"},
      {"eye", "1,2"},         {"up", "0,0,0"},   {"fov", "200"},
      {"ortho", "-1"},        {"root", "maybe"}, {"spp", "0"},
      {"threads", "-2"},      {"a", "1,x"},      {"light", "sun:1,2,3"},
      {"light", "dir:0,0,0"}, {"step", "-1"},    {"aov", "depth,colour"},
      {"background", "red"}};
  for (const auto& [name, value] : bad) {
    SessionResult r = s.run(":set " + name + " " + value);
    EXPECT_FALSE(r.ok) << name << " " << value;
    std::string cli_err;
    EXPECT_EQ(render_cli_error((name == "a" ? "-a " : "--" + name + " ") + value, &cli_err), 2)
        << name << " " << value;
    const std::string prefix = "hfrt render: ";
    ASSERT_EQ(cli_err.compare(0, prefix.size(), prefix), 0) << cli_err;
    ASSERT_EQ(r.err.compare(0, 6, "hfrt: "), 0) << r.err;
    EXPECT_EQ(r.err.substr(6), cli_err.substr(prefix.size())) << name << " " << value;
  }
  // CLI11's own checks (numbers, choices) give CLI11's messages, in both.
  SessionResult r = s.run(":set backend cuda");
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.err.find("cuda"), std::string::npos) << r.err;
  EXPECT_FALSE(s.run(":set spp banana").ok);
  EXPECT_FALSE(s.run(":set stats maybe").ok);
  EXPECT_FALSE(s.run(":set nonsense 1").ok);
  EXPECT_FALSE(s.run(":set size").ok);
  EXPECT_EQ(s.render_settings().options.width, 64);
  EXPECT_EQ(s.render_settings().options.height, 48);
}

TEST(ReplSet, ParametersObjectLightsAovAndStatsReachTheRender) {
  Session s;
  fs::path dir = temp_dir();
  // A sphere of radius a[1] (0 without -a: empty), and a second object.
  ASSERT_TRUE(
      s.run("ball(x[3], a[1]) { ball = a[1]*a[1] - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  ASSERT_TRUE(s.run("big(x[3], a[1]) { big = 4 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  EXPECT_EQ(s.current(), "big");
  std::string out = (dir / "p.png").string();
  // A fixed camera so that coverage compares sizes.
  SessionResult r = s.run(":render " + out +
                          " --size 48x48 --bbox -3,-3,-3,3,3,3 --eye 0,0,8 --look-at 0,0,0 "
                          "--object ball -a 1 --root sign");
  ASSERT_TRUE(r.ok) << r.err;
  const double small = coverage(s);
  ASSERT_TRUE(s.run(":set a 2").ok);
  r = s.run(":render " + out);
  ASSERT_TRUE(r.ok) << r.err;
  const double large = coverage(s);
  // Radius 2 covers about four times the area of radius 1.
  EXPECT_GT(small, 0.01);
  EXPECT_NEAR(large / small, 4.0, 0.6);
  // -a is for the render only: :eval of the current object is unaffected.
  EXPECT_DOUBLE_EQ(eval_value(s, "0 0 0"), 4);
  // --object default: the current object (big, radius 2, same as ball with a = 2).
  ASSERT_TRUE(s.run(":set object default").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  EXPECT_NEAR(coverage(s), large, 0.01);
  // The light's intensity reaches the shading: a dark light gives a darker centre.
  const size_t centre = (size_t(24) * 48 + 24);
  auto brightness = [&] {
    const render::Image& img = *s.last_image();
    EXPECT_GT(img.alpha[centre], 0.5f);
    return img.rgb[centre * 3] + img.rgb[centre * 3 + 1] + img.rgb[centre * 3 + 2];
  };
  ASSERT_TRUE(s.run(":set light dir:0,0,1,1").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  const float lit = brightness();
  ASSERT_TRUE(s.run(":set light dir:0,0,1,0").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  EXPECT_LT(brightness(), 0.5f * lit);
  // --aov writes the sibling files; --stats adds the stats lines.
  r = s.run(":render " + out + " --aov depth --stats on");
  EXPECT_FALSE(r.ok);  // --stats is a flag on the :render line, as on the command line
  r = s.run(":render " + out + " --aov depth --stats");
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_TRUE(fs::exists(dir / "p.depth.png")) << r.out;
  EXPECT_NE(r.out.find("stats: framing"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("primary"), std::string::npos) << r.out;
  // --backend interp renders the same picture with the interpreter.
  ASSERT_TRUE(s.run(":set light default").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  std::vector<float> jit_rgb = s.last_image()->rgb;
  int compiles = s.compiles();
  ASSERT_TRUE(s.run(":set backend interp").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  EXPECT_GT(s.compiles(), compiles);  // the backend is part of the cache key
  ASSERT_EQ(s.last_image()->rgb.size(), jit_rgb.size());
  double diff = 0;
  for (size_t i = 0; i < jit_rgb.size(); ++i)
    diff = std::max(diff, double(std::abs(jit_rgb[i] - s.last_image()->rgb[i])));
  EXPECT_LT(diff, 0.05);
  fs::remove_all(dir);
}

// --- Cancellation -----------------------------------------------------------------------------

TEST(ReplCancel, RendererStopsWhenTheFlagIsSet) {
  // The renderer itself: a flag set before the render skips every tile.
  class Ball final : public render::Field {
   public:
    void eval(size_t n, const float* x, const float* y, const float* z, float* f) const override {
      for (size_t i = 0; i < n; ++i) f[i] = 1 - x[i] * x[i] - y[i] * y[i] - z[i] * z[i];
    }
    bool has_interval() const override { return false; }
    render::Interval eval_interval(const render::Box&, bool* maybe_nan) const override {
      *maybe_nan = true;
      return {-1e30f, 1e30f};
    }
    void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f,
                       float* dx, float* dy, float* dz) const override {
      eval(n, x, y, z, f);
      for (size_t i = 0; i < n; ++i) {
        dx[i] = -2 * x[i];
        dy[i] = -2 * y[i];
        dz[i] = -2 * z[i];
      }
    }
  } ball;
  render::RenderOptions opt;
  opt.width = opt.height = 64;
  opt.bbox = {{-2, -2, -2}, {2, 2, 2}};
  opt.camera = render::resolve_camera({}, opt.bbox, 1);
  opt.root = render::RootMode::kSign;
  std::atomic<bool> cancel{true};
  opt.cancel = &cancel;
  render::RenderResult r = render::render(ball, opt);
  EXPECT_TRUE(r.stats.cancelled);
  EXPECT_EQ(r.stats.primary_rays, 0u);
  cancel = false;
  r = render::render(ball, opt);
  EXPECT_FALSE(r.stats.cancelled);
  EXPECT_EQ(r.stats.primary_rays, 64u * 64u);
  // Set from a worker thread in the middle of the render (after the third finished tile):
  // the tiles already started finish, no other starts. Counted in rays, not timed.
  cancel = false;
  opt.width = opt.height = 256;  // 256 tiles of 16x16
  opt.threads = 2;
  opt.progress = [&cancel](size_t done, size_t) {
    if (done >= 3) cancel.store(true);
  };
  r = render::render(ball, opt);
  EXPECT_TRUE(r.stats.cancelled);
  EXPECT_GE(r.stats.primary_rays, 3u * 16 * 16);
  EXPECT_LE(r.stats.primary_rays, (3u + 2) * 16 * 16);  // at most one tile more per thread
}

TEST(ReplCancel, FlagSetBeforeTheRenderCancelsItAndIsCleared) {
  Session s;
  fs::path dir = temp_dir();
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  std::string out = (dir / "c.png").string();
  ASSERT_TRUE(s.run(":render " + out + " --size 32x32 --bbox -2,-2,-2,2,2,2").ok);
  const render::Image* before = s.last_image();
  ASSERT_NE(before, nullptr);
  std::vector<float> previous = before->rgb;
  s.cancel_flag().store(true);
  SessionResult r = s.run(":render " + out + " --size 16x16");
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.err.find("render cancelled"), std::string::npos) << r.err;
  // Nothing changed: the previous image and options stay; the flag is down again.
  EXPECT_FALSE(s.cancel_flag().load());
  EXPECT_EQ(s.last_image()->rgb, previous);
  EXPECT_EQ(s.render_settings().options.width, 32);
  r = s.run(":render " + out);
  EXPECT_TRUE(r.ok) << r.err;
  fs::remove_all(dir);
}

TEST(ReplCancel, FlagSetFromAnotherThreadStopsALongRender) {
  Session s;
  fs::path dir = temp_dir();
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  // About a billion primary rays: far longer than the test's time limit when not cancelled.
  // (How many rays a cancel lets through is counted in RendererStopsWhenTheFlagIsSet.)
  const std::string cmd = ":render " + (dir / "long.png").string() +
                          " --size 4096x4096 --spp 64 --bbox -2,-2,-2,2,2,2 --root sign";
  std::thread canceller([&s] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    s.cancel_flag().store(true);
  });
  SessionResult r = s.run(cmd);
  canceller.join();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.err.find("render cancelled"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "long.png"));
  fs::remove_all(dir);
}

TEST(ReplView, EditsOfAnObjectKeepItsCameraUntilAnOptionChanges) {
  Session s;
  fs::path dir = temp_dir();
  std::string out = (dir / "v.png").string();
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  ASSERT_TRUE(s.run(":render " + out + " --size 48x48 --bbox -4,-4,-4,4,4,4").ok);
  const double r1 = coverage(s);
  // A radius of 1.5: the same camera shows it 2.25 times as large (framing anew would show it
  // at about the same size).
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 2.25 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  const double r15 = coverage(s);
  EXPECT_NEAR(r15 / r1, 2.25, 0.35);
  // An option change frames anew: the bigger ball fills about what the small one did.
  ASSERT_TRUE(s.run(":set spp 1").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  EXPECT_NEAR(coverage(s) / r1, 1.0, 0.2);
  fs::remove_all(dir);
}

TEST(ReplView, AnEditThatChangesTheEvaluatorsDecidesTheRootSearchAgain) {
  Session s;
  fs::path dir = temp_dir();
  std::string out = (dir / "e.png").string();
  // A polynomial ball (auto may take an exact root search that needs polynomial leaves), then
  // the same ball through sqrt (no polynomial leaves): the kept decision must not be reused.
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  SessionResult r = s.run(":render " + out + " --size 32x32 --bbox 2");
  ASSERT_TRUE(r.ok) << r.err;
  const double poly = coverage(s);
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }").ok);
  r = s.run(":render " + out);
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_NEAR(coverage(s), poly, 0.02);
  fs::remove_all(dir);
}

TEST(ReplView, AnEditOfANumberReusesTheCodeAndShowsTheEditedModel) {
  fs::path dir = temp_dir();
  std::string out = (dir / "n.png").string();
  auto def = [](const char* k) {
    return std::string("blob(x[3], a[1]) {\n  k = ") + k +
           ";\n  blob = k - sqrt(x[1]*x[1] + 2*x[2]*x[2] + x[3]*x[3]);\n}";
  };
  Session s;
  ASSERT_TRUE(s.run(def("0.75")).ok);
  // A fixed camera: the comparison below is of the evaluators, not of the framing.
  const std::string view = " --size 40x40 --bbox 2 --eye 0.5,-6,2 --look-at 0,0,0";
  ASSERT_TRUE(s.run(":render " + out + view).ok);
  const double small = coverage(s);
  ASSERT_TRUE(s.run(def("1.25")).ok);
  EXPECT_EQ(s.code_shares(), 1);  // compiled anew for its diagnostics, but not JIT-compiled
  SessionResult r = s.run(":render " + out + " --stats");
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_NE(r.out.find("lanes, shared: compiled for an earlier edit in"), std::string::npos)
      << r.out;
  EXPECT_GT(coverage(s), 2 * small);
  const std::vector<float> edited = s.last_image()->rgb;
  // A session that never saw the first value renders the same bits.
  Session fresh;
  ASSERT_TRUE(fresh.run(def("1.25")).ok);
  EXPECT_EQ(fresh.code_shares(), 0);
  ASSERT_TRUE(fresh.run(":render " + out + view).ok);
  EXPECT_TRUE(fresh.last_image()->rgb == edited);
  // Another structure shares nothing.
  ASSERT_TRUE(s.run("blob(x[3], a[1]) { blob = 1 - abs(x[1]); }").ok);
  EXPECT_EQ(s.code_shares(), 1);
  fs::remove_all(dir);
}

TEST(ReplView, CoarsePictureComesFirstWhenAsked) {
  Session s;
  fs::path dir = temp_dir();
  std::string out = (dir / "q.png").string();
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }").ok);
  std::vector<std::pair<int, int>> coarse;
  bool image_before = true;
  s.on_coarse = [&](const render::Image& img) {
    coarse.emplace_back(img.width, img.height);
    image_before = s.last_image() != nullptr;  // the full picture is not there yet
  };
  ASSERT_TRUE(s.run(":render " + out + " --size 128x96 --bbox 2").ok);
  ASSERT_EQ(coarse.size(), 1u);
  EXPECT_EQ(coarse[0], std::make_pair(16, 12));
  EXPECT_FALSE(image_before);
  EXPECT_EQ(s.last_image()->width, 128);
  s.on_coarse = nullptr;
  ASSERT_TRUE(s.run(":render " + out).ok);
  EXPECT_EQ(coarse.size(), 1u);
  fs::remove_all(dir);
}

TEST(ReplView, NoCoarsePictureWhereTheFullOneComesQuickly) {
  Session s;
  fs::path dir = temp_dir();
  std::string out = (dir / "q.png").string();
  auto def = [](const char* k) {
    return std::string("ball(x[3], a[1]) {\n  k = ") + k +
           ";\n  ball = k - x[1]*x[1] - x[2]*x[2] - x[3]*x[3];\n}";
  };
  int coarse = 0;
  s.on_coarse = [&](const render::Image&) { ++coarse; };
  ASSERT_TRUE(s.run(def("1.5")).ok);
  ASSERT_TRUE(s.run(":render " + out + " --size 64x64 --bbox 2").ok);
  EXPECT_EQ(coarse, 1);  // nothing known of this view yet
  ASSERT_LT(s.timings().render, Session::kQuickRenderMs);
  // A numbers-only edit runs the compiled code, and the last render of the view was quick.
  ASSERT_TRUE(s.run(def("1.25")).ok);
  EXPECT_EQ(s.code_shares(), 1);
  ASSERT_TRUE(s.run(":render " + out).ok);
  EXPECT_EQ(coarse, 1);
  // Another view (a new size) is not known to be quick.
  ASSERT_TRUE(s.run(":render " + out + " --size 72x64").ok);
  EXPECT_EQ(coarse, 2);
  // Another structure has code still to compile.
  ASSERT_TRUE(s.run("ball(x[3], a[1]) { ball = 1 - abs(x[1]) - x[2]*x[2] - x[3]*x[3]; }").ok);
  ASSERT_TRUE(s.run(":render " + out).ok);
  EXPECT_EQ(coarse, 3);
  fs::remove_all(dir);
}

TEST(ReplWatch, WatchStepReloadsTheChangedFileAndRendersAgain) {
  Session s;
  fs::path dir = temp_dir();
  fs::path model = dir / "watched.hf";
  std::ofstream(model)
      << "my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n";
  ASSERT_TRUE(s.run(":load " + model.string()).ok);
  const std::string out = (dir / "w.png").string();
  ASSERT_TRUE(s.run(":render " + out + " --size 32x32 --bbox 3 --eye 0,0,9 --look-at 0,0,0").ok);
  const double before = coverage(s);
  SessionResult r = s.run(":watch " + model.string());
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_EQ(r.watch_file, model.string());
  // The file changes (as an editor writes it); the front end calls watch_step.
  std::ofstream(model)
      << "my_model(x[3], a[1]) { my_model = 4 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }\n";
  r = s.watch_step(model.string());
  ASSERT_TRUE(r.ok) << r.err;
  EXPECT_TRUE(r.rendered);
  EXPECT_NE(r.out.find("loaded"), std::string::npos) << r.out;
  EXPECT_DOUBLE_EQ(eval_value(s, "0 0 0"), 4);
  EXPECT_NEAR(coverage(s) / before, 4.0, 0.8);  // radius 2 instead of 1, same camera
  // A broken file leaves the previous model.
  std::ofstream(model) << "my_model(x[3], a[1]) { my_model = 4 - ; }\n";
  EXPECT_FALSE(s.watch_step(model.string()).ok);
  EXPECT_DOUBLE_EQ(eval_value(s, "0 0 0"), 4);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hfrt::tools
