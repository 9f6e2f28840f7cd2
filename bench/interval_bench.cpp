// Interval throughput on corpus/bench/prospero.hf (7866 operations): boxes per second of the
// interval interpreter and the interval JIT, against points per second of the scalar
// interpreter and the scalar JIT (f64), all on one thread. The boxes tile [-1,1]^2 (z = 0)
// in an R x R grid; the points are the boxes' centres.
//
//   hfrt_bench_interval [MODEL.hf] [--grid R] [--seconds S] [-O N] [--no-trace] [--compile-only]
//                       [--inline-limit N] [--lanes W] [--hoist]
//
// -O picks the LLVM pipeline of the interval and gradient JITs (default 1); --no-trace
// compiles the interval JIT without the min/max trace; --compile-only prints the compile
// times (with their emit / optimise / codegen split) and evaluates nothing; --inline-limit
// sets IntervalJit::Options::inline_limit (0: every op through its helper); --lanes the boxes per
// SIMD block (default: the host's f64 width); --hoist compiles the numbers as parameters
// (ir::hoist_constants, what the REPL compiles). The gradient
// interpreter and JIT (f64, points/s at the box centres) are measured too.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "base/file.h"
#include "base/result.h"
#include "ir/hoist_constants.h"
#include "jit/gradient.h"
#include "jit/interpreter.h"
#include "jit/interval.h"
#include "jit/llvm_jit.h"
#include "jit/lower.h"
#include "jit/tape.h"
#include "jit/tape_vm.h"
#include "lang/frontend.h"

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Repeats `pass` (which evaluates `per_pass` items) for at least `min_s` seconds; items/s.
template <typename F>
double rate(double min_s, size_t per_pass, F pass) {
  size_t done = 0;
  auto t0 = Clock::now();
  do {
    pass();
    done += per_pass;
  } while (seconds_since(t0) < min_s);
  return static_cast<double>(done) / seconds_since(t0);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace hfrt;
  std::string path = HFRT_CORPUS_DIR "/bench/prospero.hf";
  int grid = 64;
  double min_s = 1.0;
  int opt_level = 1;
  bool trace = true;
  bool compile_only = false;
  int lanes = 0;
  bool hoist = false;
  int inline_limit = jit::IntervalJit::Options{}.inline_limit;
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--grid") && i + 1 < argc)
      grid = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "-O") && i + 1 < argc)
      opt_level = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--no-trace"))
      trace = false;
    else if (!std::strcmp(argv[i], "--compile-only"))
      compile_only = true;
    else if (!std::strcmp(argv[i], "--hoist"))
      hoist = true;
    else if (!std::strcmp(argv[i], "--lanes") && i + 1 < argc)
      lanes = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--inline-limit") && i + 1 < argc)
      inline_limit = std::atoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--seconds") && i + 1 < argc)
      min_s = std::atof(argv[++i]);
    else
      path = argv[i];
  }
  Result<std::string> text = read_file(path);
  if (!text.ok()) {
    std::fprintf(stderr, "%s\n", text.error().message.c_str());
    return 2;
  }
  auto file = std::make_shared<const lang::SourceFile>(path, std::move(text.value()));
  lang::DiagnosticSink diags(file);
  auto program = lang::compile_source(file, diags);
  if (!program) {
    std::fprintf(stderr, "%s", diags.render().c_str());
    return 1;
  }
  ir::Function fn = jit::lower_object(*program, program->default_object(), nullptr);
  const int user_params = fn.num_params;
  const std::vector<double> hoisted = hoist ? ir::hoist_constants(&fn) : std::vector<double>{};
  std::printf("model %s: %zu IR instructions, %d x %d boxes over [-1,1]^2\n", path.c_str(),
              fn.insts.size(), grid, grid);

  const size_t n = static_cast<size_t>(grid) * grid;
  const int dims = fn.num_inputs;
  std::vector<double> lo(dims * n, 0.0), hi(dims * n, 0.0), centre(dims * n, 0.0);
  std::vector<std::vector<hfrt::Interval>> boxes(n, std::vector<hfrt::Interval>(dims));
  const double step = 2.0 / grid;
  for (int j = 0; j < grid; ++j) {
    for (int i = 0; i < grid; ++i) {
      size_t b = static_cast<size_t>(j) * grid + i;
      double x0 = -1 + i * step, y0 = -1 + j * step;
      double c[2][2] = {{x0, x0 + step}, {y0, y0 + step}};
      for (int k = 0; k < std::min(dims, 2); ++k) {
        lo[k * n + b] = c[k][0];
        hi[k * n + b] = c[k][1];
        centre[k * n + b] = 0.5 * (c[k][0] + c[k][1]);
        boxes[b][k] = {c[k][0], c[k][1], false};
      }
    }
  }
  std::vector<double> a(std::max(fn.num_params, 1), 0.0);
  for (size_t j = 0; j < hoisted.size(); ++j) a[user_params + j] = hoisted[j];

  auto print_stats = [](const char* what, double wall_ms, const jit::JitStats& st) {
    std::printf(
        "%s compile: %.0f ms (emit %.0f, optimise %.0f, codegen+link %.0f; %zu LLVM "
        "instructions)\n",
        what, wall_ms, st.emit_ms, st.optimize_ms, st.codegen_ms, st.llvm_insts_after);
  };

  // Interval interpreter.
  double ii_rate = 0;
  if (!compile_only) {
    jit::IntervalInterpreter ii(fn);
    size_t ambiguous = 0;
    for (const auto& box : boxes) {
      hfrt::Interval r = ii.eval(box, a);
      if (r.lo <= 0 && r.hi >= 0) ++ambiguous;
    }
    ii_rate = rate(min_s, n, [&] {
      for (const auto& box : boxes) ii.eval(box, a);
    });
    std::printf("interval interpreter: %12.0f boxes/s (%zu of %zu boxes contain the surface)\n",
                ii_rate, ambiguous, n);
  }

  // The tape VM's interval pass (jit/tape_vm.h: what `hfrt slice` prunes with) on the whole
  // tape, one box per call, as the pruned recursion calls it.
  if (!compile_only) {
    std::string why;
    std::unique_ptr<jit::Tape> tape = jit::Tape::build(fn, a, &why);
    if (tape) {
      jit::TapeVm vm;
      const double tv_rate = rate(min_s, n, [&] {
        for (const auto& box : boxes) vm.eval_interval(*tape, box);
      });
      std::printf("interval tape VM:     %12.0f boxes/s (%zu instructions: %.1f ns each)\n",
                  tv_rate, tape->length(), 1e9 / (tv_rate * double(tape->length())));
      // The batched pass (TapeVm::eval_intervals): all the boxes in one call.
      std::vector<const double*> lo_in, hi_in;
      for (int k = 0; k < dims; ++k) {
        lo_in.push_back(lo.data() + size_t(k) * n);
        hi_in.push_back(hi.data() + size_t(k) * n);
      }
      std::vector<double> blo(n), bhi(n);
      std::vector<uint8_t> bnan(n);
      const double tb_rate = rate(min_s, n, [&] {
        vm.eval_intervals(*tape, n, lo_in, hi_in, blo.data(), bhi.data(), bnan.data());
      });
      std::printf(
          "interval tape VM, %zu boxes per pass: %12.0f boxes/s (%.2f ns per instruction "
          "and box)\n",
          jit::TapeVm::kLanes, tb_rate, 1e9 / (tb_rate * double(tape->length())));
    } else {
      std::printf("interval tape VM: no tape (%s)\n", why.c_str());
    }
  }

  // Interval JIT.
  double ij_rate = 0;
  {
    jit::IntervalJit::Options o;
    o.trace = trace;
    o.opt_level = opt_level;
    o.inline_limit = inline_limit;
    o.lanes = lanes;
    auto t0 = Clock::now();
    auto ij = jit::IntervalJit::compile(fn, o);
    double compile_s = seconds_since(t0);
    if (ij.ok()) {
      print_stats("interval JIT", compile_s * 1e3, ij.value()->stats());
      if (!compile_only) {
        std::vector<double> olo(n), ohi(n);
        std::vector<uint8_t> onan(n), choices(fn.insts.size());
        ij_rate = rate(min_s, n, [&] {
          ij.value()->eval(static_cast<int64_t>(n), lo.data(), hi.data(), a, olo.data(), ohi.data(),
                           onan.data(), choices.data());
        });
        std::printf("interval JIT (%d lanes, O%d, trace %s, ops %s): %12.0f boxes/s\n",
                    ij.value()->lanes(), o.opt_level, o.trace ? "on" : "off",
                    static_cast<int64_t>(fn.insts.size()) > o.inline_limit ? "outlined" : "inline",
                    ij_rate);
      }
    } else {
      std::printf("interval JIT: unavailable (%s)\n", ij.error().message.c_str());
    }
  }

  // Gradient interpreter and JIT (f64) at the box centres.
  std::vector<std::vector<double>> pts(n, std::vector<double>(dims, 0.0));
  for (size_t b = 0; b < n; ++b) {
    for (int k = 0; k < dims; ++k) pts[b][k] = centre[k * n + b];
  }
  double gi_rate = 0, gj_rate = 0;
  if (!compile_only) {
    jit::GradientInterpreter gi(fn);
    gi_rate = rate(min_s, n, [&] {
      for (const auto& p : pts) gi.eval(p, a);
    });
    std::printf("gradient interpreter: %12.0f points/s\n", gi_rate);
  }
  {
    jit::GradientJit::Options o;
    o.opt_level = opt_level;
    auto t0 = Clock::now();
    auto gj = jit::GradientJit::compile(fn, o);
    double compile_s = seconds_since(t0);
    if (gj.ok()) {
      print_stats("gradient JIT", compile_s * 1e3, gj.value()->stats());
      if (!compile_only) {
        std::vector<double> out(4 * n);
        gj_rate = rate(min_s, n, [&] {
          gj.value()->eval(static_cast<int64_t>(n), centre.data(), a, out.data());
        });
        std::printf("gradient JIT f64 (%d lanes): %12.0f points/s\n", gj.value()->lanes(), gj_rate);
      }
    } else {
      std::printf("gradient JIT: unavailable (%s)\n", gj.error().message.c_str());
    }
  }

  // Scalar interpreter and scalar JIT at the box centres.
  double si_rate = 0, sj_rate = 0;
  if (!compile_only) {
    jit::Interpreter interp(fn);
    si_rate = rate(min_s, n, [&] {
      for (const auto& p : pts) interp.eval(p, a);
    });
    std::printf("scalar interpreter:   %12.0f points/s\n", si_rate);
  }
  auto t1 = Clock::now();
  auto sj = jit::JitFunction::compile(fn, jit::Precision::kF64);
  if (sj.ok()) {
    print_stats("scalar JIT f64", seconds_since(t1) * 1e3, sj.value()->stats());
    if (!compile_only) {
      std::vector<double> f(n);
      sj_rate = rate(min_s, n, [&] {
        sj.value()->f64()(static_cast<int64_t>(n), centre.data(), a.data(), f.data(), nullptr);
      });
      std::printf("scalar JIT f64:       %12.0f points/s\n", sj_rate);
    }
  }
  if (compile_only) return 0;
  std::printf("ratios: interval/scalar interpreter %.2f", ii_rate / si_rate);
  if (ij_rate > 0 && sj_rate > 0) std::printf(", interval JIT/scalar JIT %.2f", ij_rate / sj_rate);
  if (ij_rate > 0) std::printf(", interval JIT/interval interpreter %.1f", ij_rate / ii_rate);
  if (gj_rate > 0) std::printf(", gradient JIT/gradient interpreter %.1f", gj_rate / gi_rate);
  std::printf("\n");
  return 0;
}
