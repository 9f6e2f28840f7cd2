// The interval JIT against the interval interpreter: the same intervals (bit for bit up to
// the sign of zero), the same maybe-NaN bits and the same min/max/select trace, for every op
// on adversarial boxes and on seeded random programs with branches, loops, arrays and checks.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "ir/builder.h"
#include "jit/interpreter.h"
#include "jit/interval.h"
#include "tests/jit/random_program.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string str(const Interval& iv) {
  std::ostringstream os;
  os.precision(17);
  os << "[" << iv.lo << ", " << iv.hi << (iv.maybe_nan ? "] nan" : "]");
  return os.str();
}

bool same(const Interval& a, const Interval& b) {
  return a.lo == b.lo && a.hi == b.hi && a.maybe_nan == b.maybe_nan;
}

double endpoint(std::mt19937_64& rng) {
  static const double kSpecial[] = {0.0,   -0.0, 1e-300, -1e-300, 1e300, -1e300, kInf, -kInf, M_PI,
                                    -M_PI, 1.0,  -1.0,   1e-6,    0.5,   2.0,    -2.0, 3.0};
  std::uniform_real_distribution<double> u(0, 1);
  double r = u(rng);
  if (r < 0.4) return kSpecial[rng() % (sizeof(kSpecial) / sizeof(kSpecial[0]))];
  if (r < 0.8) return (u(rng) - 0.5) * 8;
  return std::pow(10.0, u(rng) * 40 - 20) * (u(rng) < 0.5 ? -1 : 1);
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

/// Compares JIT and interpreter on `boxes` (SoA over fn.num_inputs); returns failures.
/// `outlined`: compile every op as a call of its helper (IntervalJit::Options::inline_limit
/// 0, the code shape of large models) instead of inline.
int compare(const Function& fn, const std::vector<std::vector<Interval>>& boxes,
            std::span<const double> a, const std::string& what, bool outlined = false) {
  IntervalJit::Options options;
  if (outlined) options.inline_limit = 0;
  auto jit = IntervalJit::compile(fn, options);
  if (!jit.ok()) {
    ADD_FAILURE() << what << ": " << jit.error().message;
    return 1;
  }
  IntervalInterpreter ii(fn);
  const size_t n = boxes.size();
  const int dims = fn.num_inputs;
  std::vector<double> lo(dims * n), hi(dims * n), olo(n), ohi(n);
  std::vector<uint8_t> onan(n);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < dims; ++k) {
      lo[k * n + i] = boxes[i][k].lo;
      hi[k * n + i] = boxes[i][k].hi;
    }
  }
  jit.value()->eval(static_cast<int64_t>(n), lo.data(), hi.data(), a, olo.data(), ohi.data(),
                    onan.data());
  int failures = 0;
  for (size_t i = 0; i < n; ++i) {
    Interval ref = ii.eval(boxes[i], a);
    Interval got{olo[i], ohi[i], onan[i] != 0};
    if (!same(ref, got) && failures++ < 5) {
      std::ostringstream os;
      for (const Interval& b : boxes[i]) os << str(b) << " ";
      ADD_FAILURE() << what << ": JIT " << str(got) << " interpreter " << str(ref) << " for "
                    << os.str();
    }
  }
  // The trace of single boxes.
  for (size_t i = 0; i < std::min<size_t>(n, 8); ++i) {
    std::vector<uint8_t> cj, ci;
    jit.value()->eval_one(boxes[i], a, &cj);
    ii.eval(boxes[i], a, &ci);
    if (cj != ci && failures++ < 5) ADD_FAILURE() << what << ": traces differ for box " << i;
  }
  return failures;
}

class IntervalJitOpTest : public ::testing::TestWithParam<OpCase> {};

TEST_P(IntervalJitOpTest, SameAsInterpreter) {
  const OpCase oc = GetParam();
  for (int same_args = 0; same_args < 2; ++same_args) {
    if (same_args && oc.arity != 2) continue;
    Function fn;
    IrBuilder b(fn);
    ValueId x = b.input(0), y = same_args ? x : b.input(1), z = b.input(2);
    ValueId r;
    if (oc.arity == 1)
      r = b.unary(oc.op, x);
    else if (oc.arity == 2)
      r = b.binary(oc.op, x, y);
    else
      r = b.select(b.gt(x, b.constant(0)), y, z);
    b.finish(r);
    std::mt19937_64 rng(static_cast<int>(oc.op) * 17 + same_args);
    std::vector<std::vector<Interval>> boxes;
    for (int i = 0; i < 3001; ++i) {
      std::vector<Interval> box;
      for (int k = 0; k < 3; ++k) {
        double u = endpoint(rng), v = rng() % 3 == 0 ? u : endpoint(rng);
        if (v < u) std::swap(u, v);
        box.push_back({u, v, false});
      }
      boxes.push_back(box);
    }
    EXPECT_EQ(compare(fn, boxes, {}, std::string(op_name(oc.op))), 0);
    EXPECT_EQ(compare(fn, boxes, {}, std::string(op_name(oc.op)) + " outlined", true), 0);
  }
}

INSTANTIATE_TEST_SUITE_P(AllOps, IntervalJitOpTest, ::testing::ValuesIn(kOps),
                         [](const ::testing::TestParamInfo<OpCase>& info) {
                           return std::string(op_name(info.param.op));
                         });

TEST(IntervalJitTest, RandomProgramsSameAsInterpreter) {
  constexpr int kPrograms = 40;  // LLVM compile time dominates (~0.3 s per program)
  int failures = 0;
  for (int seed = 0; seed < kPrograms && failures < 10; ++seed) {
    Function fn = testing::random_program(seed);
    std::mt19937_64 rng(seed + 77);
    std::uniform_real_distribution<double> u(0, 1);
    auto centres = testing::random_points(seed, 37, fn.num_inputs);
    const double widths[] = {0, 1e-9, 1e-3, 0.1, 1, 4};
    std::vector<std::vector<Interval>> boxes;
    for (size_t i = 0; i < centres.size(); ++i) {
      std::vector<Interval> box(fn.num_inputs);
      for (int k = 0; k < fn.num_inputs; ++k) {
        double w = widths[(i + k) % 6];
        box[k] = {centres[i][k] - w * u(rng), centres[i][k] + w * u(rng), false};
      }
      boxes.push_back(box);
    }
    std::vector<double> a = {0.5, -1.25};
    a.resize(std::max(fn.num_params, 1), 0.0);
    // Every other program with every op outlined (helpers under control-flow masks).
    const bool outlined = seed % 2 == 1;
    failures += compare(fn, boxes, a,
                        "seed " + std::to_string(seed) + (outlined ? " outlined" : ""), outlined);
  }
  EXPECT_EQ(failures, 0);
}

}  // namespace
}  // namespace hfrt::jit
