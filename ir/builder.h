#pragma once
// IrBuilder: the one way IR is built (the AST lowering in jit/ and the FRep library in
// stdlib/), with constant folding by the scalar semantics and common-subexpression sharing.
#include <memory>
#include <vector>

#include "ir/ir.h"
#include "lang/source.h"

namespace hfrt::ir {

/// Builds a Function with constant folding and common-subexpression sharing of pure ops
/// (only against values whose region encloses the insertion point, so sharing never breaks
/// the scoping rule). Both the AST lowering and stdlib/ build IR through this class only.
class IrBuilder {
 public:
  explicit IrBuilder(Function& fn);

  Function& function() { return fn_; }

  /// The source location stamped on the instructions emitted from now on.
  void set_loc(lang::SourceLoc loc) { loc_ = loc; }
  lang::SourceLoc loc() const { return loc_; }

  // Values.
  ValueId constant(double v);
  ValueId input(int index0);  ///< x[index0 + 1]
  ValueId param(int index0);  ///< a[index0 + 1]
  ValueId unary(Op op, ValueId a);
  ValueId binary(Op op, ValueId a, ValueId b);
  ValueId select(ValueId cond, ValueId a, ValueId b);
  ValueId table_load(int table, ValueId index0);
  int add_table(std::vector<double> values);
  /// kSurface of surfaces[index] at (x, y, z); never folded (the value comes from geom/).
  ValueId surface(int index, ValueId x, ValueId y, ValueId z);
  /// The index of `s` in Function::surfaces, adding it when new; counts one more use.
  int add_surface(std::shared_ptr<const geom::Surface> s);

  // Shorthands for library code.
  ValueId add(ValueId a, ValueId b) { return binary(Op::kAdd, a, b); }
  ValueId sub(ValueId a, ValueId b) { return binary(Op::kSub, a, b); }
  ValueId mul(ValueId a, ValueId b) { return binary(Op::kMul, a, b); }
  ValueId div(ValueId a, ValueId b) { return binary(Op::kDiv, a, b); }
  ValueId neg(ValueId a) { return unary(Op::kNeg, a); }
  ValueId sqrt(ValueId a) { return unary(Op::kSqrt, a); }
  ValueId sqr(ValueId a) { return mul(a, a); }
  ValueId lt(ValueId a, ValueId b) { return binary(Op::kLt, a, b); }
  ValueId le(ValueId a, ValueId b) { return binary(Op::kLe, a, b); }
  ValueId gt(ValueId a, ValueId b) { return binary(Op::kGt, a, b); }
  ValueId ge(ValueId a, ValueId b) { return binary(Op::kGe, a, b); }

  // Slots.
  int new_slot(double init);  ///< a fresh slot; init = NaN means "undefined"
  ValueId load(int slot);
  void store(int slot, ValueId v);
  ValueId load_index(int base_slot, int size, ValueId index1);
  void store_index(int base_slot, int size, ValueId index1, ValueId v);

  // Errors.
  void check(ValueId cond, ErrorKind kind);

  // Structured control flow. Values created inside a region are forgotten by CSE at its end.
  void begin_if(ValueId cond);
  void begin_else();
  void end_if();
  void begin_loop();
  void loop_test(ValueId cond);
  void end_loop();

  /// Sets Function::result and checks the function (HFRT_CHECK on a malformed function).
  /// Also removes dead code (unused values, stores to slots that are never loaded and are
  /// not s_slots), which RENUMBERS the values: after finish, use Function::result, not the
  /// ValueIds returned while building. Slot numbers do not change. (The builder also
  /// forwards stores to later loads of the same slot in straight-line code, so load() may
  /// return the stored value itself rather than a kLoadSlot.)
  void finish(ValueId result);

 private:
  struct Impl;
  Function& fn_;
  lang::SourceLoc loc_;
  std::shared_ptr<Impl> impl_;
};

}  // namespace hfrt::ir
