// The interval interpreter on whole programs: hand-built IR with ambiguous branches, loops
// and min/max traces, then seeded random programs (the shared generator) over random boxes.
// Every sampled point's value from the reference interpreter must lie in the interval (or be
// NaN with maybe_nan set), and the program pruned by the min/max/select trace must give the
// same values as the original at every sampled point of the box.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "ir/builder.h"
#include "ir/print.h"
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

Function sphere() {
  Function fn;
  IrBuilder b(fn);
  ValueId r2 = b.add(b.add(b.sqr(b.input(0)), b.sqr(b.input(1))), b.sqr(b.input(2)));
  b.finish(b.sub(b.constant(1), r2));
  return fn;
}

TEST(IntervalInterpreterTest, SphereBoxes) {
  Function fn = sphere();
  IntervalInterpreter ii(fn);
  Interval inside = ii.eval_box(-0.1, 0.1, -0.1, 0.1, -0.1, 0.1);
  EXPECT_GT(inside.lo, 0.9);
  EXPECT_LE(inside.hi, 1.0 + 1e-12);
  EXPECT_GE(inside.hi, 1.0);  // the centre is in the box
  EXPECT_FALSE(inside.maybe_nan);
  Interval outside = ii.eval_box(2, 3, 2, 3, 2, 3);
  EXPECT_LT(outside.hi, 0);
  Interval across = ii.eval_box(0.5, 1.5, -0.1, 0.1, -0.1, 0.1);
  EXPECT_LT(across.lo, 0);
  EXPECT_GT(across.hi, 0);
}

TEST(IntervalInterpreterTest, MinMaxTraceSaysWhichSideDecided) {
  Function fn;
  IrBuilder b(fn);
  ValueId x = b.input(0), y = b.input(1);
  ValueId m = b.binary(Op::kMax, x, y);
  ValueId n = b.binary(Op::kMin, m, b.constant(5));
  b.finish(n);
  IntervalInterpreter ii(fn);
  std::vector<uint8_t> choices;
  Interval xs[3] = {{2, 3}, {0, 1}, {0, 0}};
  Interval r = ii.eval(xs, {}, &choices);
  EXPECT_EQ(r, (Interval{2, 3, false}));
  EXPECT_EQ(choices[m], kChoiceLeft);
  EXPECT_EQ(choices[n], kChoiceLeft);
  Interval ys[3] = {{0, 1}, {2, 7}, {0, 0}};
  r = ii.eval(ys, {}, &choices);
  EXPECT_EQ(r, (Interval{2, 5, false}));
  EXPECT_EQ(choices[m], kChoiceRight);
  EXPECT_EQ(choices[n], kChoiceBoth);
}

TEST(IntervalInterpreterTest, AmbiguousIfTakesTheHullOfBothSides) {
  // s = 0; if x > 0 then s = 10 + x else s = -1 endif; F = s
  Function fn;
  IrBuilder b(fn);
  int slot = b.new_slot(0);
  ValueId x = b.input(0);
  b.begin_if(b.gt(x, b.constant(0)));
  b.store(slot, b.add(b.constant(10), x));
  b.begin_else();
  b.store(slot, b.constant(-1));
  b.end_if();
  b.finish(b.load(slot));
  IntervalInterpreter ii(fn);
  Interval r = ii.eval_box(-1, 1, 0, 0, 0, 0);
  EXPECT_EQ(r.lo, -1);
  EXPECT_GE(r.hi, 11);
  EXPECT_LT(r.hi, 11.000001);
  r = ii.eval_box(1, 2, 0, 0, 0, 0);
  EXPECT_GE(r.lo, 10.999999);
  EXPECT_LE(r.lo, 11);
  r = ii.eval_box(-2, -1, 0, 0, 0, 0);
  EXPECT_EQ(r, (Interval{-1, -1, false}));
}

TEST(IntervalInterpreterTest, LoopsHullLanesAndGiveUpAfterTheBound) {
  // i = 0; s = 0; while i < x loop s = s + 1; i = i + 1; endloop; F = s
  Function fn;
  IrBuilder b(fn);
  int i = b.new_slot(0), s = b.new_slot(0);
  b.begin_loop();
  b.loop_test(b.lt(b.load(i), b.input(0)));
  b.store(s, b.add(b.load(s), b.constant(1)));
  b.store(i, b.add(b.load(i), b.constant(1)));
  b.end_loop();
  b.finish(b.load(s));
  IntervalInterpreter ii(fn, 100);
  Interval r = ii.eval_box(2.5, 5.5, 0, 0, 0, 0);  // 3 to 6 trips
  EXPECT_LE(r.lo, 3);
  EXPECT_GE(r.lo, 2.999999);
  EXPECT_GE(r.hi, 6);
  EXPECT_LE(r.hi, 6.000001);
  EXPECT_FALSE(r.maybe_nan);
  r = ii.eval_box(0, 1e9, 0, 0, 0, 0);  // beyond the bound: give up
  EXPECT_EQ(r.lo, -kInf);
  EXPECT_EQ(r.hi, kInf);
  EXPECT_TRUE(r.maybe_nan);
}

TEST(IntervalInterpreterTest, ChecksThatMayFireSetMaybeNan) {
  Function fn;
  IrBuilder b(fn);
  ValueId x = b.input(0);
  b.check(b.lt(x, b.constant(0)), ErrorKind::kNegativeSqrt);
  b.finish(b.sqrt(x));
  IntervalInterpreter ii(fn);
  EXPECT_FALSE(ii.eval_box(1, 4, 0, 0, 0, 0).maybe_nan);
  EXPECT_TRUE(ii.eval_box(-1, 4, 0, 0, 0, 0).maybe_nan);
}

/// The program with every kMin/kMax/kSelect whose trace names one side replaced by that side
/// (min(a, a) is exactly a, select(c, b, b) exactly b), as a renderer would prune it.
Function prune(const Function& fn, const std::vector<uint8_t>& choices) {
  Function out = fn;
  for (size_t i = 0; i < out.insts.size(); ++i) {
    Inst& in = out.insts[i];
    if (choices[i] != kChoiceLeft && choices[i] != kChoiceRight) continue;
    if (in.op == Op::kMin || in.op == Op::kMax) {
      ValueId keep = in.args[choices[i] == kChoiceLeft ? 0 : 1];
      in.args[0] = in.args[1] = keep;
    } else if (in.op == Op::kSelect) {
      ValueId keep = in.args[choices[i] == kChoiceLeft ? 1 : 2];
      in.args[1] = in.args[2] = keep;
    }
  }
  return out;
}

bool same_value(double u, double v) {
  return (u != u && v != v) || u == v;
}

TEST(IntervalInterpreterTest, RandomProgramsContainEverySampledPoint) {
  constexpr int kPrograms = 300;
  constexpr int kBoxes = 12;
  constexpr int kSamples = 24;
  int failures = 0;
  int64_t checked = 0, pruned_checked = 0;
  for (int seed = 0; seed < kPrograms && failures < 10; ++seed) {
    Function fn = testing::random_program(seed);
    Interpreter interp(fn);
    IntervalInterpreter ii(fn);
    std::mt19937_64 rng(seed * 7919 + 1);
    std::uniform_real_distribution<double> u(0, 1);
    auto centres = testing::random_points(seed, kBoxes, fn.num_inputs);
    std::vector<double> a = {0.5, -1.25};
    a.resize(std::max(fn.num_params, 1), 0.0);
    const double widths[] = {0, 1e-9, 1e-3, 0.1, 1, 4};
    for (int bi = 0; bi < kBoxes && failures < 10; ++bi) {
      std::vector<Interval> box(fn.num_inputs);
      for (int k = 0; k < fn.num_inputs; ++k) {
        double w = widths[(bi + k * 3 + seed) % 6];
        box[k] = {centres[bi][k] - w * u(rng), centres[bi][k] + w * u(rng), false};
      }
      std::vector<uint8_t> choices;
      Interval r = ii.eval(box, a, &choices);
      Function pruned_fn = prune(fn, choices);
      Interpreter pruned(pruned_fn);
      for (int si = 0; si < kSamples; ++si) {
        std::vector<double> p(fn.num_inputs);
        for (int k = 0; k < fn.num_inputs; ++k) {
          double t = si < 2 ? si : u(rng);  // both corners, then random points
          if (si >= 2 && si < 6) t = std::round(t);
          p[k] = box[k].lo + (box[k].hi - box[k].lo) * t;
          if (!(p[k] <= box[k].hi)) p[k] = box[k].hi;
        }
        double v = interp.eval(p, a).value;
        ++checked;
        if (!r.contains(v) && failures++ < 10) {
          std::ostringstream os;
          os.precision(17);
          for (double c : p) os << c << " ";
          ADD_FAILURE() << "seed " << seed << ": F(" << os.str() << ") = " << v << " not in "
                        << str(r) << "\n"
                        << print(fn);
        }
        double pv = pruned.eval(p, a).value;
        ++pruned_checked;
        if (!same_value(v, pv) && failures++ < 10) {
          ADD_FAILURE() << "seed " << seed << ": pruned program gives " << pv << " instead of "
                        << v;
        }
      }
    }
  }
  EXPECT_EQ(checked, int64_t{kPrograms} * kBoxes * kSamples);
  EXPECT_EQ(pruned_checked, checked);
}

}  // namespace
}  // namespace hfrt::jit
