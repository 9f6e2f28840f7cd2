#pragma once
// hfrt's own sine and cosine kernel: the f32 meaning of kSin / kCos and the function the
// interval domain encloses. Written once here as plain IEEE double operations (no fma, no
// library call) so that vector code can compute the very same bits: the JIT emits this
// sequence over whole vectors (jit/llvm_emit.cpp, VectorEmitter::trig_kernel) where the
// per-lane libm calls it replaces cost ~15 ns a lane and dominated trigonometric models
// (the gyroid: 50 % of a render in sinf/cosf and the interval helper's sin/cos).
//
// Method (fdlibm's, without its branches): k = the integer nearest x * 2/pi (the 1.5 * 2^52
// shift rounds to nearest even), r = x - k pi/2 as a double-double y0 + y1 by Cody-Waite with
// pi/2 split into two 33-bit parts (k * part is exact for |k| < 2^20) and a tail (fdlibm's
// second reduction round, done always instead of on cancellation), then fdlibm's
// __kernel_sin / __kernel_cos on y0 + y1 (|y0| <= pi/4) and the quadrant k mod 4.
//
// Accuracy for |x| <= kTrigKernelLimit: within 1 ulp (tests/jit/trig_test.cpp measures it
// against long double: 0.78 ulps at most). Beyond the limit the reduction is not exact:
// callers use libm there (f32) or give up ([-1, 1], intervals).
//
// The C++ here must compile without floating-point contraction (the project builds with
// -ffp-contract=off): a fused multiply-add would round differently from the JIT's code.

#include <cmath>

namespace hfrt::ir {

/// |x| above which the kernel's argument reduction is no longer exact (k >= 2^20).
inline constexpr double kTrigKernelLimit = 1048576.0;

namespace trig_detail {
inline constexpr double kTwoOverPi = 0x1.45f306dc9c883p-1;
inline constexpr double kRoundShift = 0x1.8p52;            // 1.5 * 2^52: rounds to an integer
inline constexpr double kPio2Hi = 0x1.921fb54400000p+0;    // first 33 bits of pi/2
inline constexpr double kPio2Mid = 0x1.0b4611a600000p-34;  // next 33 bits
inline constexpr double kPio2Lo = 0x1.3198a2e037073p-69;   // the rest, rounded
// fdlibm __kernel_sin: sin r ~ r + r^3 (S1 + z S2 + ... + z^5 S6), z = r^2.
inline constexpr double kS1 = -1.66666666666666324348e-01;
inline constexpr double kS2 = 8.33333333332248946124e-03;
inline constexpr double kS3 = -1.98412698298579493134e-04;
inline constexpr double kS4 = 2.75573137070700676789e-06;
inline constexpr double kS5 = -2.50507602534068634195e-08;
inline constexpr double kS6 = 1.58969099521155010221e-10;
// fdlibm __kernel_cos: cos r ~ 1 - z/2 + z^2 (C1 + z C2 + ... + z^5 C6).
inline constexpr double kC1 = 4.16666666666666019037e-02;
inline constexpr double kC2 = -1.38888888888741095749e-03;
inline constexpr double kC3 = 2.48015872894767294178e-05;
inline constexpr double kC4 = -2.75573143513906633035e-07;
inline constexpr double kC5 = 2.08757232129817482790e-09;
inline constexpr double kC6 = -1.13596475577881948265e-11;
}  // namespace trig_detail

/// sin x (`cos` false) or cos x, for |x| <= kTrigKernelLimit (any value otherwise; NaN for
/// NaN). The JIT's vector code performs exactly these operations in this order.
inline double trig_kernel(double x, bool cos) {
  using namespace trig_detail;
  const double k = (x * kTwoOverPi + kRoundShift) - kRoundShift;
  // r = x - k pi/2 as the double-double y0 + y1 (fdlibm's second reduction round, always).
  double r = x - k * kPio2Hi;  // exact (both terms are multiples of 2^-53 and |r| < 1)
  double w = k * kPio2Mid;     // exact
  const double t = r;
  r = t - w;
  w = k * kPio2Lo - ((t - r) - w);
  const double y0 = r - w;
  const double y1 = (r - y0) - w;
  const double z = y0 * y0;
  // fdlibm __kernel_sin(y0, y1) and __kernel_cos(y0, y1).
  const double v = z * y0;
  const double ps = kS2 + z * (kS3 + z * (kS4 + z * (kS5 + z * kS6)));
  const double s = y0 - ((z * (0.5 * y1 - v * ps) - y1) - v * kS1);
  const double pc = z * (kC1 + z * (kC2 + z * (kC3 + z * (kC4 + z * (kC5 + z * kC6)))));
  const double hz = 0.5 * z;
  const double wc = 1.0 - hz;
  const double c = wc + (((1.0 - wc) - hz) + (z * pc - y0 * y1));
  // The quadrant k mod 4 in 0..3 (exact); cos x = sin(x + pi/2) is the next quadrant.
  const double q = (k - 4.0 * std::floor(k * 0.25)) + (cos ? 1.0 : 0.0);
  const bool odd = q == 1.0 || q == 3.0;
  const bool negative = q == 2.0 || q == 3.0;
  const double res = odd ? c : s;
  return negative ? -res : res;
}

/// kSin / kCos in single precision (the f32 JIT, the tape VM): the kernel on the exact double
/// of x, rounded to float; libm's double sin/cos beyond the kernel's range (and for inf).
inline float sin_cos_f32(float x, bool cos) {
  const double d = x;
  if (std::fabs(d) > kTrigKernelLimit) return static_cast<float>(cos ? std::cos(d) : std::sin(d));
  return static_cast<float>(trig_kernel(d, cos));
}

}  // namespace hfrt::ir
