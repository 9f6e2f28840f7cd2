// `hfrt repl` latency: how long one edit takes to show, driven through the Session as the
// terminal front end does. Measures (1) a new definition (compile of the whole session
// source), (2) the same definition again (served by the compile cache), (3) `:eval` of a
// point, (4) a `:render` at 128x128 with the remembered options. Run:
//   build/bench/hfrt_bench_repl [--rounds N]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

#include "tools/hfrt/session.h"

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

bool check(const hfrt::tools::SessionResult& r) {
  if (!r.ok) std::fprintf(stderr, "%s", r.err.c_str());
  return r.ok;
}

}  // namespace

int main(int argc, char** argv) {
  int rounds = 5;
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--rounds") == 0) rounds = std::atoi(argv[i + 1]);
  }
  const std::string out = (std::filesystem::temp_directory_path() / "hfrt_bench_repl.png").string();
  hfrt::tools::Session s;
  if (!check(s.run("base(x[3], a[1]) { base = 4 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }"))) return 1;
  if (!check(s.run(":render " + out + " --size 128x128 --bbox -3,-3,-3,3,3,3"))) return 1;
  double define_ms = 0, cached_ms = 0, eval_ms = 0, render_ms = 0;
  for (int i = 0; i < rounds; ++i) {
    // A different constant each round: a real recompile.
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
  std::printf("rounds %d: define (compile) %.2f ms, define again (cached) %.3f ms, :eval %.3f ms, "
              ":render 128x128 %.2f ms (means)\n",
              rounds, define_ms / rounds, cached_ms / rounds, eval_ms / rounds, render_ms / rounds);
  std::filesystem::remove(out);
  return 0;
}
