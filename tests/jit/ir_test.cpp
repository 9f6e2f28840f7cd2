// The op table, the verifier and the printer of ir/ (ir.h, verify.h, print.h).
#include "ir/ir.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>

#include "ir/print.h"
#include "ir/verify.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

TEST(IrOps, NamesAreSnakeCaseAndUnique) {
  std::set<std::string> names;
  for (int i = 0; i < kOpCount; ++i) {
    std::string name(op_name(static_cast<Op>(i)));
    EXPECT_FALSE(name.empty());
    for (char c : name)
      EXPECT_TRUE((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_') << name;
    names.insert(name);
  }
  EXPECT_EQ(names.size(), static_cast<size_t>(kOpCount));
  EXPECT_EQ(op_name(Op::kLoadSlot), "load_slot");
  EXPECT_EQ(op_name(Op::kPowHF), "pow_hf");
  EXPECT_EQ(op_name(Op::kEqTol), "eq_tol");
  EXPECT_EQ(op_name(Op::kAdd), "add");
}

TEST(IrOps, ArityAndFlagsFollowTheOpList) {
  EXPECT_EQ(op_num_args(Op::kConst), 0);
  EXPECT_EQ(op_num_args(Op::kNeg), 1);
  EXPECT_EQ(op_num_args(Op::kAtan2), 2);
  EXPECT_EQ(op_num_args(Op::kSelect), 3);
  EXPECT_EQ(op_num_args(Op::kStoreIdx), 2);
  EXPECT_TRUE(op_is_pure(Op::kMul));
  EXPECT_TRUE(op_has_value(Op::kMul));
  EXPECT_FALSE(op_is_pure(Op::kLoadSlot));
  EXPECT_TRUE(op_has_value(Op::kLoadSlot));
  EXPECT_FALSE(op_has_value(Op::kStoreSlot));
  EXPECT_FALSE(op_has_value(Op::kCheck));
  EXPECT_TRUE(op_flags_of(Op::kIf) & op_flags::kCtl);
  EXPECT_FALSE(op_flags_of(Op::kAdd) & op_flags::kCtl);
}

TEST(IrOps, ErrorMessagesAreTheOriginals) {
  EXPECT_EQ(error_message(ErrorKind::kDivisionByZero), "Division by zero");
  EXPECT_EQ(error_message(ErrorKind::kUninitialized), "Not initialized variable");
  EXPECT_EQ(error_message(ErrorKind::kNegativePower), "Negative value for power");
  EXPECT_EQ(error_kind_name(ErrorKind::kIndexOutOfRange), "IndexOutOfRange");
  EXPECT_EQ(error_kind_count(), static_cast<int>(ErrorKind::kLoopLimit) + 1);
}

// A tiny hand-made function: %0 = input x[1]; %1 = const 2; %2 = mul %0, %1.
Function straight_line() {
  Function fn;
  fn.name = "f";
  Inst in;
  in.op = Op::kInput;
  in.aux = 0;
  fn.insts.push_back(in);
  in = Inst{};
  in.op = Op::kConst;
  in.imm = 2;
  fn.insts.push_back(in);
  in = Inst{};
  in.op = Op::kMul;
  in.args[0] = 0;
  in.args[1] = 1;
  in.loc.line = 3;
  in.loc.col = 14;
  fn.insts.push_back(in);
  fn.result = 2;
  return fn;
}

Inst make(Op op, ValueId a0 = kNoValue, ValueId a1 = kNoValue, int aux = 0, double imm = 0) {
  Inst in;
  in.op = op;
  in.args[0] = a0;
  in.args[1] = a1;
  in.aux = aux;
  in.imm = imm;
  return in;
}

TEST(IrVerify, AcceptsWellFormed) {
  EXPECT_EQ(verify(straight_line()), "");
}

TEST(IrVerify, RejectsUseBeforeDefinition) {
  Function fn = straight_line();
  fn.insts[2].args[1] = 2;
  EXPECT_NE(verify(fn).find("not defined before use"), std::string::npos) << verify(fn);
}

TEST(IrVerify, RejectsMissingAndExtraArguments) {
  Function fn = straight_line();
  fn.insts[2].args[1] = kNoValue;
  EXPECT_NE(verify(fn).find("missing argument"), std::string::npos);
  fn = straight_line();
  fn.insts[1].args[0] = 0;
  EXPECT_NE(verify(fn).find("unused argument"), std::string::npos);
}

TEST(IrVerify, RejectsNonValueArgument) {
  Function fn;
  fn.num_slots = 1;
  fn.slot_init = {0};
  fn.insts = {make(Op::kConst), make(Op::kStoreSlot, 0), make(Op::kNeg, 1)};
  fn.result = 0;
  EXPECT_NE(verify(fn).find("not a value"), std::string::npos) << verify(fn);
}

TEST(IrVerify, RejectsSlotOutOfRange) {
  Function fn;
  fn.num_slots = 2;
  fn.slot_init = {0, 0};
  fn.insts = {make(Op::kConst), make(Op::kStoreSlot, 0, kNoValue, 2)};
  fn.result = 0;
  EXPECT_NE(verify(fn).find("slot 2 out of range"), std::string::npos) << verify(fn);
  fn.insts[1].aux = 1;
  EXPECT_EQ(verify(fn), "");
  fn.slot_init.pop_back();
  EXPECT_NE(verify(fn).find("slot_init"), std::string::npos);
}

TEST(IrVerify, RejectsIndexedArrayBeyondSlots) {
  Function fn;
  fn.num_slots = 3;
  fn.slot_init = {0, 0, 0};
  fn.insts = {make(Op::kConst, kNoValue, kNoValue, 0, 1), make(Op::kLoadIdx, 0, kNoValue, 1, 2)};
  fn.result = 1;
  EXPECT_EQ(verify(fn), "");
  fn.insts[1].imm = 3;  // slots 1..3, but only 0..2 exist
  EXPECT_NE(verify(fn).find("out of the slot range"), std::string::npos) << verify(fn);
  fn.insts[1].imm = 1.5;
  EXPECT_NE(verify(fn), "");
}

TEST(IrVerify, RejectsInputAndParamOutOfHeader) {
  Function fn;
  fn.num_inputs = 2;
  fn.insts = {make(Op::kInput, kNoValue, kNoValue, 2)};
  fn.result = 0;
  EXPECT_NE(verify(fn).find("input index"), std::string::npos);
  fn.insts[0] = make(Op::kParam, kNoValue, kNoValue, 1);
  EXPECT_NE(verify(fn).find("param index"), std::string::npos);
}

TEST(IrVerify, ValuesDoNotEscapeTheirRegion) {
  // %0 = const 1; if %0; %2 = neg %0; endif; result %2  -> the result escapes the if.
  Function fn;
  fn.insts = {make(Op::kConst), make(Op::kIf, 0), make(Op::kNeg, 0), make(Op::kEndIf)};
  fn.has_control_flow = true;
  fn.result = 2;
  EXPECT_NE(verify(fn).find("outermost"), std::string::npos) << verify(fn);
  // Used after the region closed.
  fn.insts.push_back(make(Op::kAbs, 2));
  fn.result = 4;
  EXPECT_NE(verify(fn).find("outside the region"), std::string::npos) << verify(fn);
  // Then-part values are not visible in the else-part.
  Function g;
  g.insts = {make(Op::kConst), make(Op::kIf, 0),  make(Op::kNeg, 0),
             make(Op::kElse),  make(Op::kAbs, 2), make(Op::kEndIf)};
  g.has_control_flow = true;
  g.result = 0;
  EXPECT_NE(verify(g).find("outside the region"), std::string::npos) << verify(g);
  // Outer values are visible inside.
  g.insts[4].args[0] = 0;
  EXPECT_EQ(verify(g), "");
}

TEST(IrVerify, StructureOfLoopsAndIfs) {
  Function fn;
  fn.insts = {make(Op::kConst), make(Op::kLoop), make(Op::kLoopTest, 0), make(Op::kEndLoop)};
  fn.has_control_flow = true;
  fn.result = 0;
  EXPECT_EQ(verify(fn), "");
  fn.insts = {make(Op::kConst), make(Op::kLoop), make(Op::kEndLoop)};
  EXPECT_NE(verify(fn).find("without loop_test"), std::string::npos);
  fn.insts = {make(Op::kConst), make(Op::kLoop), make(Op::kLoopTest, 0), make(Op::kLoopTest, 0),
              make(Op::kEndLoop)};
  EXPECT_NE(verify(fn).find("second loop_test"), std::string::npos);
  // A loop test nested in an if of the loop is not at the loop's level.
  fn.insts = {make(Op::kConst),       make(Op::kLoop),  make(Op::kIf, 0),
              make(Op::kLoopTest, 0), make(Op::kEndIf), make(Op::kEndLoop)};
  EXPECT_NE(verify(fn).find("not directly inside a loop"), std::string::npos);
  fn.insts = {make(Op::kConst), make(Op::kIf, 0)};
  EXPECT_NE(verify(fn).find("unterminated"), std::string::npos);
  fn.insts = {make(Op::kConst), make(Op::kElse)};
  EXPECT_NE(verify(fn).find("else without if"), std::string::npos);
  fn.insts = {make(Op::kConst), make(Op::kIf, 0), make(Op::kEndLoop)};
  EXPECT_NE(verify(fn), "");
  fn.insts = {make(Op::kConst), make(Op::kIf, 0), make(Op::kEndIf)};
  fn.has_control_flow = false;
  EXPECT_NE(verify(fn).find("has_control_flow"), std::string::npos);
}

TEST(IrVerify, RejectsBadResultAndCheckKind) {
  Function fn = straight_line();
  fn.result = kNoValue;
  EXPECT_NE(verify(fn), "");
  fn.result = 7;
  EXPECT_NE(verify(fn), "");
  fn = straight_line();
  fn.insts.push_back(make(Op::kCheck, 2, kNoValue, 200));
  EXPECT_NE(verify(fn).find("unknown error kind"), std::string::npos);
  fn.insts.back().aux = static_cast<int>(ErrorKind::kDivisionByZero);
  EXPECT_EQ(verify(fn), "");
}

TEST(IrPrint, OneInstructionPerLineWithLocation) {
  std::string text = print(straight_line());
  EXPECT_NE(text.find("%0 = input x[1]"), std::string::npos) << text;
  EXPECT_NE(text.find("%1 = const 2"), std::string::npos) << text;
  EXPECT_NE(text.find("%2 = mul %0, %1"), std::string::npos) << text;
  EXPECT_NE(text.find("; 3:14"), std::string::npos) << text;
  EXPECT_NE(text.find("return %2"), std::string::npos) << text;
}

TEST(IrPrint, IndentsByNesting) {
  Function fn;
  fn.num_slots = 1;
  fn.slot_init = {std::nan("")};
  fn.insts = {make(Op::kConst, kNoValue, kNoValue, 0, 1),
              make(Op::kLoop),
              make(Op::kLoopTest, 0),
              make(Op::kIf, 0),
              make(Op::kStoreSlot, 0),
              make(Op::kEndIf),
              make(Op::kEndLoop)};
  fn.has_control_flow = true;
  fn.result = 0;
  ASSERT_EQ(verify(fn), "");
  std::string text = print(fn);
  EXPECT_NE(text.find("\n  loop\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\n    loop_test %0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\n      store_slot $0, %0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\n    end_if\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\n  end_loop\n"), std::string::npos) << text;
}

}  // namespace
}  // namespace hfrt::jit
