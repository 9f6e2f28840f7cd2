#pragma once
// The one interval type of hfrt: a closed interval [lo, hi] plus a bit saying that NaN is
// possible too. The interval domain (ir/interval_ops.h, the interpreters and the interval JIT)
// computes in double; the renderer keeps float bounds (BasicInterval<float>) of those
// enclosures, rounded outward. The public API has its own self-contained IntervalValue
// (hfrt/model.h), which embedders see instead.

#include <limits>

namespace hfrt {

/// A closed interval [lo, hi] of T (lo <= hi, never NaN endpoints; infinite endpoints allowed)
/// plus a bit saying that NaN is possible too. When every value is NaN the real part is some
/// (arbitrary but valid) interval and maybe_nan is set.
template <typename T>
struct BasicInterval {
  T lo = 0;
  T hi = 0;
  bool maybe_nan = false;

  static BasicInterval point(T v) {
    if (v != v) return {0, 0, true};
    return {v, v, false};
  }
  static BasicInterval of(T lo, T hi, bool maybe_nan = false) { return {lo, hi, maybe_nan}; }
  static BasicInterval entire() {
    return {-std::numeric_limits<T>::infinity(), std::numeric_limits<T>::infinity(), true};
  }
  /// True when v (a value of the scalar evaluator) is allowed by this interval.
  bool contains(T v) const { return v != v ? maybe_nan : (lo <= v && v <= hi); }
  bool is_point() const { return lo == hi && !maybe_nan; }
  bool operator==(const BasicInterval&) const = default;
};

/// The interval domain's value (double bounds).
using Interval = BasicInterval<double>;

/// The smallest interval holding both.
template <typename T>
inline BasicInterval<T> hull(const BasicInterval<T>& a, const BasicInterval<T>& b) {
  return {a.lo < b.lo ? a.lo : b.lo, a.hi > b.hi ? a.hi : b.hi, a.maybe_nan || b.maybe_nan};
}

}  // namespace hfrt
