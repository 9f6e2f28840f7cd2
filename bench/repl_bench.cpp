// `hfrt repl` latency: how long one edit takes to show, driven through the Session as the
// terminal front end does. Measures (1) a new definition (compile of the whole session
// source), (2) the same definition again (served by the compile cache), (3) `:eval` of a
// point, (4) a `:render` at 128x128 with the remembered options; then (5) the latency the REPL
// exists for: from a changed definition (10 edits of one constant: a blend radius, a box size,
// a gear radius) of three corpus models (and of a generated 993-instruction model, 72 spheres
// joined by max) to the finished 512x512 image on all cores, each edit
// a compile and a `:render` through the Session, with where the time went (parse and lowering,
// the JIT of the point, interval and gradient code, framing, auto probe, ray tracing, image
// writing). Edits that change only numbers reuse the compiled code (Session::share_code); each
// set of edits is measured that way and again with every edit compiled anew (the compile
// cache on disk off), which is what an edit of the structure costs. Run:
//   build/bench/hfrt_bench_repl [--rounds N] [--edits N] [--size N] [--only NAME]
//                               [--extra "OPTIONS"]   (appended to every edit's :render, e.g.
//                                                      " --no-prune" for an A/B in one run)
//                               [--modes 1234]   (which of the four sets of edits: default
//                                                 options numbers only / compiled anew, the
//                                                 quick look numbers only / compiled anew)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "base/timer.h"
#include "hfrt/compile_cache.h"
#include "tools/hfrt/session.h"

namespace {

using hfrt::ms_since;

bool check(const hfrt::tools::SessionResult& r) {
  if (!r.ok) std::fprintf(stderr, "%s", r.err.c_str());
  return r.ok;
}

/// A corpus model and the constant its edits change: `pattern` (with "%g" for the value) is
/// searched with `first` in the file, replaced with the edited values.
struct EditCase {
  const char* name;
  const char* file;      // under HFRT_CORPUS_DIR/models; null: spheres_source()
  const char* original;  // the exact text changed in the file
  const char* pattern;   // printf pattern of the replacement, one %g
  double lo, hi;         // the edited values, evenly spread
};

const EditCase kCases[] = {
    {"s3_blend", "github/alexander-penev__FRep-Designer-Bench/s3_blend.hf", "k = 0.25;", "k = %g;",
     0.12, 0.38},
    {"s2_csg", "github/alexander-penev__FRep-Designer-Bench/s2_csg.hf", "box = 0.9 - m;",
     "box = %g - m;", 0.8, 0.98},
    {"c1_gear", "github/alexander-penev__FRep-Designer-Bench/c1_gear.hf", "t6 = 0.850000023842;",
     "t6 = %g;", 0.8, 0.9},
    // Issue 25's "compile time of a 1000-op model": 72 spheres joined by max (993 IR
    // instructions of plain arithmetic), its first radius edited.
    {"spheres72", nullptr, "r0 = 0.4;", "r0 = %g;", 0.35, 0.45},
};

/// 72 spheres of radius 0.2-0.6 (the first r0) at centres in [-1.5, 1.5]^3 joined by max: a
/// fixed pseudo-random model (the same text on every machine).
std::string spheres_source() {
  uint32_t state = 12345;
  auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return double(state >> 8) / double(1u << 24);
  };
  std::string src = "my_model(x[3], a[1]) {\n  r0 = 0.4;\n";
  char line[256];
  for (int i = 0; i < 72; ++i) {
    const double cx = -1.5 + 3 * next(), cy = -1.5 + 3 * next(), cz = -1.5 + 3 * next();
    const double r = 0.2 + 0.4 * next();
    std::snprintf(line, sizeof line,
                  "  dx%d = x[1] - (%.3f); dy%d = x[2] - (%.3f); dz%d = x[3] - (%.3f);\n", i, cx, i,
                  cy, i, cz);
    src += line;
    if (i == 0) {
      std::snprintf(line, sizeof line, "  s0 = r0 * r0 - dx0*dx0 - dy0*dy0 - dz0*dz0;\n");
    } else {
      std::snprintf(line, sizeof line, "  s%d = %.4f - dx%d*dx%d - dy%d*dy%d - dz%d*dz%d;\n", i,
                    r * r, i, i, i, i, i, i);
    }
    src += line;
    if (i > 0) {
      std::snprintf(line, sizeof line, "  u%d = max(%s%d, s%d);\n", i, i == 1 ? "s" : "u", i - 1,
                    i);
      src += line;
    }
  }
  return src + "  my_model = u71;\n}\n";
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Stat {
  std::vector<double> v;
  double min() const { return *std::min_element(v.begin(), v.end()); }
  double max() const { return *std::max_element(v.begin(), v.end()); }
  double median() const {
    std::vector<double> s = v;
    std::sort(s.begin(), s.end());
    return s.size() % 2 ? s[s.size() / 2] : 0.5 * (s[s.size() / 2 - 1] + s[s.size() / 2]);
  }
  double mean() const {
    double t = 0;
    for (double x : v) t += x;
    return t / double(v.size());
  }
};

/// Edits of one model: each a new definition (compile) then `:render` to 512x512. False on error.
bool bench_edits(const EditCase& c, int edits, int size, const std::string& extra,
                 const std::string& out, bool share) {
  const std::string text =
      c.file ? slurp(std::string(HFRT_CORPUS_DIR) + "/models/" + c.file) : spheres_source();
  const size_t at = text.find(c.original);
  if (text.empty() || at == std::string::npos) {
    std::fprintf(stderr, "%s: cannot find '%s' in %s\n", c.name, c.original,
                 c.file ? c.file : "the generated model");
    return false;
  }
  hfrt::tools::Session s;
  s.share_code = share;
  // The benchmark scenes' domain is [-1.6, 1.6]^3 (FRep-Designer-Bench scenes/MATH.md).
  const std::string opts =
      " --size " + std::to_string(size) + "x" + std::to_string(size) + " --bbox 1.6" + extra;
  if (!check(s.run(text)) || !check(s.run(":render " + out + opts))) return false;  // warm-up
  Stat total, compile, prepare, frame, probe, render, write, first;
  // The coarse picture a terminal shows first (1/8 of the size, see Session::on_coarse).
  std::chrono::steady_clock::time_point t0;
  double coarse_ms = 0;
  s.on_coarse = [&](const hfrt::render::Image&) { coarse_ms = ms_since(t0); };
  for (int i = 0; i < edits; ++i) {
    char value[64];
    std::snprintf(value, sizeof value, c.pattern,
                  c.lo + (c.hi - c.lo) * i / std::max(1, edits - 1));
    std::string edited = text;
    edited.replace(at, std::strlen(c.original), value);
    coarse_ms = -1;
    t0 = std::chrono::steady_clock::now();
    if (!check(s.run(edited)) || !check(s.run(":render " + out))) return false;
    total.v.push_back(ms_since(t0));
    if (coarse_ms >= 0) first.v.push_back(coarse_ms);
    const hfrt::tools::SessionTimings& t = s.timings();
    compile.v.push_back(t.compile);
    prepare.v.push_back(t.prepare);
    frame.v.push_back(t.frame);
    probe.v.push_back(t.probe);
    render.v.push_back(t.render);
    write.v.push_back(t.write);
  }
  // The session skips the coarse picture where the full one comes quickly
  // (Session::kQuickRenderMs): say in how many edits it was drawn.
  char coarse[96];
  if (first.v.empty()) {
    std::snprintf(coarse, sizeof coarse, "none (the full one came quickly)");
  } else {
    std::snprintf(coarse, sizeof coarse, "median %.1f ms (in %zu of %d edits)", first.median(),
                  first.v.size(), edits);
  }
  std::printf(
      "%-9s edit -> %dx%d image: min %6.1f  median %6.1f  max %6.1f ms; coarse picture first: "
      "%s\n          (median: parse+lower %.1f, "
      "JIT of point+interval+gradient code %.1f, framing %.1f, auto probe %.1f, ray tracing %.1f, "
      "write %.1f)\n",
      c.name, size, size, total.min(), total.median(), total.max(), coarse, compile.median(),
      prepare.median(), frame.median(), probe.median(), render.median(), write.median());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  int rounds = 5, edits = 10, size = 512;
  std::string only, extra_all, modes = "1234";
  for (int i = 1; i + 1 < argc; ++i) {
    // --modes 13: only the first and third sections below (default options numbers only, the
    // quick look numbers only), for profiles and A/B runs of one kind of edit.
    if (std::strcmp(argv[i], "--modes") == 0) modes = argv[i + 1];
    if (std::strcmp(argv[i], "--extra") == 0) extra_all = std::string(" ") + argv[i + 1];
    if (std::strcmp(argv[i], "--rounds") == 0) rounds = std::atoi(argv[i + 1]);
    if (std::strcmp(argv[i], "--edits") == 0) edits = std::max(1, std::atoi(argv[i + 1]));
    if (std::strcmp(argv[i], "--size") == 0) size = std::max(8, std::atoi(argv[i + 1]));
    if (std::strcmp(argv[i], "--only") == 0) only = argv[i + 1];
  }
  const std::string out = (std::filesystem::temp_directory_path() / "hfrt_bench_repl.png").string();
  hfrt::tools::Session s;
  if (!check(s.run("base(x[3], a[1]) { base = 4 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }"))) return 1;
  if (!check(s.run(":render " + out + " --size 128x128 --bbox -3,-3,-3,3,3,3"))) return 1;
  double define_ms = 0, cached_ms = 0, eval_ms = 0, render_ms = 0;
  for (int i = 0; i < rounds; ++i) {
    // A different number each round: a new model to parse and lower (its compiled code is
    // shared with the first round's, Session::share_code).
    std::string def = "top(x[3], a[1]) { v = base(x, a); top = v - 0." + std::to_string(i + 1) +
                      " * sin(4 * x[1]); }";
    auto t0 = std::chrono::steady_clock::now();
    if (!check(s.run(def))) return 1;
    define_ms += ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    if (!check(s.run(def))) return 1;
    cached_ms += ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    if (!check(s.run(":eval 0.5 0.25 0"))) return 1;
    eval_ms += ms_since(t0);
    t0 = std::chrono::steady_clock::now();
    if (!check(s.run(":render " + out))) return 1;
    render_ms += ms_since(t0);
  }
  std::printf(
      "rounds %d: define (compile) %.2f ms, define again (cached) %.3f ms, :eval %.3f ms, "
      ":render 128x128 %.2f ms (means)\n",
      rounds, define_ms / rounds, cached_ms / rounds, eval_ms / rounds, render_ms / rounds);
  std::filesystem::remove(out);

  const std::string out512 =
      (std::filesystem::temp_directory_path() / "hfrt_bench_repl_edit.png").string();
  // The default options (shadows, `--root auto`), then the quick look: the sign-change march
  // without shadow rays. An edit of a number reuses the compiled code (Session::share_code);
  // the same edits compiled anew measure what an edit of the structure costs.
  struct Mode {
    const char* extra;
    bool share;
  };
  const Mode all_modes[] = {Mode{"", true}, Mode{"", false},
                            Mode{" --root sign --no-shadows", true},
                            Mode{" --root sign --no-shadows", false}};
  for (int mi = 0; mi < 4; ++mi) {
    if (modes.find(char('1' + mi)) == std::string::npos) continue;
    const Mode m = all_modes[mi];
    std::printf("%d edits of one constant each, compile + :render%s on all cores, %s:\n", edits,
                *m.extra ? m.extra : " (default options)",
                m.share ? "numbers only: the compiled code is reused"
                        : "every edit JIT-compiled anew (no code shared, the compile cache off), "
                          "as an edit of the structure is");
    // Without sharing, the edits' code (the numbers are hoisted: the same IR every time) would
    // come from the compile cache on disk after the first: a structure seen before, not a new
    // one. Before 2026-12-03 this mode measured that (c1_gear: 14 ms of "JIT" instead of
    // ~0.3 s).
    const bool cache_was_on = hfrt::compile_cache_enabled();
    if (!m.share) hfrt::configure_compile_cache(false);
    for (const EditCase& c : kCases) {
      if (!only.empty() && only != c.name) continue;
      if (!bench_edits(c, edits, size, m.extra + extra_all, out512, m.share)) return 1;
    }
    hfrt::configure_compile_cache(cache_was_on);
  }
  std::filesystem::remove(out512);
  return 0;
}
