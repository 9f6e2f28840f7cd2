// The reference interpreter: every op, control flow, run-time errors, threads.
#include "jit/interpreter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "ir/builder.h"
#include "ir/print.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();

// Evaluates `op` applied to x[1], x[2], x[3] (the inputs keep the builder from folding).
double run_op(Op op, double a, double b = 0, double c = 0) {
  Function fn;
  IrBuilder bld(fn);
  ValueId v;
  switch (op_num_args(op)) {
    case 1:
      v = bld.unary(op, bld.input(0));
      break;
    case 2:
      v = bld.binary(op, bld.input(0), bld.input(1));
      break;
    default:
      v = bld.select(bld.input(0), bld.input(1), bld.input(2));
      break;
  }
  bld.finish(v);
  EXPECT_NE(fn.insts[fn.result].op, Op::kConst);
  double x[3] = {a, b, c};
  EvalResult r = Interpreter(fn).eval(x, {});
  EXPECT_FALSE(r.error);
  return r.value;
}

TEST(Interpreter, Arithmetic) {
  EXPECT_EQ(run_op(Op::kAdd, 2, 3), 5);
  EXPECT_EQ(run_op(Op::kSub, 2, 3), -1);
  EXPECT_EQ(run_op(Op::kMul, 2, 3), 6);
  EXPECT_EQ(run_op(Op::kDiv, 3, 2), 1.5);
  EXPECT_TRUE(std::isinf(run_op(Op::kDiv, 1, 0)));  // IEEE; the HyperFun check is separate
  EXPECT_EQ(run_op(Op::kNeg, 2), -2);
  EXPECT_EQ(run_op(Op::kAbs, -2.5), 2.5);
  EXPECT_EQ(run_op(Op::kMin, 2, 3), 2);
  EXPECT_EQ(run_op(Op::kMax, 2, 3), 3);
  EXPECT_EQ(run_op(Op::kMin, kNaN, 3), 3);  // (a < b ? a : b): NaN -> b
  EXPECT_EQ(run_op(Op::kMax, kNaN, 3), 3);
  EXPECT_TRUE(std::isnan(run_op(Op::kMin, 3, kNaN)));
}

TEST(Interpreter, Elementary) {
  EXPECT_EQ(run_op(Op::kSqrt, 16), 4);
  EXPECT_TRUE(std::isnan(run_op(Op::kSqrt, -1)));
  EXPECT_DOUBLE_EQ(run_op(Op::kExp, 1), M_E);
  EXPECT_DOUBLE_EQ(run_op(Op::kLog, M_E), 1);
  EXPECT_DOUBLE_EQ(run_op(Op::kLog10, 1000), 3);
  EXPECT_DOUBLE_EQ(run_op(Op::kSin, M_PI / 2), 1);
  EXPECT_DOUBLE_EQ(run_op(Op::kCos, 0), 1);
  EXPECT_DOUBLE_EQ(run_op(Op::kTan, M_PI / 4), 1);
  EXPECT_DOUBLE_EQ(run_op(Op::kAsin, 1), M_PI / 2);
  EXPECT_DOUBLE_EQ(run_op(Op::kAcos, -1), M_PI);
  EXPECT_DOUBLE_EQ(run_op(Op::kAtan, 1), M_PI / 4);
  EXPECT_DOUBLE_EQ(run_op(Op::kAtan2, 1, -1), 3 * M_PI / 4);  // atan2(y, x) as in C
  EXPECT_DOUBLE_EQ(run_op(Op::kSinh, 1), (M_E - 1 / M_E) / 2);
  EXPECT_DOUBLE_EQ(run_op(Op::kCosh, 1), (M_E + 1 / M_E) / 2);
  EXPECT_DOUBLE_EQ(run_op(Op::kTanh, 1), (M_E - 1 / M_E) / (M_E + 1 / M_E));
  EXPECT_DOUBLE_EQ(run_op(Op::kPow, 2, 0.5), M_SQRT2);
}

TEST(Interpreter, Rounding) {
  EXPECT_EQ(run_op(Op::kFloor, -1.5), -2);
  EXPECT_EQ(run_op(Op::kCeil, -1.5), -1);
  EXPECT_EQ(run_op(Op::kTrunc, -1.7), -1);
  EXPECT_EQ(run_op(Op::kRound, 2.5), 3);
  EXPECT_EQ(run_op(Op::kRound, -2.5), -3);  // half away from zero
  EXPECT_EQ(run_op(Op::kFmod, -7, 3), -1);
  EXPECT_EQ(run_op(Op::kFmod, 7, -3), 1);
  EXPECT_TRUE(std::isnan(run_op(Op::kFmod, 7, 0)));
}

TEST(Interpreter, HyperFunPower) {
  EXPECT_EQ(run_op(Op::kPowHF, 2, 10), 1024);
  EXPECT_EQ(run_op(Op::kPowHF, -2, 3), -8);  // integral exponent: negative bases work
  EXPECT_EQ(run_op(Op::kPowHF, -2, -2), 0.25);
  EXPECT_EQ(run_op(Op::kPowHF, 3, 2.0000001), 9);  // |frac(e)| < 1e-6: integral
  EXPECT_EQ(run_op(Op::kPowHF, 5, 0), 1);
  EXPECT_EQ(run_op(Op::kPowHF, 1e-7, 2), 0);  // |b| < 1e-6 -> 0
  EXPECT_EQ(run_op(Op::kPowHF, 4, 0.5), std::exp(0.5 * std::log(4.0)));
  EXPECT_TRUE(std::isnan(run_op(Op::kPowHF, -4, 0.5)));
  // Repeated multiplication, not pow(): 1.1^3 as ((1*1.1)*1.1)*1.1.
  double m = 1.0;
  for (int i = 0; i < 3; ++i) m *= 1.1;
  EXPECT_EQ(run_op(Op::kPowHF, 1.1, 3), m);
  EXPECT_TRUE(std::isinf(run_op(Op::kPowHF, 10, 1e9)));  // huge exponents do not loop forever
}

TEST(Interpreter, SignIsMinusZeroPlus) {
  EXPECT_EQ(run_op(Op::kSign, -5), -1);
  EXPECT_EQ(run_op(Op::kSign, 0), 0);
  EXPECT_EQ(run_op(Op::kSign, 5), 1);
}

TEST(Interpreter, CbrtIsTheRealCubeRoot) {
  const double kInf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(run_op(Op::kCbrt, -8), -2);        // real, odd: not pow(x, 1/3)
  EXPECT_DOUBLE_EQ(run_op(Op::kCbrt, 27), 3);  // glibc: 3 + 1 ulp (cbrt is not correctly rounded)
  EXPECT_EQ(run_op(Op::kCbrt, 0), 0);
  EXPECT_TRUE(std::signbit(run_op(Op::kCbrt, -0.0)));
  EXPECT_EQ(run_op(Op::kCbrt, kInf), kInf);
  EXPECT_EQ(run_op(Op::kCbrt, -kInf), -kInf);
  EXPECT_TRUE(std::isnan(run_op(Op::kCbrt, kNaN)));
  // The closed form: r = cbrt(x) has r^3 = x (to rounding) and the sign of x, and grows with x.
  double last = -kInf;
  for (double x = -30; x <= 30; x += 0.37) {
    const double r = run_op(Op::kCbrt, x);
    EXPECT_NEAR(r * r * r, x, 1e-14 * std::fabs(x)) << x;
    EXPECT_EQ(std::signbit(r), std::signbit(x)) << x;
    EXPECT_GT(r, last) << x;
    last = r;
  }
  for (double x : {1e-300, 5e-324, 1e300, -2.0, 0.001})
    EXPECT_EQ(run_op(Op::kCbrt, x), std::cbrt(x));
  // Folded by the builder to the interpreter's bits; printed as `cbrt`.
  Function fn;
  IrBuilder b(fn);
  ValueId folded = b.unary(Op::kCbrt, b.constant(-3.5));
  EXPECT_EQ(fn.insts[folded].op, Op::kConst);
  EXPECT_EQ(fn.insts[folded].imm, run_op(Op::kCbrt, -3.5));
  b.finish(b.add(b.unary(Op::kCbrt, b.input(0)), folded));
  EXPECT_NE(print(fn).find(" = cbrt %"), std::string::npos) << print(fn);
}

TEST(Interpreter, Comparisons) {
  EXPECT_EQ(run_op(Op::kLt, 1, 2), 1);
  EXPECT_EQ(run_op(Op::kLt, 2, 2), 0);
  EXPECT_EQ(run_op(Op::kLe, 2, 2), 1);
  EXPECT_EQ(run_op(Op::kGt, 2, 1), 1);
  EXPECT_EQ(run_op(Op::kGe, 1, 2), 0);
  EXPECT_EQ(run_op(Op::kEqTol, 1, 1.0000005), 1);
  EXPECT_EQ(run_op(Op::kEqTol, 1, 1.000002), 0);
  EXPECT_EQ(run_op(Op::kNeTol, 1, 1.0000005), 0);
  EXPECT_EQ(run_op(Op::kNeTol, 1, 1.000002), 1);
  EXPECT_EQ(run_op(Op::kEq, 1, 1.0000005), 0);
  EXPECT_EQ(run_op(Op::kEq, 1, 1), 1);
  EXPECT_EQ(run_op(Op::kNe, 1, 1), 0);
  EXPECT_EQ(run_op(Op::kLt, kNaN, 1), 0);
}

TEST(Interpreter, TruthValues) {
  EXPECT_EQ(run_op(Op::kTruth, 1e-6), 1);
  EXPECT_EQ(run_op(Op::kTruth, -2e-7), 0);
  EXPECT_EQ(run_op(Op::kAnd, 2, -3), 1);
  EXPECT_EQ(run_op(Op::kAnd, 2, 1e-9), 0);
  EXPECT_EQ(run_op(Op::kOr, 1e-9, -1e-9), 0);
  EXPECT_EQ(run_op(Op::kOr, 1e-9, 5), 1);
  EXPECT_EQ(run_op(Op::kNot, 0.5), 0);
  EXPECT_EQ(run_op(Op::kNot, 1e-7), 1);
  EXPECT_EQ(run_op(Op::kSelect, 1, 10, 20), 10);
  EXPECT_EQ(run_op(Op::kSelect, 0, 10, 20), 20);
}

TEST(Interpreter, InputsParamsAndMissingEntries) {
  Function fn;
  fn.num_inputs = 4;
  fn.num_params = 2;
  IrBuilder b(fn);
  b.finish(b.add(b.add(b.input(0), b.input(3)), b.mul(b.param(0), b.param(1))));
  Interpreter interp(fn);
  double x[4] = {1, 2, 3, 4};
  double a[2] = {5, 6};
  EXPECT_EQ(interp.eval(x, a).value, 1 + 4 + 30);
  double x2[2] = {1, 2};
  EXPECT_EQ(interp.eval(x2, {}).value, 1);  // x[4] and a[] read as 0
}

TEST(Interpreter, IfElseAndLoops) {
  // s = 0; i = 1; while i <= x[1] loop s = s + i; i = i + 1; endloop;
  // if s > 10 then r = s; else r = -s; endif
  Function fn;
  IrBuilder b(fn);
  int s = b.new_slot(0), i = b.new_slot(0), r = b.new_slot(kNaN);
  b.store(i, b.constant(1));
  b.begin_loop();
  b.loop_test(b.le(b.load(i), b.input(0)));
  b.store(s, b.add(b.load(s), b.load(i)));
  b.store(i, b.add(b.load(i), b.constant(1)));
  b.end_loop();
  b.begin_if(b.gt(b.load(s), b.constant(10)));
  b.store(r, b.load(s));
  b.begin_else();
  b.store(r, b.neg(b.load(s)));
  b.end_if();
  b.finish(b.load(r));
  ASSERT_TRUE(fn.has_control_flow);
  Interpreter interp(fn);
  double x[1] = {4};
  EXPECT_EQ(interp.eval(x, {}).value, 10 * -1);
  x[0] = 5;
  EXPECT_EQ(interp.eval(x, {}).value, 15);
  x[0] = 0;
  EXPECT_EQ(interp.eval(x, {}).value, 0);
}

TEST(Interpreter, NestedLoops) {
  // count = 0; i = 0; while i < 3 loop j = 0; while j < x[1] loop count += 1; j += 1; endloop; i +=
  // 1; endloop
  Function fn;
  IrBuilder b(fn);
  int count = b.new_slot(0), i = b.new_slot(0), j = b.new_slot(0);
  b.begin_loop();
  b.loop_test(b.lt(b.load(i), b.constant(3)));
  b.store(j, b.constant(0));
  b.begin_loop();
  b.loop_test(b.lt(b.load(j), b.input(0)));
  b.store(count, b.add(b.load(count), b.constant(1)));
  b.store(j, b.add(b.load(j), b.constant(1)));
  b.end_loop();
  b.store(i, b.add(b.load(i), b.constant(1)));
  b.end_loop();
  b.finish(b.load(count));
  double x[1] = {4};
  EXPECT_EQ(Interpreter(fn).eval(x, {}).value, 12);
}

TEST(Interpreter, ChecksRecordTheFirstErrorAndGiveNaN) {
  Function fn;
  IrBuilder b(fn);
  lang::SourceLoc l1{0, 3, 14}, l2{0, 4, 2};
  ValueId x = b.input(0);
  b.set_loc(l1);
  b.check(b.lt(b.unary(Op::kAbs, x), b.constant(1e-6)), ErrorKind::kDivisionByZero);
  ValueId q = b.div(b.constant(1), x);
  b.set_loc(l2);
  b.check(b.lt(x, b.constant(0)), ErrorKind::kNegativeSqrt);
  b.finish(b.add(q, b.sqrt(x)));
  Interpreter interp(fn);
  double ok[1] = {4};
  EvalResult r = interp.eval(ok, {});
  EXPECT_FALSE(r.error);
  EXPECT_EQ(r.value, 0.25 + 2);
  double zero[1] = {0};
  r = interp.eval(zero, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kDivisionByZero);
  EXPECT_EQ(r.error->loc.line, 3u);
  EXPECT_EQ(r.error->loc.col, 14u);
  EXPECT_TRUE(std::isnan(r.value));
  double neg[1] = {-4};
  r = interp.eval(neg, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kNegativeSqrt);
  EXPECT_EQ(r.error->loc.line, 4u);
  EXPECT_EQ(describe_runtime_error(*r.error, fn), "4:2: Square root of negative value");
}

TEST(Interpreter, AttributesAreReturned) {
  Function fn;
  IrBuilder b(fn);
  int s1 = b.new_slot(0), s2 = b.new_slot(0);
  b.store(s2, b.mul(b.input(0), b.constant(2)));
  fn.s_slots = {s1, s2};
  b.finish(b.constant(1));
  double x[1] = {3};
  EvalResult r = Interpreter(fn).eval(x, {});
  ASSERT_EQ(r.s.size(), 2u);
  EXPECT_EQ(r.s[0], 0);
  EXPECT_EQ(r.s[1], 6);
}

TEST(Interpreter, IndexedAccessIsSafeEvenWithoutChecks) {
  Function fn;
  IrBuilder b(fn);
  int base = b.new_slot(10);
  b.new_slot(20);
  ValueId v = b.load_index(base, 2, b.input(0));
  b.finish(v);
  Interpreter interp(fn);
  double x[1] = {2};
  EXPECT_EQ(interp.eval(x, {}).value, 20);
  x[0] = 3;
  EvalResult r = interp.eval(x, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kIndexOutOfRange);
  x[0] = 1.5;
  EXPECT_TRUE(interp.eval(x, {}).error);
}

TEST(Interpreter, EndlessLoopStopsWithLoopLimit) {
  Function fn;
  IrBuilder b(fn);
  int i = b.new_slot(0);
  b.begin_loop();
  b.loop_test(b.constant(1));
  b.store(i, b.add(b.load(i), b.constant(1)));
  b.end_loop();
  b.finish(b.load(i));
  EvalResult r = Interpreter(fn, /*max_iterations=*/10000).eval({}, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kLoopLimit);
  EXPECT_TRUE(std::isnan(r.value));
}

TEST(Interpreter, ConcurrentEvaluationsAreIndependent) {
  Function fn;
  IrBuilder b(fn);
  int acc = b.new_slot(0), i = b.new_slot(0);
  b.begin_loop();
  b.loop_test(b.lt(b.load(i), b.constant(100)));
  b.store(acc, b.add(b.load(acc), b.input(0)));
  b.store(i, b.add(b.load(i), b.constant(1)));
  b.end_loop();
  b.finish(b.load(acc));
  const Interpreter interp(fn);
  std::vector<std::thread> threads;
  std::vector<int> bad(4, 0);
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (int k = 0; k < 500; ++k) {
        double x[1] = {static_cast<double>(t + 1)};
        if (interp.eval(x, {}).value != 100.0 * (t + 1)) ++bad[t];
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) EXPECT_EQ(bad[t], 0) << "thread " << t;
}

}  // namespace
}  // namespace hfrt::jit
