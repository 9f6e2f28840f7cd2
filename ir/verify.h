#pragma once
// The IR verifier: the structure rules of ir_ops.h, checked after every pass that builds or
// rewrites a Function (IrBuilder::finish, tests, fuzzing).
#include <string>

#include "ir/ir.h"

namespace hfrt::ir {

/// Checks the structure rules of ir_ops.h (nesting, def-before-use, scoping, slot ranges).
/// Returns an empty string when the function is well formed, else a description.
std::string verify(const Function& fn);

}  // namespace hfrt::ir
