#pragma once
// hfrt's one IR: a flat instruction list in SSA form with structured control flow markers
// (see ir_ops.h for the op list and the semantics of each op). Lowering produces it once;
// the interpreter and every LLVM emitter consume the same Function. No LLVM types here.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "jit/ir_ops.h"
#include "lang/source.h"

namespace hfrt::geom {
class Surface;  // geom/surface.h: the IR only holds shared pointers to it
}  // namespace hfrt::geom

namespace hfrt::jit {

namespace op_flags {
inline constexpr unsigned kPure = 1;
inline constexpr unsigned kValue = 2;
inline constexpr unsigned kCtl = 4;
}  // namespace op_flags

enum class Op : uint8_t {
#define HFRT_X(name, n, f) k##name,
  HFRT_IR_OPS(HFRT_X)
#undef HFRT_X
};

inline constexpr int kOpCount = 0
#define HFRT_X(name, n, f) +1
    HFRT_IR_OPS(HFRT_X)
#undef HFRT_X
    ;

enum class ErrorKind : uint8_t {
#define HFRT_X(name, msg) k##name,
  HFRT_IR_ERRORS(HFRT_X)
#undef HFRT_X
};

std::string_view op_name(Op op);

int op_num_args(Op op);
unsigned op_flags_of(Op op);
inline bool op_is_pure(Op op) {
  return op_flags_of(op) & op_flags::kPure;
}
inline bool op_has_value(Op op) {
  return op_flags_of(op) & op_flags::kValue;
}
std::string_view error_message(ErrorKind kind);
/// The enum spelling without the k, e.g. "DivisionByZero" (printer, tests, tools).
std::string_view error_kind_name(ErrorKind kind);
/// Number of ErrorKind values.
int error_kind_count();

/// A value is the index of the instruction that defines it.
using ValueId = uint32_t;
inline constexpr ValueId kNoValue = UINT32_MAX;

struct Inst {
  Op op = Op::kConst;
  ValueId args[3] = {kNoValue, kNoValue, kNoValue};
  double imm = 0;       ///< kConst value; kLoadIdx/kStoreIdx array size
  int32_t aux = 0;      ///< slot, input/param index, table id, or ErrorKind
  lang::SourceLoc loc;  ///< where in the source this came from (for run-time errors)
};

/// A lowered object: evaluates F (and the attributes s[]) at one point.
struct Function {
  std::string name;
  std::vector<Inst> insts;
  int num_inputs = 3;  ///< x size of the object's header
  int num_params = 1;  ///< a size
  /// Parameters from this index on are numbers of the source turned into parameters
  /// (hoist_constants): always finite, so evaluators need not guard them against NaN.
  int hoisted_params_from = 1 << 30;
  int num_slots = 0;  ///< mutable scalar slots (locals, array elements, x copy, ...)
  std::vector<double>
      slot_init;              ///< initial value of each slot at every evaluation (NaN = undefined)
  ValueId result = kNoValue;  ///< F: a value defined at the outermost level
  std::vector<int32_t> s_slots;             ///< slots holding s[1..k] at the end of the evaluation
  std::vector<std::vector<double>> tables;  ///< constant tables for kTableLoad
  /// The mesh and patch surfaces of kSurface (aux indexes this list). Shared (one loaded file
  /// serves every leaf and every model that uses it) and immutable; compiled code holds raw
  /// pointers to them, so the Function must outlive its code (it does: see jit/model.cpp).
  std::vector<std::shared_ptr<const geom::Surface>> surfaces;
  /// Per surface, how many kSurface leaves use it (instancing, `hfrt render --stats`).
  std::vector<int> surface_uses;
  bool has_control_flow = false;  ///< any kIf/kLoop (else the list is a straight-line tape)
  std::shared_ptr<const lang::SourceFile> source;  ///< for locating run-time errors
};

/// Checks the structure rules of ir_ops.h (nesting, def-before-use, scoping, slot ranges).
/// Returns an empty string when the function is well formed, else a description.
std::string verify(const Function& fn);

/// Text form for `hfrt ir` and golden tests: one instruction per line, indented by nesting,
/// e.g. `%12 = add %10, %11    ; 3:14`.
std::string print(const Function& fn);

/// Control-flow partners, for evaluators that jump over regions: kIf -> its kElse or kEndIf,
/// kElse -> kEndIf, kLoop -> kLoopTest, kLoopTest -> kEndLoop, kEndLoop -> its kLoop; -1
/// elsewhere. HFRT_CHECKs proper nesting (the verifier's contract).
std::vector<int32_t> match_regions(const Function& fn);

/// True when value v is the R-function f1 + f2 + sqrt(f1*f1 + f2*f2) (*plus: the union of the
/// lowering's `|` and the library) or f1 + f2 - sqrt(...) (intersection `&`, subtraction `\`
/// with f2 = -g), in the IR shape jit/lower.cpp r_function emits.
bool match_r_function(const Function& fn, ValueId v, ValueId* f1, ValueId* f2, bool* plus);

/// The R-function nodes of a function, per instruction: kind 0 (none), 1 (union, plus) or 2
/// (intersection), with its operands f1, f2 at args[2 i], args[2 i + 1] (kNoValue elsewhere).
struct RFunctionNodes {
  std::vector<uint8_t> kind;
  std::vector<ValueId> args;
};
RFunctionNodes find_r_functions(const Function& fn);

/// Per instruction: 1 when its value is the same for every point (every lane of a vector
/// evaluator): computed from constants, parameters and tables by pure ops, and from variables
/// (slots) that only ever hold such values, stored under conditions that are such values
/// (a loop over a constant count, `if mod(i, 2) = 0`). A vector evaluator may compute such a
/// value once and broadcast it (the per-lane libm calls of sin, cos, fmod, pow).
std::vector<uint8_t> uniform_values(const Function& fn);

/// Turns the numeric constants of `fn` whose every use is plain arithmetic (an operand of
/// + - * /, min, max, negation, or a value stored to a variable) into parameters
/// a[num_params + j] and returns their values (value j for parameter num_params + j, in
/// instruction order); fn.num_params grows by their number. Every evaluator computes the
/// same results with those values passed as parameters (constants and parameters are both
/// runtime-invariant inputs to every domain), so that code compiled for the hoisted function
/// serves every edit that changes only such numbers (the REPL). Constants that other uses
/// read as compile-time facts stay: exponents, comparisons and conditions, indices,
/// surface arguments, and anything else not listed.
std::vector<double> hoist_constants(Function* fn);

/// A text equal for two functions exactly when they compute the same from the same inputs
/// and parameters: instructions (ops, operands, immediates), slots and their initial values,
/// tables, surfaces, attributes, and the line and column of every instruction but a
/// hoisted parameter (where errors are reported). The key of compiled-code sharing.
std::string structure_key(const Function& fn);

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

}  // namespace hfrt::jit
