// AST -> IR lowering: HyperFun's evaluation rules, checked through the reference interpreter
// and through the shape of the IR where the shape is the point (folding, mul chains, checks).
#include "jit/lower.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ir/print.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

using testutil::compile;
using testutil::eval_source;

int count_ops(const Function& fn, Op op) {
  int n = 0;
  for (const Inst& in : fn.insts) n += in.op == op;
  return n;
}

// The error kind of the model at x (fails the test when there is none).
std::optional<ErrorKind> error_at(const std::string& text, std::vector<double> x = {1, 2, 3}) {
  EvalResult r = eval_source(text, x);
  if (!r.error) return std::nullopt;
  EXPECT_TRUE(std::isnan(r.value));
  return r.error->kind;
}

TEST(Lower, SlotLayoutOfXAAndS) {
  auto c = compile("m(x[3], a[2]) { m = x[1] + a[2]; }");
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EXPECT_EQ(c.fn.num_inputs, 3);
  EXPECT_EQ(c.fn.num_params, 2);
  ASSERT_EQ(c.fn.s_slots.size(), 1u);  // no s in the header: one s of 0
  EXPECT_EQ(c.fn.s_slots[0], 5);
  EXPECT_EQ(c.fn.slot_init[5], 0);
  double x[3] = {1, 2, 3}, a[2] = {10, 20};
  EvalResult r = Interpreter(c.fn).eval(x, a);
  EXPECT_EQ(r.value, 21);
  EXPECT_EQ(r.s, std::vector<double>({0}));

  auto d = compile("m(x[2], a[1], s[3]) { s[2] = x[2]; m = 0; }");
  ASSERT_TRUE(d.ok) << d.diagnostics;
  EXPECT_EQ(d.fn.s_slots, std::vector<int32_t>({3, 4, 5}));
  double y[2] = {7, 8};
  EXPECT_EQ(Interpreter(d.fn).eval(y, {}).s, std::vector<double>({0, 8, 0}));
}

TEST(Lower, ConstantExpressionsFoldAway) {
  auto c = compile("m(x[3], a[1]) { r = 2; q = r * 3 + 1; m = q; }");
  ASSERT_TRUE(c.ok) << c.diagnostics;
  ASSERT_EQ(c.fn.insts[c.fn.result].op, Op::kConst);
  EXPECT_EQ(c.fn.insts[c.fn.result].imm, 7);
  EXPECT_EQ(count_ops(c.fn, Op::kCheck), 0);
}

TEST(Lower, ArgumentsAreEvaluatedRightToLeft) {
  // The first error reported is the right operand's, as in the original.
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = sqrt(-x[1]) + 1/(x[1]-1); }"),
            ErrorKind::kDivisionByZero);
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = 1/(x[1]-1) + sqrt(-x[1]); }"), ErrorKind::kNegativeSqrt);
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = max(log(x[1]-1), asin(x[2])); }"), ErrorKind::kAsinRange);
}

TEST(Lower, RuntimeErrorsPointAtTheOperatorOrCall) {
  auto c = compile("m(x[3], a[1])\n{\n v = 2;\n m = v + 1/(x[1]-1) + log( x[2] - 2);\n}\n");
  ASSERT_TRUE(c.ok) << c.diagnostics;
  Interpreter interp(c.fn);
  double at_div[3] = {1, 3, 0};
  EvalResult r = interp.eval(at_div, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kDivisionByZero);
  EXPECT_EQ(r.error->loc.line, 4u);
  EXPECT_EQ(r.error->loc.col, 11u);  // the '/'
  double at_log[3] = {2, 2, 0};
  r = interp.eval(at_log, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kLogNonPositive);
  EXPECT_EQ(r.error->loc.col, 23u);  // 'log'
  EXPECT_EQ(describe_runtime_error(*r.error, c.fn),
            "test.hf:4:23: Logarithm of non-positive value");
}

TEST(Lower, ElementaryFunctionErrors) {
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = sqrt(x[1] - 1.5); }"), ErrorKind::kNegativeSqrt);
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = logd(x[1] - 1); }"), ErrorKind::kLogNonPositive);
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = acos(x[2]); }"), ErrorKind::kAcosRange);
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = 1 / (x[1] - 0.9999995); }"), ErrorKind::kDivisionByZero);
  EXPECT_FALSE(
      error_at("m(x[3], a[1]) { m = 1 / (x[1] - 0.999998) + sqrt(x[1] - 1) + acos(x[1]); }"));
}

TEST(Lower, ConstantIntegralPowersBecomeMultiplications) {
  auto c = compile("m(x[3], a[1]) { m = x[1]^3 + x[2]^-2; }");
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EXPECT_EQ(count_ops(c.fn, Op::kPowHF), 0);
  EXPECT_GE(count_ops(c.fn, Op::kMul), 3);
  double x[3] = {1.5, 2, 0};
  EXPECT_DOUBLE_EQ(Interpreter(c.fn).eval(x, {}).value, 1.5 * 1.5 * 1.5 + 0.25);
  double tiny[3] = {1e-7, 2, 0};  // |b| < 1e-6 -> 0
  EXPECT_EQ(Interpreter(c.fn).eval(tiny, {}).value, 0.25);
  double zero[3] = {1, 0, 0};  // 0 ^ -2: error
  EvalResult r = Interpreter(c.fn).eval(zero, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kZeroPower);
}

TEST(Lower, PowerSemantics) {
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = (-2)^x[3]; }").value, -8);  // integral: ok
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = (-x[1])^0.5; }"), ErrorKind::kNegativePower);
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = (-x[1])^(x[1]/2); }"), ErrorKind::kNegativePower);
  EXPECT_EQ(error_at("m(x[3], a[1]) { m = (x[1]-1)^(x[1]-1); }"), ErrorKind::kZeroPower);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = (x[1]-1)^x[2]; }").value, 0);
  EXPECT_DOUBLE_EQ(eval_source("m(x[3], a[1]) { m = x[3]^0.5; }").value,
                   std::exp(0.5 * std::log(3.0)));
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = 2^x[2]^x[1]; }").value, 4);  // left associative
}

TEST(Lower, SetOperatorsUseTheRFunctionFormulas) {
  const double a = 1, b = 2;
  const double root = std::sqrt(a * a + b * b);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = x[1] | x[2]; }").value, a + b + root);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = x[1] & x[2]; }").value, a + b - root);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = x[1] @ x[2]; }").value, a + b - root);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = x[1] \\ x[2]; }").value, a - b - root);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = ~x[1]; }").value, -1);
}

TEST(Lower, BuiltinsFollowTheSpec) {
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = mod(-7.6, x[3]); }").value, -2);
  EXPECT_TRUE(std::isnan(eval_source("m(x[3], a[1]) { m = mod(x[3], 0.2); }").value));  // fmod by 0
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = int(-x[3] - 0.5); }").value, -3);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = frac(-x[3] - 0.25); }").value, -0.25);
  EXPECT_EQ(
      eval_source("m(x[3], a[1]) { m = sign(-x[1]) + 10*sign(x[1]-1) + 100*sign(x[1]); }").value,
      99);
  EXPECT_EQ(eval_source("m(x[3], a[1]) { m = max(x[1], x[2]) + 10*min(x[1], x[2]); }").value, 12);
  EXPECT_DOUBLE_EQ(eval_source("m(x[3], a[1]) { m = atan2(x[1], x[2]); }").value,
                   std::atan2(1.0, 2.0));
  EXPECT_DOUBLE_EQ(eval_source("m(x[3], a[1]) { m = logd(x[3]*100/3); }").value, 2);
}

TEST(Lower, ConditionsAndComparisons) {
  const char* eq = "m(x[3], a[1]) { v = 0; if x[1] = 1.0000009 then v = 1; endif; m = v; }";
  EXPECT_EQ(eval_source(eq).value, 1);
  const char* ne = "m(x[3], a[1]) { v = 0; if x[1] /= 1.0000009 then v = 1; endif; m = v; }";
  EXPECT_EQ(eval_source(ne).value, 0);
  const char* chain = "m(x[3], a[1]) { v = 0; if 0 < x[1] < 0.5 then v = 1; endif; m = v; }";
  EXPECT_EQ(eval_source(chain).value, 0);  // (0 < 1) < 0.5 = 1 < 0.5
  const char* andor =
      "m(x[3], a[1]) { v = 0; if x[1] > 0 or x[1] > 0 and x[1] < 0 then v = 1; endif; m = v; }";
  EXPECT_EQ(eval_source(andor).value, 0);  // left to right, one level
  const char* truth = "m(x[3], a[1]) { v = 0; if x[1] - 0.9999995 then v = 1; endif; m = v; }";
  EXPECT_EQ(eval_source(truth).value, 0);  // |v| < 1e-6 is false
  const char* nots = "m(x[3], a[1]) { v = 0; if not (x[1] > 5) then v = 1; endif; m = v; }";
  EXPECT_EQ(eval_source(nots).value, 1);
}

TEST(Lower, IfElseAndConstantConditions) {
  const char* src = "m(x[3], a[1]) { if x[1] > 0 then v = 1; else v = 2; endif; m = v; }";
  auto c = compile(src);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EXPECT_EQ(count_ops(c.fn, Op::kCheck), 0);  // v is assigned on both paths: no check
  EXPECT_EQ(count_ops(c.fn, Op::kIf), 1);
  EXPECT_EQ(eval_source(src, {1, 0, 0}).value, 1);
  EXPECT_EQ(eval_source(src, {-1, 0, 0}).value, 2);
  auto k = compile("m(x[3], a[1]) { if 2 > 1 then v = x[1]; else v = 2; endif; m = v; }");
  ASSERT_TRUE(k.ok) << k.diagnostics;
  EXPECT_FALSE(k.fn.has_control_flow);  // decided at compile time
  EXPECT_EQ(k.fn.insts[k.fn.result].op, Op::kInput);
}

TEST(Lower, UninitialisedScalars) {
  const char* src = "m(x[3], a[1]) { if x[1] > 5 then v = 1; endif; m = v; }";
  auto c = compile(src);
  ASSERT_TRUE(c.ok);
  EXPECT_EQ(count_ops(c.fn, Op::kCheck), 1);
  EXPECT_EQ(error_at(src), ErrorKind::kUninitialized);
  EXPECT_FALSE(error_at(src, {6, 0, 0}));
  // Assigned in a loop body that may not run.
  const char* loop =
      "m(x[3], a[1]) { i = 0; while i < x[1] loop v = i; i = i + 1; endloop; m = v; }";
  EXPECT_EQ(error_at(loop, {0, 0, 0}), ErrorKind::kUninitialized);
  EXPECT_EQ(eval_source(loop, {3, 0, 0}).value, 2);
}

TEST(Lower, WhileLoops) {
  const char* sum =
      "m(x[3], a[1]) { t = 0; i = 1; while i <= x[1] loop t = t + i; i = i + 1; endloop; m = t; }";
  EXPECT_EQ(eval_source(sum, {10, 0, 0}).value, 55);
  EXPECT_EQ(eval_source(sum, {0, 0, 0}).value, 0);
  const char* nested =
      "m(x[3], a[1]) { n = 0; i = 0; while i < x[1] loop j = 0; while j < x[2] loop n = n + 1; j = "
      "j + 1; "
      "endloop; i = i + 1; endloop; m = n; }";
  EXPECT_EQ(eval_source(nested, {3, 4, 0}).value, 12);
}

TEST(Lower, EndlessLoopsStopWithLoopLimit) {
  const char* src =
      "m(x[3], a[1])\n{\n i = 0;\n while i > -1 loop i = i + 1; endloop;\n m = i;\n}\n";
  auto c = compile(src);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EvalResult r = Interpreter(c.fn).eval(std::vector<double>{0, 0, 0}, {});
  ASSERT_TRUE(r.error);
  EXPECT_EQ(r.error->kind, ErrorKind::kLoopLimit);
  EXPECT_EQ(r.error->loc.line, 4u);
}

TEST(Lower, LocalArrays) {
  const char* src =
      "m(x[3], a[1]) { array c[3]; c = [10, 20, 30]; c[2] = x[1]; m = c[x[2]] + 100*c[1.6] + "
      "1000*c[3]; }";
  EXPECT_EQ(eval_source(src, {7, 2, 0}).value, 7 + 100 * 7 + 1000 * 30);
  EXPECT_EQ(eval_source(src, {7, 1.4, 0}).value, 10 + 100 * 7 + 1000 * 30);  // indices round
  EXPECT_EQ(error_at(src, {7, 3.5, 0}), ErrorKind::kIndexOutOfRange);
  EXPECT_EQ(error_at(src, {7, 0.4, 0}), ErrorKind::kIndexOutOfRange);
  EXPECT_EQ(error_at("m(x[3], a[1]) { array c[2]; c[x[1]+2] = 1; m = 1; }"),
            ErrorKind::kIndexOutOfRange);
  // Elements read before they are assigned.
  const char* partial = "m(x[3], a[1]) { array c[3]; c[1] = 5; c[x[3]] = 6; m = c[x[1]]; }";
  EXPECT_EQ(eval_source(partial, {1, 0, 3}).value, 5);
  EXPECT_EQ(eval_source(partial, {3, 0, 3}).value, 6);
  EXPECT_EQ(error_at(partial, {2, 0, 3}), ErrorKind::kUninitialized);
  EXPECT_EQ(error_at("m(x[3], a[1]) { array c[3]; c[1] = 5; m = c[2]; }"),
            ErrorKind::kUninitialized);
}

TEST(Lower, LibraryArraysMustBeFullyAssigned) {
  const char* partial = "m(x[3], a[1]) { array c[3]; c[1] = 0; c[2] = 0; m = hfSphere(x, c, 1); }";
  EXPECT_EQ(error_at(partial), ErrorKind::kArrayUninitialized);
  auto full = compile("m(x[3], a[1]) { array c[3]; c = [0, 0, 0]; m = hfSphere(x, c, 1); }");
  ASSERT_TRUE(full.ok) << full.diagnostics;
  EXPECT_EQ(count_ops(full.fn, Op::kCheck), 0);  // provably assigned: no check emitted
  EvalResult r = Interpreter(full.fn).eval(std::vector<double>{1, 2, 3}, {});
  EXPECT_FALSE(r.error);
  EXPECT_DOUBLE_EQ(r.value, 1 - (1 + 4 + 9));  // hfSphere: R^2 - |x - c|^2
}

TEST(Lower, CalledObjectsWorkOnCopiesAndWriteBackS) {
  const char* src =
      "inner(x[3], a[1], s[2]) { s[2] = 5; t = hfShift3D(x, 1, 0, 0); inner = x[1]; }\n"
      "my_model(x[3], a[1], s[2]) { array p[3]; p = [4, 0, 0]; v = inner(p, a, s); "
      "my_model = v * 100 + p[1] * 10 + x[1]; }\n";
  auto c = compile(src);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EvalResult r = Interpreter(c.fn).eval(std::vector<double>{1, 2, 3}, {});
  ASSERT_FALSE(r.error) << describe_runtime_error(*r.error, c.fn);
  // hfShift3D moves the callee's copy (x[1] - 1 = 3); the caller's p and x stay.
  EXPECT_EQ(r.value, 3 * 100 + 4 * 10 + 1);
  EXPECT_EQ(r.s, std::vector<double>({0, 5}));
  // Without an s argument the callee's s is its own.
  auto d = compile(
      "inner(x[3], a[1], s[1]) { s[1] = 5; inner = s[1]; }\n"
      "my_model(x[3], a[1], s[1]) { my_model = inner(x, a) + s[1]; }\n");
  ASSERT_TRUE(d.ok) << d.diagnostics;
  r = Interpreter(d.fn).eval(std::vector<double>{1, 2, 3}, {});
  EXPECT_EQ(r.value, 5);
  EXPECT_EQ(r.s, std::vector<double>({0}));
}

TEST(Lower, LocalsOfACalledObjectStartUndefinedAtEveryCall) {
  const char* src =
      "inner(x[3], a[1]) { if x[1] > 0 then u = 1; endif; inner = u; }\n"
      "my_model(x[3], a[1]) { array p[3]; p[2] = 0; p[3] = 0; i = 0; t = 0;\n"
      " while i < 2 loop p[1] = 1 - 2*i; t = t + inner(p, a); i = i + 1; endloop;\n"
      " my_model = t; }\n";
  auto c = compile(src);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EvalResult r = Interpreter(c.fn).eval(std::vector<double>{1, 2, 3}, {});
  ASSERT_TRUE(r.error);  // the second call reads u, which that call never assigned
  EXPECT_EQ(r.error->kind, ErrorKind::kUninitialized);
  EXPECT_EQ(r.error->loc.line, 1u);
}

TEST(Lower, SelectsTheObjectByName) {
  const char* src =
      "first(x[3], a[1]) { first = 1; }\nsecond(x[3], a[1]) { second = first(x, a) + 1; }\n";
  auto c = compile(src);
  ASSERT_TRUE(c.ok);
  EXPECT_EQ(c.fn.name, "first");  // no my_model: the first object
  auto d = compile(src, "second");
  ASSERT_TRUE(d.ok);
  EXPECT_EQ(d.fn.name, "second");
  EXPECT_EQ(Interpreter(d.fn).eval(std::vector<double>{0, 0, 0}, {}).value, 2);
}

TEST(Lower, InstructionsCarrySourceLocations) {
  auto c = compile("m(x[3], a[1])\n{\n m = sin(x[1]) * x[2];\n}\n");
  ASSERT_TRUE(c.ok);
  int located = 0;
  for (const Inst& in : c.fn.insts) located += in.loc.valid();
  EXPECT_EQ(located, static_cast<int>(c.fn.insts.size()));
  EXPECT_EQ(c.fn.insts[c.fn.result].op, Op::kMul);
  EXPECT_EQ(c.fn.insts[c.fn.result].loc.line, 3u);
  EXPECT_EQ(c.fn.insts[c.fn.result].loc.col, 16u);  // the '*'
  EXPECT_NE(print(c.fn).find("; 3:16"), std::string::npos);
}

}  // namespace
}  // namespace hfrt::jit

namespace hfrt::jit {
namespace {

using testutil::compile;

// ---- limits on hostile input (base/limits.h) ------------------------------------------------

Limits loop_limit(int64_t n) {
  Limits l;
  l.max_loop_iterations = n;
  return l;
}

ErrorKind error_of(const testutil::Compiled& c) {
  EvalResult r = Interpreter(c.fn).eval(std::vector<double>{0, 0, 0}, {});
  return r.error ? r.error->kind : ErrorKind::kDivisionByZero;
}

TEST(Lower, LoopJustUnderTheLimitRunsAndOneMoreStops) {
  const char* src =
      "m(x[3], a[1])\n{\n i = 0;\n while i < 1000 loop i = i + 1; endloop;\n m = i;\n}\n";
  auto at = compile(src, "", "test.hf", loop_limit(1000));
  ASSERT_TRUE(at.ok) << at.diagnostics;
  EvalResult r = Interpreter(at.fn).eval(std::vector<double>{0, 0, 0}, {});
  EXPECT_FALSE(r.error);
  EXPECT_EQ(r.value, 1000);
  auto under = compile(src, "", "test.hf", loop_limit(999));
  EvalResult e = Interpreter(under.fn).eval(std::vector<double>{0, 0, 0}, {});
  ASSERT_TRUE(e.error);
  EXPECT_EQ(e.error->kind, ErrorKind::kLoopLimit);
  EXPECT_TRUE(std::isnan(e.value));
  EXPECT_EQ(describe_runtime_error(*e.error, under.fn),
            "test.hf:4:2: Loop iteration limit exceeded");
}

TEST(Lower, LoopLimitCountsEveryLoopOfTheEvaluation) {
  // 10 outer iterations + 10 x 10 inner ones = 110, in the object and an inlined call.
  const char* src =
      "inner(x[3], a[1])\n{\n n = 0;\n j = 0;\n while j < 10 loop n = n + 1; j = j + 1; endloop;\n"
      " inner = n;\n}\n"
      "m(x[3], a[1])\n{\n t = 0;\n i = 0;\n while i < 10 loop t = t + inner(x, a); i = i + 1; "
      "endloop;\n m = t;\n}\n";
  auto fits = compile(src, "m", "test.hf", loop_limit(110));
  ASSERT_TRUE(fits.ok) << fits.diagnostics;
  EvalResult r = Interpreter(fits.fn).eval(std::vector<double>{0, 0, 0}, {});
  EXPECT_FALSE(r.error);
  EXPECT_EQ(r.value, 100);
  auto over = compile(src, "m", "test.hf", loop_limit(109));
  EvalResult e = Interpreter(over.fn).eval(std::vector<double>{0, 0, 0}, {});
  ASSERT_TRUE(e.error);
  EXPECT_EQ(e.error->kind, ErrorKind::kLoopLimit);
  EXPECT_EQ(e.error->loc.line, 5u);  // the inner loop's 110th iteration
  // The counter starts again with each point.
  EXPECT_FALSE(Interpreter(fits.fn).eval(std::vector<double>{1, 0, 0}, {}).error);
}

TEST(Lower, EndlessLoopWithTheDefaultLimitStopsQuickly) {
  const char* src = "m(x[3], a[1]) { i = 0; while 1 loop i = i + 1; endloop; m = i; }";
  auto c = compile(src);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EXPECT_EQ(error_of(c), ErrorKind::kLoopLimit);
}

// Objects that call the previous one twice: the inlined size doubles at each level.
std::string doubling_chain(int levels) {
  std::string s = "o0(x[3], a[1]) { o0 = x[1] * x[2]; }\n";
  for (int i = 1; i <= levels; ++i) {
    const std::string p = "o" + std::to_string(i - 1), o = "o" + std::to_string(i);
    s += o + "(x[3], a[1]) { " + o + " = " + p + "(x, a) + " + p + "(x, a); }\n";
  }
  return s;
}

TEST(Lower, ExponentialInliningIsALocatedErrorBeforeLowering) {
  // 2^40 copies: counted on the AST, refused at once.
  const std::string src = doubling_chain(40);
  auto c = compile(src, "o40");
  ASSERT_TRUE(c.ok);
  EXPECT_NE(c.diagnostics.find("test.hf:41:25: error: object 'o40' is too large once its object "
                               "calls are inlined: "),
            std::string::npos)
      << c.diagnostics;
  EXPECT_NE(c.diagnostics.find("more than the limit of 4000000"), std::string::npos);
  EXPECT_NE(c.diagnostics.find("--max-model-size N"), std::string::npos);
  // The stub has no value anywhere.
  EXPECT_TRUE(std::isnan(Interpreter(c.fn).eval(std::vector<double>{1, 2, 3}, {}).value));
  // Ten levels fit the default; a small limit refuses them.
  EXPECT_EQ(compile(doubling_chain(10), "o10").diagnostics, "");
  Limits small;
  small.max_model_size = 1000;
  EXPECT_NE(compile(doubling_chain(10), "o10", "test.hf", small)
                .diagnostics.find("more than the limit of 1000"),
            std::string::npos);
}

TEST(Lower, SlotLimitIsLocatedAtTheLargestArray) {
  const char* src =
      "m(x[3], a[1])\n{\n array small[10], big[5000], mid[100];\n big[1] = 1;\n m = big[1];\n}\n";
  EXPECT_EQ(compile(src).diagnostics, "");
  Limits l;
  l.max_slots = 10000;  // 2 x (10 + 5000 + 100) slots with the flags, plus x, a, s
  auto c = compile(src, "", "test.hf", l);
  EXPECT_NE(c.diagnostics.find("test.hf:3:19: error: object 'm' needs 10226 slots for its "
                               "variables and array elements"),
            std::string::npos)
      << c.diagnostics;
  EXPECT_NE(c.diagnostics.find("--max-slots N"), std::string::npos);
}

}  // namespace
}  // namespace hfrt::jit
