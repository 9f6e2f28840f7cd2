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

#include "base/limits.h"
#include "ir/ir.h"
#include "lang/ast.h"
#include "lang/diagnostics.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// Lowers `program.objects[object_index]` of a CHECKED program (every Symbol resolved).
/// Located warnings found while lowering (e.g. library array-size mismatches, reads of
/// possibly uninitialised variables) go to `warnings` when it is not null, and so do the
/// lowering's errors (a mesh file that does not load, a limit below): the caller tests
/// `warnings->has_errors()`.
///
/// Limits (base/limits.h, docs/limits.md): before lowering, the object's size once every
/// object call is inlined (limits.max_model_size) and its slots (limits.max_slots) are
/// counted; beyond either the error is located at the largest call or array of the object and
/// the result is a stub (NaN everywhere). Every `while` loop counts its iterations in one
/// counter per evaluation; beyond limits.max_loop_iterations the loop stops with a LoopLimit
/// run-time error, so no evaluator can hang on a model. Mesh and patch files are read within
/// limits.max_mesh_bytes and limits.max_mesh_triangles.
Function lower_object(const lang::Program& program, int object_index,
                      lang::DiagnosticSink* warnings, const Limits& limits = {});

}  // namespace hfrt::jit
