// Numbers as hidden parameters (hoist_constants.h).
#include "ir/hoist_constants.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/regions.h"

namespace hfrt::ir {

using namespace op_flags;

std::vector<double> hoist_constants(Function* fn) {
  const size_t n = fn->insts.size();
  // Per value: may it become a parameter? Until a use says otherwise, a constant may.
  std::vector<uint8_t> ok(n, 0), used(n, 0);
  for (size_t i = 0; i < n; ++i) {
    ok[i] = fn->insts[i].op == Op::kConst && std::isfinite(fn->insts[i].imm);
  }
  for (const Inst& in : fn->insts) {
    const bool arithmetic = op_flags_of(in.op) & kHoistUse;
    for (ValueId a : in.args) {
      if (a == kNoValue) continue;
      used[size_t(a)] = 1;
      if (!arithmetic) ok[size_t(a)] = 0;
    }
  }
  if (fn->result != kNoValue) ok[size_t(fn->result)] = 0;
  std::vector<double> values;
  for (size_t i = 0; i < n; ++i) {
    if (!ok[i] || !used[i]) continue;
    Inst& in = fn->insts[i];
    values.push_back(in.imm);
    in.op = Op::kParam;
    in.aux = fn->num_params + int32_t(values.size()) - 1;
    in.imm = 0;
  }
  if (!values.empty()) fn->hoisted_params_from = std::min(fn->hoisted_params_from, fn->num_params);
  fn->num_params += int(values.size());
  return values;
}

}  // namespace hfrt::ir
