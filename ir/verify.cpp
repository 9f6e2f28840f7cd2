// The IR verifier (verify.h).
#include "ir/verify.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/regions.h"

namespace hfrt::ir {

using namespace op_flags;

std::string verify(const Function& fn) {
  std::ostringstream err;
  auto fail = [&](size_t i, const std::string& what) {
    err << "instruction %" << i;
    if (i < fn.insts.size()) err << " (" << op_name(fn.insts[i].op) << ")";
    err << ": " << what;
    return err.str();
  };

  if (fn.num_slots < 0 || fn.num_inputs < 0 || fn.num_params < 0)
    return "negative size in function header";
  if (fn.slot_init.size() != static_cast<size_t>(fn.num_slots)) {
    return "slot_init has " + std::to_string(fn.slot_init.size()) + " entries for " +
           std::to_string(fn.num_slots) + " slots";
  }
  for (int32_t s : fn.s_slots) {
    if (s < 0 || s >= fn.num_slots) return "s slot " + std::to_string(s) + " out of range";
  }

  // Regions: 0 is the function body; every kIf/kElse/kLoop opens one. A value may be used
  // while the region that defined it is still open (it then encloses the use).
  struct Open {
    int region;
    Op kind;  // kIf (then-part), kElse, kLoop
    bool seen_test = false;
  };
  std::vector<Open> stack = {{0, Op::kLoop, true}};
  std::vector<bool> region_open = {true};
  std::vector<int> region_of(fn.insts.size(), 0);
  bool control_flow = false;

  for (size_t i = 0; i < fn.insts.size(); ++i) {
    const Inst& in = fn.insts[i];
    if (static_cast<int>(in.op) >= kOpCount) return fail(i, "unknown op");
    const int n = op_num_args(in.op);
    for (int k = 0; k < 3; ++k) {
      ValueId a = in.args[k];
      if (k >= n) {
        if (a != kNoValue) return fail(i, "unused argument " + std::to_string(k) + " is set");
        continue;
      }
      if (a == kNoValue) return fail(i, "missing argument " + std::to_string(k));
      if (a >= i) return fail(i, "argument %" + std::to_string(a) + " is not defined before use");
      if (!op_has_value(fn.insts[a].op)) {
        return fail(i, "argument %" + std::to_string(a) + " is not a value");
      }
      if (!region_open[region_of[a]]) {
        return fail(
            i, "argument %" + std::to_string(a) + " is used outside the region that defines it");
      }
    }
    region_of[i] = stack.back().region;

    auto check_slot = [&](int32_t s) { return s >= 0 && s < fn.num_slots; };
    switch (in.op) {
      case Op::kInput:
        if (in.aux < 0 || in.aux >= fn.num_inputs) return fail(i, "input index out of range");
        break;
      case Op::kParam:
        if (in.aux < 0 || in.aux >= fn.num_params) return fail(i, "param index out of range");
        break;
      case Op::kLoadSlot:
      case Op::kStoreSlot:
        if (!check_slot(in.aux)) return fail(i, "slot " + std::to_string(in.aux) + " out of range");
        break;
      case Op::kLoadIdx:
      case Op::kStoreIdx: {
        double size = in.imm;
        if (!(size >= 1) || size != std::floor(size) || !check_slot(in.aux) ||
            in.aux + size > fn.num_slots) {
          return fail(i, "indexed array [" + std::to_string(in.aux) + ", +" + format_double(size) +
                             ") out of the slot range");
        }
        break;
      }
      case Op::kTableLoad:
        if (in.aux < 0 || in.aux >= static_cast<int32_t>(fn.tables.size()) ||
            fn.tables[in.aux].empty()) {
          return fail(i, "table " + std::to_string(in.aux) + " does not exist");
        }
        break;
      case Op::kCheck:
        if (in.aux < 0 || in.aux >= error_kind_count()) return fail(i, "unknown error kind");
        break;
      case Op::kSurface:
        if (in.aux < 0 || in.aux >= static_cast<int32_t>(fn.surfaces.size()) ||
            !fn.surfaces[in.aux]) {
          return fail(i, "surface " + std::to_string(in.aux) + " does not exist");
        }
        break;
      case Op::kIf: {
        control_flow = true;
        int r = static_cast<int>(region_open.size());
        region_open.push_back(true);
        stack.push_back({r, Op::kIf});
        break;
      }
      case Op::kElse: {
        if (stack.size() < 2 || stack.back().kind != Op::kIf) return fail(i, "else without if");
        region_open[stack.back().region] = false;
        int r = static_cast<int>(region_open.size());
        region_open.push_back(true);
        stack.back() = {r, Op::kElse};
        break;
      }
      case Op::kEndIf:
        if (stack.size() < 2 || (stack.back().kind != Op::kIf && stack.back().kind != Op::kElse)) {
          return fail(i, "endif without if");
        }
        region_open[stack.back().region] = false;
        stack.pop_back();
        break;
      case Op::kLoop: {
        control_flow = true;
        int r = static_cast<int>(region_open.size());
        region_open.push_back(true);
        stack.push_back({r, Op::kLoop});
        region_of[i] = stack[stack.size() - 2].region;
        break;
      }
      case Op::kLoopTest:
        if (stack.size() < 2 || stack.back().kind != Op::kLoop) {
          return fail(i, "loop_test not directly inside a loop");
        }
        if (stack.back().seen_test) return fail(i, "second loop_test in one loop");
        stack.back().seen_test = true;
        break;
      case Op::kEndLoop:
        if (stack.size() < 2 || stack.back().kind != Op::kLoop)
          return fail(i, "endloop without loop");
        if (!stack.back().seen_test) return fail(i, "loop without loop_test");
        region_open[stack.back().region] = false;
        stack.pop_back();
        break;
      case Op::kConst:
        HFRT_OP_CASES_ARITH
        break;
    }
    // The markers that close a region belong to the enclosing one.
    if (in.op == Op::kEndIf || in.op == Op::kEndLoop) region_of[i] = stack.back().region;
  }
  if (stack.size() != 1) return "unterminated if or loop at the end of the function";
  if (fn.result == kNoValue) return "no result";
  if (fn.result >= fn.insts.size())
    return "result %" + std::to_string(fn.result) + " does not exist";
  if (!op_has_value(fn.insts[fn.result].op)) return "result is not a value";
  if (region_of[fn.result] != 0) return "result is not defined at the outermost level";
  if (fn.has_control_flow != control_flow)
    return "has_control_flow does not match the instructions";
  return {};
}

}  // namespace hfrt::ir
