#pragma once
// The double-precision meaning of every pure arithmetic op of ir_ops.h, written once.
// The IrBuilder's constant folder and the reference interpreter both call apply_op, so a
// folded constant is bit-for-bit what the interpreter would have computed at run time.
// Evaluators in other domains (LLVM scalar code, intervals, ...) must agree with these
// definitions; hf_pow and hf_sign are plain functions so a JIT can call them as helpers.

#include <cmath>
#include <type_traits>

#include "ir/ir.h"
#include "ir/trig.h"

namespace hfrt::ir {

/// HyperFun's tolerance for truth values, '=' / '/=', division and power checks.
inline constexpr double kHfEps = 1e-6;

/// Above this many factors an integral power is computed with std::pow instead of a loop of
/// multiplications (the loop then only reproduces overflow to inf, underflow to 0 or +-1).
inline constexpr double kHfPowMaxLoop = 1024;

/// kPowHF: HyperFun's `b ^ e` value without the error report (the checks are kCheck ops), in
/// the precision T (float: the f32 JIT's helper and the tape VM; double: everything else).
/// Every constant is rounded to T first, as the f32 code does.
template <typename T>
inline T hf_pow_t(T b, T e) {
  const T eps = static_cast<T>(kHfEps);
  if (std::fabs(b) < eps) return T(0);
  if (std::fabs(e - std::trunc(e)) < eps) {
    // Integral exponent: b multiplied round(|e|) times, left to right as the original does.
    const T n = std::round(std::fabs(e));
    T v = T(1);
    if (n <= static_cast<T>(kHfPowMaxLoop)) {
      for (int i = 0; i < static_cast<int>(n); ++i) v *= b;
    } else {
      v = std::pow(b, n);
    }
    return e < 0 ? T(1) / v : v;
  }
  return std::exp(e * std::log(b));  // NaN for b < 0 (reported by a separate kCheck)
}

/// kPowHF in double precision (the interpreter, the constant folder, the f64 JIT's helper).
inline double hf_pow(double b, double e) {
  return hf_pow_t<double>(b, e);
}

/// kSign with hfrt's semantics: -1, 0 or 1 (NaN stays NaN).
template <typename T>
inline T hf_sign(T v) {
  if (v > 0) return T(1);
  if (v < 0) return T(-1);
  return v == 0 ? T(0) : v;
}

template <typename T>
inline T hf_truth(T v) {
  return std::fabs(v) >= static_cast<T>(kHfEps) ? T(1) : T(0);
}

/// Applies an op computed from its arguments (op_is_arith: the kinds Arith, Step and Bool of
/// ir_ops.h) in the precision T: double is the IR's meaning; float is what the f32 evaluators
/// compute (the same formulas with float operations, the float libm functions, hfrt's
/// sin/cos kernel of ir/trig.h, and the tolerances rounded to float), used by the tape VM
/// (jit/tape_vm.h). Unused arguments are ignored. Returns NaN for other ops (callers never pass
/// them). With a constant `op` it inlines to the one formula (the tape VM's lane loops rely on that
/// to vectorise: hence always_inline, as GCC would otherwise call the whole switch per lane).
template <typename T>
[[gnu::always_inline]] inline T apply_op_t(Op op, T a, T b, T c) {
  const T eps = static_cast<T>(kHfEps);
  switch (op) {
    case Op::kAdd:
      return a + b;
    case Op::kSub:
      return a - b;
    case Op::kMul:
      return a * b;
    case Op::kDiv:
      return a / b;
    case Op::kNeg:
      return -a;
    case Op::kAbs:
      return std::fabs(a);
    case Op::kMin:
      return a < b ? a : b;
    case Op::kMax:
      return a > b ? a : b;
    case Op::kSqrt:
      return std::sqrt(a);
    case Op::kExp:
      return std::exp(a);
    case Op::kLog:
      return std::log(a);
    case Op::kLog10:
      return std::log10(a);
    case Op::kSin:
    case Op::kCos:
      // f32: hfrt's kernel (ir/trig.h), which the f32 JIT computes in vector code.
      if constexpr (std::is_same_v<T, float>) {
        return sin_cos_f32(a, op == Op::kCos);
      } else {
        return op == Op::kCos ? std::cos(a) : std::sin(a);
      }
    case Op::kTan:
      return std::tan(a);
    case Op::kAsin:
      return std::asin(a);
    case Op::kAcos:
      return std::acos(a);
    case Op::kAtan:
      return std::atan(a);
    case Op::kAtan2:
      return std::atan2(a, b);
    case Op::kSinh:
      return std::sinh(a);
    case Op::kCosh:
      return std::cosh(a);
    case Op::kTanh:
      return std::tanh(a);
    case Op::kFloor:
      return std::floor(a);
    case Op::kCeil:
      return std::ceil(a);
    case Op::kTrunc:
      return std::trunc(a);
    case Op::kRound:
      return std::round(a);
    case Op::kFmod:
      return std::fmod(a, b);
    case Op::kPow:
      return std::pow(a, b);
    case Op::kPowHF:
      return hf_pow_t<T>(a, b);
    case Op::kSign:
      return hf_sign<T>(a);
    case Op::kLt:
      return a < b ? T(1) : T(0);
    case Op::kLe:
      return a <= b ? T(1) : T(0);
    case Op::kGt:
      return a > b ? T(1) : T(0);
    case Op::kGe:
      return a >= b ? T(1) : T(0);
    case Op::kEqTol:
      return std::fabs(a - b) < eps ? T(1) : T(0);
    case Op::kNeTol:
      return std::fabs(a - b) >= eps ? T(1) : T(0);
    case Op::kEq:
      return a == b ? T(1) : T(0);
    case Op::kNe:
      return a != b ? T(1) : T(0);
    case Op::kTruth:
      return hf_truth<T>(a);
    case Op::kAnd:
      return (hf_truth<T>(a) != 0 && hf_truth<T>(b) != 0) ? T(1) : T(0);
    case Op::kOr:
      return (hf_truth<T>(a) != 0 || hf_truth<T>(b) != 0) ? T(1) : T(0);
    case Op::kNot:
      return hf_truth<T>(a) != 0 ? T(0) : T(1);
    case Op::kSelect:
      return a != 0 ? b : c;
    case Op::kCbrt:
      return std::cbrt(a);
      // Not computed from arguments (kSurface needs Function::surfaces: jit/surface_ops.h).
      HFRT_OP_CASES_NON_ARITH
      break;
  }
  return static_cast<T>(std::nan(""));
}

/// apply_op_t in double: the IR's meaning of every op computed from its arguments.
inline double apply_op(Op op, double a, double b, double c) {
  return apply_op_t<double>(op, a, b, c);
}

}  // namespace hfrt::ir
