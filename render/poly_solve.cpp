#include "render/poly_solve.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace hfrt::render {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();

/// A leading coefficient at most this fraction of the largest coefficient is dropped: on the
/// range |t| <= 1, where callers scale the ray parameter (the box), its term is below the
/// rounding of the others. Roots of a quartic with all roots up to 1e3 keep a leading term of
/// about 1e-13 of the largest coefficient, so this does not drop legitimate degrees.
constexpr double kNegligible = 1e-15;

/// A point where |p| is within this many units of the rounding bound sum |c_k| |t|^k eps counts
/// as a root to working precision: coefficients computed from a ray carry a few roundings each.
constexpr double kRootTolerance = 64;

/// Up to 4 candidate roots of the polynomial being solved; closed forms push into it.
struct Candidates {
  double t[8];
  int n = 0;
  void push(double x) {
    if (n < 8 && std::isfinite(x)) t[n++] = x;
  }
};

/// p(t) and p'(t) by Horner, and the rounding bound of p(t).
struct PolyValue {
  double p, dp, bound;
};

PolyValue eval_poly(const double* c, int n, double t) {
  double p = c[n], dp = 0, mag = std::abs(c[n]);
  double at = std::abs(t);
  for (int k = n - 1; k >= 0; --k) {
    dp = dp * t + p;
    p = p * t + c[k];
    mag = mag * at + std::abs(c[k]);
  }
  return {p, dp, mag * kEps};
}

/// Newton on p from t, keeping only steps that reduce |p| (so a start on a double root, where
/// p' vanishes, stays put instead of jumping away).
double polish(const double* c, int n, double t) {
  PolyValue v = eval_poly(c, n, t);
  for (int it = 0; it < 16 && v.p != 0; ++it) {
    if (v.dp == 0) break;
    double nt = t - v.p / v.dp;
    if (!std::isfinite(nt)) break;
    PolyValue nv = eval_poly(c, n, nt);
    if (!(std::abs(nv.p) < std::abs(v.p))) break;
    bool small_step = std::abs(nt - t) <= 4 * kEps * std::abs(nt);
    t = nt;
    v = nv;
    if (small_step) break;
  }
  return t;
}

/// Kahan's accurate discriminant b^2 - 4ac: the fma corrections recover the digits the plain
/// subtraction cancels when the roots nearly coincide.
double discriminant(double a, double b, double c) {
  double p = b * b, q = 4 * a * c;
  double d = p - q;
  if (3 * std::abs(d) < p + std::abs(q)) {
    double dp = std::fma(b, b, -p);
    double dq = std::fma(4 * a, c, -q);
    d = (p - q) + (dp - dq);
  }
  return d;
}

/// Roots of a t^2 + b t + c, a != 0. A complex pair contributes its real part (a candidate
/// that the caller keeps only when p vanishes there to rounding: a double root whose
/// discriminant came out slightly negative).
void quadratic_candidates(double a, double b, double c, Candidates* out) {
  double d = discriminant(a, b, c);
  if (d < 0) {
    out->push(-b / (2 * a));
    return;
  }
  double q = -0.5 * (b + std::copysign(std::sqrt(d), b));
  if (q == 0) {  // b == 0 and d == 0: c == 0, double root at 0.
    out->push(0);
    return;
  }
  out->push(q / a);
  out->push(c / q);
}

/// Roots of the monic cubic t^3 + a t^2 + b t + c (Cardano; trigonometric form when the three
/// roots are real). A complex pair contributes its real part, as above.
void cubic_candidates(double a, double b, double c, Candidates* out) {
  double q = (a * a - 3 * b) / 9;
  double r = (2 * a * a * a - 9 * a * b + 27 * c) / 54;
  double shift = a / 3;
  double q3 = q * q * q;
  if (r * r < q3) {
    double sq = std::sqrt(q);
    double theta = std::acos(std::clamp(r / (sq * q), -1.0, 1.0));
    constexpr double kTwoPi = 2 * std::numbers::pi;
    out->push(-2 * sq * std::cos(theta / 3) - shift);
    out->push(-2 * sq * std::cos((theta + kTwoPi) / 3) - shift);
    out->push(-2 * sq * std::cos((theta - kTwoPi) / 3) - shift);
    return;
  }
  double big = -std::copysign(std::cbrt(std::abs(r) + std::sqrt(r * r - q3)), r);
  double small = big == 0 ? 0 : q / big;
  out->push(big + small - shift);
  // The complex pair -(big + small)/2 - shift +- i sqrt(3)/2 (big - small): near-real when
  // big ~ small (a double root).
  out->push(-0.5 * (big + small) - shift);
}

/// The largest real root of the monic cubic t^3 + a t^2 + b t + c, polished.
double largest_cubic_root(double a, double b, double c) {
  Candidates cand;
  cubic_candidates(a, b, c, &cand);
  double coef[4] = {c, b, a, 1};
  double best = -std::numeric_limits<double>::infinity();
  for (int i = 0; i < cand.n; ++i) best = std::max(best, polish(coef, 3, cand.t[i]));
  return best;
}

/// Roots of the monic quartic t^4 + a t^3 + b t^2 + c t + d (Ferrari): depress with
/// t = y - a/4 to y^4 + p y^2 + q y + r, take the largest root m of the resolvent cubic
/// 8m^3 + 8p m^2 + (2p^2 - 8r) m - q^2 = 0 (positive when q != 0) and split into the two
/// quadratics y^2 -+ s y + (p/2 + m +- q/(2s)), s = sqrt(2m).
void quartic_candidates(double a, double b, double c, double d, Candidates* out) {
  double shift = a / 4;
  double a2 = a * a;
  double p = b - 3 * a2 / 8;
  double q = c - a * b / 2 + a2 * a / 8;
  double r = d - a * c / 4 + a2 * b / 16 - 3 * a2 * a2 / 256;
  Candidates y;
  double scale = std::max({std::abs(p), std::sqrt(std::abs(r)), std::cbrt(std::abs(q)), 1e-300});
  if (std::abs(q) <= 16 * kEps * scale * scale * scale) {
    // Biquadratic: z^2 + p z + r with z = y^2.
    Candidates z;
    quadratic_candidates(1, p, r, &z);
    for (int i = 0; i < z.n; ++i) {
      if (z.t[i] >= 0) {
        double s = std::sqrt(z.t[i]);
        y.push(s);
        y.push(-s);
      } else {
        y.push(0);  // z slightly negative: maybe a double root at y = 0.
      }
    }
  } else {
    double m = largest_cubic_root(p, p * p / 4 - r, -q * q / 8);
    if (!(m > 0)) m = std::max(m, 1e-300);
    double s = std::sqrt(2 * m);
    double h = q / (2 * s);
    quadratic_candidates(1, -s, p / 2 + m + h, &y);
    quadratic_candidates(1, s, p / 2 + m - h, &y);
  }
  for (int i = 0; i < y.n; ++i) out->push(y.t[i] - shift);
}

int solve_leading(const double* c, int max_degree, double* roots);

/// Solves the polynomial of exact degree n (1..4) given by c[0..n], with t scaled so that the
/// roots are of order one (scale = a power of two, so the scaling is exact).
int solve_degree(const double* c, int n, double* roots) {
  if (n == 1) {
    double t = -c[0] / c[1];
    if (!std::isfinite(t)) return 0;
    roots[0] = t;
    return 1;
  }
  // Root scale (Fujiwara bound): every root has |t| <= 2 max (|c_k / c_n|)^(1/(n-k)).
  double bound = 0;
  for (int k = 0; k < n; ++k) {
    double v = std::abs(c[k] / c[n]);
    if (v > 0) bound = std::max(bound, std::pow(v, 1.0 / (n - k)));
  }
  if (bound == 0) {  // c[n] t^n: a root of multiplicity n at 0.
    roots[0] = 0;
    return 1;
  }
  int e;
  std::frexp(bound, &e);
  double s = std::ldexp(1.0, e);  // t = s u
  // Monic polynomial in u: u^n + m[n-1] u^(n-1) + ... + m[0], m[k] = c[k] s^k / (c[n] s^n).
  double m[4];
  for (int k = 0; k < n; ++k) m[k] = c[k] / c[n] * std::ldexp(1.0, (k - n) * e);
  Candidates cand;
  if (n == 2) quadratic_candidates(1, m[1], m[0], &cand);
  if (n == 3) cubic_candidates(m[2], m[1], m[0], &cand);
  if (n == 4) quartic_candidates(m[3], m[2], m[1], m[0], &cand);

  // Polish on the original polynomial, keep points where it vanishes to rounding.
  double found[8];
  int count = 0;
  for (int i = 0; i < cand.n; ++i) {
    double t = polish(c, n, cand.t[i] * s);
    PolyValue v = eval_poly(c, n, t);
    if (count < 8 && std::isfinite(t) && std::abs(v.p) <= kRootTolerance * v.bound)
      found[count++] = t;
  }
  // The closed forms lose the small roots when a large one dominates the coefficients (two
  // roots near 1e-3 next to one near 1e3 come out as a complex pair). Dividing the largest
  // root out (backward deflation, stable for a large root) and solving the rest again recovers
  // them; polishing on the original polynomial removes the deflation's rounding.
  if (n >= 3 && count > 0) {
    double big = found[0];
    for (int i = 1; i < count; ++i)
      if (std::abs(found[i]) > std::abs(big)) big = found[i];
    double rest = std::pow(std::abs(c[0] / (c[n] * big)), 1.0 / (n - 1));
    if (big != 0 && std::abs(big) > 32 * rest) {
      double q[4];
      q[0] = -c[0] / big;
      for (int k = 1; k < n; ++k) q[k] = (q[k - 1] - c[k]) / big;
      double sub[4];
      int m = solve_leading(q, n - 1, sub);
      for (int i = 0; i < m; ++i) {
        double t = polish(c, n, sub[i]);
        PolyValue v = eval_poly(c, n, t);
        if (count < 8 && std::isfinite(t) && std::abs(v.p) <= kRootTolerance * v.bound)
          found[count++] = t;
      }
    }
  }

  // Insertion sort (at most 8 values).
  for (int i = 1; i < count; ++i)
    for (int j = i; j > 0 && found[j] < found[j - 1]; --j) std::swap(found[j], found[j - 1]);
  // Merge approximations of one multiple root: neighbours between which p does not rise above
  // rounding are the same root to working precision (keep the one with the smaller |p|).
  int out = 0;
  for (int i = 0; i < count; ++i) {
    if (out > 0) {
      double prev = roots[out - 1];
      PolyValue mid = eval_poly(c, n, 0.5 * (prev + found[i]));
      if (found[i] == prev || std::abs(mid.p) <= kRootTolerance * mid.bound) {
        if (std::abs(eval_poly(c, n, found[i]).p) < std::abs(eval_poly(c, n, prev).p))
          roots[out - 1] = found[i];
        continue;
      }
    }
    if (out == 4) break;
    roots[out++] = found[i];
  }
  return out;
}

int solve_leading(const double* c, int max_degree, double* roots) {
  double mag = 0;
  for (int k = 0; k <= max_degree; ++k) {
    if (!std::isfinite(c[k])) return 0;
    mag = std::max(mag, std::abs(c[k]));
  }
  if (mag == 0) return 0;
  int n = max_degree;
  while (n > 0 && std::abs(c[n]) <= kNegligible * mag) --n;
  if (n == 0) return 0;
  return solve_degree(c, n, roots);
}

}  // namespace

int solve_polynomial(const double c[5], double roots[4]) {
  return solve_leading(c, 4, roots);
}

int solve_quadratic(double c0, double c1, double c2, double roots[2]) {
  double c[3] = {c0, c1, c2};
  double r[4];
  int n = solve_leading(c, 2, r);
  std::copy(r, r + n, roots);
  return n;
}

int solve_cubic(double c0, double c1, double c2, double c3, double roots[3]) {
  double c[4] = {c0, c1, c2, c3};
  double r[4];
  int n = solve_leading(c, 3, r);
  std::copy(r, r + n, roots);
  return n;
}

int solve_quartic(double c0, double c1, double c2, double c3, double c4, double roots[4]) {
  double c[5] = {c0, c1, c2, c3, c4};
  return solve_leading(c, 4, roots);
}

}  // namespace hfrt::render
