// Fuzz target: differential testing of the evaluators. The fuzzer's bytes drive a small
// generator of WELL-FORMED HyperFun programs (x[1..3], constants, + - * /, sqrt, min, max,
// the set operators | and &, unary minus, locals assigned under if/else), compiled twice: with
// the JIT and with the interpreter backend. At points chosen by the bytes:
//   - the f64 scalar JIT and the interpreter agree bit for bit (NaN with NaN);
//   - the interval JIT and the interval interpreter agree bit for bit, and every value the
//     scalar evaluator computes at the point and at the corners of a small box around it lies
//     in the box's interval (or is NaN and the interval says maybe_nan);
//   - the gradient JIT and the gradient interpreter agree bit for bit; where F is smooth at the
//     point (central differences at two steps and the one-sided ones agree) the gradient
//     matches central differences within a loose tolerance (NaN, inf and huge values skipped).
// A mismatch aborts with the program and the point, so the crash file reproduces it.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "hfrt/model.h"

namespace {

/// Reads the fuzzer's bytes as choices; zeros once they run out (so every input ends).
class Bytes {
 public:
  Bytes(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  uint8_t next() { return pos_ < size_ ? data_[pos_++] : 0; }
  int pick(int n) { return next() % n; }
  bool empty() const { return pos_ >= size_; }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

/// Generates one expression over x[1..3], the locals defined so far, and constants.
class Generator {
 public:
  explicit Generator(Bytes* in) : in_(in) {}

  std::string constant() {
    static const char* const kTable[] = {"0",  "1",     "2",   "0.5",  "3.25",
                                         "10", "0.001", "100", "1e-7", "1e6"};
    const int k = in_->pick(12);
    if (k < 10) return kTable[k];
    // A byte-made number: 0.0 .. 25.5.
    const int v = in_->next();
    return std::to_string(v / 10) + "." + std::to_string(v % 10);
  }

  std::string leaf() {
    const int k = in_->pick(locals_ > 0 ? 5 : 4);
    if (k < 3) return "x[" + std::to_string(k + 1) + "]";
    if (k == 3) return constant();
    return "v" + std::to_string(in_->pick(locals_) + 1);
  }

  std::string expr(int depth) {
    if (depth <= 0 || in_->empty()) return leaf();
    const int k = in_->pick(13);
    const auto sub = [&] { return expr(depth - 1); };
    switch (k) {
      case 0:
        return leaf();
      case 1:
        return "(" + sub() + " + " + sub() + ")";
      case 2:
        return "(" + sub() + " - " + sub() + ")";
      case 3:
        return "(" + sub() + " * " + sub() + ")";
      case 4:
        return "(" + sub() + " / " + sub() + ")";
      case 5:
        return "sqrt(" + sub() + ")";
      case 6:
        return "min(" + sub() + ", " + sub() + ")";
      case 7:
        return "max(" + sub() + ", " + sub() + ")";
      case 8:
        return "(" + sub() + " | " + sub() + ")";
      case 9:
        return "(" + sub() + " & " + sub() + ")";
      case 10:
        return "(-" + sub() + ")";
      case 11:
        return "abs(" + sub() + ")";
      default:
        return "(" + sub() + " * " + sub() + " - " + sub() + ")";
    }
  }

  std::string condition() {
    static const char* const kRel[] = {"<", "<=", ">", ">=", "=", "/="};
    std::string c = expr(2) + " " + kRel[in_->pick(6)] + " " + expr(2);
    if (in_->pick(4) == 0) {
      c += in_->pick(2) ? " and " : " or ";
      c += expr(1) + " " + kRel[in_->pick(6)] + " " + expr(1);
    }
    return c;
  }

  /// The whole object: up to 4 locals (each assigned before any read), some reassigned under
  /// if/else, then my_model.
  std::string program() {
    std::string body;
    const int statements = in_->pick(5);
    for (int i = 0; i < statements; ++i) {
      if (locals_ > 0 && in_->pick(3) == 0) {
        const std::string v = "v" + std::to_string(in_->pick(locals_) + 1);
        body += "  if " + condition() + " then\n    " + v + " = " + expr(3) + ";\n";
        if (in_->pick(2)) body += "  else\n    " + v + " = " + expr(3) + ";\n";
        body += "  endif;\n";
      } else if (locals_ < 4) {
        const std::string e = expr(3);
        ++locals_;
        body += "  v" + std::to_string(locals_) + " = " + e + ";\n";
      }
    }
    body += "  my_model = " + expr(4) + ";\n";
    return "my_model(x[3], a[1])\n{\n" + body + "}\n";
  }

 private:
  Bytes* in_;
  int locals_ = 0;
};

std::string g_program;  // for the failure message

[[noreturn]] void fail(const char* what, const double* p, double got, double want) {
  std::fprintf(stderr, "differential mismatch: %s\n  at x = (%.17g, %.17g, %.17g)\n", what, p[0],
               p[1], p[2]);
  std::fprintf(stderr, "  got %.17g (%016llx), want %.17g (%016llx)\nprogram:\n%s", got,
               static_cast<unsigned long long>(std::bit_cast<uint64_t>(got)), want,
               static_cast<unsigned long long>(std::bit_cast<uint64_t>(want)), g_program.c_str());
  std::abort();
}

bool same_bits(double a, double b) {
  return (std::isnan(a) && std::isnan(b)) ||
         std::bit_cast<uint64_t>(a) == std::bit_cast<uint64_t>(b);
}

/// F at the points pts (3 coordinates each) with the model's f64 batch evaluator.
std::vector<double> eval_points(const hfrt::Model& m,
                                const std::vector<std::array<double, 3>>& pts) {
  const int64_t n = static_cast<int64_t>(pts.size());
  std::vector<double> xs(3 * pts.size());
  for (size_t i = 0; i < pts.size(); ++i) {
    for (int k = 0; k < 3; ++k) xs[k * n + i] = pts[i][k];
  }
  std::vector<double> f(pts.size());
  m.eval_batch(n, xs.data(), f.data());
  return f;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Bytes in(data, size);
  Generator gen(&in);
  g_program = gen.program();
  // HFRT_FUZZ_PRINT=1: show the generated program (to look at what the corpus exercises).
  static const bool print = std::getenv("HFRT_FUZZ_PRINT") != nullptr;
  if (print) std::fprintf(stderr, "%s", g_program.c_str());

  hfrt::ModelOptions jit_options;
  jit_options.interval_jit_max_insts = -1;  // always the JIT in every domain
  jit_options.gradient_jit_max_insts = -1;
  hfrt::ModelOptions interp_options;
  interp_options.backend = hfrt::Backend::kInterp;
  hfrt::CompileResult jit = hfrt::Model::compile(g_program, jit_options);
  hfrt::CompileResult interp = hfrt::Model::compile(g_program, interp_options);
  if (!jit.ok() || !interp.ok()) {
    std::fprintf(stderr, "generated program does not compile:\n%s\n%s%s\n", g_program.c_str(),
                 jit.rendered.c_str(), jit.error.c_str());
    std::abort();
  }
  const hfrt::Model& mj = *jit.model;
  const hfrt::Model& mi = *interp.model;

  // Points: coordinates from a small set (ties, zeros) or from the remaining bytes.
  static const double kCoords[] = {0, 1, -1, 0.5, -2.25, 3, 1e-3, 0.1};
  std::vector<std::array<double, 3>> pts;
  for (int i = 0; i < 8; ++i) {
    std::array<double, 3> p;
    for (double& c : p) {
      const uint8_t b = in.next();
      c = b < 64 ? kCoords[b % 8] : (static_cast<double>(b) - 160.0) / 23.0;
    }
    pts.push_back(p);
  }
  pts.push_back({0.37, -1.41, 2.03});

  // 1. Scalar: JIT against the interpreter, bit for bit.
  const std::vector<double> fj = eval_points(mj, pts);
  const std::vector<double> fi = eval_points(mi, pts);
  for (size_t i = 0; i < pts.size(); ++i) {
    if (!same_bits(fj[i], fi[i])) fail("scalar JIT vs interpreter", pts[i].data(), fj[i], fi[i]);
  }

  const double h = 1e-3;
  for (size_t i = 0; i < pts.size(); ++i) {
    const std::array<double, 3>& p = pts[i];
    // 2. Intervals over the box p +- h: JIT against the interpreter, and the values of the
    // point and of two corners inside.
    const double lo[3] = {p[0] - h, p[1] - h, p[2] - h};
    const double hi[3] = {p[0] + h, p[1] + h, p[2] + h};
    const hfrt::IntervalValue ij = mj.eval_interval(lo, hi);
    const hfrt::IntervalValue ii = mi.eval_interval(lo, hi);
    if (!same_bits(ij.lo, ii.lo)) fail("interval lo JIT vs interpreter", p.data(), ij.lo, ii.lo);
    if (!same_bits(ij.hi, ii.hi)) fail("interval hi JIT vs interpreter", p.data(), ij.hi, ii.hi);
    if (ij.maybe_nan != ii.maybe_nan) {
      fail("interval maybe_nan JIT vs interpreter", p.data(), ij.maybe_nan, ii.maybe_nan);
    }
    const std::vector<std::array<double, 3>> box_pts = {
        p, {lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}, {lo[0], hi[1], p[2]}};
    const std::vector<double> fb = eval_points(mj, box_pts);
    for (size_t k = 0; k < box_pts.size(); ++k) {
      if (!ij.contains(fb[k])) {
        std::fprintf(stderr, "interval [%.17g, %.17g] maybe_nan=%d over box +-%g\n", ij.lo, ij.hi,
                     ij.maybe_nan, h);
        fail("value outside its interval", box_pts[k].data(), fb[k], ij.lo);
      }
    }

    // 3. Gradients: JIT against the interpreter, and against central differences.
    const hfrt::GradientValue gj = mj.eval_gradient(p);
    const hfrt::GradientValue gi = mi.eval_gradient(p);
    if (!same_bits(gj.f, gi.f)) fail("gradient f JIT vs interpreter", p.data(), gj.f, gi.f);
    if (!same_bits(gj.f, fj[i])) fail("gradient f vs scalar f", p.data(), gj.f, fj[i]);
    for (int k = 0; k < 3; ++k) {
      if (!same_bits(gj.d[k], gi.d[k]))
        fail("gradient JIT vs interpreter", p.data(), gj.d[k], gi.d[k]);
    }
    const double f0 = fj[i];
    if (!std::isfinite(f0) || std::abs(f0) > 1e6) continue;
    for (int k = 0; k < 3; ++k) {
      const double g = gj.d[k];
      if (!std::isfinite(g) || std::abs(g) > 1e6) continue;
      const double step = 1e-6 * std::max(1.0, std::abs(p[k]));
      std::vector<std::array<double, 3>> q(4, p);
      q[0][k] += step;
      q[1][k] -= step;
      q[2][k] += 10 * step;
      q[3][k] -= 10 * step;
      const std::vector<double> fq = eval_points(mj, q);
      bool finite = true;
      for (double v : fq) finite = finite && std::isfinite(v) && std::abs(v) < 1e6;
      if (!finite) continue;
      const double c1 = (fq[0] - fq[1]) / (2 * step);
      const double c10 = (fq[2] - fq[3]) / (20 * step);
      const double fwd = (fq[0] - f0) / step;
      const double bwd = (f0 - fq[1]) / step;
      const auto near = [](double a, double b, double tol) {
        return std::abs(a - b) <= tol * (1 + std::max(std::abs(a), std::abs(b)));
      };
      // Smooth at p: the steps agree with each other (no kink or branch within 10 steps).
      if (!near(c1, c10, 1e-4) || !near(fwd, bwd, 1e-4)) continue;
      // And p is not a point where a subexpression is not differentiable: there the gradient
      // domain gives the formal derivative of one branch (a subgradient), which differences
      // of F cannot see when kinks cancel (e.g. (v3 & 0) at v3 = 0 with v3 = -min(-x3, x3 + x2)
      // at x2 = x3 = 0: F is flat, the formal derivative 1; found by this fuzzer). The
      // computed gradient is then discontinuous at p: compare it with its neighbours' first.
      const hfrt::GradientValue g_plus = mj.eval_gradient(q[0]);
      const hfrt::GradientValue g_minus = mj.eval_gradient(q[1]);
      if (!near(g_plus.d[k], g, 1e-3) || !near(g_minus.d[k], g, 1e-3)) continue;
      if (!near(g, c1, 1e-3)) {
        std::fprintf(stderr, "d/dx[%d]: central difference %.17g (10 steps: %.17g)\n", k + 1, c1,
                     c10);
        fail("gradient vs central differences", p.data(), g, c1);
      }
    }
  }
  return 0;
}
