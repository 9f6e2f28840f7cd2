// The gradient domain's semantics: apply_dual, the dual-number extension of every pure op
// (dual_ops.h). Values come from apply_op (scalar_ops.h), so they are the scalar
// interpreter's values bit for bit.

#include "ir/dual_ops.h"

#include <cmath>
#include <limits>

#include "base/check.h"
#include "ir/scalar_ops.h"

namespace hfrt::ir {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The chain rule for a unary function with derivative k at the argument: components whose
/// input derivative is exactly 0 stay 0 (no 0 * inf NaN from a constant sub-expression).
Dual chain(double v, const Dual& a, double k) {
  Dual r{v, {0, 0, 0}};
  for (int i = 0; i < 3; ++i) r.d[i] = a.d[i] == 0 ? 0.0 : k * a.d[i];
  return r;
}

/// v with derivative ka * a' + kb * b' (zero components skipped as in chain).
Dual chain2(double v, const Dual& a, double ka, const Dual& b, double kb) {
  Dual r{v, {0, 0, 0}};
  for (int i = 0; i < 3; ++i) {
    double t = a.d[i] == 0 ? 0.0 : ka * a.d[i];
    double u = b.d[i] == 0 ? 0.0 : kb * b.d[i];
    r.d[i] = t + u;
  }
  return r;
}

Dual flat(double v) {
  return Dual::constant(v);
}

}  // namespace

Dual apply_dual(Op op, const Dual& a, const Dual& b, const Dual& c) {
  const double v = apply_op(op, a.v, b.v, c.v);
  switch (op) {
    case Op::kAdd:
      return chain2(v, a, 1, b, 1);
    case Op::kSub:
      return chain2(v, a, 1, b, -1);
    case Op::kMul:
      return chain2(v, a, b.v, b, a.v);
    case Op::kDiv:
      return chain2(v, a, 1 / b.v, b, -v / b.v);
    case Op::kNeg:
      return chain(v, a, -1);
    case Op::kAbs:
      return chain(v, a, a.v < 0 ? -1 : 1);
    case Op::kMin: {
      Dual r = a.v < b.v ? a : b;
      r.v = v;
      return r;
    }
    case Op::kMax: {
      Dual r = a.v > b.v ? a : b;
      r.v = v;
      return r;
    }
    case Op::kSqrt:
      return chain(v, a, 0.5 / v);
    case Op::kExp:
      return chain(v, a, v);
    case Op::kLog:
      return chain(v, a, 1 / a.v);
    case Op::kLog10:
      return chain(v, a, 1 / (a.v * std::log(10.0)));
    case Op::kSin:
      return chain(v, a, std::cos(a.v));
    case Op::kCos:
      return chain(v, a, -std::sin(a.v));
    case Op::kTan:
      return chain(v, a, 1 + v * v);
    case Op::kAsin:
      return chain(v, a, 1 / std::sqrt(1 - a.v * a.v));
    case Op::kAcos:
      return chain(v, a, -1 / std::sqrt(1 - a.v * a.v));
    case Op::kAtan:
      return chain(v, a, 1 / (1 + a.v * a.v));
    case Op::kAtan2: {  // d atan2(y, x) = (x dy - y dx) / (x^2 + y^2)
      double r2 = a.v * a.v + b.v * b.v;
      return chain2(v, a, b.v / r2, b, -a.v / r2);
    }
    case Op::kSinh:
      return chain(v, a, std::cosh(a.v));
    case Op::kCosh:
      return chain(v, a, std::sinh(a.v));
    case Op::kTanh:
      return chain(v, a, 1 - v * v);
    case Op::kFmod: {  // fmod(a, b) = a - q b with q = trunc(a / b) integral
      double q = std::round((a.v - v) / b.v);
      return chain2(v, a, 1, b, -q);
    }
    case Op::kPow: {  // d a^b = b a^(b-1) da + a^b log(a) db
      double ka = b.v == 0 ? 0.0 : b.v * std::pow(a.v, b.v - 1);
      double kb = v * std::log(a.v);
      return chain2(v, a, ka, b, kb);
    }
    case Op::kPowHF: {
      if (std::fabs(a.v) < kHfEps) return flat(v);
      if (std::fabs(b.v - std::trunc(b.v)) < kHfEps) {
        // Integral exponent: constant in e nearby; d b^n = n b^(n-1) db.
        double n = std::round(std::fabs(b.v));
        if (b.v < 0) n = -n;
        double ka = n == 0 ? 0.0 : n * hf_pow(a.v, n - 1);
        return chain(v, a, ka);
      }
      return chain2(v, a, v * b.v / a.v, b, v * std::log(a.v));
    }
      // Floor, ceil, trunc, round, sign, comparisons and logic: zero derivative.
      HFRT_OP_CASES_PIECEWISE_CONSTANT
      return flat(v);
    case Op::kSelect: {
      Dual r = a.v != 0 ? b : c;
      r.v = v;
      return r;
    }
    case Op::kCbrt:  // d cbrt(a) = da / (3 cbrt(a)^2): infinite at 0, as sqrt's
      return chain(v, a, 1 / (3 * (v * v)));
      // Not computed from arguments (kSurface: surface_dual in jit/surface_ops.h).
      HFRT_OP_CASES_NON_ARITH
      break;
  }
  HFRT_CHECK_MSG(false, "apply_dual: op without arguments " << op_name(op));
  return {};
}

}  // namespace hfrt::ir
