// The interval domain's semantics: apply_interval, the sound extension of every pure op, and
// r_function_interval. Used by the interval interpreter and, per lane, by the interval JIT's
// helpers (jit/llvm_interval.cpp), so both compute the same enclosures. See interval_ops.h.
//
// Rounding: results of inexact ops are computed in round-to-nearest at the endpoints that
// bound them (monotone pieces, corners, critical points) and then widened outward by one or
// two ulps (IEEE basic ops, which are correctly rounded and monotone) or more (libm functions,
// whose error is below one ulp but whose monotonicity is not promised). Exact ops (neg, abs,
// min/max, floor/ceil/trunc/round, comparisons) are not widened.

#include "ir/interval_ops.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/check.h"
#include "ir/scalar_ops.h"
#include "ir/trig.h"

namespace hfrt::ir {
namespace {

using namespace interval_detail;
// Declared here too, so that the ulps overloads below add to them rather than hide them.
using interval_detail::down;
using interval_detail::up;

constexpr double kPi = 3.141592653589793;  // the double nearest pi (below pi)

double down(double v, int ulps) {
  for (int i = 0; i < ulps; ++i) v = down(v);
  return v;
}
double up(double v, int ulps) {
  for (int i = 0; i < ulps; ++i) v = up(v);
  return v;
}

Interval widen(Interval r, int ulps) {
  r.lo = down(r.lo, ulps);
  r.hi = up(r.hi, ulps);
  return r;
}

/// Widens by a relative amount `rel` (for results whose error grows with an exponent), plus
/// one ulp; values near the underflow / overflow thresholds (where relative error bounds do
/// not hold) are pushed to 0 / inf.
Interval widen_rel(Interval r, double rel) {
  auto lower = [&](double v) {
    if (!std::isfinite(v)) return down(v);
    if (std::fabs(v) < 1e-290) return v > 0 ? 0.0 : down(std::min(v, -1e-290));
    if (std::fabs(v) > 1e290) return v > 0 ? down(1e290) : -kInf;
    return down(v - std::fabs(v) * rel);
  };
  auto upper = [&](double v) {
    if (!std::isfinite(v)) return up(v);
    if (std::fabs(v) < 1e-290) return v < 0 ? 0.0 : up(std::max(v, 1e-290));
    if (std::fabs(v) > 1e290) return v < 0 ? up(-1e290) : kInf;
    return up(v + std::fabs(v) * rel);
  };
  r.lo = lower(r.lo);
  r.hi = upper(r.hi);
  return r;
}

/// Tri-state truth: can the scalar value be nonzero (true) / zero (false) somewhere?
Interval from_tri(Tri t) {
  return {t.can_false ? 0.0 : 1.0, t.can_true ? 1.0 : 0.0, false};
}

/// |a| >= 1e-6 (HyperFun truth).
Tri truth(const Interval& a) {
  double mag_hi = std::max(std::fabs(a.lo), std::fabs(a.hi));
  double mag_lo = contains_zero(a) ? 0.0 : std::min(std::fabs(a.lo), std::fabs(a.hi));
  return {mag_hi >= kHfEps, mag_lo < kHfEps || a.maybe_nan};
}

Interval div(Interval a, Interval b) {
  bool nan = a.maybe_nan || b.maybe_nan;
  if (contains_zero(b)) {
    // x / ±0 is ±inf (either sign, as zero carries no known sign), 0 / 0 is NaN.
    nan = nan || contains_zero(a) || std::isinf(b.lo) || std::isinf(b.hi);
    return {-kInf, kInf, nan};
  }
  nan = nan || ((std::isinf(a.lo) || std::isinf(a.hi)) && (std::isinf(b.lo) || std::isinf(b.hi)));
  auto q = [](double u, double v) {
    double r = u / v;
    return r != r ? 0.0 : r;
  };
  double c0 = q(a.lo, b.lo), c1 = q(a.lo, b.hi), c2 = q(a.hi, b.lo), c3 = q(a.hi, b.hi);
  double lo = std::min(std::min(c0, c1), std::min(c2, c3));
  double hi = std::max(std::max(c0, c1), std::max(c2, c3));
  return make(down(lo), up(hi), nan);
}

/// A monotone non-decreasing libm function f on its domain [dlo, dhi]; arguments outside the
/// domain give NaN. `ulps` of outward widening; the range is clipped to [rlo, rhi].
template <typename F>
Interval monotone(Interval a, F f, double dlo, double dhi, int ulps, double rlo = -kInf,
                  double rhi = kInf) {
  bool nan = a.maybe_nan || a.lo < dlo || a.hi > dhi;
  double lo = std::clamp(a.lo, dlo, dhi), hi = std::clamp(a.hi, dlo, dhi);
  Interval r = make(down(f(lo), ulps), up(f(hi), ulps), nan);
  r.lo = std::clamp(r.lo, rlo, rhi);
  r.hi = std::clamp(r.hi, rlo, rhi);
  return r;
}

/// sin (or cos) over [lo, hi]: hfrt's kernel (ir/trig.h) at the ends, widened by two steps of
/// |v| 2^-52 (at least 2 ulps: the kernel's 1 ulp and libm's, the f64 points' sin), and
/// +1 / -1 where a maximum / minimum may lie inside. The interval JIT emits the same
/// operations as vector code (llvm_interval.cpp, sin_cos), so both give the same bits; the
/// libm-free kernel is what lets it (the per-lane libm calls were half of a gyroid render).
/// Beyond the kernel's range, or over 64 or more, [-1, 1].
Interval sin_cos(Interval a, bool is_cos) {
  const bool nan = a.maybe_nan || std::isinf(a.lo) || std::isinf(a.hi);
  if (!(a.hi - a.lo < 64.0) || std::fabs(a.lo) > kTrigKernelLimit ||
      std::fabs(a.hi) > kTrigKernelLimit) {
    return {-1, 1, nan};
  }
  // Extrema of sin at pi/2 + k pi (max for even k); of cos at k pi (max for even k). An
  // extremum within a small tolerance of the interval counts as inside (conservative).
  const double offset = is_cos ? 0.0 : kPi / 2;
  const double tol = 1e-9 * std::max(1.0, std::max(std::fabs(a.lo), std::fabs(a.hi)));
  const double k0 = std::ceil((a.lo - offset - tol) / kPi);
  const double k1 = std::floor((a.hi - offset + tol) / kPi);
  const double f_lo = trig_kernel(a.lo, is_cos), f_hi = trig_kernel(a.hi, is_cos);
  double lo = std::min(f_lo, f_hi), hi = std::max(f_lo, f_hi);
  lo = down(lo, 2);
  hi = up(hi, 2);
  // Some k in [k0, k1]: an even one (a maximum) unless the only one is odd, and vice versa.
  const bool some = k0 <= k1, several = k0 < k1;
  const bool k0_even = k0 - 2.0 * std::floor(k0 * 0.5) == 0.0;
  if (some && (several || k0_even)) hi = 1;
  if (some && (several || !k0_even)) lo = -1;
  return {std::max(lo, -1.0), std::min(hi, 1.0), nan};
}

Interval tan_i(Interval a) {
  bool nan = a.maybe_nan || std::isinf(a.lo) || std::isinf(a.hi);
  if (!(a.hi - a.lo < 3.0) || std::fabs(a.lo) > 1e12 || std::fabs(a.hi) > 1e12) {
    return {-kInf, kInf, nan};
  }
  double tol = 1e-9 * std::max(1.0, std::max(std::fabs(a.lo), std::fabs(a.hi)));
  double k0 = std::ceil((a.lo - kPi / 2 - tol) / kPi);
  double k1 = std::floor((a.hi - kPi / 2 + tol) / kPi);
  if (k0 <= k1) return {-kInf, kInf, nan};  // a pole (pi/2 + k pi) may be inside
  return {down(std::tan(a.lo), 2), up(std::tan(a.hi), 2), nan};
}

Interval abs_i(Interval a) {
  if (a.lo >= 0) return a;
  if (a.hi <= 0) return neg(a);
  return {0, std::max(-a.lo, a.hi), a.maybe_nan};
}

Interval cosh_i(Interval a) {
  Interval m = abs_i(a);
  return {std::max(1.0, down(std::cosh(m.lo), 2)), up(std::cosh(m.hi), 2), a.maybe_nan};
}

/// Evaluates f at the corners of the sub-boxes of a x b split at a = sa and b = sb (f is
/// monotone in each argument inside each sub-box): the hull of the corner values.
template <typename F>
Interval corners(Interval a, Interval b, double sa, double sb, F f, bool* any_nan) {
  double as[3] = {a.lo, a.hi, sa}, bs[3] = {b.lo, b.hi, sb};
  int na = (a.lo < sa && sa < a.hi) ? 3 : 2, nb = (b.lo < sb && sb < b.hi) ? 3 : 2;
  double lo = kInf, hi = -kInf;
  for (int i = 0; i < na; ++i) {
    for (int j = 0; j < nb; ++j) {
      double v = f(as[i], bs[j]);
      if (v != v) {
        *any_nan = true;
        continue;
      }
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (lo > hi) return {0, 0, true};
  return {lo, hi, false};
}

Interval atan2_i(Interval y, Interval x) {
  bool nan = y.maybe_nan || x.maybe_nan;
  // The branch cut (x <= 0, y = 0) gives +-pi on its two sides.
  if (contains_zero(y) && x.lo <= 0) return {down(-kPi), up(kPi), nan};
  bool dummy = false;
  Interval r = corners(
      y, x, 0.0, 0.0, [](double u, double v) { return std::atan2(u, v); }, &dummy);
  r = widen(r, 2);
  r.lo = std::max(r.lo, down(-kPi));
  r.hi = std::min(r.hi, up(kPi));
  r.maybe_nan = nan || dummy;
  return r;
}

Interval fmod_i(Interval a, Interval b) {
  bool nan = a.maybe_nan || b.maybe_nan || contains_zero(b) || std::isinf(a.lo) || std::isinf(a.hi);
  // Tight case: a fixed divisor and a dividend within one period on one side of zero.
  if (b.lo == b.hi && b.lo != 0 && std::isfinite(b.lo) && std::isfinite(a.lo) &&
      std::isfinite(a.hi) && (a.lo >= 0 || a.hi <= 0)) {
    double m = std::fabs(b.lo);
    double big = std::max(std::fabs(a.lo), std::fabs(a.hi));
    double r_lo = std::fmod(a.lo, b.lo), r_hi = std::fmod(a.hi, b.lo);
    if (big < 1e15 * m && r_lo <= r_hi && (r_hi - r_lo) >= (a.hi - a.lo) - 0.5 * m) {
      return {r_lo, r_hi, nan};  // fmod is exact
    }
  }
  double bmax = std::max(std::fabs(b.lo), std::fabs(b.hi));
  double lo = a.lo < 0 ? -std::min(-a.lo, bmax) : 0.0;
  double hi = a.hi > 0 ? std::min(a.hi, bmax) : 0.0;
  return {lo, hi, nan};
}

/// Magnitude |b|^t for b in [blo, bhi] (blo >= 0) and t in [tlo, thi], with C pow (monotone in
/// each argument on the quadrants split at b = 1, t = 0), widened by `rel`.
Interval pow_magnitude(double blo, double bhi, double tlo, double thi, double rel) {
  bool dummy = false;
  blo += 0.0;  // -0 -> +0: pow(-0, odd negative) would be -inf
  bhi += 0.0;
  Interval r = corners(
      Interval{blo, bhi, false}, Interval{tlo, thi, false}, 1.0, 0.0,
      [](double u, double v) { return std::pow(u, v); }, &dummy);
  r = widen_rel(r, rel);
  r.lo = std::max(r.lo, 0.0);
  return r;
}

/// Relative error allowance of an integral power computed by a loop of n multiplications (or
/// std::pow above kHfPowMaxLoop), compared with C pow.
double pow_rel(double max_abs_exp) {
  double n = std::min(max_abs_exp, kHfPowMaxLoop);
  return (n + 8) * std::numeric_limits<double>::epsilon();
}

Interval pow_c(Interval b, Interval e) {
  bool nan = e.maybe_nan || b.maybe_nan;
  Interval r{kInf, -kInf, false};
  auto join = [&](Interval v) { r = (r.lo > r.hi) ? v : hull(r, v); };
  // pow(x, 0) = 1 and pow(1, y) = 1 even for NaN x / y.
  if ((b.maybe_nan && contains_zero(e)) || (e.maybe_nan && b.lo <= 1 && 1 <= b.hi)) join({1, 1});
  double rel = 8 * std::numeric_limits<double>::epsilon();
  if (b.hi >= 0) join(pow_magnitude(std::max(b.lo, 0.0), b.hi, e.lo, e.hi, rel));
  if (b.lo <= 0) {
    // Negative bases (and -0): +-|b|^e for integral e, NaN for the others.
    Interval m = pow_magnitude(std::max(-b.hi, 0.0), -b.lo, e.lo, e.hi, rel);
    bool single_int = e.lo == e.hi && std::isfinite(e.lo) && std::trunc(e.lo) == e.lo;
    if (single_int) {
      bool odd = std::fmod(e.lo, 2.0) != 0;
      join(odd ? neg(m) : m);
    } else {
      join({-m.hi, m.hi, false});
      if (b.lo < 0) nan = true;
    }
  }
  if (r.lo > r.hi) return {0, 0, true};
  r.maybe_nan = nan;
  return r;
}

Interval pow_hf(Interval b, Interval e) {
  bool nan = b.maybe_nan || e.maybe_nan;
  Interval r{kInf, -kInf, false};
  auto join = [&](Interval v) { r = (r.lo > r.hi) ? v : hull(r, v); };
  if (b.lo < kHfEps && b.hi > -kHfEps) join({0, 0});                 // |b| < 1e-6 -> 0
  if (b.maybe_nan && e.lo < kHfEps && e.hi > -kHfEps) join({1, 1});  // NaN ^ 0 = 1
  bool has_pos = b.hi >= kHfEps, has_neg = b.lo <= -kHfEps;
  Interval pos{std::max(b.lo, kHfEps), b.hi, false};
  Interval negp{b.lo, std::min(b.hi, -kHfEps), false};
  if (e.lo == e.hi && std::isfinite(e.lo)) {
    double ev = e.lo;
    if (std::fabs(ev - std::trunc(ev)) < kHfEps) {
      // Integral: hf_pow is monotone on each sign of b (a loop of correctly rounded
      // multiplications), so its values at the piece ends bound it exactly.
      double rel = pow_rel(std::fabs(ev));
      if (has_pos) {
        double u = hf_pow(pos.lo, ev), v = hf_pow(pos.hi, ev);
        join(widen_rel({std::min(u, v), std::max(u, v), false}, rel));
      }
      if (has_neg) {
        double u = hf_pow(negp.lo, ev), v = hf_pow(negp.hi, ev);
        join(widen_rel({std::min(u, v), std::max(u, v), false}, rel));
      }
    } else {
      if (has_pos) {
        double u = hf_pow(pos.lo, ev), v = hf_pow(pos.hi, ev);
        Interval m{std::min(u, v), std::max(u, v), false};
        m = widen_rel(m, 16 * std::numeric_limits<double>::epsilon());
        m.lo = std::max(m.lo, 0.0);
        join(m);
      }
      if (has_neg) nan = true;
    }
  } else {
    // A range of exponents: integral ones use round(|e|), within 1e-6 of e.
    double tlo = e.lo - 2 * kHfEps, thi = e.hi + 2 * kHfEps;
    if (std::isinf(e.lo) || std::isinf(e.hi)) nan = true;
    double rel = pow_rel(std::max(std::fabs(tlo), std::fabs(thi))) +
                 16 * std::numeric_limits<double>::epsilon();
    if (has_pos) join(pow_magnitude(pos.lo, pos.hi, tlo, thi, rel));
    if (has_neg) {
      nan = true;  // non-integral exponents of a negative base
      double klo = std::ceil(tlo), khi = std::floor(thi);
      if (klo <= khi) {
        Interval m = pow_magnitude(-negp.hi, -negp.lo, klo, khi, rel);
        join({-m.hi, m.hi, false});
      }
    }
  }
  if (r.lo > r.hi) return {0, 0, true};
  r.maybe_nan = nan;
  return r;
}

Interval sign_i(Interval a) {
  Interval r{hf_sign(a.lo), hf_sign(a.hi), a.maybe_nan};
  return r;
}

Tri lt(Interval a, Interval b) {
  return {a.lo < b.hi, !(a.hi < b.lo) || a.maybe_nan || b.maybe_nan};
}
Tri le(Interval a, Interval b) {
  return {a.lo <= b.hi, a.hi > b.lo || a.maybe_nan || b.maybe_nan};
}

}  // namespace

Tri nonzero(const Interval& c) {
  return {c.maybe_nan || c.lo != 0 || c.hi != 0, contains_zero(c)};
}

Interval apply_interval(Op op, Interval a, Interval b, Interval c, bool same_args,
                        uint8_t* choice) {
  switch (op) {
    case Op::kAdd:
      return add(a, b);
    case Op::kSub:
      return add(a, neg(b));
    case Op::kMul:
      return same_args ? square(a) : mul(a, b);
    case Op::kDiv:
      return div(a, b);
    case Op::kNeg:
      return neg(a);
    case Op::kAbs:
      return abs_i(a);
    case Op::kMin:
      return same_args ? a : min_max(a, b, true, choice);
    case Op::kMax:
      return same_args ? a : min_max(a, b, false, choice);
    case Op::kSqrt: {
      Interval r = monotone(
          a, [](double v) { return std::sqrt(v); }, 0, kInf, 1);
      r.lo = std::max(r.lo, 0.0);
      return r;
    }
    case Op::kExp:
      return monotone(
          a, [](double v) { return std::exp(v); }, -kInf, kInf, 2, 0);
    case Op::kLog:
      return monotone(
          a, [](double v) { return std::log(v); }, 0, kInf, 2);
    case Op::kLog10:
      return monotone(
          a, [](double v) { return std::log10(v); }, 0, kInf, 2);
    case Op::kSin:
      return sin_cos(a, false);
    case Op::kCos:
      return sin_cos(a, true);
    case Op::kTan:
      return tan_i(a);
    case Op::kAsin:
      return monotone(
          a, [](double v) { return std::asin(v); }, -1, 1, 2);
    case Op::kAcos: {  // decreasing on [-1, 1]
      bool nan = a.maybe_nan || a.lo < -1 || a.hi > 1;
      double lo = std::clamp(a.lo, -1.0, 1.0), hi = std::clamp(a.hi, -1.0, 1.0);
      return {std::max(0.0, down(std::acos(hi), 2)), up(std::acos(lo), 2), nan};
    }
    case Op::kAtan:
      return monotone(
          a, [](double v) { return std::atan(v); }, -kInf, kInf, 2);
    case Op::kAtan2:
      return atan2_i(a, b);
    case Op::kSinh:
      return monotone(
          a, [](double v) { return std::sinh(v); }, -kInf, kInf, 2);
    case Op::kCosh:
      return cosh_i(a);
    case Op::kTanh:
      return monotone(
          a, [](double v) { return std::tanh(v); }, -kInf, kInf, 2, -1, 1);
    case Op::kFloor:
      return {std::floor(a.lo), std::floor(a.hi), a.maybe_nan};
    case Op::kCeil:
      return {std::ceil(a.lo), std::ceil(a.hi), a.maybe_nan};
    case Op::kTrunc:
      return {std::trunc(a.lo), std::trunc(a.hi), a.maybe_nan};
    case Op::kRound:
      return {std::round(a.lo), std::round(a.hi), a.maybe_nan};
    case Op::kFmod:
      return fmod_i(a, b);
    case Op::kPow:
      return pow_c(a, b);
    case Op::kPowHF:
      return pow_hf(a, b);
    case Op::kSign:
      return sign_i(a);
    case Op::kLt:
      return from_tri(lt(a, b));
    case Op::kLe:
      return from_tri(le(a, b));
    case Op::kGt:
      return from_tri(lt(b, a));
    case Op::kGe:
      return from_tri(le(b, a));
    case Op::kEqTol:
    case Op::kNeTol: {
      // |a - b| < 1e-6 (NaN: false) / |a - b| >= 1e-6 (NaN: false too).
      Interval d = abs_i(add(a, neg(b)));
      if (op == Op::kEqTol) return from_tri({d.lo < kHfEps, d.hi >= kHfEps || d.maybe_nan});
      return from_tri({d.hi >= kHfEps, d.lo < kHfEps || d.maybe_nan});
    }
    case Op::kEq:
    case Op::kNe: {
      bool overlap = a.lo <= b.hi && b.lo <= a.hi;
      bool all_equal = a.lo == a.hi && b.lo == b.hi && a.lo == b.lo;
      Tri t{overlap, !all_equal || a.maybe_nan || b.maybe_nan};
      if (op == Op::kNe) std::swap(t.can_true, t.can_false);
      return from_tri(t);
    }
    case Op::kTruth:
      return from_tri(truth(a));
    case Op::kAnd: {
      Tri ta = truth(a), tb = truth(b);
      return from_tri({ta.can_true && tb.can_true, ta.can_false || tb.can_false});
    }
    case Op::kOr: {
      Tri ta = truth(a), tb = truth(b);
      return from_tri({ta.can_true || tb.can_true, ta.can_false && tb.can_false});
    }
    case Op::kNot: {
      Tri t = truth(a);
      return from_tri({t.can_false, t.can_true});
    }
    case Op::kSelect: {
      Tri t = nonzero(a);
      if (choice) *choice |= (t.can_true ? kChoiceLeft : 0) | (t.can_false ? kChoiceRight : 0);
      if (!t.can_false) return b;
      if (!t.can_true) return c;
      return hull(b, c);
    }
    case Op::kCbrt:
      // Increasing on the whole line, but glibc's cbrt is not correctly rounded nor monotone
      // (over 2e7 random doubles: errors up to 3.4 ulps, cbrt(27) = 3 + 1 ulp, and a larger
      // neighbour's value up to 4 ulps smaller): 8 ulps outward covers errors up to 4 ulps.
      return monotone(
          a, [](double v) { return std::cbrt(v); }, -kInf, kInf, 8);
      // Not computed from arguments (kSurface: surface_interval in jit/surface_ops.h).
      HFRT_OP_CASES_NON_ARITH
      break;
  }
  HFRT_CHECK_MSG(false, "apply_interval: op without arguments " << op_name(op));
  return {};
}

Interval r_function_interval(const Interval& composed, const Interval& f1, const Interval& f2,
                             bool plus) {
  if (f1.maybe_nan || f2.maybe_nan) return composed;
  const double m1 = std::max(std::fabs(f1.lo), std::fabs(f1.hi));
  const double m2 = std::max(std::fabs(f2.lo), std::fabs(f2.hi));
  const double m = m1 + m2;
  if (!(m < 1e150)) return composed;  // also infinite or NaN ends
  // Rounding: every value of the scalar evaluator at a point of the box, and the formula at
  // the ends as computed here, is within 8 u (|f1| + |f2|) of the exact R-function (u = 2^-53).
  const double slack = 0x1p-48 * m + 1e-150;
  auto r = [plus](double x, double y) {
    const double s = x + y, t = std::sqrt(x * x + y * y);
    return plus ? s + t : s - t;
  };
  const double lo = down(r(f1.lo, f2.lo) - slack), hi = up(r(f1.hi, f2.hi) + slack);
  Interval t{std::max(composed.lo, lo), std::min(composed.hi, hi), composed.maybe_nan};
  if (!(t.lo <= t.hi)) return composed;
  return t;
}

}  // namespace hfrt::ir
