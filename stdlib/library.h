#pragma once
// The HyperFun FRep library (../shared/spec/library.md), written once as IR-building code, so
// every evaluator (interpreter, scalar JIT, interval, gradient, polynomial) gets every function.

#include <span>
#include <string>

#include "base/limits.h"
#include "ir/builder.h"
#include "ir/ir.h"
#include "lang/diagnostics.h"
#include "lang/library_table.h"

namespace hfrt::stdlib {

/// One argument of a library call, as the lowering hands it over.
struct LibArg {
  bool is_array = false;
  ir::ValueId value = ir::kNoValue;  ///< real argument, already evaluated
  int base_slot = -1;                ///< array argument: slots base_slot .. base_slot+size-1
  int size = 0;                      ///< array argument: its declared size
  lang::SourceRange range;           ///< the argument's text, for warnings
  std::string text;                  ///< file argument ('F'): the string literal's text
};

/// Per-compilation state shared by the calls of one model (e.g. which Perlin table each
/// noise function owns: the original builds them from one random stream in first-call order).
struct LibState {
  int perlin_table_noisep = -1;      ///< Function::tables id of hfA_NoiseP's table (-1: none yet)
  int perlin_table_turbulence = -1;  ///< same for hfA_Turbulence
  int perlin_tables_built = 0;       ///< how many 1791-number blocks of the stream are taken
  /// Which block of the shared rand() stream each function's table comes from (-1: not yet
  /// called). Kept apart from the table ids so that one LibState may serve several Functions:
  /// a Function that lacks the table gets it re-added with the same content.
  int perlin_block_noisep = -1;
  int perlin_block_turbulence = -1;
};

struct LibContext {
  ir::IrBuilder& b;
  /// Located warnings (array size mismatches) and the errors of the mesh and patch leaves
  /// (a file that does not load: the Model fails to compile); may be null.
  lang::DiagnosticSink* diags = nullptr;
  lang::SourceRange call_range;
  LibState& state;
  /// The limits on mesh and patch files (base/limits.h); null: the defaults.
  const Limits* limits = nullptr;
};

/// Emits the IR of one library call and returns its value. Array arguments are read and
/// written through their slots (transformations write the moved point back, attribute
/// functions write s). Arity and argument kinds were checked by the front end.
ir::ValueId lower_library_call(lang::LibraryFn fn, LibContext& ctx, std::span<const LibArg> args);

}  // namespace hfrt::stdlib
