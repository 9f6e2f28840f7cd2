// R-function nodes (r_functions.h).
#include "ir/r_functions.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/regions.h"

namespace hfrt::ir {

using namespace op_flags;

bool match_r_function(const Function& fn, ValueId v, ValueId* f1, ValueId* f2, bool* plus) {
  const Inst& in = fn.insts[size_t(v)];
  if (in.op != Op::kAdd && in.op != Op::kSub) return false;
  if (in.args[0] == kNoValue || in.args[1] == kNoValue) return false;
  const Inst& sum = fn.insts[size_t(in.args[0])];
  const Inst& root = fn.insts[size_t(in.args[1])];
  if (sum.op != Op::kAdd || root.op != Op::kSqrt) return false;
  const Inst& q = fn.insts[size_t(root.args[0])];
  if (q.op != Op::kAdd) return false;
  const Inst& m1 = fn.insts[size_t(q.args[0])];
  const Inst& m2 = fn.insts[size_t(q.args[1])];
  if (m1.op != Op::kMul || m2.op != Op::kMul) return false;
  if (m1.args[0] != m1.args[1] || m2.args[0] != m2.args[1]) return false;
  const ValueId g = m1.args[0], h = m2.args[0];
  if ((sum.args[0] == g && sum.args[1] == h) || (sum.args[0] == h && sum.args[1] == g)) {
    *f1 = g;
    *f2 = h;
    *plus = in.op == Op::kAdd;
    return true;
  }
  return false;
}

RFunctionNodes find_r_functions(const Function& fn) {
  RFunctionNodes r;
  r.kind.assign(fn.insts.size(), 0);
  r.args.assign(2 * fn.insts.size(), kNoValue);
  for (size_t i = 0; i < fn.insts.size(); ++i) {
    ValueId f1, f2;
    bool plus;
    if (match_r_function(fn, ValueId(i), &f1, &f2, &plus)) {
      r.kind[i] = plus ? 1 : 2;
      r.args[2 * i] = f1;
      r.args[2 * i + 1] = f2;
    }
  }
  return r;
}

}  // namespace hfrt::ir
