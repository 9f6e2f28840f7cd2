#pragma once
// Writes a lowered HyperFun object as a POV-Ray 3.7 user function, so that a model can be
// handed to POV-Ray's `isosurface` (and so that bench/peers/povray renders the very same
// function hfrt renders). `hfrt emit --pov` is the command-line front end.
//
// What can be written. A POV-Ray function is one expression over x, y, z: no statements,
// no loops, no arrays, no local variables. So:
//  - straight-line IR becomes an expression DAG; slots are resolved symbolically (stores
//    forward to loads), `if` regions become select() of both branches;
//  - a `while` loop, or an array element read or written with a computed index, cannot be
//    written: emission fails with a located diagnostic naming the construct;
//  - constant tables (library lookup tables) read with a computed index become a balanced
//    tree of select() (up to kMaxPovTable entries);
//  - ops POV-Ray lacks are emulated: round (half away from zero), sign, HyperFun's `^`
//    (kPowHF), the tolerance comparisons and the truth value;
//  - run-time error checks (kCheck) are dropped: POV-Ray has no NaN result, so a point where
//    hfrt reports an error gets whatever value POV-Ray computes there;
//  - parameters a[] are baked in as constants (PovEmitOptions::params, missing ones 0);
//  - coordinates beyond x[3] read 0, as in hfrt's renderer.
// Values used more than once are not duplicated in the text (which could grow exponentially
// for nested blends): they are passed as arguments to helper functions, a let-chain
// `NAME_k(x, y, z, p.., value)`. POV-Ray allows 56 parameters per function, so at most 53
// shared values may be alive at once; beyond that emission fails (a diagnostic).

#include <string>
#include <vector>

#include "ir/ir.h"
#include "lang/diagnostics.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// Largest constant table that a computed-index read turns into a select() tree.
inline constexpr int kMaxPovTable = 4096;

/// POV-Ray's limit on the parameters of one user function.
inline constexpr int kMaxPovParams = 56;

struct PovEmitOptions {
  /// POV-Ray identifier of the declared function (helpers are NAME_1, NAME_2, ...). Must be a
  /// valid POV identifier that is not a keyword; see pov_identifier().
  std::string name = "hf_model";
  /// a[1..]; parameters beyond the list read 0 (hfrt's default).
  std::vector<double> params;
};

/// What was emitted.
struct PovFunction {
  /// `#declare` lines; the last declares `name` as function(x, y, z) = F, F >= 0 the solid.
  std::string text;
  int helpers = 0;           ///< number of helper functions of the let-chain
  int shared_values = 0;     ///< values passed as parameters instead of duplicated
  int expression_nodes = 0;  ///< operations in the written expression (after emulation)
  int dropped_checks = 0;    ///< run-time error checks not written
  int undefined_reads = 0;   ///< reads of never-assigned variables, written as 0
};

/// Emits `fn` as POV-Ray SDL. On success fills `*out` and returns true. When the function
/// uses a construct POV-Ray functions cannot express, reports a located error to `diags`
/// (message naming the construct, hint saying what to do) and returns false.
bool emit_pov_function(const Function& fn, const PovEmitOptions& options, PovFunction* out,
                       lang::DiagnosticSink* diags);

/// A POV-Ray identifier derived from `base` (letters, digits and '_', not starting with a
/// digit, not a POV-Ray keyword): invalid characters become '_', keywords get a `hf_` prefix.
std::string pov_identifier(const std::string& base);

}  // namespace hfrt::jit
