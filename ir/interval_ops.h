#pragma once
// The interval domain's meaning of every pure op, written once: apply_interval is the sound
// enclosure of one op over interval arguments (the contract is in jit/interval.h: every value
// the f64 scalar evaluator computes at a point of the box is inside, or NaN with maybe_nan
// set). The interval interpreter calls it per instruction and the interval JIT's per-lane
// helpers call it for the ops they do not emit as vector code, so both domains' engines agree.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "base/interval.h"
#include "ir/ir.h"

namespace hfrt::ir {

/// Values of the min/max/select trace (bit set: 1 = the left operand / then-value can be the
/// result somewhere in the box, 2 = the right one can). 0 = the instruction was not reached
/// (or is not a min/max/select). Loops OR the bits of every iteration.
inline constexpr uint8_t kChoiceNone = 0;
inline constexpr uint8_t kChoiceLeft = 1;
inline constexpr uint8_t kChoiceRight = 2;
inline constexpr uint8_t kChoiceBoth = 3;

/// The enclosures of the most frequent ops, inline so that an interval VM with a constant op
/// compiles them in place (jit/tape_vm.cpp); apply_interval uses the very same functions.
namespace interval_detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();
// Outward widening by at least one ulp: v +- max(|v| 2^-52, denorm_min) in round-to-nearest
// moves a finite v by one or two ulps (never zero); an infinite bound moves to the largest
// finite double, as nextafter does. The same
// formula is what the interval JIT emits (four FP ops, no integer tricks that would slow
// LLVM's instruction selection), so both evaluators give the same bits.
inline constexpr double kUlpScale = 0x1p-52;
inline constexpr double kDenormMin = std::numeric_limits<double>::denorm_min();
inline constexpr double kMax = std::numeric_limits<double>::max();
inline double up(double v) {
  if (v == -kInf) return -kMax;  // as nextafter: an overflowed bound moves to the largest finite
  double step = std::fabs(v) * kUlpScale;
  return v + (step > kDenormMin ? step : kDenormMin);
}
inline double down(double v) {
  if (v == kInf) return kMax;
  double step = std::fabs(v) * kUlpScale;
  return v - (step > kDenormMin ? step : kDenormMin);
}
/// NaN endpoints (from inf - inf and the like) become the widest bound on their side.
inline Interval make(double lo, double hi, bool nan) {
  if (lo != lo) lo = -kInf;
  if (hi != hi) hi = kInf;
  return {lo, hi, nan};
}

inline bool contains_zero(const Interval& a) {
  return a.lo <= 0 && a.hi >= 0;
}

inline Interval add(Interval a, Interval b) {
  bool nan = a.maybe_nan || b.maybe_nan || (a.lo == -kInf && b.hi == kInf) ||
             (a.hi == kInf && b.lo == -kInf);
  return make(down(a.lo + b.lo), up(a.hi + b.hi), nan);
}

inline Interval neg(Interval a) {
  return {-a.hi, -a.lo, a.maybe_nan};
}

inline Interval mul(Interval a, Interval b) {
  bool nan = a.maybe_nan || b.maybe_nan ||
             (contains_zero(a) && (std::isinf(b.lo) || std::isinf(b.hi))) ||
             (contains_zero(b) && (std::isinf(a.lo) || std::isinf(a.hi)));
  // 0 * inf corners are NaN; the products near them are bounded by the other corners and 0.
  auto p = [](double u, double v) {
    double r = u * v;
    return r != r ? 0.0 : r;
  };
  double c0 = p(a.lo, b.lo), c1 = p(a.lo, b.hi), c2 = p(a.hi, b.lo), c3 = p(a.hi, b.hi);
  double lo = std::min(std::min(c0, c1), std::min(c2, c3));
  double hi = std::max(std::max(c0, c1), std::max(c2, c3));
  return make(down(lo), up(hi), nan);
}

inline Interval square(Interval a) {
  double m_lo = contains_zero(a) ? 0.0 : std::min(std::fabs(a.lo), std::fabs(a.hi));
  double m_hi = std::max(std::fabs(a.lo), std::fabs(a.hi));
  double lo = m_lo * m_lo;
  return {lo == 0 ? 0.0 : down(lo), up(m_hi * m_hi), a.maybe_nan};
}

inline Interval min_max(Interval a, Interval b, bool is_min, uint8_t* choice) {
  // kMin: a < b ? a : b; kMax: a > b ? a : b. A NaN a gives b; a NaN b gives b (NaN).
  bool left_only, right_only;
  if (is_min) {
    left_only = !a.maybe_nan && !b.maybe_nan && a.hi < b.lo;
    right_only = b.hi <= a.lo;
  } else {
    left_only = !a.maybe_nan && !b.maybe_nan && a.lo > b.hi;
    right_only = b.lo >= a.hi;
  }
  if (choice) *choice |= left_only ? kChoiceLeft : right_only ? kChoiceRight : kChoiceBoth;
  if (left_only) return a;
  if (right_only) return b;
  Interval r;
  if (is_min) {
    r.lo = std::min(a.lo, b.lo);
    r.hi = a.maybe_nan ? b.hi : std::min(a.hi, b.hi);
  } else {
    r.lo = a.maybe_nan ? b.lo : std::max(a.lo, b.lo);
    r.hi = std::max(a.hi, b.hi);
  }
  r.maybe_nan = b.maybe_nan;
  return r;
}

}  // namespace interval_detail

/// What a condition can be over a box: true somewhere, false somewhere, or both.
struct Tri {
  bool can_true;
  bool can_false;
};

/// Over a condition value (0/1 normally): where `c != 0` can hold and where it can fail
/// (NaN != 0 is true). How kIf, kLoopTest and kSelect decide over a box.
Tri nonzero(const Interval& c);

/// The sound interval extension of one pure op with arguments (the ops apply_op of
/// scalar_ops.h accepts). `same_args` says that arguments 0 and 1 are the same SSA value
/// (x*x is then a square, never negative). `choice`, when non-null, receives the trace bits
/// for kMin/kMax/kSelect.
Interval apply_interval(Op op, Interval a, Interval b, Interval c, bool same_args = false,
                        uint8_t* choice = nullptr);

/// The enclosure of an R-function node f1 + f2 +- sqrt(f1^2 + f2^2) (match_r_function) given
/// its op-by-op enclosure `composed` and those of f1 and f2: both R-functions are
/// non-decreasing in each argument (d/df1 = 1 +- f1 / sqrt(f1^2 + f2^2) >= 0), so the value
/// lies between the formula at the lower ends and at the upper ends, widened by a bound on
/// the formula's rounding in double (2^-48 (|f1| + |f2|) at most, plus 1e-150 for
/// underflow). Op by op the enclosure is loose (f1 and f2 occur twice: the dependency
/// problem); the result is its intersection with this one. Unchanged when an operand may be
/// NaN, has an infinite end or is beyond 1e150.
Interval r_function_interval(const Interval& composed, const Interval& f1, const Interval& f2,
                             bool plus);

}  // namespace hfrt::ir
