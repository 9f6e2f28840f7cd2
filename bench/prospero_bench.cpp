// Prospero benchmark: evaluates corpus/bench/prospero.hf (7866 operations) on a 1024x1024
// grid over [-1,1]^2 at z = 0 with the LLVM JIT (f32 and f64, all cores) and with the
// reference interpreter, and prints milliseconds per frame and the ratio.
//
//   hfrt_bench_prospero [MODEL.hf] [--size N] [--frames K] [--threads T] [--interp-rows R]
//                       [--out image.pgm]
//
// The interpreter needs seconds per frame, so by default it evaluates R = 64 evenly spaced
// rows (all cores) and its frame time is extrapolated from those rows (printed as such).
// The "physical limit" lines (bench/README.md) compare the brute-force rate, computing IR ops x
// points per second, with the peak of a tight loop of vector adds measured in the same run.
// The pruned slice (docs/tape_vm.md) runs in the same process: `hfrt slice`'s recursion with
// tapes pruned per block and the tape VMs (render_slice with a ModelField that has tapes), on
// the same grid and threads, printed beside the JIT's brute force with the ratio, the average
// tape length per recursion level, and the pixels where its image differs from the unpruned
// render_slice (compiled interval + f32 code) and from the brute-force f32 signs. Beside them,
// the hand AVX2 brute force: the challenge's own VM file (prospero.vm, next to prospero.hf)
// as straight-line AVX2 intrinsics, generated at build time by bench/prospero_avx2_gen.py,
// the peer that issue 25 measures the pruned slice against.
// A pixel is inside the solid where F >= 0 (HyperFun's convention; prospero.hf negates the
// challenge expression, whose inside is < 0).

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "app/model_field.h"
#include "base/file.h"
#include "base/result.h"
#include "base/timer.h"
#include "hfrt/model.h"
#include "ir/ir.h"
#include "jit/lower.h"
#include "lang/frontend.h"
#include "render/slice.h"

#if HFRT_PROSPERO_AVX2
/// The straight-line AVX2 brute force generated from prospero.vm (bench/prospero_avx2_gen.py):
/// the challenge expression (inside < 0) at (x[i], y), i < n, n a multiple of 8.
void prospero_avx2(const float* x, float y, float* out, std::size_t n);
#endif

namespace {

using hfrt::Clock;
using hfrt::ms_since;

struct Options {
  std::string model = HFRT_CORPUS_DIR "/bench/prospero.hf";
  int size = 1024;
  int frames = 5;
  int threads = 0;
  int interp_rows = 64;
  int lanes = 0;
  std::string out;
};

/// Runs `row(y, scratch)` for the given rows on `threads` threads (rows handed out one at a
/// time through an atomic counter, so uneven rows balance).
template <typename Fn>
void parallel_rows(const std::vector<int>& rows, int threads, Fn row) {
  std::atomic<size_t> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    pool.emplace_back([&] {
      for (size_t i; (i = next.fetch_add(1)) < rows.size();) row(rows[i]);
    });
  }
  for (auto& th : pool) th.join();
}

// The machine's limit for the "physical limit" line: a tight loop of independent 8-lane f32
// vector adds (AVX2 when the CPU has it, else whatever the compiler makes of the vector type),
// run on every thread at once. 12 accumulator chains (in registers: 16 ymm) hide the add
// latency on 2 add ports. Returns the lane-adds done (iters x 12 x 8).
typedef float V8 __attribute__((vector_size(32)));
#if defined(__x86_64__)
__attribute__((target("avx2")))
#endif
double
add_loop_avx2(long iters, float* sink) {
  V8 a0 = V8{} + 0.f, a1 = V8{} + 1.f, a2 = V8{} + 2.f, a3 = V8{} + 3.f, a4 = V8{} + 4.f,
     a5 = V8{} + 5.f, a6 = V8{} + 6.f, a7 = V8{} + 7.f, a8 = V8{} + 8.f, a9 = V8{} + 9.f,
     a10 = V8{} + 10.f, a11 = V8{} + 11.f;
  const V8 inc = V8{} + 1e-7f;
  for (long i = 0; i < iters; ++i) {
    a0 += inc;
    a1 += inc;
    a2 += inc;
    a3 += inc;
    a4 += inc;
    a5 += inc;
    a6 += inc;
    a7 += inc;
    a8 += inc;
    a9 += inc;
    a10 += inc;
    a11 += inc;
    // Keeps the accumulators in registers and the adds as adds (no strength reduction).
    asm volatile(""
                 : "+x"(a0), "+x"(a1), "+x"(a2), "+x"(a3), "+x"(a4), "+x"(a5), "+x"(a6), "+x"(a7),
                   "+x"(a8), "+x"(a9), "+x"(a10), "+x"(a11));
  }
  V8 sum = a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7 + a8 + a9 + a10 + a11;
  *sink = sum[0] + sum[7];
  return double(iters) * 12 * 8;
}

/// Lane-adds per second of wall time over all threads; *per_cpu_s gets lane-adds per second
/// of CPU time of one thread (what a core does when it is not shared).
double peak_vector_adds_per_s(int threads, double* per_cpu_s) {
  constexpr long kIters = 50'000'000;
#if defined(__x86_64__)
  if (!__builtin_cpu_supports("avx2")) return 0;  // the loop is compiled for AVX2
#endif
  std::vector<float> sink(threads);
  std::vector<double> lanes(threads), cpu(threads);
  float warm = 0;
  add_loop_avx2(kIters / 50, &warm);
  // The best of 5 rounds: on a shared machine, the round least disturbed by other work.
  double best = 0, best_core = 0;
  for (int round = 0; round < 5; ++round) {
    std::vector<std::thread> pool;
    auto t0 = Clock::now();
    for (int t = 0; t < threads; ++t) {
      pool.emplace_back([&, t] {
        timespec c0, c1;
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
        lanes[t] = add_loop_avx2(kIters, &sink[t]);
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
        cpu[t] = double(c1.tv_sec - c0.tv_sec) + 1e-9 * double(c1.tv_nsec - c0.tv_nsec);
      });
    }
    for (auto& th : pool) th.join();
    const double s = ms_since(t0) / 1000.0;
    double total = 0, total_cpu = 0;
    for (int t = 0; t < threads; ++t) {
      total += lanes[t];
      total_cpu += cpu[t];
    }
    best = std::max(best, total / s);
    best_core = std::max(best_core, total / total_cpu);
  }
  *per_cpu_s = best_core;
  return best;
}

/// The IR instructions that compute something at every point (everything but constants,
/// inputs, parameters and control markers), counted on the object the Model evaluates. -1 when
/// the file cannot be read again.
int compute_ops(const std::string& path) {
  hfrt::Result<std::string> text = hfrt::read_file(path);
  if (!text) return -1;
  auto file = std::make_shared<const hfrt::lang::SourceFile>(path, std::move(text).value());
  hfrt::lang::DiagnosticSink diags(file);
  std::unique_ptr<hfrt::lang::Program> prog = hfrt::lang::compile_source(file, diags);
  if (!prog) return -1;
  hfrt::ir::Function fn = hfrt::jit::lower_object(*prog, prog->default_object(), nullptr);
  int n = 0;
  for (const hfrt::ir::Inst& in : fn.insts) {
    using hfrt::ir::Op;
    if (in.op == Op::kConst || in.op == Op::kInput || in.op == Op::kParam) continue;
    if (hfrt::ir::op_flags_of(in.op) & hfrt::ir::op_flags::kCtl) continue;
    ++n;
  }
  return n;
}

/// The grid's pixel centres over [-1, 1]^2: x of column i, y of row j (pointing up).
double pixel_x(int i, int size) {
  return -1.0 + (i + 0.5) * 2.0 / size;
}
double pixel_y(int j, int size) {
  return 1.0 - (j + 0.5) * 2.0 / size;
}

template <typename T>
void eval_row(const hfrt::Model& model, int size, int y, T* out) {
  // SoA: x row, y constant, z = 0.
  thread_local std::vector<T> xs;
  const int nx = model.num_inputs();
  xs.assign(static_cast<size_t>(nx) * size, T(0));
  const double py = pixel_y(y, size);
  for (int i = 0; i < size; ++i) {
    xs[i] = static_cast<T>(pixel_x(i, size));
    if (nx > 1) xs[size + i] = static_cast<T>(py);
  }
  model.eval_batch(size, xs.data(), out, nullptr);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--size")
      o.size = std::atoi(next());
    else if (a == "--frames")
      o.frames = std::atoi(next());
    else if (a == "--threads")
      o.threads = std::atoi(next());
    else if (a == "--interp-rows")
      o.interp_rows = std::atoi(next());
    else if (a == "--out")
      o.out = next();
    else if (a == "--lanes")
      o.lanes = std::atoi(next());
    else if (!a.empty() && a[0] != '-')
      o.model = a;
    else {
      std::fprintf(stderr,
                   "usage: %s [MODEL.hf] [--size N] [--frames K] [--threads T] "
                   "[--interp-rows R] [--lanes W] [--out image.pgm]\n",
                   argv[0]);
      return 2;
    }
  }
  if (o.threads <= 0) o.threads = std::max(1u, std::thread::hardware_concurrency());
  o.interp_rows = std::clamp(o.interp_rows, 1, o.size);

  auto t0 = Clock::now();
  hfrt::ModelOptions mo;
  mo.eager_f32 = true;
  mo.lanes = o.lanes;
  hfrt::CompileResult jit = hfrt::Model::compile_file(o.model, mo);
  if (!jit.ok()) {
    std::fprintf(stderr, "%s%s\n", jit.rendered.c_str(), jit.error.c_str());
    return 1;
  }
  const double compile_ms = ms_since(t0);
  mo.backend = hfrt::Backend::kInterp;
  hfrt::CompileResult interp = hfrt::Model::compile_file(o.model, mo);
  if (!interp.ok()) return 1;
  const hfrt::Model& mj = *jit.model;
  const hfrt::Model& mi = *interp.model;
  hfrt::ModelStats st = mj.stats();
  std::printf("model %s: %d IR instructions; %d threads; %dx%d grid at z = 0\n", o.model.c_str(),
              st.ir_insts, o.threads, o.size, o.size);
  std::printf(
      "compile: %.1f ms total (front end %.1f, lowering %.1f; jit f64 %.1f + %.1f + %.1f, "
      "f32 %.1f + %.1f + %.1f ms emit+opt+codegen; %d / %d lanes)\n",
      compile_ms, st.frontend_ms, st.lower_ms, st.jit_f64.emit_ms, st.jit_f64.optimize_ms,
      st.jit_f64.codegen_ms, st.jit_f32.emit_ms, st.jit_f32.optimize_ms, st.jit_f32.codegen_ms,
      st.jit_f64.lanes, st.jit_f32.lanes);

  const size_t pixels = static_cast<size_t>(o.size) * o.size;
  std::vector<int> all_rows(o.size);
  for (int y = 0; y < o.size; ++y) all_rows[y] = y;

  std::vector<float> img32(pixels);
  std::vector<double> img64(pixels);
  // Wall-clock median per frame, and the CPU time of all threads per frame (std::clock is
  // process CPU time): on a busy machine the latter still shows what the code costs.
  double cpu_ms = 0, best_ms = 0;  // of the last frame_ms() call
  auto frame_ms = [&](auto run) {
    run();  // warm-up (page faults, thread start)
    std::vector<double> times;
    std::clock_t c0 = std::clock();  // process CPU time, all threads
    for (int k = 0; k < o.frames; ++k) {
      auto t = Clock::now();
      run();
      times.push_back(ms_since(t));
    }
    cpu_ms = 1000.0 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC / o.frames;
    std::sort(times.begin(), times.end());
    best_ms = times.front();
    return times[times.size() / 2];  // median
  };
  double jit32 = frame_ms([&] {
    parallel_rows(all_rows, o.threads, [&](int y) {
      eval_row<float>(mj, o.size, y, &img32[static_cast<size_t>(y) * o.size]);
    });
  });
  const double jit32_cpu = cpu_ms, jit32_best = best_ms;
  double jit64 = frame_ms([&] {
    parallel_rows(all_rows, o.threads, [&](int y) {
      eval_row<double>(mj, o.size, y, &img64[static_cast<size_t>(y) * o.size]);
    });
  });

  const double jit64_cpu = cpu_ms, jit64_best = best_ms;
  // The hand AVX2 brute force of the challenge's own VM file beside prospero.hf (same grid,
  // pixel centres and threads as the JIT's; its inside is < 0 where prospero.hf's F >= 0).
  double hand = 0, hand_cpu = 0;
  size_t hand_mismatch = 0;
#if HFRT_PROSPERO_AVX2
  const bool is_prospero = std::filesystem::path(o.model).filename() == "prospero.hf";
  if (is_prospero && __builtin_cpu_supports("avx2") && o.size % 8 == 0) {
    std::vector<float> hand_img(pixels);
    hand = frame_ms([&] {
      parallel_rows(all_rows, o.threads, [&](int y) {
        // A row of x per thread: one array shared by both threads ran this loop ~1.3x slower
        // (52 -> 70 ms/frame on the AMD VM, for a reason not established; filling it is cheap).
        thread_local std::vector<float> xs;
        xs.resize(size_t(o.size));
        for (int i = 0; i < o.size; ++i) xs[size_t(i)] = float(pixel_x(i, o.size));
        prospero_avx2(xs.data(), float(pixel_y(y, o.size)), &hand_img[size_t(y) * size_t(o.size)],
                      size_t(o.size));
      });
    });
    hand_cpu = cpu_ms;
    for (size_t p = 0; p < pixels; ++p) hand_mismatch += (hand_img[p] <= 0) != (img32[p] >= 0);
  }
#endif
  // Interpreter on evenly spaced rows; compared with the JIT there.
  std::vector<int> rows;
  for (int k = 0; k < o.interp_rows; ++k)
    rows.push_back(static_cast<int>((k + 0.5) * o.size / o.interp_rows));
  std::vector<double> ref(static_cast<size_t>(o.size) * rows.size());
  auto ti = Clock::now();
  std::clock_t ci = std::clock();
  {
    std::vector<int> idx(rows.size());
    for (size_t k = 0; k < rows.size(); ++k) idx[k] = static_cast<int>(k);
    parallel_rows(idx, o.threads, [&](int k) {
      eval_row<double>(mi, o.size, rows[k], &ref[static_cast<size_t>(k) * o.size]);
    });
  }
  const double interp_ms = ms_since(ti) * o.size / static_cast<double>(rows.size());
  const double interp_cpu = 1000.0 * static_cast<double>(std::clock() - ci) / CLOCKS_PER_SEC *
                            o.size / static_cast<double>(rows.size());

  size_t inside32 = 0, inside64 = 0, sign_mismatch32 = 0;
  double max_diff64 = 0;
  for (size_t p = 0; p < pixels; ++p) {
    inside32 += img32[p] >= 0;
    inside64 += img64[p] >= 0;
  }
  for (size_t k = 0; k < rows.size(); ++k) {
    for (int i = 0; i < o.size; ++i) {
      size_t p = static_cast<size_t>(rows[k]) * o.size + i;
      double r = ref[k * o.size + i];
      max_diff64 = std::max(max_diff64, std::fabs(img64[p] - r));
      sign_mismatch32 += (img32[p] >= 0) != (r >= 0);
    }
  }
  std::printf("jit f32:     %10.2f ms/frame  (CPU time %.2f ms/frame, all threads)\n", jit32,
              jit32_cpu);
  std::printf("jit f64:     %10.2f ms/frame  (CPU time %.2f ms/frame)\n", jit64, jit64_cpu);
  std::printf(
      "interpreter: %10.2f ms/frame  (CPU time %.2f ms/frame; extrapolated from %zu rows)\n",
      interp_ms, interp_cpu, rows.size());
  std::printf("ratio interpreter / jit f32: %.1fx; interpreter / jit f64: %.1fx\n",
              interp_ms / jit32, interp_ms / jit64);
  if (hand > 0) {
    std::printf(
        "hand AVX2 brute force: %8.2f ms/frame  (CPU time %.2f ms/frame; straight-line "
        "intrinsics generated from prospero.vm, no hfrt code); pixels whose sign differs from "
        "jit f32: %zu\n",
        hand, hand_cpu, hand_mismatch);
  } else {
    std::printf("hand AVX2 brute force: not run (needs prospero.hf and an AVX2 x86-64 CPU)\n");
  }
  // The pruned slice against the brute force above, same grid (render_slice's pixel centres
  // over [-1, 1]^2), same threads.
  {
    hfrt::app::ModelField field(mj, o.model);
    std::string why;
    if (!field.prepare_tapes(&why)) {
      std::printf("pruned slice: no tape (%s)\n", why.c_str());
    } else {
      hfrt::render::SliceOptions so;
      so.width = so.height = o.size;
      so.x0 = so.y0 = -1;
      so.x1 = so.y1 = 1;
      so.threads = o.threads;
      hfrt::render::SliceResult pr;
      const double pruned = frame_ms([&] { pr = hfrt::render::render_slice(field, so); });
      const double pruned_cpu = cpu_ms, pruned_best = best_ms;
      std::printf(
          "pruned slice: %10.2f ms/frame  (best %.2f, CPU time %.2f ms/frame; tape VM, no JIT)\n",
          pruned, pruned_best, pruned_cpu);
      std::printf("ratio pruned slice / jit f32 brute force: %.3fx (CPU time %.3fx)\n",
                  pruned / jit32, pruned_cpu / jit32_cpu);
      if (hand > 0) {
        std::printf("ratio pruned slice / hand AVX2 brute force: %.3fx (CPU time %.3fx)\n",
                    pruned / hand, pruned_cpu / hand_cpu);
      }
      const hfrt::render::SliceStats& ps = pr.stats;
      std::printf("pruned tape length per level (average over the blocks pruned): root %zu",
                  ps.root_tape_length);
      for (size_t l = 0; l < ps.tapes_by_level.size(); ++l) {
        if (ps.tapes_by_level[l] == 0) continue;
        std::printf("; L%zu %.1f (%llu)", l,
                    double(ps.tape_length_by_level[l]) / double(ps.tapes_by_level[l]),
                    (unsigned long long)ps.tapes_by_level[l]);
      }
      std::printf("\n  interval calls %llu, pixels settled by intervals %llu, points %llu\n",
                  (unsigned long long)ps.evals.interval_calls,
                  (unsigned long long)ps.pixels_by_interval,
                  (unsigned long long)ps.evals.eval_points);
      // Today's slice (compiled interval code or the interval interpreter, f32 JIT points),
      // once: its image is the reference of the pruned one.
      so.prune = false;
      auto tu = Clock::now();
      hfrt::render::SliceResult ur = hfrt::render::render_slice(field, so);
      const double unpruned_ms = ms_since(tu);
      size_t diff_slice = 0, diff_brute = 0;
      for (size_t p = 0; p < pixels; ++p) {
        diff_slice += pr.inside[p] != ur.inside[p];
        diff_brute += pr.inside[p] != (img32[p] >= 0 ? 1 : 0);
      }
      std::printf(
          "unpruned slice (render_slice with prune off): %.2f ms, one frame; pixels differing "
          "from the pruned slice: %zu; from the brute-force f32 signs: %zu\n",
          unpruned_ms, diff_slice, diff_brute);
    }
  }
  // Distance to the machine's limit: brute force (no pruning) evaluates every IR instruction
  // at every pixel, so IR instructions x pixels / time is the achieved lane-op rate, against
  // the measured peak of vector adds on the same threads, measured now.
  {
    const bool avx2 =
#if defined(__x86_64__)
        __builtin_cpu_supports("avx2");
#else
        false;
#endif
    double peak_core = 0;
    const double peak = peak_vector_adds_per_s(o.threads, &peak_core);
    // Constants and inputs are not work per point: count the computing instructions (the
    // run-time error checks included: the JIT evaluates them at every point too).
    const int per_point = compute_ops(o.model);
    const double ops = double(per_point > 0 ? per_point : st.ir_insts) * double(pixels);
    // Best frames against the best peak round (medians are printed above).
    const double achieved32 = ops / (jit32_best / 1000.0), achieved64 = ops / (jit64_best / 1000.0);
    // Per core (CPU time): independent of other load on a shared machine.
    const double core32 = ops / (jit32_cpu / 1000.0), core64 = ops / (jit64_cpu / 1000.0);
    std::printf(
        "physical limit: %d computing IR ops (of %d IR instructions) x %zu points "
        "(brute force, no pruning)\n",
        per_point, st.ir_insts, pixels);
    std::printf(
        "  wall, %d threads, best frame: jit f32 %.2f, jit f64 %.2f G lane-ops/s; peak vector "
        "adds%s "
        "%.2f G lane-ops/s; f32 at %.1f%% of peak\n",
        o.threads, achieved32 / 1e9, achieved64 / 1e9, avx2 ? " (8-lane AVX2)" : "", peak / 1e9,
        100.0 * achieved32 / peak);
    std::printf(
        "  per core (CPU time): jit f32 %.2f, jit f64 %.2f G lane-ops/s; peak vector adds "
        "%.2f G lane-ops/s; f32 at %.1f%%, f64 at %.1f%% of peak\n",
        core32 / 1e9, core64 / 1e9, peak_core / 1e9, 100.0 * core32 / peak_core,
        100.0 * core64 / peak_core);
  }
  std::printf(
      "check: inside pixels f32 %zu, f64 %zu; on the interpreter rows: max |f64 - interp| "
      "= %.3g, f32 sign mismatches %zu\n",
      inside32, inside64, max_diff64, sign_mismatch32);
  if (!o.out.empty()) {
    FILE* f = std::fopen(o.out.c_str(), "wb");
    if (!f) {
      std::perror(o.out.c_str());
      return 1;
    }
    std::fprintf(f, "P5\n%d %d\n255\n", o.size, o.size);
    for (size_t p = 0; p < pixels; ++p) std::fputc(img32[p] >= 0 ? 255 : 0, f);
    std::fclose(f);
  }
  return max_diff64 < 1e-9 ? 0 : 1;
}
