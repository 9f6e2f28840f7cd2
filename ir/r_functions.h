#pragma once
// Recognises the R-function nodes f1 + f2 +- sqrt(f1^2 + f2^2) (the lowering's `|`, `&`, `\`
// and the library's R-functions), which the interval domain encloses by monotonicity and the
// polynomial analysis reads as set operations.
#include <cstdint>
#include <vector>

#include "ir/ir.h"

namespace hfrt::ir {

/// True when value v is the R-function f1 + f2 + sqrt(f1*f1 + f2*f2) (*plus: the union of the
/// lowering's `|` and the library) or f1 + f2 - sqrt(...) (intersection `&`, subtraction `\`
/// with f2 = -g), in the IR shape jit/lower.cpp r_function emits.
bool match_r_function(const Function& fn, ValueId v, ValueId* f1, ValueId* f2, bool* plus);

/// The R-function nodes of a function, per instruction: kind 0 (none), 1 (union, plus) or 2
/// (intersection), with its operands f1, f2 at args[2 i], args[2 i + 1] (kNoValue elsewhere).
struct RFunctionNodes {
  std::vector<uint8_t> kind;
  std::vector<ValueId> args;
};
RFunctionNodes find_r_functions(const Function& fn);

}  // namespace hfrt::ir
