// Points/s of Model::eval_batch (f64 and f32, one thread) on N points of a model: the C++
// side of bench/python_eval_bench.py (Python's hfrt.Model.eval and pure NumPy on the same
// model). The points are uniform in [-L, L]^k from a fixed seed, structure of arrays, and are
// evaluated in one eval_batch call per repetition; the best of R repetitions is printed.
//
//   build/bench/hfrt_bench_eval_points MODEL.hf [--n N] [--repeat R] [--half L]
//
// Prints `cxx f64 POINTS_PER_S`, `cxx f32 ...` and `cxx f64-rows ...` (the points stored row
// by row, transposed in blocks first) lines (and a checksum, so that the
// evaluation cannot be optimised away and so that runs can be compared).

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "hfrt/model.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODEL.hf [--n N] [--repeat R] [--half L]\n", argv[0]);
    return 2;
  }
  int64_t n = 1000000;
  int repeat = 7;
  double half = 1.6;
  for (int i = 2; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--n")) n = std::atoll(argv[i + 1]);
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::atoi(argv[i + 1]);
    if (!std::strcmp(argv[i], "--half")) half = std::atof(argv[i + 1]);
  }
  hfrt::ModelOptions options;
  options.eager_f32 = true;
  hfrt::CompileResult compiled = hfrt::Model::compile_file(argv[1], options);
  if (!compiled.ok()) {
    std::fprintf(stderr, "%s%s\n", compiled.rendered.c_str(), compiled.error.c_str());
    return 1;
  }
  const hfrt::Model& model = *compiled.model;
  const int k = model.num_inputs();
  std::vector<double> xs(size_t(k) * n), f(n);
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(-half, half);
  for (double& v : xs) v = u(rng);
  std::vector<float> xs32(xs.begin(), xs.end()), f32(n);

  // Every repetition starts with cold caches (64 MB written): the points (24 MB at 10^6) come
  // from memory, as they would in an application, in every variant alike.
  std::vector<char> flush(64 << 20);
  auto best = [&](auto&& call) {
    double best_s = 1e30;
    for (int r = 0; r < repeat; ++r) {
      for (size_t i = 0; i < flush.size(); i += 64) flush[i] = char(flush[i] + 1);
      auto t0 = std::chrono::steady_clock::now();
      call();
      double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      best_s = std::min(best_s, s);
    }
    return best_s;
  };
  model.eval_batch(std::min<int64_t>(n, 64), xs.data(), f.data());  // warm up
  double t64 = best([&] { model.eval_batch(n, xs.data(), f.data()); });
  double t32 = best([&] { model.eval_batch(n, xs32.data(), f32.data()); });
  // The same from points stored row by row (x y z x y z ...: a C-ordered (n, k) NumPy array):
  // the evaluator takes structures of arrays, so blocks of 2048 points are transposed first,
  // as the Python module does.
  std::vector<double> aos(size_t(k) * n);
  for (int64_t i = 0; i < n; ++i) {
    for (int c = 0; c < k; ++c) aos[size_t(i) * k + c] = xs[size_t(c) * n + i];
  }
  const int64_t kBlock = 2048;
  std::vector<double> block(size_t(k) * kBlock);
  double taos = best([&] {
    for (int64_t s = 0; s < n; s += kBlock) {
      const int64_t m = std::min(kBlock, n - s);
      const double* src = aos.data() + size_t(s) * k;
      for (int64_t i = 0; i < m; ++i, src += k) {
        for (int c = 0; c < k; ++c) block[size_t(c) * m + i] = src[c];
      }
      model.eval_batch(m, block.data(), f.data() + s);
    }
  });
  double sum = 0;
  for (double v : f) sum += v;
  std::printf("cxx f64 %.6g points/s (%.3f ms for %lld points, best of %d)\n", n / t64, t64 * 1e3,
              (long long)n, repeat);
  std::printf("cxx f32 %.6g points/s (%.3f ms)\n", n / t32, t32 * 1e3);
  std::printf("cxx f64-rows %.6g points/s (%.3f ms, row-major points transposed in blocks)\n",
              n / taos, taos * 1e3);
  std::printf("checksum %.17g\n", sum);
  return 0;
}
