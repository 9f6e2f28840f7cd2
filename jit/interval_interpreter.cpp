// The reference interval evaluator: IntervalInterpreter runs structured control flow over
// boxes; each op's enclosure is apply_interval (ir/interval_ops.h). See interval.h for the
// contract.

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/check.h"
#include "ir/r_functions.h"
#include "ir/regions.h"
#include "ir/scalar_ops.h"
#include "jit/interval.h"
#include "jit/surface_ops.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

IntervalInterpreter::IntervalInterpreter(const Function& fn, int loop_limit)
    : fn_(fn), loop_limit_(loop_limit) {
  match_ = match_regions(fn);
  values_.resize(fn.insts.size());
  r_nodes_ = find_r_functions(fn);
}

Interval IntervalInterpreter::eval(std::span<const Interval> x, std::span<const double> a,
                                   std::vector<uint8_t>* choices) {
  x_ = x;
  a_ = a;
  choices_ = choices;
  if (choices) choices->assign(fn_.insts.size(), kChoiceNone);
  error_possible_ = false;
  slots_.resize(fn_.num_slots);
  for (int s = 0; s < fn_.num_slots; ++s) {
    double init = s < static_cast<int>(fn_.slot_init.size()) ? fn_.slot_init[s] : 0.0;
    slots_[s] = Interval::point(init);
  }
  run(0, fn_.insts.size());
  HFRT_CHECK(fn_.result != kNoValue);
  Interval r = values_[fn_.result];
  r.maybe_nan = r.maybe_nan || error_possible_;
  return r;
}

Interval IntervalInterpreter::eval_box(double x0, double x1, double y0, double y1, double z0,
                                       double z1, std::span<const double> a) {
  Interval box[3] = {{x0, x1, false}, {y0, y1, false}, {z0, z1, false}};
  return eval(box, a);
}

void IntervalInterpreter::run(size_t begin, size_t end) {
  const std::vector<Inst>& insts = fn_.insts;
  size_t i = begin;
  while (i < end) {
    const Inst& in = insts[i];
    auto arg = [&](int k) -> const Interval& { return values_[in.args[k]]; };
    switch (in.op) {
      case Op::kConst:
        values_[i] = Interval::point(in.imm);
        break;
      case Op::kInput:
        values_[i] = in.aux < static_cast<int>(x_.size()) ? x_[in.aux] : Interval::point(0);
        break;
      case Op::kParam:
        values_[i] = Interval::point(in.aux < static_cast<int>(a_.size()) ? a_[in.aux] : 0.0);
        break;
      case Op::kLoadSlot:
        values_[i] = slots_[in.aux];
        break;
      case Op::kStoreSlot:
        slots_[in.aux] = arg(0);
        break;
      case Op::kLoadIdx:
      case Op::kStoreIdx: {
        // The index is integral and range-checked by an earlier kCheck where it matters:
        // out-of-range points are NaN anyway, so the range is clipped.
        const Interval& idx = arg(0);
        int size = static_cast<int>(in.imm);
        double klo = std::max(1.0, std::ceil(idx.lo)),
               khi = std::min<double>(size, std::floor(idx.hi));
        if (idx.maybe_nan) error_possible_ = true;
        if (klo > khi) {  // no valid index: every point of the box fails
          error_possible_ = true;
          if (in.op == Op::kLoadIdx) values_[i] = Interval{0, 0, true};
          break;
        }
        int k0 = static_cast<int>(klo) - 1, k1 = static_cast<int>(khi) - 1;
        if (in.op == Op::kLoadIdx) {
          Interval r = slots_[in.aux + k0];
          for (int k = k0 + 1; k <= k1; ++k) r = hull(r, slots_[in.aux + k]);
          values_[i] = r;
        } else if (k0 == k1) {
          slots_[in.aux + k0] = arg(1);
        } else {
          for (int k = k0; k <= k1; ++k) slots_[in.aux + k] = hull(slots_[in.aux + k], arg(1));
        }
        break;
      }
      case Op::kTableLoad: {
        const std::vector<double>& t = fn_.tables[in.aux];
        const Interval& idx = arg(0);
        double klo = std::max(0.0, std::ceil(idx.lo));
        double khi = std::min<double>(static_cast<double>(t.size()) - 1, std::floor(idx.hi));
        if (klo > khi) {
          values_[i] = Interval{0, 0, true};
          break;
        }
        Interval r = Interval::point(t[static_cast<size_t>(klo)]);
        for (size_t k = static_cast<size_t>(klo) + 1; k <= static_cast<size_t>(khi); ++k) {
          r = hull(r, Interval::point(t[k]));
        }
        r.maybe_nan = r.maybe_nan || idx.maybe_nan;
        values_[i] = r;
        break;
      }
      case Op::kSurface:
        values_[i] = surface_interval(*fn_.surfaces[in.aux], arg(0), arg(1), arg(2));
        break;
      case Op::kCheck:
        if (nonzero(arg(0)).can_true) error_possible_ = true;
        break;
      case Op::kIf: {
        Tri t = nonzero(arg(0));
        size_t m = static_cast<size_t>(match_[i]);
        bool has_else = insts[m].op == Op::kElse;
        size_t endif = has_else ? static_cast<size_t>(match_[m]) : m;
        if (t.can_true && !t.can_false) {
          run(i + 1, m);
        } else if (!t.can_true) {
          if (has_else) run(m + 1, endif);
        } else {
          std::vector<Interval> saved = slots_;
          run(i + 1, m);
          if (has_else) {
            std::swap(saved, slots_);  // slots_ = entry state, saved = then state
            run(m + 1, endif);
          }
          for (size_t s = 0; s < slots_.size(); ++s) slots_[s] = hull(slots_[s], saved[s]);
        }
        i = endif + 1;
        continue;
      }
      case Op::kLoop:
        run_loop(i);
        i = static_cast<size_t>(match_[match_[i]]) + 1;
        continue;
      case Op::kElse:
      case Op::kEndIf:
      case Op::kLoopTest:
      case Op::kEndLoop:
        HFRT_CHECK_MSG(false, "unbalanced control marker at " << i);
        break;
        // Every op computed from its arguments (case labels generated from ir_ops.h).
        HFRT_OP_CASES_ARITH {
          bool same = in.args[0] == in.args[1] && in.args[0] != kNoValue;
          Interval b = in.args[1] != kNoValue ? values_[in.args[1]] : Interval{};
          Interval c = in.args[2] != kNoValue ? values_[in.args[2]] : Interval{};
          uint8_t* ch = choices_ ? &(*choices_)[i] : nullptr;
          values_[i] = apply_interval(in.op, values_[in.args[0]], b, c, same, ch);
          if (r_nodes_.kind[i]) {
            values_[i] =
                r_function_interval(values_[i], values_[r_nodes_.args[2 * i]],
                                    values_[r_nodes_.args[2 * i + 1]], r_nodes_.kind[i] == 1);
          }
          break;
        }
    }
    ++i;
  }
}

void IntervalInterpreter::run_loop(size_t at) {
  size_t test = static_cast<size_t>(match_[at]);
  size_t end = static_cast<size_t>(match_[test]);
  std::vector<Interval> exited;  // hull of the states of lanes that may have left
  bool any_exited = false;
  auto merge_exit = [&] {
    if (!any_exited) {
      exited = slots_;
      any_exited = true;
    } else {
      for (size_t s = 0; s < slots_.size(); ++s) exited[s] = hull(exited[s], slots_[s]);
    }
  };
  for (int iter = 0;; ++iter) {
    run(at + 1, test);
    Tri t = nonzero(values_[fn_.insts[test].args[0]]);
    if (!t.can_true) break;  // every lane leaves here
    if (t.can_false) merge_exit();
    if (iter >= loop_limit_) {
      // Give up: every slot the loop writes may hold anything (or the limit error fired).
      error_possible_ = true;
      for (size_t k = at; k < end; ++k) {
        const Inst& in = fn_.insts[k];
        if (in.op == Op::kStoreSlot) slots_[in.aux] = Interval::entire();
        if (in.op == Op::kStoreIdx) {
          for (int s = 0; s < static_cast<int>(in.imm); ++s)
            slots_[in.aux + s] = Interval::entire();
        }
      }
      break;
    }
    run(test + 1, end);
  }
  if (any_exited) {
    for (size_t s = 0; s < slots_.size(); ++s) slots_[s] = hull(slots_[s], exited[s]);
  }
}

}  // namespace hfrt::jit
