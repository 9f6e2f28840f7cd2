#pragma once
// Which values are the same for every point (every lane of a vector evaluator).
#include <cstdint>
#include <vector>

#include "ir/ir.h"

namespace hfrt::ir {

/// Per instruction: 1 when its value is the same for every point (every lane of a vector
/// evaluator): computed from constants, parameters and tables by pure ops, and from variables
/// (slots) that only ever hold such values, stored under conditions that are such values
/// (a loop over a constant count, `if mod(i, 2) = 0`). A vector evaluator may compute such a
/// value once and broadcast it (the per-lane libm calls of sin, cos, fmod, pow).
std::vector<uint8_t> uniform_values(const Function& fn);

}  // namespace hfrt::ir
