// Values equal on every lane (uniform_values.h).
#include "ir/uniform_values.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/regions.h"

namespace hfrt::ir {

using namespace op_flags;

std::vector<uint8_t> uniform_values(const Function& fn) {
  const size_t n = fn.insts.size();
  std::vector<uint8_t> value(n, 0), slot(size_t(std::max(fn.num_slots, 0)), 1);
  // Slots only lose uniformity, so this reaches a fixpoint in at most num_slots + 1 passes.
  for (bool changed = true; changed;) {
    changed = false;
    // Uniformity of the conditions of the regions open at each point (1 = all uniform).
    std::vector<uint8_t> region{1};
    auto lose = [&](int32_t s) {
      if (s >= 0 && s < fn.num_slots && slot[size_t(s)]) {
        slot[size_t(s)] = 0;
        changed = true;
      }
    };
    for (size_t i = 0; i < n; ++i) {
      const Inst& in = fn.insts[i];
      auto uni = [&](int k) { return in.args[k] == kNoValue || value[size_t(in.args[k])]; };
      const bool args_uniform = uni(0) && uni(1) && uni(2);
      switch (in.op) {
        case Op::kInput:
        case Op::kSurface:
          value[i] = 0;
          break;
        case Op::kConst:
        case Op::kParam:
          value[i] = 1;
          break;
        case Op::kLoadSlot:
          value[i] = slot[size_t(in.aux)];
          break;
        case Op::kLoadIdx: {
          bool all = args_uniform;
          for (int k = 0; k < int(in.imm) && all; ++k) all = slot[size_t(in.aux + k)];
          value[i] = all;
          break;
        }
        case Op::kStoreSlot:
          if (!args_uniform || !region.back()) lose(in.aux);
          break;
        case Op::kStoreIdx:
          if (!args_uniform || !region.back()) {
            for (int k = 0; k < int(in.imm); ++k) lose(in.aux + k);
          }
          break;
        case Op::kIf:
          region.push_back(region.back() && args_uniform);
          break;
        case Op::kEndIf:
          region.pop_back();
          break;
        case Op::kLoop:
          // The test comes inside: until it, lanes run the same as around the loop.
          region.push_back(region.back());
          break;
        case Op::kLoopTest:
          // Lanes may leave at different iterations unless the test is uniform; what the body
          // stores then differs per lane (and so may what the loop's header recomputes).
          if (!args_uniform && region.back()) {
            region.back() = 0;
            int depth = 0;  // loops nested in the header, walked backwards
            for (size_t j = i; j-- > 0;) {
              const Inst& e = fn.insts[j];
              if (e.op == Op::kEndLoop) ++depth;
              if (e.op == Op::kLoop && depth-- == 0) break;
              if (e.op == Op::kStoreSlot) lose(e.aux);
              if (e.op == Op::kStoreIdx) {
                for (int k = 0; k < int(e.imm); ++k) lose(e.aux + k);
              }
            }
          }
          break;
        case Op::kEndLoop:
          region.pop_back();
          break;
        case Op::kTableLoad:
          HFRT_OP_CASES_ARITH
          value[i] = args_uniform;
          break;
        case Op::kCheck:
        case Op::kElse:
          value[i] = 0;  // no value
          break;
      }
    }
  }
  return value;
}

}  // namespace hfrt::ir
