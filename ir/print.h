#pragma once
// The IR printer (`hfrt ir`, golden tests, debugging): every IR is printable.
#include <string>

#include "ir/ir.h"

namespace hfrt::ir {

/// Text form for `hfrt ir` and golden tests: one instruction per line, indented by nesting,
/// e.g. `%12 = add %10, %11    ; 3:14`.
std::string print(const Function& fn);

}  // namespace hfrt::ir
