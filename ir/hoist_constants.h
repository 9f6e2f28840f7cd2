#pragma once
// Numbers of the source as hidden parameters, so that compiled code serves edits that change
// only numbers (the REPL).
#include <vector>

#include "ir/ir.h"

namespace hfrt::ir {

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

}  // namespace hfrt::ir
