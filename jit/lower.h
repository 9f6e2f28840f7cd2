#pragma once
// AST -> IR: turns one checked HyperFun object (with every object it calls inlined and
// every library call expanded by stdlib/) into a jit::Function. This is the only place
// that knows the language's evaluation rules (right-to-left argument order, tolerance
// comparisons, run-time error checks, uninitialised variables); everything after it sees
// plain IR.
//
// Slot layout of the result (all arrays are runs of consecutive slots):
//   - x copy: slots [0, x_size): x[i] is copied in at the start (library transformations
//     move the point in place), then slots of a copy [x_size, x_size + a_size);
//   - s: Function::s_slots (size max(1, s_size), initialised to 0; an object without s
//     reports one s of 0, as the original does);
//   - after those: locals, local arrays, copies made for object calls, "defined" flags,
//     loop counters (layout not part of the contract).

#include "ir/ir.h"
#include "lang/ast.h"
#include "lang/diagnostics.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// Maximum number of iterations of one `while` loop per entry; the loop then stops with a
/// LoopLimit run-time error, so no evaluator can hang on a model.
inline constexpr double kLoopIterationLimit = 1e6;

/// Lowers `program.objects[object_index]` of a CHECKED program (every Symbol resolved).
/// Located warnings found while lowering (e.g. library array-size mismatches, reads of
/// possibly uninitialised variables) go to `warnings` when it is not null.
Function lower_object(const lang::Program& program, int object_index,
                      lang::DiagnosticSink* warnings);

}  // namespace hfrt::jit
