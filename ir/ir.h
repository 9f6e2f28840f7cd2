#pragma once
// hfrt's one IR: a flat instruction list in SSA form with structured control flow markers
// (see ir_ops.h for the op list and the semantics of each op). Lowering produces it once;
// the interpreter and every LLVM emitter consume the same Function. No LLVM types here.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "ir/ir_ops.h"
#include "lang/source.h"

namespace hfrt::geom {
class Surface;  // geom/surface.h: the IR only holds shared pointers to it
}  // namespace hfrt::geom

namespace hfrt::ir {

namespace op_flags {
inline constexpr unsigned kPure = 1;
inline constexpr unsigned kValue = 2;
inline constexpr unsigned kCtl = 4;
inline constexpr unsigned kHoistUse =
    8;  ///< an argument may be a hoisted constant (hoist_constants)
inline constexpr unsigned kTraced = 16;  ///< records min/max/select choice bits (interval trace)
}  // namespace op_flags

/// What an op is (the `kind` column of ir_ops.h).
enum class OpKind : uint8_t {
  kLeaf,     ///< kConst, kInput, kParam
  kSlot,     ///< loads and stores of slots
  kTable,    ///< kTableLoad
  kArith,    ///< computed from its arguments by apply_op (not piecewise constant)
  kStep,     ///< computed from its arguments, piecewise constant but not 0/1
  kBool,     ///< computed from its arguments, always 0 or 1 (piecewise constant)
  kSurface,  ///< kSurface
  kCheck,    ///< kCheck
  kCtl,      ///< structured control flow markers
};

/// How the vector emitters compute an op's value (the `lane` column of ir_ops.h).
enum class OpLane : uint8_t {
  kNone,       ///< not computed from arguments
  kInline,     ///< vector code
  kIntrinsic,  ///< an IEEE-exact LLVM intrinsic (the libm name is its fallback symbol)
  kLibm,       ///< a per-lane call of the libm function op_libm_name
  kHelper,     ///< a per-lane call of hfrt's C helper op_libm_name
};

/// How the polynomial analysis treats an op (the `poly` column of ir_ops.h).
enum class OpPolyRule : uint8_t {
  kNA,       ///< not computed from arguments (handled per op)
  kNone,     ///< never a polynomial of x (only of degree 0)
  kAddSub,   ///< sum or difference: the larger degree
  kNeg,      ///< the same degree
  kMul,      ///< the sum of the degrees
  kDiv,      ///< only by a value independent of x
  kSqrt,     ///< a square-root form A + B sqrt(C)
  kPow,      ///< a power with an integral constant exponent
  kSelect,   ///< a choice by a condition independent of x
  kMinMax,   ///< a set operation (skeleton node), not arithmetic
  kCompare,  ///< a comparison or logic op (0/1): not a polynomial when it depends on x
};

enum class Op : uint8_t {
#define HFRT_X(name, ...) k##name,
  HFRT_IR_OPS(HFRT_X)
#undef HFRT_X
};

inline constexpr int kOpCount = 0
#define HFRT_X(name, ...) +1
    HFRT_IR_OPS(HFRT_X)
#undef HFRT_X
    ;

namespace detail {

/// One row of the X-macro (ir_ops.h).
struct OpInfo {
  std::string_view camel;  ///< as written in the X-macro, e.g. "LoadSlot"
  int num_args;
  unsigned flags;
  OpKind kind;
  OpLane lane;
  const char* libm_f64;  ///< Intrinsic/Libm/Helper lanes: the C function's name, else null
  const char* libm_f32;
  OpPolyRule poly;
};

// The C function names of the `libm` column, by lane.
#define HFRT_OP_LIBM_NAMES_None(t) nullptr, nullptr
#define HFRT_OP_LIBM_NAMES_Inline(t) nullptr, nullptr
#define HFRT_OP_LIBM_NAMES_Intrinsic(t) #t, #t "f"
#define HFRT_OP_LIBM_NAMES_Libm(t) #t, #t "f"
#define HFRT_OP_LIBM_NAMES_Helper(t) #t "_f64", #t "_f32"

using namespace op_flags;
inline constexpr OpInfo kOpInfo[kOpCount] = {
#define HFRT_X(name, n, f, kind, lane, libm, poly) \
  {#name,                                          \
   n,                                              \
   f,                                              \
   OpKind::k##kind,                                \
   OpLane::k##lane,                                \
   HFRT_OP_LIBM_NAMES_##lane(libm),                \
   OpPolyRule::k##poly},
    HFRT_IR_OPS(HFRT_X)
#undef HFRT_X
};

}  // namespace detail

enum class ErrorKind : uint8_t {
#define HFRT_X(name, msg) k##name,
  HFRT_IR_ERRORS(HFRT_X)
#undef HFRT_X
};

/// The printer's name, e.g. "load_slot" (snake_case of the X-macro's spelling).
std::string_view op_name(Op op);

constexpr int op_num_args(Op op) {
  return detail::kOpInfo[static_cast<int>(op)].num_args;
}
constexpr unsigned op_flags_of(Op op) {
  return detail::kOpInfo[static_cast<int>(op)].flags;
}
constexpr bool op_is_pure(Op op) {
  return op_flags_of(op) & op_flags::kPure;
}
constexpr bool op_has_value(Op op) {
  return op_flags_of(op) & op_flags::kValue;
}
constexpr OpKind op_kind(Op op) {
  return detail::kOpInfo[static_cast<int>(op)].kind;
}
/// Computed from its arguments by apply_op (kinds Arith, Step and Bool).
constexpr bool op_is_arith(Op op) {
  const OpKind k = op_kind(op);
  return k == OpKind::kArith || k == OpKind::kStep || k == OpKind::kBool;
}
/// The result is always 0 or 1 (comparisons, truth values and logic).
constexpr bool op_is_boolean(Op op) {
  return op_kind(op) == OpKind::kBool;
}
/// Piecewise constant in its arguments: the derivative is zero wherever it exists.
constexpr bool op_is_piecewise_constant(Op op) {
  return op_kind(op) == OpKind::kStep || op_kind(op) == OpKind::kBool;
}
constexpr OpLane op_lane(Op op) {
  return detail::kOpInfo[static_cast<int>(op)].lane;
}
/// The C function a vector emitter calls per lane (OpLane kLibm, kHelper) or an intrinsic's
/// libm fallback (kIntrinsic), in double or single precision; null for other ops.
constexpr const char* op_libm_name(Op op, bool f32) {
  const detail::OpInfo& i = detail::kOpInfo[static_cast<int>(op)];
  return f32 ? i.libm_f32 : i.libm_f64;
}
constexpr OpPolyRule op_poly_rule(Op op) {
  return detail::kOpInfo[static_cast<int>(op)].poly;
}

// Case labels generated from the columns, for the switches that treat a whole group alike
// (a dispatcher sending every Arith/Step/Bool op to apply_op, say). Each expands to
// `case Op::kA: case Op::kB: ...`; a domain's own per-op switch still names every op, so a new
// op fails to compile there. The groups:
//   HFRT_OP_CASES_ARITH                 kinds Arith, Step, Bool (computed by apply_op)
//   HFRT_OP_CASES_NON_ARITH             every other op
//   HFRT_OP_CASES_PIECEWISE_CONSTANT    kinds Step, Bool
//   HFRT_OP_CASES_LANE_CALL             lanes Libm, Helper (a per-lane C call)
#define HFRT_OP_IF_ARITH_Leaf(...)
#define HFRT_OP_IF_ARITH_Slot(...)
#define HFRT_OP_IF_ARITH_Table(...)
#define HFRT_OP_IF_ARITH_Arith(...) __VA_ARGS__
#define HFRT_OP_IF_ARITH_Step(...) __VA_ARGS__
#define HFRT_OP_IF_ARITH_Bool(...) __VA_ARGS__
#define HFRT_OP_IF_ARITH_Surface(...)
#define HFRT_OP_IF_ARITH_Check(...)
#define HFRT_OP_IF_ARITH_Ctl(...)
#define HFRT_OP_IF_NON_ARITH_Leaf(...) __VA_ARGS__
#define HFRT_OP_IF_NON_ARITH_Slot(...) __VA_ARGS__
#define HFRT_OP_IF_NON_ARITH_Table(...) __VA_ARGS__
#define HFRT_OP_IF_NON_ARITH_Arith(...)
#define HFRT_OP_IF_NON_ARITH_Step(...)
#define HFRT_OP_IF_NON_ARITH_Bool(...)
#define HFRT_OP_IF_NON_ARITH_Surface(...) __VA_ARGS__
#define HFRT_OP_IF_NON_ARITH_Check(...) __VA_ARGS__
#define HFRT_OP_IF_NON_ARITH_Ctl(...) __VA_ARGS__
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Leaf(...)
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Slot(...)
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Table(...)
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Arith(...)
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Step(...) __VA_ARGS__
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Bool(...) __VA_ARGS__
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Surface(...)
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Check(...)
#define HFRT_OP_IF_PIECEWISE_CONSTANT_Ctl(...)
#define HFRT_OP_IF_LANE_CALL_None(...)
#define HFRT_OP_IF_LANE_CALL_Inline(...)
#define HFRT_OP_IF_LANE_CALL_Intrinsic(...)
#define HFRT_OP_IF_LANE_CALL_Libm(...) __VA_ARGS__
#define HFRT_OP_IF_LANE_CALL_Helper(...) __VA_ARGS__
#define HFRT_OP_CASE_ARITH_X(name, n, f, kind, ...) \
  HFRT_OP_IF_ARITH_##kind(case ::hfrt::ir::Op::k##name:)
#define HFRT_OP_CASE_NON_ARITH_X(name, n, f, kind, ...) \
  HFRT_OP_IF_NON_ARITH_##kind(case ::hfrt::ir::Op::k##name:)
#define HFRT_OP_CASE_PIECEWISE_CONSTANT_X(name, n, f, kind, ...) \
  HFRT_OP_IF_PIECEWISE_CONSTANT_##kind(case ::hfrt::ir::Op::k##name:)
#define HFRT_OP_CASE_LANE_CALL_X(name, n, f, kind, lane, ...) \
  HFRT_OP_IF_LANE_CALL_##lane(case ::hfrt::ir::Op::k##name:)
#define HFRT_OP_CASES_ARITH HFRT_IR_OPS(HFRT_OP_CASE_ARITH_X)
#define HFRT_OP_CASES_NON_ARITH HFRT_IR_OPS(HFRT_OP_CASE_NON_ARITH_X)
#define HFRT_OP_CASES_PIECEWISE_CONSTANT HFRT_IR_OPS(HFRT_OP_CASE_PIECEWISE_CONSTANT_X)
#define HFRT_OP_CASES_LANE_CALL HFRT_IR_OPS(HFRT_OP_CASE_LANE_CALL_X)

std::string_view error_message(ErrorKind kind);
/// The enum spelling without the k, e.g. "DivisionByZero" (printer, tests, tools).
std::string_view error_kind_name(ErrorKind kind);
/// Number of ErrorKind values.
int error_kind_count();

/// A number as the IR text writes it (%.17g: round-trips every double).
std::string format_double(double v);

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

}  // namespace hfrt::ir
