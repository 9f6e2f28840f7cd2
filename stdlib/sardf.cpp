// SARDF set operations hfDUni / hfDInt / hfDSub (library.md §7, P.-A. Fayolle): the rule
// lists become kSelect chains (first matching rule wins), and the quartic is solved by
// Ferrari's method exactly as the original's calc_roots_of_quartic, in IR ops.
#include <utility>
#include <vector>

#include "base/check.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

/// "The first rule whose condition holds gives the value; none: `otherwise`", as selects.
class Rules {
 public:
  void add(V cond, V value) { rules_.emplace_back(cond, value); }
  V build(V otherwise) const {
    V r = otherwise;
    for (auto it = rules_.rbegin(); it != rules_.rend(); ++it) r = sel(it->first, it->second, r);
    return r;
  }

 private:
  std::vector<std::pair<V, V>> rules_;
};

/// C's cbrt through pow (no cbrt op): agrees with cbrt to about 1 ulp.
V cbrt_v(V v) {
  const double third = 1.0 / 3.0;
  return sel(lt(v, 0.0), -pow(-v, third), pow(v, third));
}

/// The largest real root of the original's resolvent cubic c3 y³ + c2 y² + c1 y + c0
/// (its general path: c3 != 0, c2 != 0, c0 != 0, which holds wherever SARDF needs it).
V resolvent_hi_root(V c3, V c2, V c1, V c0) {
  V k = -c2 / (3.0 * c3);
  V p = (3.0 * c3 * c1 - c2 * c2) / (-3.0 * c3 * c3);
  V q = (2.0 * c2 * c2 * c2 - 9.0 * c3 * c2 * c1 + 27.0 * c3 * c3 * c0) / (-27.0 * c3 * c3 * c3);
  V p_d3_e3 = p * p / 27.0 * p;
  V w = q / 4.0 * q - p_d3_e3;
  // w < 0: three real roots (trigonometric form).
  V cos3a = q / (2.0 * sqrt(p_d3_e3));
  V a = acos(cos3a) / 3.0;
  V t = sqrt(p * 1.33333333333333);
  const double rad120 = 2.0 * kPi / 3.0, rad240 = 4.0 * kPi / 3.0;
  V r0 = t * cos(a) + k;
  V r1 = t * cos(a + rad120) + k;
  V r2 = t * cos(a + rad240) + k;
  V hi = sel(gt(r1, r2), sel(gt(r1, r0), r1, r0), sel(gt(r2, r0), r2, r0));
  // w == 0 and w > 0: one real root (Cardano).
  V one_double = 2.0 * cbrt_v(q / 2.0) + k;
  V one = cbrt_v(q / 2.0 + sqrt(w)) + cbrt_v(q / 2.0 - sqrt(w)) + k;
  return sel(lt(w, 0.0), hi, sel(eq(w, 0.0), one_double, one));
}

/// The second entry of the original's root list of m⁴ + a3 m³ + a2 m² + a1 m + a0 (library.md
/// §7: the roots of the first quadratic factor, `+sqrt` first, then those of the second).
/// Where the original would read an unset entry the result is NaN.
V quartic_second_root(V a3, V a2, V a1, V a0) {
  V hi = resolvent_hi_root(cst(a3.b, -8.0), 4.0 * a2, 8.0 * a0 - 2.0 * a1 * a3,
                           a1 * a1 - a0 * (4.0 * a2 - a3 * a3));
  V hi2 = hi * hi;
  V b = sqrt(hi2 - a0);
  V m = (a3 * hi - a1) / (2.0 * b);
  V b1 = a3 / 2.0 + m, c1 = hi + b;
  V b2 = a3 / 2.0 - m, c2 = hi - b;
  V d1 = b1 * b1 - 4.0 * c1;
  V d2 = b2 * b2 - 4.0 * c2;
  V q1_minus = (-b1 - sqrt(d1)) / 2.0;
  V q2_plus = (-b2 + sqrt(d2)) / 2.0;
  V q2_minus = (-b2 - sqrt(d2)) / 2.0;
  V q2_first = sel(gt(d2, 0.0), q2_plus, sel(eq(d2, 0.0), -b2 / 2.0, kNaN));
  V q2_second = sel(gt(d2, 0.0), q2_minus, kNaN);
  V second = sel(gt(d1, 0.0), q1_minus, sel(eq(d1, 0.0), q2_first, q2_second));
  return sel(gt(hi2, a0), second, kNaN);
}

constexpr double kTiny = 1e-7;

V duni(Call& c, V x, V y, V r, V alpha) {
  Rules rules;
  V ax = abs(x), ay = abs(y);
  V x_small = lt(ax, kTiny), y_small = lt(ay, kTiny);
  rules.add(land(x_small, y_small), c.k(0));
  rules.add(land(x_small, gt(y, 0.0)), y);
  rules.add(land(x_small, lt(y, 0.0)), c.k(0));
  rules.add(land(y_small, gt(x, 0.0)), x);
  rules.add(land(y_small, lt(x, 0.0)), c.k(0));
  V both = land(gt(ay, kTiny), gt(ax, kTiny));
  rules.add(land(both, land(gt(y, 0.0), lt(x, 0.0))), y);
  rules.add(land(both, land(gt(x, 0.0), lt(y, 0.0))), x);
  // Quadrant I: unbounded angle blend.
  V q1 = land(both, land(gt(x, 0.0), gt(y, 0.0)));
  V g = 1.0 / tan(alpha);
  V g2 = tan(alpha);
  V gt_ = x / y;
  {
    V t = tan(alpha);
    V aa = t * t + 2.0 * t - 1.0;
    V b = -2.0 * t * (x + y);
    V cc = x * x + y * y;
    V d1 = (-b - sqrt(b * b - 4.0 * aa * cc)) / (2.0 * aa);
    rules.add(land(q1, land(lt(gt_, g), gt(gt_, g2))), d1);
    rules.add(land(q1, ge(gt_, g)), x);
    rules.add(land(q1, le(gt_, g2)), y);
  }
  // Quadrant III: bounded (radius r) blend.
  V q3 = land(both, land(lt(x, 0.0), lt(y, 0.0)));
  V lim2 = (x + 2.0 * r) * (x + 2.0 * r) + (y + 2.0 * r) * (y + 2.0 * r);
  V angle =
      lor(lor(ge(x, -r), ge(y, -r)), land(land(ge(x, -2.0 * r), ge(y, -2.0 * r)), ge(lim2, r * r)));
  V xx = -(x * x) / (4.0 * r);
  V yy = -(y * y) / (4.0 * r);
  V qa = land(q3, angle);
  {
    V sr = sqrt(r);
    V mu = quartic_second_root(-4.0 * sr, -4.0 * r, -4.0 * sr * (x + y), -(x * x + y * y));
    rules.add(land(qa, land(le(x, yy), le(y, xx))), -(mu * mu));
    rules.add(land(qa, gt(y, xx)), y);
    rules.add(land(qa, lt(yy, x)), x);
  }
  V qs = land(q3, lnot(angle));
  {
    V strip = land(le(y, x + r), ge(y, x - r));
    V b = -2.0 * x - 4.0 * r - 2.0 * y;
    V cc = x * x + y * y + r * r + 2.0 * x * r + 2.0 * y * r;
    V ds = b * b - 8.0 * cc;
    rules.add(land(land(qs, strip), ge(ds, 0.0)), (-b - sqrt(ds)) / 4.0);
    V out = land(qs, lnot(strip));
    rules.add(land(out, lt(y, x - r)), x);
    rules.add(land(out, gt(y, x + r)), y);
  }
  return rules.build(c.k(0));
}

V dint(Call& c, V x, V y, V r, V alpha) {
  Rules rules;
  V ax = abs(x), ay = abs(y);
  V x_small = lt(ax, kTiny), y_small = lt(ay, kTiny);
  rules.add(land(x_small, y_small), c.k(0));
  rules.add(land(y_small, gt(x, 0.0)), c.k(0));
  rules.add(land(y_small, lt(x, 0.0)), x);
  rules.add(land(x_small, gt(y, 0.0)), c.k(0));
  rules.add(land(x_small, lt(y, 0.0)), y);
  V both = land(gt(ay, kTiny), gt(ax, kTiny));
  rules.add(land(both, land(lt(x, 0.0), gt(y, 0.0))), x);
  rules.add(land(both, land(lt(y, 0.0), gt(x, 0.0))), y);
  // Quadrant I: bounded (radius r) blend.
  V q1 = land(both, land(gt(x, 0.0), gt(y, 0.0)));
  V lim = (x - 2.0 * r) * (x - 2.0 * r) + (y - 2.0 * r) * (y - 2.0 * r);
  V angle =
      lor(lor(le(x, r), le(y, r)), land(land(le(x, 2.0 * r), le(y, 2.0 * r)), ge(lim, r * r)));
  V xx = x * x / (4.0 * r);
  V yy = y * y / (4.0 * r);
  V qa = land(q1, angle);
  {
    V sr = sqrt(r);
    V mu = quartic_second_root(-4.0 * sr, -4.0 * r, 4.0 * (x + y) * sr, -(x * x + y * y));
    rules.add(land(qa, land(le(xx, y), le(yy, x))), mu * mu);
    rules.add(land(qa, gt(xx, y)), y);
    rules.add(land(qa, gt(yy, x)), x);
  }
  V qs = land(q1, lnot(angle));
  {
    V strip = land(le(y, x + r), ge(y, x - r));
    V b = -2.0 * x + 4.0 * r - 2.0 * y;
    V cc = x * x + y * y + r * r - 2.0 * x * r - 2.0 * y * r;
    V ds = b * b - 8.0 * cc;
    rules.add(land(land(qs, strip), ge(ds, 0.0)), (-b + sqrt(ds)) / 4.0);
    V out = land(qs, lnot(strip));
    rules.add(land(out, lt(y, x - r)), y);
    rules.add(land(out, gt(y, x + r)), x);
  }
  // Quadrant III: unbounded angle blend.
  V q3 = land(both, land(lt(x, 0.0), lt(y, 0.0)));
  {
    V g = 1.0 / tan(alpha);
    V g2 = tan(alpha);
    V gt_ = x / y;
    V t = tan(alpha);
    V aa = 1.0 - t * t - 2.0 * t;
    V b = 2.0 * t * (x + y);
    V cc = -x * x - y * y;
    V ds = b * b - 4.0 * aa * cc;
    rules.add(land(q3, land(lt(gt_, g), gt(gt_, g2))), (-b - sqrt(ds)) / (2.0 * aa));
    rules.add(land(q3, ge(gt_, g)), x);
    rules.add(land(q3, le(gt_, g2)), y);
  }
  return rules.build(c.k(0));
}

}  // namespace

V lower_sardf(Call& c) {
  V f1 = c.real(0), f2 = c.real(1), r = c.real(2), alpha = c.real(3);
  switch (c.fn()) {
    case LibraryFn::kDUni:
      return duni(c, f1, f2, r, alpha);
    case LibraryFn::kDInt:
      return dint(c, f1, f2, r, alpha);
    case LibraryFn::kDSub:
      return dint(c, f1, -f2, r, alpha);
    default:
      HFRT_CHECK_MSG(false, "not a SARDF operation: " << c.name());
  }
}

}  // namespace hfrt::stdlib::detail
