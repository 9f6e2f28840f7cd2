// The gradient interpreter: values must be the reference interpreter's bit for bit, and the
// partial derivatives must agree with central differences of the f64 interpreter (relative
// 1e-6) wherever F is smooth around the point (forward and backward differences agree), for
// every op and on seeded random programs.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "ir/builder.h"
#include "jit/gradient.h"
#include "jit/interpreter.h"
#include "tests/jit/random_program.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

bool same_value(double u, double v) {
  return (u != u && v != v) || u == v;
}

struct Stats {
  int64_t points = 0;
  int64_t compared = 0;  ///< derivative components compared with central differences
  int failures = 0;
};

/// Checks F and its gradient at p against the interpreter; returns false on a mismatch.
void check_point(const Function& fn, const Interpreter& interp, GradientInterpreter& grad,
                 const std::vector<double>& p, const std::vector<double>& a,
                 const std::string& what, Stats* st) {
  Dual g = grad.eval(p, a);
  double f0 = interp.eval(p, a).value;
  ++st->points;
  std::ostringstream where;
  where.precision(17);
  where << what << " at (";
  for (double c : p) where << c << " ";
  where << ")";
  if (!same_value(g.v, f0)) {
    if (st->failures++ < 10) ADD_FAILURE() << where.str() << ": value " << g.v << " vs " << f0;
    return;
  }
  if (!std::isfinite(f0)) return;
  for (int k = 0; k < std::min(3, fn.num_inputs); ++k) {
    double h = 1e-5 * std::max(1.0, std::fabs(p[k]));
    std::vector<double> q = p;
    q[k] = p[k] + h;
    double fp = interp.eval(q, a).value;
    q[k] = p[k] - h;
    double fm = interp.eval(q, a).value;
    if (!std::isfinite(fp) || !std::isfinite(fm)) continue;
    double central = (fp - fm) / (2 * h);
    double forward = (fp - f0) / h, backward = (f0 - fm) / h;
    double scale = std::max(1.0, std::fabs(central));
    if (std::fabs(forward - backward) > 1e-3 * scale) continue;  // a kink or a jump nearby
    ++st->compared;
    double tol = 1e-6 * scale + 1e-9 * std::fabs(f0);
    if (!(std::fabs(g.d[k] - central) <= tol) && st->failures++ < 10) {
      ADD_FAILURE() << where.str() << ": d/dx" << k + 1 << " = " << g.d[k]
                    << " but central difference " << central << " (f = " << f0 << ")";
    }
  }
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

class GradientOpTest : public ::testing::TestWithParam<OpCase> {};

/// op(g1, g2[, g3]) with smooth arguments that depend on all three coordinates.
Function op_program(const OpCase& oc, bool int_exponent) {
  Function fn;
  IrBuilder b(fn);
  ValueId x = b.input(0), y = b.input(1), z = b.input(2);
  ValueId g1 = b.add(b.add(b.mul(b.constant(0.7), x), b.mul(b.constant(0.3), y)),
                     b.sub(b.constant(0.1), b.mul(b.constant(0.2), z)));
  ValueId g2 = b.add(b.mul(y, z), b.mul(b.constant(0.5), x));
  if (oc.op == Op::kPowHF || oc.op == Op::kPow) {
    // exponent: an integer constant or a smooth function of the point
    g2 = int_exponent ? b.constant(3) : b.add(b.constant(1.5), b.mul(b.constant(0.25), g2));
  }
  ValueId r;
  if (oc.arity == 1)
    r = b.unary(oc.op, g1);
  else if (oc.arity == 2)
    r = b.binary(oc.op, g1, g2);
  else
    r = b.select(b.gt(g2, b.constant(0)), g1, b.mul(g1, g2));
  b.finish(r);
  return fn;
}

TEST_P(GradientOpTest, MatchesCentralDifferences) {
  const OpCase oc = GetParam();
  Stats st;
  for (int variant = 0; variant < 2; ++variant) {
    Function fn = op_program(oc, variant == 0);
    Interpreter interp(fn);
    GradientInterpreter grad(fn);
    std::mt19937_64 rng(static_cast<int>(oc.op) * 31 + variant);
    std::uniform_real_distribution<double> u(-2, 2);
    std::vector<double> a = {0};
    for (int i = 0; i < 2000 && st.failures < 10; ++i) {
      std::vector<double> p = {u(rng), u(rng), u(rng)};
      if (i % 4 == 0) p[0] = std::round(p[0] * 2) / 2;  // integers and halves
      check_point(fn, interp, grad, p, a, std::string(op_name(oc.op)), &st);
    }
  }
  EXPECT_GT(st.compared, 400) << "too few smooth points compared";
}

INSTANTIATE_TEST_SUITE_P(AllOps, GradientOpTest, ::testing::ValuesIn(kOps),
                         [](const ::testing::TestParamInfo<OpCase>& info) {
                           return std::string(op_name(info.param.op));
                         });

TEST(GradientInterpreterTest, CbrtDerivativeIsTheClosedForm) {
  // d cbrt(g) = dg / (3 cbrt(g)^2) with g = 2x - y: components whose dg is exactly 0 (z)
  // stay 0, also at g = 0 where the others are infinite.
  Function fn;
  IrBuilder b(fn);
  ValueId g = b.sub(b.mul(b.constant(2), b.input(0)), b.input(1));
  b.finish(b.unary(Op::kCbrt, g));
  GradientInterpreter grad(fn);
  for (double x : {-4.0, -0.3, 0.3, 1.0, 13.5}) {
    const std::vector<double> p = {x, 0.5, 7};
    const double c = std::cbrt(2 * x - 0.5);
    const Dual d = grad.eval(p, {});
    EXPECT_EQ(d.v, c);
    EXPECT_DOUBLE_EQ(d.d[0], 2 / (3 * c * c)) << x;
    EXPECT_DOUBLE_EQ(d.d[1], -1 / (3 * c * c)) << x;
    EXPECT_EQ(d.d[2], 0) << x;
  }
  const Dual at0 = grad.eval(std::vector<double>{0.25, 0.5, 7}, {});
  EXPECT_EQ(at0.v, 0);
  EXPECT_EQ(at0.d[0], std::numeric_limits<double>::infinity());
  EXPECT_EQ(at0.d[1], -std::numeric_limits<double>::infinity());
  EXPECT_EQ(at0.d[2], 0);
}

TEST(GradientInterpreterTest, SphereGradient) {
  Function fn;
  IrBuilder b(fn);
  ValueId r2 = b.add(b.add(b.sqr(b.input(0)), b.sqr(b.input(1))), b.sqr(b.input(2)));
  b.finish(b.sub(b.constant(1), b.sqrt(r2)));
  GradientInterpreter g(fn);
  std::vector<double> p = {3, 0, 4};
  Dual d = g.eval(p, {});
  EXPECT_DOUBLE_EQ(d.v, -4);
  EXPECT_DOUBLE_EQ(d.d[0], -0.6);
  EXPECT_DOUBLE_EQ(d.d[1], 0);
  EXPECT_DOUBLE_EQ(d.d[2], -0.8);
}

TEST(GradientInterpreterTest, BranchesAndSlotsCarryDuals) {
  // if x > 0 then s = x*x else s = -3*y endif; F = s
  Function fn;
  IrBuilder b(fn);
  int s = b.new_slot(0);
  ValueId x = b.input(0), y = b.input(1);
  b.begin_if(b.gt(x, b.constant(0)));
  b.store(s, b.mul(x, x));
  b.begin_else();
  b.store(s, b.mul(b.constant(-3), y));
  b.end_if();
  b.finish(b.load(s));
  GradientInterpreter g(fn);
  std::vector<double> p = {2, 5, 0};
  Dual d = g.eval(p, {});
  EXPECT_EQ(d.v, 4);
  EXPECT_EQ(d.d[0], 4);
  EXPECT_EQ(d.d[1], 0);
  p = {-2, 5, 0};
  d = g.eval(p, {});
  EXPECT_EQ(d.v, -15);
  EXPECT_EQ(d.d[0], 0);
  EXPECT_EQ(d.d[1], -3);
}

TEST(GradientInterpreterTest, RandomProgramsMatchCentralDifferences) {
  constexpr int kPrograms = 300;
  Stats st;
  for (int seed = 0; seed < kPrograms && st.failures < 10; ++seed) {
    Function fn = testing::random_program(seed);
    Interpreter interp(fn);
    GradientInterpreter grad(fn);
    std::vector<double> a = {0.5, -1.25};
    a.resize(std::max(fn.num_params, 1), 0.0);
    for (const auto& p : testing::random_points(seed, 20, fn.num_inputs)) {
      check_point(fn, interp, grad, p, a, "seed " + std::to_string(seed), &st);
    }
  }
  EXPECT_GT(st.compared, 1000);
}

}  // namespace
}  // namespace hfrt::jit
