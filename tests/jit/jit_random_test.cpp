// Differential test: the LLVM JIT (f64 and f32, vectorised with masks) against the reference
// interpreter on seeded random IR programs with ifs, loops, arrays, tables and checks.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "ir/print.h"
#include "jit/interpreter.h"
#include "jit/llvm_jit.h"
#include "tests/jit/random_program.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

using testing::random_points;
using testing::random_program;
using testing::RandomProgramOptions;

constexpr int kPrograms = 300;
constexpr int kPoints = 61;  // not a multiple of any lane count: exercises the tail

bool close_f64(double jit, double ref) {
  if (std::isnan(ref) || std::isnan(jit)) return std::isnan(ref) && std::isnan(jit);
  if (jit == ref) return true;  // also equal infinities
  return std::fabs(jit - ref) <= 1e-12 * std::max(std::fabs(jit), std::fabs(ref));
}

/// SoA input block for the batch ABI.
template <typename T>
std::vector<T> soa(const std::vector<std::vector<double>>& pts, int dims) {
  std::vector<T> xs(static_cast<size_t>(dims) * pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    for (int k = 0; k < dims; ++k) xs[k * pts.size() + i] = static_cast<T>(pts[i][k]);
  }
  return xs;
}

/// Compares one program on all points; returns "" or a description of the first mismatch.
std::string compare_f64(const Function& fn, uint64_t seed, const JitOptions& options) {
  auto compiled = JitFunction::compile(fn, Precision::kF64, options);
  if (!compiled.ok()) return "compile failed: " + compiled.error().message;
  Interpreter interp(fn);
  auto pts = random_points(seed, kPoints, fn.num_inputs);
  std::vector<double> a = {0.5, -1.25};
  a.resize(std::max(fn.num_params, 1), 0.0);
  auto xs = soa<double>(pts, fn.num_inputs);
  const size_t n = pts.size(), ns = fn.s_slots.size();
  std::vector<double> f(n), s(ns * n);
  compiled.value()->f64()(static_cast<int64_t>(n), xs.data(), a.data(), f.data(), s.data());
  for (size_t i = 0; i < n; ++i) {
    EvalResult r = interp.eval(pts[i], a);
    std::ostringstream os;
    os.precision(17);
    if (!close_f64(f[i], r.value)) {
      os << "point " << i << ": jit F=" << f[i] << " interp F=" << r.value;
    }
    for (size_t k = 0; k < ns && os.str().empty(); ++k) {
      double ref = r.error ? std::nan("") : r.s[k];
      if (!close_f64(s[k * n + i], ref)) {
        os << "point " << i << ": jit s" << k + 1 << "=" << s[k * n + i] << " interp=" << ref;
      }
    }
    if (!os.str().empty()) return os.str() + "\n" + print(fn);
  }
  // Without out_s the batch function must still work (and leave f unchanged).
  std::vector<double> f2(n);
  compiled.value()->f64()(static_cast<int64_t>(n), xs.data(), a.data(), f2.data(), nullptr);
  for (size_t i = 0; i < n; ++i) {
    if (!close_f64(f2[i], f[i])) return "out_s == null changes F";
  }
  return "";
}

/// Seeds [first, last): every program agrees at every point; returns (programs with loops,
/// with ifs) so the caller can check the generator really produced control flow.
std::pair<int, int> check_f64_range(int first, int last) {
  int with_loops = 0, with_ifs = 0;
  for (int seed = first; seed < last; ++seed) {
    Function fn = random_program(seed);
    bool loop = false, branch = false;
    for (const Inst& in : fn.insts) {
      loop |= in.op == Op::kLoop;
      branch |= in.op == Op::kIf;
    }
    with_loops += loop;
    with_ifs += branch;
    JitOptions options;
    options.opt_level = seed % 16 == 0 ? 0 : 2;  // also check the unoptimised code
    std::string err = compare_f64(fn, seed, options);
    EXPECT_EQ(err, "") << "seed " << seed;
    if (!err.empty()) break;
  }
  return {with_loops, with_ifs};
}

// Two halves, so that each CTest test stays short.
TEST(JitRandomTest, F64AgreesWithInterpreterA) {
  auto [loops, ifs] = check_f64_range(0, kPrograms / 2);
  EXPECT_GT(loops, kPrograms / 4);
  EXPECT_GT(ifs, kPrograms / 4);
}

TEST(JitRandomTest, F64AgreesWithInterpreterB) {
  auto [loops, ifs] = check_f64_range(kPrograms / 2, kPrograms);
  EXPECT_GT(loops, kPrograms / 4);
  EXPECT_GT(ifs, kPrograms / 4);
}

TEST(JitRandomTest, EveryOpIsGenerated) {
  std::set<Op> seen;
  for (int seed = 0; seed < kPrograms; ++seed) {
    for (const Inst& in : random_program(seed).insts) seen.insert(in.op);
  }
  for (int k = 0; k < kOpCount; ++k) {
    // kSurface needs a loaded surface: surface_test.cpp checks its evaluators against each other.
    if (static_cast<Op>(k) == Op::kSurface) continue;
    EXPECT_TRUE(seen.count(static_cast<Op>(k)))
        << op_name(static_cast<Op>(k)) << " never generated";
  }
}

TEST(JitRandomTest, OtherLaneCountsAndLevels) {
  // Lane counts other than the host's (2 = SSE-like, 16 = AVX-512-like) and O1/O3.
  for (int seed = 1000; seed < 1024; ++seed) {
    Function fn = random_program(seed);
    JitOptions options;
    options.lanes = seed % 2 ? 2 : 16;
    options.opt_level = seed % 3 == 0 ? 1 : 3;
    std::string err = compare_f64(fn, seed, options);
    ASSERT_EQ(err, "") << "seed " << seed << " lanes " << options.lanes;
  }
}

TEST(JitOps, CbrtMatchesTheInterpreter) {
  // cbrt(x[1]) * x[2] + cbrt(a[1]): a per-lane libm call (cbrt / cbrtf) and, for the
  // parameter, a uniform one (computed once and broadcast).
  Function fn;
  fn.num_params = 1;
  IrBuilder b(fn);
  b.finish(
      b.add(b.mul(b.unary(Op::kCbrt, b.input(0)), b.input(1)), b.unary(Op::kCbrt, b.param(0))));
  auto pts = random_points(5, kPoints, fn.num_inputs);
  for (double x :
       {-8.0, 27.0, -0.0, 1e-300, -1e300, std::numeric_limits<double>::infinity(), std::nan("")})
    pts.push_back({x, 1.5, 0});
  const size_t n = pts.size();
  const std::vector<double> a = {-8};
  Interpreter interp(fn);

  auto f64 = JitFunction::compile(fn, Precision::kF64);
  ASSERT_TRUE(f64.ok()) << f64.error().message;
  auto xs = soa<double>(pts, fn.num_inputs);
  std::vector<double> f(n);
  f64.value()->f64()(static_cast<int64_t>(n), xs.data(), a.data(), f.data(), nullptr);
  for (size_t i = 0; i < n; ++i) {
    const double ref = interp.eval(pts[i], a).value;
    EXPECT_TRUE(std::isnan(ref) ? std::isnan(f[i]) : f[i] == ref)
        << "f64 at x = " << pts[i][0] << ": JIT " << f[i] << " interpreter " << ref;
  }

  auto f32 = JitFunction::compile(fn, Precision::kF32);
  ASSERT_TRUE(f32.ok()) << f32.error().message;
  auto xf = soa<float>(pts, fn.num_inputs);
  const std::vector<float> af(a.begin(), a.end());
  std::vector<float> g(n);
  f32.value()->f32()(static_cast<int64_t>(n), xf.data(), af.data(), g.data(), nullptr);
  for (size_t i = 0; i < n; ++i) {
    std::vector<double> p(pts[i].size());
    for (size_t k = 0; k < p.size(); ++k) p[k] = static_cast<float>(pts[i][k]);
    const double ref = interp.eval(p, a).value;
    if (!std::isfinite(ref)) {
      EXPECT_TRUE(std::isnan(ref) ? std::isnan(g[i]) : g[i] == ref)
          << "f32 at x = " << p[0] << ": JIT " << g[i] << " interpreter " << ref;
      continue;
    }
    EXPECT_NEAR(g[i], ref, 1e-6 * (1 + std::fabs(ref))) << "f32 at x = " << p[0];
  }
}

TEST(JitRandomTest, F32CloseToInterpreter) {
  // Single precision: well-conditioned programs agree within float tolerance. A comparison
  // may flip where its operands differ by rounding, so a few points per program may differ.
  RandomProgramOptions opts;
  opts.tame = true;
  int points = 0, bad = 0;
  for (int seed = 0; seed < 80; ++seed) {
    Function fn = random_program(seed, opts);
    auto compiled = JitFunction::compile(fn, Precision::kF32);
    ASSERT_TRUE(compiled.ok()) << compiled.error().message;
    Interpreter interp(fn);
    auto pts = random_points(seed, kPoints, fn.num_inputs);
    std::vector<double> a = {0.5, -1.25};
    std::vector<float> af(a.begin(), a.end());
    auto xs = soa<float>(pts, fn.num_inputs);
    std::vector<float> f(pts.size());
    compiled.value()->f32()(static_cast<int64_t>(pts.size()), xs.data(), af.data(), f.data(),
                            nullptr);
    for (size_t i = 0; i < pts.size(); ++i) {
      std::vector<double> p(pts[i].size());
      for (size_t k = 0; k < p.size(); ++k) p[k] = static_cast<float>(pts[i][k]);
      double ref = interp.eval(p, a).value;
      ++points;
      bool ok = (std::isnan(ref) && std::isnan(f[i])) ||
                std::fabs(f[i] - ref) <= 1e-4 * (1 + std::fabs(ref));
      bad += !ok;
    }
  }
  EXPECT_LT(bad, points / 100) << bad << " of " << points << " points differ";
}

}  // namespace
}  // namespace hfrt::jit
