#pragma once
// The gradient domain: forward-mode automatic differentiation of F with respect to
// x[1], x[2], x[3]. Each value is a dual number (value and three partial derivatives); the
// value part is bit-for-bit what the scalar interpreter computes (scalar_ops.h apply_op), the
// derivative parts are exact derivatives (chain rule), not finite differences.
//
// Where an op is not differentiable the derivative is the one-sided derivative of the branch
// the scalar code takes: abs (x < 0 ? -x : x), min/max (the chosen operand), floor/ceil/
// trunc/round/sign and comparisons (0), fmod (d a - q d b, q the integral quotient), kSelect
// and branches (the dual of the branch taken). Slots carry duals. A derivative component
// whose input component is exactly 0 stays 0 (so sqrt(0 + const) has no NaN partials), and a
// point where a kCheck fires gets NaN in all four components.

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "base/result.h"
#include "ir/dual_ops.h"
#include "ir/ir.h"
#include "jit/llvm_jit.h"  // Precision (no LLVM types)

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// Iteration limit of while loops in the gradient interpreter (a point that exceeds it gets
/// NaN, like the LoopLimit error of the scalar interpreter).
inline constexpr int64_t kGradientLoopLimit = 100000000;

/// Evaluates F and its gradient at points, in double precision, interpreting the IR.
/// Owns its scratch memory: one per thread. The Function must outlive it.
class GradientInterpreter {
 public:
  explicit GradientInterpreter(const Function& fn, int64_t loop_limit = kGradientLoopLimit);

  /// F and dF/dx[1..3] at the point x (missing coordinates are 0), parameters a.
  Dual eval(std::span<const double> x, std::span<const double> a);

  /// True when a kCheck fired during the last eval (the result is then NaN).
  bool error() const { return error_; }

 private:
  const Function& fn_;
  int64_t loop_limit_;
  std::vector<int32_t> match_;
  std::vector<Dual> values_;
  std::vector<Dual> slots_;
  bool error_ = false;
};

/// The compiled gradient evaluator (LLVM, f64 or f32, W points per SIMD block; see
/// llvm_gradient.cpp). Values and derivatives follow the same formulas as apply_dual, control
/// flow uses lane masks like the scalar JIT. Immutable after compile(); thread-safe.
class GradientJit {
 public:
  ~GradientJit();
  GradientJit(const GradientJit&) = delete;
  GradientJit& operator=(const GradientJit&) = delete;

  struct Options {
    Precision precision = Precision::kF64;
    int lanes = 0;      ///< points per SIMD block (power of two); 0 = the host's width
    int opt_level = 1;  ///< LLVM pipeline O0..O3
  };
  static Result<std::unique_ptr<GradientJit>> compile(const Function& fn, const Options& options);
  static Result<std::unique_ptr<GradientJit>> compile(const Function& fn) {
    return compile(fn, Options{});
  }

  /// n points, structure of arrays: x[k+1] of point i is xs[k*n + i] (k < num_inputs);
  /// out[c*n + i] gets F (c = 0) and dF/dx[c] (c = 1..3). A point where a run-time error
  /// fired gets NaN in all four. Use the overload matching the compiled precision.
  void eval(int64_t n, const double* xs, std::span<const double> a, double* out) const;
  void eval(int64_t n, const float* xs, std::span<const double> a, float* out) const;

  /// One point (convenience for tests and tools), in the compiled precision.
  Dual eval_one(std::span<const double> x, std::span<const double> a) const;

  Precision precision() const;
  int lanes() const;
  /// Compile-latency figures (emit, optimise, code generation).
  const JitStats& stats() const;

 private:
  struct Impl;
  explicit GradientJit(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace hfrt::jit
