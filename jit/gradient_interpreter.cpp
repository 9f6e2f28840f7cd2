// The reference gradient evaluator: forward-mode AD over the IR in double precision.
// See gradient.h for the contract; values come from apply_op (scalar_ops.h) so they are the
// scalar interpreter's values bit for bit.

#include <cmath>
#include <limits>

#include "base/check.h"
#include "ir/regions.h"
#include "ir/scalar_ops.h"
#include "jit/gradient.h"
#include "jit/surface_ops.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

GradientInterpreter::GradientInterpreter(const Function& fn, int64_t loop_limit)
    : fn_(fn), loop_limit_(loop_limit) {
  match_ = match_regions(fn);
  values_.resize(fn.insts.size());
}

Dual GradientInterpreter::eval(std::span<const double> x, std::span<const double> a) {
  error_ = false;
  slots_.resize(fn_.num_slots);
  for (int s = 0; s < fn_.num_slots; ++s) {
    slots_[s] = Dual::constant(s < static_cast<int>(fn_.slot_init.size()) ? fn_.slot_init[s] : 0.0);
  }
  const std::vector<Inst>& insts = fn_.insts;
  std::vector<int64_t> trips;  // iteration counters of the active loops (innermost last)
  const size_t n = insts.size();
  size_t i = 0;
  while (i < n) {
    const Inst& in = insts[i];
    switch (in.op) {
      case Op::kConst:
        values_[i] = Dual::constant(in.imm);
        break;
      case Op::kInput: {
        Dual r = Dual::constant(in.aux < static_cast<int>(x.size()) ? x[in.aux] : 0.0);
        if (in.aux < 3) r.d[in.aux] = 1;
        values_[i] = r;
        break;
      }
      case Op::kParam:
        values_[i] = Dual::constant(in.aux < static_cast<int>(a.size()) ? a[in.aux] : 0.0);
        break;
      case Op::kLoadSlot:
        values_[i] = slots_[in.aux];
        break;
      case Op::kStoreSlot:
        slots_[in.aux] = values_[in.args[0]];
        break;
      case Op::kLoadIdx:
      case Op::kStoreIdx: {
        double idx = values_[in.args[0]].v;
        if (!(idx >= 1 && idx <= in.imm)) {  // the range check should have fired
          error_ = true;
          break;
        }
        int k = in.aux + static_cast<int>(idx) - 1;
        if (in.op == Op::kLoadIdx)
          values_[i] = slots_[k];
        else
          slots_[k] = values_[in.args[1]];
        break;
      }
      case Op::kTableLoad: {
        const std::vector<double>& t = fn_.tables[in.aux];
        double idx = values_[in.args[0]].v;
        if (!(idx >= 0 && idx < static_cast<double>(t.size()))) {
          error_ = true;
          break;
        }
        values_[i] = Dual::constant(t[static_cast<size_t>(idx)]);
        break;
      }
      case Op::kSurface:
        values_[i] = surface_dual(*fn_.surfaces[in.aux], values_[in.args[0]], values_[in.args[1]],
                                  values_[in.args[2]]);
        break;
      case Op::kCheck:
        if (values_[in.args[0]].v != 0) error_ = true;
        break;
      case Op::kIf:
        if (values_[in.args[0]].v == 0) {
          size_t m = static_cast<size_t>(match_[i]);
          i = m + 1;  // past kElse into the else part, or past kEndIf
          continue;
        }
        break;
      case Op::kElse:
        i = static_cast<size_t>(match_[i]) + 1;
        continue;
      case Op::kEndIf:
        break;
      case Op::kLoop:
        trips.push_back(0);
        break;
      case Op::kLoopTest:
        if (values_[in.args[0]].v == 0) {
          trips.pop_back();
          i = static_cast<size_t>(match_[i]) + 1;
          continue;
        }
        if (++trips.back() > loop_limit_) error_ = true;
        break;
      case Op::kEndLoop:
        i = static_cast<size_t>(match_[i]) + 1;
        continue;
        // Every op computed from its arguments (case labels generated from ir_ops.h).
        HFRT_OP_CASES_ARITH {
          const Dual zero{};
          const Dual& b = in.args[1] != kNoValue ? values_[in.args[1]] : zero;
          const Dual& c = in.args[2] != kNoValue ? values_[in.args[2]] : zero;
          values_[i] = apply_dual(in.op, values_[in.args[0]], b, c);
          break;
        }
    }
    if (error_) return Dual{kNaN, {kNaN, kNaN, kNaN}};
    ++i;
  }
  HFRT_CHECK(fn_.result != kNoValue);
  return values_[fn_.result];
}

}  // namespace hfrt::jit
