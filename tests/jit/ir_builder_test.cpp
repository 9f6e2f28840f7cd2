// IrBuilder: folding, sharing, store forwarding, dead-code removal, region scoping.
#include <gtest/gtest.h>

#include <cmath>

#include "ir/builder.h"
#include "ir/ir.h"
#include "ir/verify.h"
#include "jit/interpreter.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

int count_ops(const Function& fn, Op op) {
  int n = 0;
  for (const Inst& in : fn.insts) n += in.op == op;
  return n;
}

TEST(IrBuilder, FoldsConstantArithmetic) {
  Function fn;
  IrBuilder b(fn);
  ValueId v = b.add(b.mul(b.constant(2), b.constant(3)), b.constant(0.5));
  ASSERT_EQ(fn.insts[v].op, Op::kConst);
  EXPECT_EQ(fn.insts[v].imm, 6.5);
  ValueId p = b.binary(Op::kPowHF, b.constant(-2), b.constant(3));
  EXPECT_EQ(fn.insts[p].imm, -8);
  ValueId c = b.binary(Op::kEqTol, b.constant(1), b.constant(1.0000001));
  EXPECT_EQ(fn.insts[c].imm, 1);
  b.finish(v);
  // Dead constants (2, 3, 0.5, ...) were removed: only the result remains.
  EXPECT_EQ(fn.insts.size(), 1u);
  EXPECT_EQ(fn.insts[fn.result].imm, 6.5);
}

TEST(IrBuilder, FoldingAgreesWithTheInterpreterBitForBit) {
  // Folded at build time vs computed at run time from inputs: the same double.
  const double xs[] = {0.3, -1.7, 2.5, 1e-7, -0.0};
  const Op ops[] = {Op::kSin, Op::kExp, Op::kTanh, Op::kRound, Op::kSign, Op::kTruth, Op::kAtan};
  for (Op op : ops) {
    for (double x : xs) {
      Function folded;
      IrBuilder fb(folded);
      fb.finish(fb.unary(op, fb.constant(x)));
      ASSERT_EQ(folded.insts.size(), 1u);
      Function live;
      IrBuilder lb(live);
      lb.finish(lb.unary(op, lb.input(0)));
      ASSERT_GT(live.insts.size(), 1u);
      double in[3] = {x, 0, 0};
      double got = Interpreter(live).eval(in, {}).value;
      double want = folded.insts[0].imm;
      EXPECT_TRUE(got == want || (std::isnan(got) && std::isnan(want))) << op_name(op) << " " << x;
    }
  }
}

TEST(IrBuilder, SharesPureSubexpressions) {
  Function fn;
  IrBuilder b(fn);
  ValueId x = b.input(0);
  ValueId s1 = b.sqrt(b.add(x, b.constant(1)));
  ValueId s2 = b.sqrt(b.add(b.input(0), b.constant(1)));
  EXPECT_EQ(s1, s2);
  EXPECT_NE(b.add(x, b.constant(1)), b.add(b.constant(1), x));  // no commutativity assumed
  b.finish(b.add(s1, s2));
  EXPECT_EQ(count_ops(fn, Op::kSqrt), 1);
  EXPECT_EQ(count_ops(fn, Op::kInput), 1);
}

TEST(IrBuilder, SharingIsScopedToEnclosingRegions) {
  Function fn;
  IrBuilder b(fn);
  int slot = b.new_slot(0);
  ValueId x = b.input(0);
  ValueId cond = b.gt(x, b.constant(0));
  b.begin_if(cond);
  ValueId inside = b.sqrt(x);  // defined in the then-part
  b.store(slot, inside);
  b.begin_else();
  ValueId in_else = b.sqrt(x);  // must not reuse the then-part's value
  EXPECT_NE(in_else, inside);
  b.store(slot, b.neg(in_else));
  b.end_if();
  ValueId after = b.sqrt(x);  // nor after the if
  EXPECT_NE(after, inside);
  EXPECT_NE(after, in_else);
  // A value from before the if is reused inside.
  ValueId outer = b.unary(Op::kExp, x);
  b.begin_if(cond);
  EXPECT_EQ(b.unary(Op::kExp, x), outer);
  b.end_if();
  b.finish(b.add(b.load(slot), after));
  EXPECT_EQ(verify(fn), "");
}

TEST(IrBuilder, ForwardsStoresToLoadsInStraightLineCode) {
  Function fn;
  IrBuilder b(fn);
  int slot = b.new_slot(std::nan(""));
  ValueId x = b.input(0);
  b.store(slot, x);
  EXPECT_EQ(b.load(slot), x);
  int zero = b.new_slot(0);
  ValueId z = b.load(zero);  // never stored: its initial value
  ASSERT_EQ(fn.insts[z].op, Op::kConst);
  EXPECT_EQ(fn.insts[z].imm, 0);
  b.finish(b.add(b.load(slot), z));
  EXPECT_EQ(count_ops(fn, Op::kLoadSlot), 0);
  EXPECT_EQ(count_ops(fn, Op::kStoreSlot), 0);  // the slot is never read: the store is dead
}

TEST(IrBuilder, ForwardingRespectsBranchesAndLoops) {
  Function fn;
  IrBuilder b(fn);
  int v = b.new_slot(0);
  ValueId x = b.input(0);
  b.store(v, b.constant(1));
  b.begin_if(b.gt(x, b.constant(0)));
  EXPECT_EQ(fn.insts[b.load(v)].imm, 1);  // the value from before the if
  b.store(v, b.constant(2));
  b.begin_else();
  EXPECT_EQ(fn.insts[b.load(v)].imm, 1);  // the else-part does not see the then-part's store
  b.end_if();
  ValueId after_if = b.load(v);  // either 1 or 2: a real load
  EXPECT_EQ(fn.insts[after_if].op, Op::kLoadSlot);

  int i = b.new_slot(0);
  b.store(i, b.constant(0));
  b.begin_loop();
  ValueId iv = b.load(i);  // the back edge may bring a new value
  EXPECT_EQ(fn.insts[iv].op, Op::kLoadSlot);
  b.loop_test(b.lt(iv, b.constant(3)));
  b.store(i, b.add(iv, b.constant(1)));
  b.end_loop();
  ValueId i_after = b.load(i);
  EXPECT_EQ(fn.insts[i_after].op, Op::kLoadSlot);
  b.finish(b.add(after_if, i_after));
  double in[3] = {1, 0, 0};
  EXPECT_EQ(Interpreter(fn).eval(in, {}).value, 2 + 3);
  in[0] = -1;
  EXPECT_EQ(Interpreter(fn).eval(in, {}).value, 1 + 3);
}

TEST(IrBuilder, IndexedStoresInvalidateTheArray) {
  Function fn;
  IrBuilder b(fn);
  int base = b.new_slot(10);
  b.new_slot(20);
  ValueId k = b.unary(Op::kRound, b.input(0));
  ValueId before = b.load(base + 1);
  EXPECT_EQ(fn.insts[before].imm, 20);
  b.store_index(base, 2, k, b.constant(7));
  ValueId after = b.load(base + 1);
  EXPECT_EQ(fn.insts[after].op, Op::kLoadSlot);
  // A constant index becomes a direct slot access.
  ValueId direct = b.load_index(base, 2, b.constant(1));
  EXPECT_EQ(fn.insts[direct].op, Op::kLoadSlot);
  EXPECT_EQ(fn.insts[direct].aux, base);
  b.finish(b.add(after, direct));
  double in[3] = {2, 0, 0};
  EXPECT_EQ(Interpreter(fn).eval(in, {}).value, 7 + 10);
  in[0] = 1;
  EXPECT_EQ(Interpreter(fn).eval(in, {}).value, 20 + 7);
}

TEST(IrBuilder, SelectAndChecksWithConstantConditions) {
  Function fn;
  IrBuilder b(fn);
  ValueId x = b.input(0);
  ValueId y = b.input(1);
  EXPECT_EQ(b.select(b.constant(1), x, y), x);
  EXPECT_EQ(b.select(b.constant(0), x, y), y);
  b.check(b.constant(0), ErrorKind::kDivisionByZero);  // can never fire: dropped
  EXPECT_EQ(count_ops(fn, Op::kCheck), 0);
  ValueId c = b.lt(x, y);
  b.check(c, ErrorKind::kNegativeSqrt);
  b.check(c, ErrorKind::kNegativeSqrt);  // identical: shared
  EXPECT_EQ(count_ops(fn, Op::kCheck), 1);
  EXPECT_EQ(b.unary(Op::kTruth, c), c);  // comparisons are already truth values
  b.finish(x);
  EXPECT_EQ(count_ops(fn, Op::kCheck), 1);  // checks are never dead code
}

TEST(IrBuilder, TablesFoldWithConstantIndex) {
  Function fn;
  IrBuilder b(fn);
  int t = b.add_table({1.5, 2.5, 3.5});
  ValueId c = b.table_load(t, b.constant(2));
  EXPECT_EQ(fn.insts[c].imm, 3.5);
  ValueId d = b.table_load(t, b.unary(Op::kFloor, b.input(0)));
  EXPECT_EQ(fn.insts[d].op, Op::kTableLoad);
  b.finish(b.add(c, d));
  double in[3] = {1.2, 0, 0};
  EXPECT_EQ(Interpreter(fn).eval(in, {}).value, 3.5 + 2.5);
}

TEST(IrBuilder, SetsControlFlowFlagAndLocations) {
  Function fn;
  IrBuilder b(fn);
  lang::SourceLoc loc;
  loc.line = 4;
  loc.col = 9;
  b.set_loc(loc);
  ValueId x = b.input(0);
  b.check(b.lt(x, b.constant(0)), ErrorKind::kNegativeSqrt);
  ValueId r = b.sqrt(x);
  b.finish(r);
  EXPECT_FALSE(fn.has_control_flow);
  EXPECT_EQ(fn.insts[fn.result].loc.line, 4u);
  EXPECT_EQ(fn.insts[fn.result].loc.col, 9u);

  Function g;
  IrBuilder gb(g);
  int s = gb.new_slot(0);
  gb.begin_if(gb.gt(gb.input(0), gb.constant(0)));
  gb.store(s, gb.constant(1));
  gb.end_if();
  gb.finish(gb.load(s));
  EXPECT_TRUE(g.has_control_flow);
}

TEST(IrBuilderDeath, FinishRejectsAnOpenRegion) {
  Function fn;
  IrBuilder b(fn);
  ValueId x = b.input(0);
  b.begin_if(x);
  EXPECT_DEATH(b.finish(x), "open if or loop");
}

}  // namespace
}  // namespace hfrt::jit
