#pragma once
// The key of compiled-code sharing: equal texts mean equal computations.
#include <string>

#include "ir/ir.h"

namespace hfrt::ir {

/// A text equal for two functions exactly when they compute the same from the same inputs
/// and parameters: instructions (ops, operands, immediates), slots and their initial values,
/// tables, surfaces, attributes, and the line and column of every instruction but a
/// hoisted parameter (where errors are reported). The key of compiled-code sharing.
std::string structure_key(const Function& fn);

}  // namespace hfrt::ir
