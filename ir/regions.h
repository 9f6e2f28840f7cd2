#pragma once
// Control-flow partners of the structured markers (kIf/kElse/kEndIf, kLoop/kLoopTest/kEndLoop),
// for evaluators that jump over regions.
#include <cstdint>
#include <vector>

#include "ir/ir.h"

namespace hfrt::ir {

/// Control-flow partners, for evaluators that jump over regions: kIf -> its kElse or kEndIf,
/// kElse -> kEndIf, kLoop -> kLoopTest, kLoopTest -> kEndLoop, kEndLoop -> its kLoop; -1
/// elsewhere. HFRT_CHECKs proper nesting (the verifier's contract).
std::vector<int32_t> match_regions(const Function& fn);

}  // namespace hfrt::ir
