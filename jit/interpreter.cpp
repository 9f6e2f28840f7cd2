// The reference interpreter (see interpreter.h).
#include "jit/interpreter.h"

#include <cmath>
#include <limits>

#include "base/check.h"
#include "ir/scalar_ops.h"
#include "ir/verify.h"
#include "jit/surface_ops.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

Interpreter::Interpreter(const Function& fn, uint64_t max_iterations)
    : fn_(fn), max_iterations_(max_iterations), target_(fn.insts.size(), 0) {
  std::string err = verify(fn_);
  HFRT_CHECK_MSG(err.empty(), "Interpreter given malformed IR: " << err);
  // Control targets, by matching the structured markers with a stack:
  //   kIf       -> first instruction after its kElse, or after its kEndIf (condition false)
  //   kElse     -> first instruction after its kEndIf (end of the then-part)
  //   kLoopTest -> first instruction after its kEndLoop (leaving the loop)
  //   kEndLoop  -> its kLoop (the back edge)
  std::vector<uint32_t> open;
  std::vector<uint32_t> loop_tests;  // the kLoopTest of each open loop (parallel to loops)
  for (uint32_t i = 0; i < fn_.insts.size(); ++i) {
    switch (fn_.insts[i].op) {
      case Op::kIf:
      case Op::kLoop:
        open.push_back(i);
        break;
      case Op::kElse:
        target_[open.back()] = i + 1;
        open.back() = i;
        break;
      case Op::kEndIf:
        target_[open.back()] = i + 1;
        open.pop_back();
        break;
      case Op::kLoopTest:
        target_[i] = open.back();  // temporarily: the loop this test belongs to
        loop_tests.push_back(i);
        break;
      case Op::kEndLoop: {
        uint32_t loop = open.back();
        open.pop_back();
        target_[i] = loop;
        uint32_t test = loop_tests.back();
        loop_tests.pop_back();
        target_[test] = i + 1;
        target_[loop] = i + 1;  // where the guard exits to
        break;
      }
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
}

EvalResult Interpreter::eval(std::span<const double> x, std::span<const double> a) const {
  const size_t n = fn_.insts.size();
  std::vector<double> val(n, 0.0);
  std::vector<double> slot(fn_.slot_init);
  EvalResult res;
  auto raise = [&](ErrorKind kind, const Inst& in) {
    if (!res.error) res.error = RuntimeError{kind, in.loc};
  };
  uint64_t iterations = 0;

  size_t pc = 0;
  while (pc < n) {
    const Inst& in = fn_.insts[pc];
    const double a0 = in.args[0] != kNoValue ? val[in.args[0]] : 0.0;
    const double a1 = in.args[1] != kNoValue ? val[in.args[1]] : 0.0;
    const double a2 = in.args[2] != kNoValue ? val[in.args[2]] : 0.0;
    size_t next = pc + 1;
    switch (in.op) {
      case Op::kConst:
        val[pc] = in.imm;
        break;
      case Op::kInput:
        val[pc] = static_cast<size_t>(in.aux) < x.size() ? x[in.aux] : 0.0;
        break;
      case Op::kParam:
        val[pc] = static_cast<size_t>(in.aux) < a.size() ? a[in.aux] : 0.0;
        break;
      case Op::kLoadSlot:
        val[pc] = slot[in.aux];
        break;
      case Op::kStoreSlot:
        slot[in.aux] = a0;
        break;
      case Op::kLoadIdx:
      case Op::kStoreIdx: {
        // Lowering range-checks and clamps indices; stay safe with hand-built IR anyway.
        const bool ok = a0 >= 1 && a0 <= in.imm && a0 == std::floor(a0);
        if (!ok) {
          raise(ErrorKind::kIndexOutOfRange, in);
          if (in.op == Op::kLoadIdx) val[pc] = std::numeric_limits<double>::quiet_NaN();
          break;
        }
        const size_t s = static_cast<size_t>(in.aux) + static_cast<size_t>(a0) - 1;
        if (in.op == Op::kLoadIdx) {
          val[pc] = slot[s];
        } else {
          slot[s] = a1;
        }
        break;
      }
      case Op::kTableLoad: {
        const auto& t = fn_.tables[in.aux];
        const bool ok = a0 >= 0 && a0 < static_cast<double>(t.size()) && a0 == std::floor(a0);
        if (!ok) {
          raise(ErrorKind::kIndexOutOfRange, in);
          val[pc] = std::numeric_limits<double>::quiet_NaN();
        } else {
          val[pc] = t[static_cast<size_t>(a0)];
        }
        break;
      }
      case Op::kSurface:
        val[pc] = surface_value(*fn_.surfaces[in.aux], a0, a1, a2);
        break;
      case Op::kCheck:
        if (a0 != 0) raise(static_cast<ErrorKind>(in.aux), in);
        break;
      case Op::kIf:
        if (a0 == 0) next = target_[pc];
        break;
      case Op::kElse:
        next = target_[pc];
        break;
      case Op::kEndIf:
        break;
      case Op::kLoop:
        if (++iterations > max_iterations_) {
          raise(ErrorKind::kLoopLimit, in);
          next = target_[pc];
        }
        break;
      case Op::kLoopTest:
        if (a0 == 0) next = target_[pc];
        break;
      case Op::kEndLoop:
        next = target_[pc];
        break;
        // Every op computed from its arguments: one definition shared with the folder.
        HFRT_OP_CASES_ARITH
        val[pc] = apply_op(in.op, a0, a1, a2);
        break;
    }
    pc = next;
  }

  res.value = res.error ? std::numeric_limits<double>::quiet_NaN() : val[fn_.result];
  res.s.reserve(fn_.s_slots.size());
  for (int32_t s : fn_.s_slots) res.s.push_back(slot[s]);
  return res;
}

std::string describe_runtime_error(const RuntimeError& error, const Function& fn) {
  std::string out;
  if (error.loc.valid()) {
    if (fn.source) out += fn.source->name() + ":";
    out += std::to_string(error.loc.line) + ":" + std::to_string(error.loc.col) + ": ";
  }
  out += error_message(error.kind);
  return out;
}

}  // namespace hfrt::jit
