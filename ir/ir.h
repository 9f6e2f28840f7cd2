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
