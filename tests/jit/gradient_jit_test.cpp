// The gradient JIT against the gradient interpreter: in f64 the same value and partial
// derivatives (bit for bit up to the sign of zero) for every op and on seeded random
// programs with branches, loops, arrays and checks; in f32 close to them (relative 1e-3) on
// well-conditioned programs.

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

#include "ir/builder.h"
#include "jit/gradient.h"
#include "tests/jit/random_program.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

bool same(double u, double v) {
  return (u != u && v != v) || u == v;
}

std::string str(const Dual& d) {
  std::ostringstream os;
  os.precision(17);
  os << "(" << d.v << "; " << d.d[0] << ", " << d.d[1] << ", " << d.d[2] << ")";
  return os.str();
}

/// Compares JIT and interpreter at `pts`; f32: relative tolerance, else exact.
int compare(const Function& fn, const std::vector<std::vector<double>>& pts,
            std::span<const double> a, bool f32, const std::string& what) {
  GradientJit::Options o;
  o.precision = f32 ? Precision::kF32 : Precision::kF64;
  auto jit = GradientJit::compile(fn, o);
  if (!jit.ok()) {
    ADD_FAILURE() << what << ": " << jit.error().message;
    return 1;
  }
  GradientInterpreter gi(fn);
  const size_t n = pts.size();
  const int dims = fn.num_inputs;
  std::vector<double> xs(dims * n), out(4 * n);
  std::vector<float> xf(dims * n), outf(4 * n);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < dims; ++k) {
      xs[k * n + i] = pts[i][k];
      xf[k * n + i] = static_cast<float>(pts[i][k]);
    }
  }
  if (f32)
    jit.value()->eval(static_cast<int64_t>(n), xf.data(), a, outf.data());
  else
    jit.value()->eval(static_cast<int64_t>(n), xs.data(), a, out.data());
  int failures = 0;
  for (size_t i = 0; i < n; ++i) {
    std::vector<double> p = pts[i];
    if (f32) {
      for (double& c : p) c = static_cast<float>(c);  // the point the f32 code saw
    }
    Dual ref = gi.eval(p, a);
    Dual got;
    for (int c = 0; c < 4; ++c) {
      double v = f32 ? outf[c * n + i] : out[c * n + i];
      if (c == 0)
        got.v = v;
      else
        got.d[c - 1] = v;
    }
    bool ok = true;
    double comps_ref[4] = {ref.v, ref.d[0], ref.d[1], ref.d[2]};
    double comps_got[4] = {got.v, got.d[0], got.d[1], got.d[2]};
    for (int c = 0; c < 4; ++c) {
      if (!f32) {
        ok = ok && same(comps_ref[c], comps_got[c]);
      } else if (std::isfinite(ref.v) && std::isfinite(comps_ref[c]) &&
                 std::fabs(comps_ref[c]) < 1e6) {
        ok = ok && std::fabs(comps_got[c] - comps_ref[c]) <=
                       1e-3 * std::max(1.0, std::fabs(comps_ref[c]));
      }
    }
    if (!ok && failures++ < 5) {
      std::ostringstream os;
      os.precision(17);
      for (double c : p) os << c << " ";
      ADD_FAILURE() << what << (f32 ? " f32" : " f64") << " at " << os.str() << ": JIT " << str(got)
                    << " interpreter " << str(ref);
    }
  }
  return failures;
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

class GradientJitOpTest : public ::testing::TestWithParam<OpCase> {};

TEST_P(GradientJitOpTest, SameAsInterpreter) {
  const OpCase oc = GetParam();
  Function fn;
  IrBuilder b(fn);
  ValueId x = b.input(0), y = b.input(1), z = b.input(2);
  ValueId g1 = b.add(b.mul(b.constant(0.7), x), b.sub(b.mul(b.constant(0.3), y), z));
  ValueId g2 = oc.op == Op::kPowHF || oc.op == Op::kPow
                   ? b.add(b.constant(1.5), b.mul(b.constant(0.25), z))
                   : b.add(b.mul(y, z), b.constant(0.5));
  ValueId r = oc.arity == 1   ? b.unary(oc.op, g1)
              : oc.arity == 2 ? b.binary(oc.op, g1, g2)
                              : b.select(b.gt(g2, b.constant(0)), g1, b.mul(g1, g2));
  b.finish(r);
  std::mt19937_64 rng(static_cast<int>(oc.op));
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<std::vector<double>> pts;
  for (int i = 0; i < 203; ++i) {
    pts.push_back({u(rng), u(rng), u(rng)});
    if (i % 5 == 0) pts.back()[2] = std::round(pts.back()[2]);  // integral exponents
  }
  EXPECT_EQ(compare(fn, pts, {}, false, std::string(op_name(oc.op))), 0);
  EXPECT_EQ(compare(fn, pts, {}, true, std::string(op_name(oc.op))), 0);
}

INSTANTIATE_TEST_SUITE_P(AllOps, GradientJitOpTest, ::testing::ValuesIn(kOps),
                         [](const ::testing::TestParamInfo<OpCase>& info) {
                           return std::string(op_name(info.param.op));
                         });

TEST(GradientJitTest, RandomProgramsSameAsInterpreter) {
  constexpr int kPrograms = 40;  // LLVM compile time dominates
  int failures = 0;
  for (int seed = 0; seed < kPrograms && failures < 10; ++seed) {
    Function fn = testing::random_program(seed);
    std::vector<double> a = {0.5, -1.25};
    a.resize(std::max(fn.num_params, 1), 0.0);
    failures += compare(fn, testing::random_points(seed, 29, fn.num_inputs), a, false,
                        "seed " + std::to_string(seed));
  }
  EXPECT_EQ(failures, 0);
}

}  // namespace
}  // namespace hfrt::jit
