#pragma once
// Device math: the libm functions that hfrt's IR calls per lane (the Libm and Helper lanes of
// ir/ir_ops.h, single precision), for code that has no libm: the NVPTX kernels
// (jit/llvm_nvptx.cpp). Written once, as templates over an arithmetic backend, and
// instantiated twice: with plain `double` here (the unit tests compare that with glibc over
// many inputs) and with LLVM values in jit/llvm_nvptx.cpp (the code that goes into the PTX,
// which the tests compare bit for bit with the `double` instantiation on the host).
//
// The algorithms work in double precision on the float argument and round once at the end,
// so most results are the correctly rounded float (glibc's f32 functions are within 1-2 ulp
// of it). They are branch-free (selects), as a GPU likes them. Known limits, documented in
// docs/gpu.md: sin, cos and tan reduce their argument with a three-part pi/2 (Cody-Waite),
// exact for |x| < 2^19 pi/2; kPowHF multiplies in double
// where the CPU multiplies floats one by one (a few ulp apart for large exponents).
//
// A backend is a value type R (a double) and a mask type M with
//   R + - * / R, -R, R op double, comparisons R < R ... -> M, M & M, M | M, !M,
//   select(M, R, R), fabs_(R), sqrt_(R), floor_(R), trunc_(R), rint_(R) (half to even),
//   copysign_(R, R), frexp_mantissa_(R) and frexp_exponent_(R) (x = m 2^e, m in [0.5, 1),
//   for positive normal x), pow2_(R) (2^k for integral |k| <= 600, exact), to_f32_(R) (rounded
//   to float and back).
// No LLVM here.

#include <cmath>
#include <cstdint>

#include "ir/scalar_ops.h"

namespace hfrt::jit::devmath {

// --- The double backend -----------------------------------------------------------------
inline double select(bool m, double a, double b) {
  return m ? a : b;
}
inline double fabs_(double x) {
  return std::fabs(x);
}
inline double sqrt_(double x) {
  return std::sqrt(x);
}
inline double floor_(double x) {
  return std::floor(x);
}
inline double trunc_(double x) {
  return std::trunc(x);
}
inline double rint_(double x) {
  return std::nearbyint(x);
}
inline double copysign_(double a, double b) {
  return std::copysign(a, b);
}
inline double frexp_mantissa_(double x) {
  int e;
  return std::frexp(x, &e);
}
inline double frexp_exponent_(double x) {
  int e;
  std::frexp(x, &e);
  return e;
}
inline double pow2_(double k) {
  // k is NaN or huge only where the algorithms select the value away (the LLVM backend's
  // fptosi then makes poison, which a select does not propagate); converting such a k to int
  // would be undefined behaviour here.
  if (!(std::fabs(k) <= 2000.0)) return k;
  return std::ldexp(1.0, static_cast<int>(k));
}
inline double to_f32_(double x) {
  return static_cast<double>(static_cast<float>(x));
}

// --- Constants ---------------------------------------------------------------------------
inline constexpr double kLn2Hi = 6.93147180369123816490e-01;  // fdlibm's ln 2 split
inline constexpr double kLn2Lo = 1.90821492927058770002e-10;
inline constexpr double kLog2e = 1.44269504088896338700e+00;
inline constexpr double kPio2_1 = 1.57079632673412561417e+00;   // first 33 bits of pi/2
inline constexpr double kPio2_2 = 6.07710050630396597660e-11;   // next 33 bits
inline constexpr double kPio2_2t = 2.02226624879595063154e-21;  // pi/2 - kPio2_1 - kPio2_2
inline constexpr double kTwoOverPi = 6.36619772367581382433e-01;
inline constexpr double kPi = 3.14159265358979311600e+00;
inline constexpr double kPio2 = 1.57079632679489655800e+00;
inline constexpr double kInvLn10 = 4.34294481903251816668e-01;
inline constexpr double kSqrtHalf = 7.07106781186547524401e-01;
inline constexpr double kInf = HUGE_VAL;

// --- Helpers -----------------------------------------------------------------------------
template <class R>
auto isnan_(R x) {
  return !(x == x);
}

/// c[0] + c[1] z + ... + c[n-1] z^(n-1), Horner.
template <class R, int N>
R horner(R z, const double (&c)[N]) {
  R p = R(c[N - 1]);
  for (int i = N - 2; i >= 0; --i) p = p * z + c[i];
  return p;
}

// --- exp, log ----------------------------------------------------------------------------
template <class R>
R exp(R x) {
  // e^x = 2^k e^r, r = x - k ln 2 in [-ln2/2, ln2/2]; Taylor to r^12 (error < 1e-16).
  static constexpr double kC[] = {1.0,
                                  1.0,
                                  1.0 / 2,
                                  1.0 / 6,
                                  1.0 / 24,
                                  1.0 / 120,
                                  1.0 / 720,
                                  1.0 / 5040,
                                  1.0 / 40320,
                                  1.0 / 362880,
                                  1.0 / 3628800,
                                  1.0 / 39916800,
                                  1.0 / 479001600};
  R xc = select(x > 720.0, R(720.0), select(x < -760.0, R(-760.0), x));
  R k = rint_(xc * kLog2e);
  R r = (xc - k * kLn2Hi) - k * kLn2Lo;
  R p = horner(r, kC);
  // 2^k in two exact halves, so that neither overflows or underflows on its own.
  R k1 = floor_(k * 0.5);
  R y = p * pow2_(k1) * pow2_(k - k1);
  return select(isnan_(x), x, y);
}

template <class R>
R log(R x) {
  // x = m 2^e with m in [sqrt(1/2), sqrt(2)); log m = 2 atanh(s), s = (m - 1) / (m + 1).
  R m = frexp_mantissa_(x);
  R e = frexp_exponent_(x);
  auto small = m < kSqrtHalf;
  m = select(small, m * 2.0, m);
  e = select(small, e - 1.0, e);
  R s = (m - 1.0) / (m + 1.0);
  R z = s * s;
  static constexpr double kC[] = {2.0,      2.0 / 3,  2.0 / 5,  2.0 / 7,  2.0 / 9,
                                  2.0 / 11, 2.0 / 13, 2.0 / 15, 2.0 / 17, 2.0 / 19};
  R log_m = s * horner(z, kC);
  R y = e * kLn2Hi + (e * kLn2Lo + log_m);
  y = select(x == kInf, x, y);
  y = select(x == 0.0, R(-kInf), y);
  R nan = R(0.0) / R(0.0);
  return select(x < 0.0, nan, select(isnan_(x), x, y));
}

template <class R>
R log10(R x) {
  return log(x) * kInvLn10;
}

// --- sin, cos, tan -----------------------------------------------------------------------
/// x = k pi/2 + r, |r| <= pi/4 (Cody-Waite with three parts of pi/2); q = k mod 4.
template <class R>
void reduce_pio2(R x, R* r, R* q) {
  R k = rint_(x * kTwoOverPi);
  *r = ((x - k * kPio2_1) - k * kPio2_2) - k * kPio2_2t;
  *q = k - floor_(k * 0.25) * 4.0;
}

template <class R>
R sin_kernel(R r) {
  static constexpr double kC[] = {1.0,
                                  -1.0 / 6,
                                  1.0 / 120,
                                  -1.0 / 5040,
                                  1.0 / 362880,
                                  -1.0 / 39916800,
                                  1.0 / 6227020800.0,
                                  -1.0 / 1307674368000.0,
                                  1.0 / 355687428096000.0};
  return r * horner(r * r, kC);
}

template <class R>
R cos_kernel(R r) {
  static constexpr double kC[] = {1.0,
                                  -1.0 / 2,
                                  1.0 / 24,
                                  -1.0 / 720,
                                  1.0 / 40320,
                                  -1.0 / 3628800,
                                  1.0 / 479001600,
                                  -1.0 / 87178291200.0,
                                  1.0 / 20922789888000.0};
  return horner(r * r, kC);
}

template <class R>
R sin(R x) {
  R r = 0.0, q = 0.0;
  reduce_pio2(x, &r, &q);
  R s = sin_kernel(r), c = cos_kernel(r);
  R y = select(q == 0.0, s, select(q == 1.0, c, select(q == 2.0, -s, -c)));
  // sin(-0) = -0; infinities give NaN through the reduction.
  return select(x == 0.0, x, y);
}

template <class R>
R cos(R x) {
  R r = 0.0, q = 0.0;
  reduce_pio2(x, &r, &q);
  R s = sin_kernel(r), c = cos_kernel(r);
  return select(q == 0.0, c, select(q == 1.0, -s, select(q == 2.0, -c, s)));
}

template <class R>
R tan(R x) {
  R r = 0.0, q = 0.0;
  reduce_pio2(x, &r, &q);
  R s = sin_kernel(r), c = cos_kernel(r);
  R odd = q - floor_(q * 0.5) * 2.0;
  R y = select(odd == 0.0, s / c, -c / s);
  return select(x == 0.0, x, y);
}

// --- atan, atan2, asin, acos ---------------------------------------------------------------
template <class R>
R atan(R x) {
  R a = fabs_(x);
  auto inv = a > 1.0;
  R t = select(inv, R(1.0) / a, a);
  // Two halvings atan(t) = 2 atan(t / (1 + sqrt(1 + t^2))): t <= tan(pi/16) ~ 0.199.
  t = t / (sqrt_(t * t + 1.0) + 1.0);
  t = t / (sqrt_(t * t + 1.0) + 1.0);
  static constexpr double kC[] = {1.0,      -1.0 / 3,  1.0 / 5,  -1.0 / 7,  1.0 / 9,  -1.0 / 11,
                                  1.0 / 13, -1.0 / 15, 1.0 / 17, -1.0 / 19, 1.0 / 21, -1.0 / 23};
  R y = t * horner(t * t, kC) * 4.0;
  y = select(inv, R(kPio2) - y, y);
  return select(isnan_(x), x, copysign_(y, x));
}

template <class R>
R atan2(R y, R x) {
  R base = atan(y / x);
  // x < 0: the other half plane.
  R sy = copysign_(R(1.0), y);
  R sx = copysign_(R(1.0), x);
  R r = select(x < 0.0, base + copysign_(R(kPi), sy), base);
  // x = +-0: +-pi/2 for y != 0; for y = +-0, +-0 (x = +0) or +-pi (x = -0).
  R at_zero = select(y == 0.0, select(sx < 0.0, copysign_(R(kPi), sy), y), copysign_(R(kPio2), sy));
  r = select(x == 0.0, at_zero, r);
  // Both infinite.
  auto both_inf = (fabs_(x) == kInf) & (fabs_(y) == kInf);
  r = select(both_inf, copysign_(select(sx > 0.0, R(kPio2 * 0.5), R(kPio2 * 1.5)), sy), r);
  return select(isnan_(x), x, select(isnan_(y), y, r));
}

template <class R>
R asin(R x) {
  return atan2(x, sqrt_((R(1.0) - x) * (R(1.0) + x)));
}

template <class R>
R acos(R x) {
  return atan2(sqrt_((R(1.0) - x) * (R(1.0) + x)), x);
}

// --- sinh, cosh, tanh --------------------------------------------------------------------
template <class R>
R sinh_small(R a) {  // |a| <= 0.5: Taylor to a^15 (error < 1e-17)
  static constexpr double kC[] = {
      1.0,          1.0 / 6,        1.0 / 120,          1.0 / 5040,
      1.0 / 362880, 1.0 / 39916800, 1.0 / 6227020800.0, 1.0 / 1307674368000.0};
  return a * horner(a * a, kC);
}

template <class R>
R sinh(R x) {
  R a = fabs_(x);
  R e = exp(a);
  R big = (e - R(1.0) / e) * 0.5;
  return copysign_(select(a <= 0.5, sinh_small(a), big), x);
}

template <class R>
R cosh(R x) {
  R e = exp(fabs_(x));
  return (e + R(1.0) / e) * 0.5;
}

template <class R>
R tanh(R x) {
  R a = fabs_(x);
  R e = exp(a);
  R s = select(a <= 0.5, sinh_small(a), (e - R(1.0) / e) * 0.5);
  R t = s / sqrt_(s * s + 1.0);
  t = select(a > 20.0, R(1.0), t);
  return select(isnan_(x), x, copysign_(t, x));
}

// --- pow, cbrt, fmod, kPowHF -----------------------------------------------------------------
template <class R>
R pow(R x, R y) {
  R ax = fabs_(x);
  auto integral = floor_(y) == y;
  auto odd = integral & (fabs_(y) < 9007199254740992.0) & (floor_(y * 0.5) != y * 0.5);
  R r = exp(y * log(ax));
  R nan = R(0.0) / R(0.0);
  r = select(x < 0.0, select(integral, select(odd, -r, r), nan), r);
  // x = +-0: +-0 / +-inf for odd integral y, else +0 / +inf.
  R zero_pow = select(y > 0.0, select(odd, x, R(0.0)), select(odd, copysign_(R(kInf), x), R(kInf)));
  r = select(x == 0.0, zero_pow, r);
  // x = -inf: like +inf, negative for odd integral y.
  R minf_pow = select(y > 0.0, select(odd, R(-kInf), R(kInf)), select(odd, R(-0.0), R(0.0)));
  r = select(x == -kInf, minf_pow, r);
  // pow(-1, +-inf) = 1; pow(x, NaN) and pow(NaN, y) are NaN except as below.
  r = select((x == -1.0) & (fabs_(y) == kInf), R(1.0), r);
  r = select(isnan_(x) | isnan_(y), x + y, r);
  return select((y == 0.0) | (x == 1.0), R(1.0), r);
}

template <class R>
R cbrt(R x) {
  R a = fabs_(x);
  R y = exp(log(a) * (1.0 / 3.0));
  y = y - (y * y * y - a) / (y * y * 3.0);  // one Newton step
  y = copysign_(y, x);
  // 0, infinities and NaN are their own cube roots.
  return select((a == 0.0) | (a == kInf) | isnan_(x), x, y);
}

template <class R>
R fmod(R a, R b) {
  // Exact: each step takes r modulo b 2^e, the multiple of b whose quotient has at most 25
  // bits, so that q (b 2^e) and r - q (b 2^e) are exact in double; 12 steps cover the 277
  // binary orders between the largest and the smallest float.
  R ab = fabs_(b);
  R r = fabs_(a);
  for (int i = 0; i < 12; ++i) {
    R e = frexp_exponent_(r) - frexp_exponent_(ab) - 24.0;
    e = select(e > 0.0, e, R(0.0));
    R bb = ab * pow2_(e);
    r = r - trunc_(r / bb) * bb;
  }
  r = copysign_(r, a);
  R nan = R(0.0) / R(0.0);
  r = select((b == 0.0) | (fabs_(a) == kInf), nan, r);
  r = select((fabs_(b) == kInf) & (fabs_(a) != kInf), a, r);
  return select(isnan_(a) | isnan_(b), a + b, r);
}

/// kPowHF in single precision (jit/llvm_jit.cpp hfrt_jit_powhf_f32): b, e are floats.
template <class R>
R powhf_f32(R b, R e) {
  R n = rint_(fabs_(e));
  // |b| < 1e-6 -> 0; integral e (|frac| < 1e-6) -> b^round(|e|), inverted if e < 0;
  // else expf(e * logf(b)) with the float roundings of the C helper.
  R bn = to_f32_(pow(b, n));
  R integral_value = select(e < 0.0, to_f32_(R(1.0) / bn), bn);
  R t = to_f32_(e * to_f32_(log(b)));
  R general = exp(t);
  auto is_integral = fabs_(e - trunc_(e)) < to_f32_(R(1e-6));
  R r = select(is_integral, integral_value, general);
  return select(fabs_(b) < to_f32_(R(1e-6)), R(0.0), r);
}

}  // namespace hfrt::jit::devmath
