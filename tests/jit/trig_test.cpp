// hfrt's sine/cosine kernel (ir/trig.h): its accuracy against long double, and that the
// f32 JIT's vector code, the f32 gradient JIT and the interval JIT compute exactly what the
// C++ kernel and the interval interpreter compute (bit for bit), including the lanes beyond
// the kernel's range that take libm, NaN, infinities and signed zeros.

#include "ir/trig.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "ir/builder.h"
#include "ir/interval_ops.h"
#include "jit/gradient.h"
#include "jit/interval.h"
#include "jit/llvm_jit.h"

namespace hfrt::jit {

using namespace ::hfrt::ir;
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// |v - ref| in units of ulp(ref) (long double reference).
double ulps(double v, long double ref) {
  const double r = static_cast<double>(ref);
  const double ulp = std::nextafter(std::fabs(r), kInf) - std::fabs(r);
  return static_cast<double>(std::fabs(static_cast<long double>(v) - ref) / ulp);
}

/// Arguments that stress the reduction: random over the kernel's range and near 0, and the
/// doubles next to multiples of pi/2 (where sin or cos is smallest).
std::vector<double> hard_arguments() {
  std::vector<double> xs;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> wide(-kTrigKernelLimit, kTrigKernelLimit), near(-10, 10),
      unit(-1, 1);
  for (int i = 0; i < 200000; ++i) xs.push_back(wide(rng));
  for (int i = 0; i < 200000; ++i) xs.push_back(near(rng));
  for (int i = 0; i < 20000; ++i) xs.push_back(std::ldexp(unit(rng), -int(rng() % 1000)));
  const long double half_pi = 1.5707963267948966192313216916397514L;
  for (long k = -660000; k <= 660000; k += 97) {
    const double x = static_cast<double>(k * half_pi);
    xs.push_back(x);
    xs.push_back(std::nextafter(x, kInf));
    xs.push_back(std::nextafter(x, -kInf));
  }
  return xs;
}

TEST(TrigKernel, WithinItsErrorBoundOfLongDouble) {
  double worst[2] = {0, 0};
  for (double x : hard_arguments()) {
    for (int c = 0; c < 2; ++c) {
      const long double ref = c ? cosl(x) : sinl(x);
      const double v = trig_kernel(x, c == 1);
      // The bound ir/trig.h states (and the interval enclosures rely on): 1 ulp.
      const double e = ulps(v, ref);
      worst[c] = std::max(worst[c], e);
      ASSERT_LE(e, 1.0) << (c ? "cos(" : "sin(") << x << ")";
    }
  }
  RecordProperty("sin_worst_ulps", std::to_string(worst[0]));
  RecordProperty("cos_worst_ulps", std::to_string(worst[1]));
}

TEST(TrigKernel, F32IsTheCorrectlyRoundedValueAlmostEverywhere) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<float> u(-20000.0f, 20000.0f);
  int off = 0;
  const int n = 400000;
  for (int i = 0; i < n; ++i) {
    const float x = u(rng);
    for (int c = 0; c < 2; ++c) {
      const float v = sin_cos_f32(x, c == 1);
      const float ref = static_cast<float>(c ? cosl(x) : sinl(x));
      if (v != ref) {
        ++off;
        // Never more than the neighbouring float.
        ASSERT_TRUE(v == std::nextafter(ref, 2.0f) || v == std::nextafter(ref, -2.0f)) << x;
      }
    }
  }
  EXPECT_LE(off, 2 * n / 10000) << "more than 0.01 % of the values are not correctly rounded";
}

TEST(TrigKernel, EdgesOfTheDomain) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_TRUE(std::isnan(sin_cos_f32(nan, false)));
  EXPECT_TRUE(std::isnan(sin_cos_f32(static_cast<float>(kInf), true)));
  EXPECT_EQ(sin_cos_f32(0.0f, true), 1.0f);
  EXPECT_EQ(sin_cos_f32(0.0f, false), 0.0f);
  // Beyond the kernel's range: libm's double function, rounded.
  const float big = 3.0e7f;
  EXPECT_EQ(sin_cos_f32(big, false), static_cast<float>(std::sin(double(big))));
  EXPECT_EQ(sin_cos_f32(-big, true), static_cast<float>(std::cos(double(-big))));
}

/// Bit equality that treats every NaN alike.
bool same_bits(float a, float b) {
  if (a != a || b != b) return a != a && b != b;
  return std::memcmp(&a, &b, sizeof a) == 0;
}

/// f32 test points: the hard arguments that are floats, specials, and beyond-range lanes
/// scattered among in-range ones (the vector code's libm branch).
std::vector<float> f32_arguments() {
  std::vector<float> xs;
  for (double x : hard_arguments()) xs.push_back(static_cast<float>(x));
  const float specials[] = {0.0f,
                            -0.0f,
                            1e-45f,
                            -1e-40f,
                            1.0f,
                            1048576.f,
                            1048577.f,
                            -2e6f,
                            3e38f,
                            -3e38f,
                            static_cast<float>(kInf),
                            -static_cast<float>(kInf),
                            std::numeric_limits<float>::quiet_NaN()};
  for (int rep = 0; rep < 37; ++rep) {
    for (float s : specials) xs.push_back(s);
  }
  std::mt19937_64 rng(11);
  std::shuffle(xs.end() - 37 * 13, xs.end(), rng);
  return xs;
}

Function unary_function(Op op) {
  Function fn;
  fn.num_inputs = 1;
  IrBuilder b(fn);
  b.finish(b.unary(op, b.input(0)));
  return fn;
}

TEST(TrigJit, F32VectorCodeIsTheKernelBitForBit) {
  const std::vector<float> xs = f32_arguments();
  for (Op op : {Op::kSin, Op::kCos}) {
    const Function fn = unary_function(op);
    auto jit = JitFunction::compile(fn, Precision::kF32);
    ASSERT_TRUE(jit.ok()) << jit.error().message;
    std::vector<float> out(xs.size());
    (*jit)->f32()(static_cast<int64_t>(xs.size()), xs.data(), nullptr, out.data(), nullptr);
    int bad = 0;
    for (size_t i = 0; i < xs.size() && bad < 5; ++i) {
      const float want = sin_cos_f32(xs[i], op == Op::kCos);
      if (!same_bits(out[i], want)) {
        ++bad;
        ADD_FAILURE() << op_name(op) << "(" << xs[i] << "): JIT " << out[i] << ", kernel " << want;
      }
    }
  }
}

// Regression: every compile printed its module as text for llvm_ir(), cache hits included;
// with the kernel's vector constants that was ~13 ms of each f32 compile of the gyroid.
TEST(TrigJit, LlvmIrTextIsKeptOnlyWhenAsked) {
  const Function fn = unary_function(Op::kSin);
  auto plain = JitFunction::compile(fn, Precision::kF32);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_TRUE((*plain)->llvm_ir().empty());
  JitOptions options;
  options.keep_llvm_ir = true;
  auto kept = JitFunction::compile(fn, Precision::kF32, options);
  ASSERT_TRUE(kept.ok()) << kept.error().message;
  EXPECT_NE((*kept)->llvm_ir().find("define"), std::string::npos);
}

TEST(TrigJit, F32GradientUsesTheKernelForValueAndDerivative) {
  std::vector<float> xs;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  for (int i = 0; i < 4096; ++i) xs.push_back(u(rng));
  xs.push_back(5e6f);  // one lane beyond the kernel's range
  const int64_t n = static_cast<int64_t>(xs.size());
  for (Op op : {Op::kSin, Op::kCos}) {
    const Function fn = unary_function(op);
    GradientJit::Options options;
    options.precision = Precision::kF32;
    auto g = GradientJit::compile(fn, options);
    ASSERT_TRUE(g.ok()) << g.error().message;
    std::vector<float> out(4 * n);
    (*g)->eval(n, xs.data(), {}, out.data());
    for (int64_t i = 0; i < n; ++i) {
      const bool is_cos = op == Op::kCos;
      ASSERT_TRUE(same_bits(out[i], sin_cos_f32(xs[i], is_cos))) << xs[i];
      const float d = is_cos ? -sin_cos_f32(xs[i], false) : sin_cos_f32(xs[i], true);
      ASSERT_TRUE(same_bits(out[n + i], d)) << xs[i];
    }
  }
}

TEST(TrigJit, IntervalCodeEqualsTheInterpreterAndEnclosesTheFunction) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> centre(-50, 50), width(0, 8), unit(0, 1);
  std::vector<Interval> boxes;
  for (int i = 0; i < 20000; ++i) {
    const double c = centre(rng), w = width(rng) * (unit(rng) < 0.3 ? 1e-6 : 1);
    boxes.push_back({c - w / 2, c + w / 2, false});
  }
  // Ends at the extrema, beyond the range, wide, infinite, tiny.
  const double hp = M_PI / 2;
  for (Interval iv :
       {Interval{hp, hp, false}, Interval{-hp, 3 * hp, false}, Interval{0, 0, false},
        Interval{1e6, 1e6 + 1, false}, Interval{2e6, 2e6 + 1, false}, Interval{-1, 70, false},
        Interval{-kInf, 0, false}, Interval{1e-300, 2e-300, false}}) {
    boxes.push_back(iv);
  }
  const size_t n = boxes.size();
  std::vector<double> lo(n), hi(n), olo(n), ohi(n);
  std::vector<uint8_t> onan(n);
  for (size_t i = 0; i < n; ++i) {
    lo[i] = boxes[i].lo;
    hi[i] = boxes[i].hi;
  }
  for (Op op : {Op::kSin, Op::kCos}) {
    const Function fn = unary_function(op);
    auto jit = IntervalJit::compile(fn, IntervalJit::Options{});
    ASSERT_TRUE(jit.ok()) << jit.error().message;
    (*jit)->eval(static_cast<int64_t>(n), lo.data(), hi.data(), {}, olo.data(), ohi.data(),
                 onan.data());
    for (size_t i = 0; i < n; ++i) {
      const Interval want = apply_interval(op, boxes[i], {}, {});
      ASSERT_TRUE(olo[i] == want.lo && ohi[i] == want.hi && bool(onan[i]) == want.maybe_nan)
          << op_name(op) << " [" << lo[i] << ", " << hi[i] << "]: JIT [" << olo[i] << ", " << ohi[i]
          << "], interpreter [" << want.lo << ", " << want.hi << "]";
      if (!std::isfinite(lo[i]) || !std::isfinite(hi[i])) continue;
      for (int k = 0; k <= 16; ++k) {
        const double x = std::min(hi[i], lo[i] + (hi[i] - lo[i]) * k / 16);  // inside
        const long double exact = op == Op::kCos ? cosl(x) : sinl(x);
        const double glibc = op == Op::kCos ? std::cos(x) : std::sin(x);
        ASSERT_TRUE(olo[i] <= exact && exact <= ohi[i] && olo[i] <= glibc && glibc <= ohi[i])
            << op_name(op) << "(" << x << ") = " << static_cast<double>(exact) << " outside ["
            << olo[i] << ", " << ohi[i] << "], the enclosure over [" << lo[i] << ", " << hi[i]
            << "]";
      }
    }
  }
}

}  // namespace
}  // namespace hfrt::jit
