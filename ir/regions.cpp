// Control-flow partners (regions.h).
#include "ir/regions.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/regions.h"

namespace hfrt::ir {

using namespace op_flags;

std::vector<int32_t> match_regions(const Function& fn) {
  std::vector<int32_t> match(fn.insts.size(), -1);
  std::vector<size_t> stack, loops;
  for (size_t i = 0; i < fn.insts.size(); ++i) {
    switch (fn.insts[i].op) {
      case Op::kIf:
        stack.push_back(i);
        break;
      case Op::kLoop:
        stack.push_back(i);
        loops.push_back(i);
        break;
      case Op::kElse:
      case Op::kLoopTest:
        HFRT_CHECK(!stack.empty());
        match[stack.back()] = static_cast<int32_t>(i);
        stack.back() = i;
        break;
      case Op::kEndIf:
        HFRT_CHECK(!stack.empty());
        match[stack.back()] = static_cast<int32_t>(i);
        stack.pop_back();
        break;
      case Op::kEndLoop:
        HFRT_CHECK(!stack.empty() && !loops.empty());
        match[stack.back()] = static_cast<int32_t>(i);
        match[i] = static_cast<int32_t>(loops.back());
        stack.pop_back();
        loops.pop_back();
        break;
      case Op::kConst:
      case Op::kInput:
      case Op::kParam:
      case Op::kLoadSlot:
      case Op::kStoreSlot:
      case Op::kLoadIdx:
      case Op::kStoreIdx:
      case Op::kTableLoad:
      case Op::kSurface:
      case Op::kCheck:
        HFRT_OP_CASES_ARITH
        break;
    }
  }
  HFRT_CHECK(stack.empty());
  return match;
}

}  // namespace hfrt::ir
