// Property tests of the interval extension of every op (apply_interval): seeded random
// intervals with adversarial endpoints (0, -0, +-1e-300, huge, +-inf, pi, tiny widths, NaN
// bits); every sampled point's scalar value (apply_op, the interpreter's definition of the
// op) must lie in the computed interval, or be NaN with maybe_nan set. Plus a comparison with
// Boost.Interval on finite intervals and a check of the min/max/select trace.

#include <gtest/gtest.h>

#include <boost/numeric/interval.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "ir/scalar_ops.h"
#include "jit/interval.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kBoxesPerOp = 100000;

/// Seeded generator of adversarial intervals and of points inside them.
class Gen {
 public:
  explicit Gen(uint64_t seed) : rng_(seed) {}

  double uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng_);
  }
  int below(int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng_); }
  bool chance(double p) { return uniform(0, 1) < p; }

  /// An endpoint: special values two thirds of the time, else random numbers of all scales.
  double endpoint() {
    static const double kSpecial[] = {0.0,
                                      -0.0,
                                      1e-300,
                                      -1e-300,
                                      1e300,
                                      -1e300,
                                      kInf,
                                      -kInf,
                                      M_PI,
                                      -M_PI,
                                      M_PI / 2,
                                      -M_PI / 2,
                                      2 * M_PI,
                                      1.0,
                                      -1.0,
                                      1e-6,
                                      -1e-6,
                                      0.5,
                                      -0.5,
                                      2.0,
                                      -2.0,
                                      3.0,
                                      -3.0,
                                      std::numeric_limits<double>::max(),
                                      std::numeric_limits<double>::denorm_min(),
                                      1e6,
                                      -1e6,
                                      710.0,
                                      -745.0,
                                      1024.0};
    switch (below(6)) {
      case 0:
      case 1:
      case 2:
        return kSpecial[below(sizeof(kSpecial) / sizeof(kSpecial[0]))];
      case 3:
        return uniform(-4, 4);
      case 4:
        return std::round(uniform(-6, 6)) + (chance(0.5) ? 0.0 : uniform(-2e-6, 2e-6));
      default: {
        double m = std::pow(10.0, uniform(-20, 20));
        return chance(0.5) ? m : -m;
      }
    }
  }

  Interval interval(double nan_p = 0.1) {
    double a = endpoint(), b;
    switch (below(4)) {
      case 0:
        b = a;
        break;  // a point
      case 1:
        b = std::nextafter(a, chance(0.5) ? kInf : -kInf);
        break;  // one-ulp width
      case 2:
        b = a + uniform(-1, 1) * std::pow(10.0, uniform(-12, 1));
        break;  // narrow
      default:
        b = endpoint();
        break;
    }
    if (b != b) b = a;
    if (b < a) std::swap(a, b);
    return {a, b, chance(nan_p)};
  }

  /// Points of an interval: both ends, zeros of both signs, integers, random interior points
  /// and NaN when allowed.
  std::vector<double> points(const Interval& iv, int n_random) {
    std::vector<double> p = {iv.lo, iv.hi};
    if (iv.lo <= 0 && iv.hi >= 0) {
      p.push_back(0.0);
      p.push_back(-0.0);
    }
    if (iv.maybe_nan) p.push_back(kNaN);
    if (std::isfinite(iv.lo) && std::isfinite(iv.hi) && iv.hi - iv.lo < 1e6) {
      for (double k = std::ceil(iv.lo); k <= iv.hi && p.size() < 8; k += 1) p.push_back(k);
    }
    for (int i = 0; i < n_random; ++i) {
      double lo = std::max(iv.lo, -1e308), hi = std::min(iv.hi, 1e308);
      double v = lo + (hi - lo) * uniform(0, 1);
      if (!(v >= iv.lo && v <= iv.hi)) v = iv.lo;
      p.push_back(v);
      // points near the ends
      p.push_back(std::min(iv.hi, std::nextafter(iv.lo, kInf)));
    }
    return p;
  }

 private:
  std::mt19937_64 rng_;
};

std::string str(const Interval& iv) {
  std::ostringstream os;
  os.precision(17);
  os << "[" << iv.lo << ", " << iv.hi << (iv.maybe_nan ? "] nan" : "]");
  return os.str();
}

bool well_formed(const Interval& r) {
  return r.lo == r.lo && r.hi == r.hi && r.lo <= r.hi;
}

struct OpCase {
  Op op;
  int arity;
};

const OpCase kOps[] = {
    {Op::kAdd, 2},   {Op::kSub, 2},   {Op::kMul, 2},    {Op::kDiv, 2},   {Op::kNeg, 1},
    {Op::kAbs, 1},   {Op::kMin, 2},   {Op::kMax, 2},    {Op::kSqrt, 1},  {Op::kExp, 1},
    {Op::kLog, 1},   {Op::kLog10, 1}, {Op::kSin, 1},    {Op::kCos, 1},   {Op::kTan, 1},
    {Op::kAsin, 1},  {Op::kAcos, 1},  {Op::kAtan, 1},   {Op::kAtan2, 2}, {Op::kSinh, 1},
    {Op::kCosh, 1},  {Op::kTanh, 1},  {Op::kFloor, 1},  {Op::kCeil, 1},  {Op::kTrunc, 1},
    {Op::kRound, 1}, {Op::kFmod, 2},  {Op::kPow, 2},    {Op::kPowHF, 2}, {Op::kSign, 1},
    {Op::kLt, 2},    {Op::kLe, 2},    {Op::kGt, 2},     {Op::kGe, 2},    {Op::kEqTol, 2},
    {Op::kNeTol, 2}, {Op::kEq, 2},    {Op::kNe, 2},     {Op::kTruth, 1}, {Op::kAnd, 2},
    {Op::kOr, 2},    {Op::kNot, 1},   {Op::kSelect, 3}, {Op::kCbrt, 1},
};

class IntervalOpTest : public ::testing::TestWithParam<OpCase> {};

TEST_P(IntervalOpTest, EverySampledPointIsInside) {
  const OpCase oc = GetParam();
  Gen gen(1234 + static_cast<int>(oc.op));
  int failures = 0;
  int64_t checked = 0;
  for (int box = 0; box < kBoxesPerOp && failures < 10; ++box) {
    Interval a = gen.interval(), b = gen.interval(), c = gen.interval();
    if (oc.op == Op::kSelect) {
      // The condition of kSelect is 0/1.
      int k = gen.below(3);
      a = k == 0 ? Interval{0, 0} : k == 1 ? Interval{1, 1} : Interval{0, 1};
    }
    bool same = oc.arity >= 2 && gen.chance(0.05);
    if (same) b = a;
    uint8_t choice = 0;
    Interval r = apply_interval(oc.op, a, b, c, same, &choice);
    if (!well_formed(r)) {
      ADD_FAILURE() << op_name(oc.op) << " malformed " << str(r) << " from " << str(a) << " "
                    << str(b);
      ++failures;
      continue;
    }
    std::vector<double> pa = gen.points(a, 2);
    std::vector<double> pb = oc.arity >= 2 ? gen.points(b, 1) : std::vector<double>{0.0};
    std::vector<double> pc = oc.arity >= 3 ? gen.points(c, 1) : std::vector<double>{0.0};
    for (size_t i = 0; i < pa.size(); ++i) {
      for (size_t j = 0; j < pb.size(); ++j) {
        for (size_t k = 0; k < pc.size(); ++k) {
          double x = pa[i], y = same ? x : pb[j], z = pc[k];
          double v = apply_op(oc.op, x, y, z);
          ++checked;
          bool ok = r.contains(v);
          // The trace: an operand marked impossible must never be the one chosen.
          if (ok && (oc.op == Op::kMin || oc.op == Op::kMax) && !same) {
            bool took_left = oc.op == Op::kMin ? (x < y) : (x > y);
            ok = (choice & (took_left ? kChoiceLeft : kChoiceRight)) != 0;
          }
          if (ok && oc.op == Op::kSelect) {
            ok = (choice & (x != 0 ? kChoiceLeft : kChoiceRight)) != 0;
          }
          if (!ok && failures++ < 10) {
            ADD_FAILURE() << op_name(oc.op) << "(" << x << ", " << y << ", " << z << ") = " << v
                          << " not in " << str(r) << " (choice " << int(choice) << ") for "
                          << str(a) << " " << str(b) << " " << str(c);
          }
          if (same) break;
        }
      }
    }
  }
  EXPECT_GT(checked, kBoxesPerOp);
}

INSTANTIATE_TEST_SUITE_P(AllOps, IntervalOpTest, ::testing::ValuesIn(kOps),
                         [](const ::testing::TestParamInfo<OpCase>& info) {
                           return std::string(op_name(info.param.op));
                         });

// --- Boost.Interval as the reference on finite intervals ---------------------------------

namespace bi = boost::numeric::interval_lib;
using BoostI =
    boost::numeric::interval<double, bi::policies<bi::save_state<bi::rounded_transc_std<double>>,
                                                  bi::checking_base<double>>>;

enum class Match {
  kContains,   ///< IEEE ops: ours contains Boost's, and is at most `slack` ulps wider
  kClose,      ///< libm: equal up to `slack` ulps both ways (libm under directed rounding,
               ///< Boost's transcendental policy, is not always within an ulp)
  kNotLooser,  ///< sin/cos: Boost's range reduction is coarse; ours must not be looser
};

void expect_match(Op op, const Interval& ours, const BoostI& ref, int slack, Match mode,
                  const Interval& a, const Interval& b, int* failures) {
  double lo = ref.lower(), hi = ref.upper();
  double wlo = lo, whi = hi, olo = ours.lo, ohi = ours.hi;
  for (int i = 0; i < slack; ++i) {
    wlo = std::nextafter(wlo, -kInf);
    whi = std::nextafter(whi, kInf);
    olo = std::nextafter(olo, -kInf);
    ohi = std::nextafter(ohi, kInf);
  }
  bool not_looser = wlo <= ours.lo && ours.hi <= whi;
  bool ok = mode == Match::kContains ? (ours.lo <= lo && hi <= ours.hi && not_looser)
            : mode == Match::kClose  ? (not_looser && olo <= lo && hi <= ohi)
                                     : not_looser;
  if (!ok && (*failures)++ < 10) {
    ADD_FAILURE() << op_name(op) << ": ours " << str(ours) << " boost [" << lo << ", " << hi
                  << "] for " << str(a) << " " << str(b);
  }
}

TEST(IntervalOps, CbrtIsIncreasingAndOutwardRounded) {
  // cbrt is increasing on the whole line (negative arguments included): the ends map to
  // the ends, widened outward by a few ulps; NaN is passed on.
  Interval r = apply_interval(Op::kCbrt, {-8, 27, false}, {}, {});
  EXPECT_LE(r.lo, -2);
  EXPECT_GE(r.lo, -2 - 1e-14);
  EXPECT_GE(r.hi, 3);
  EXPECT_LE(r.hi, 3 + 1e-14);
  EXPECT_FALSE(r.maybe_nan);
  r = apply_interval(Op::kCbrt, {-kInf, kInf, true}, {}, {});
  EXPECT_EQ(r.lo, -kInf);
  EXPECT_EQ(r.hi, kInf);
  EXPECT_TRUE(r.maybe_nan);
  // Across 0, where the slope is infinite.
  const Interval box{-1e-3, 2e-3, false};
  r = apply_interval(Op::kCbrt, box, {}, {});
  for (int i = 0; i <= 1000; ++i) {
    const double x = box.lo + (box.hi - box.lo) * i / 1000;
    EXPECT_TRUE(r.contains(apply_op(Op::kCbrt, x, 0, 0))) << x << " " << str(r);
  }
  EXPECT_LT(r.hi - r.lo, 0.23);  // cbrt(2e-3) - cbrt(-1e-3) = 0.226
}

TEST(IntervalBoostTest, AgreesWithBoostOnFiniteIntervals) {
  Gen gen(99);
  int failures = 0;
  auto finite = [&](double lo, double hi) {
    Interval r;
    do {
      r = gen.interval(0);
    } while (!std::isfinite(r.lo) || !std::isfinite(r.hi) || std::fabs(r.lo) > 1e100 ||
             std::fabs(r.hi) > 1e100);
    r.lo = std::clamp(r.lo, lo, hi);
    r.hi = std::clamp(r.hi, lo, hi);
    return r;
  };
  auto bx = [](const Interval& i) { return BoostI(i.lo, i.hi); };
  const Interval none{};
  for (int t = 0; t < 20000; ++t) {
    Interval a = finite(-1e100, 1e100), b = finite(-1e100, 1e100);
    expect_match(Op::kAdd, apply_interval(Op::kAdd, a, b, none), bx(a) + bx(b), 2, Match::kContains,
                 a, b, &failures);
    expect_match(Op::kSub, apply_interval(Op::kSub, a, b, none), bx(a) - bx(b), 2, Match::kContains,
                 a, b, &failures);
    expect_match(Op::kMul, apply_interval(Op::kMul, a, b, none), bx(a) * bx(b), 2, Match::kContains,
                 a, b, &failures);
    expect_match(Op::kMul, apply_interval(Op::kMul, a, a, none, true),
                 boost::numeric::square(bx(a)), 2, Match::kContains, a, a, &failures);
    if (!(b.lo <= 0 && b.hi >= 0)) {
      expect_match(Op::kDiv, apply_interval(Op::kDiv, a, b, none), bx(a) / bx(b), 2,
                   Match::kContains, a, b, &failures);
    }
    expect_match(Op::kMin, apply_interval(Op::kMin, a, b, none), boost::numeric::min(bx(a), bx(b)),
                 0, Match::kContains, a, b, &failures);
    expect_match(Op::kMax, apply_interval(Op::kMax, a, b, none), boost::numeric::max(bx(a), bx(b)),
                 0, Match::kContains, a, b, &failures);
    expect_match(Op::kAbs, apply_interval(Op::kAbs, a, b, none), boost::numeric::abs(bx(a)), 0,
                 Match::kContains, a, b, &failures);
    Interval p = finite(0, 1e100);
    expect_match(Op::kSqrt, apply_interval(Op::kSqrt, p, none, none), boost::numeric::sqrt(bx(p)),
                 2, Match::kContains, p, none, &failures);
    Interval e = finite(-700, 700);
    expect_match(Op::kExp, apply_interval(Op::kExp, e, none, none), boost::numeric::exp(bx(e)), 8,
                 Match::kClose, e, none, &failures);
    expect_match(Op::kSinh, apply_interval(Op::kSinh, e, none, none), boost::numeric::sinh(bx(e)),
                 8, Match::kClose, e, none, &failures);
    expect_match(Op::kCosh, apply_interval(Op::kCosh, e, none, none), boost::numeric::cosh(bx(e)),
                 8, Match::kClose, e, none, &failures);
    expect_match(Op::kTanh, apply_interval(Op::kTanh, e, none, none), boost::numeric::tanh(bx(e)),
                 8, Match::kClose, e, none, &failures);
    expect_match(Op::kAtan, apply_interval(Op::kAtan, a, none, none), boost::numeric::atan(bx(a)),
                 8, Match::kClose, a, none, &failures);
    Interval pl = finite(1e-300, 1e100);
    expect_match(Op::kLog, apply_interval(Op::kLog, pl, none, none), boost::numeric::log(bx(pl)), 8,
                 Match::kClose, pl, none, &failures);
    Interval u = finite(-1, 1);
    expect_match(Op::kAsin, apply_interval(Op::kAsin, u, none, none), boost::numeric::asin(bx(u)),
                 8, Match::kClose, u, none, &failures);
    expect_match(Op::kAcos, apply_interval(Op::kAcos, u, none, none), boost::numeric::acos(bx(u)),
                 8, Match::kClose, u, none, &failures);
    // Slack 5: the enclosure's ends come from hfrt's kernel (ir/trig.h, within 0.78 ulps,
    // where libm's cos and sin, which Boost calls, are within 0.52), widened by two steps.
    Interval s = finite(-1e4, 1e4);
    expect_match(Op::kSin, apply_interval(Op::kSin, s, none, none), boost::numeric::sin(bx(s)), 5,
                 Match::kNotLooser, s, none, &failures);
    expect_match(Op::kCos, apply_interval(Op::kCos, s, none, none), boost::numeric::cos(bx(s)), 5,
                 Match::kNotLooser, s, none, &failures);
  }
  EXPECT_EQ(failures, 0);
}

}  // namespace
}  // namespace hfrt::jit
