// The IR's op table, verifier and printer (see ir.h, ir_ops.h).
#include "jit/ir.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "lang/check.h"

namespace hfrt::jit {

namespace {

using namespace op_flags;

struct OpInfo {
  std::string_view camel;  // as written in the X-macro, e.g. "LoadSlot"
  int num_args;
  unsigned flags;
};

constexpr std::array<OpInfo, kOpCount> kOpInfo = {{
#define HFRT_X(name, n, f) {#name, n, f},
    HFRT_IR_OPS(HFRT_X)
#undef HFRT_X
}};

constexpr std::array<std::string_view, 0
#define HFRT_X(name, msg) +1
                     HFRT_IR_ERRORS(HFRT_X)
#undef HFRT_X
                     >
    kErrorMessages = {{
#define HFRT_X(name, msg) msg,
        HFRT_IR_ERRORS(HFRT_X)
#undef HFRT_X
    }};

constexpr std::array<std::string_view, kErrorMessages.size()> kErrorNames = {{
#define HFRT_X(name, msg) #name,
    HFRT_IR_ERRORS(HFRT_X)
#undef HFRT_X
}};

// snake_case names for the printer, derived once from the X-macro spelling so that the op
// list stays the only place an op is named ("LoadSlot" -> "load_slot", "PowHF" -> "pow_hf").
const std::array<std::string, kOpCount>& snake_names() {
  static const std::array<std::string, kOpCount> names = [] {
    std::array<std::string, kOpCount> out;
    for (int i = 0; i < kOpCount; ++i) {
      std::string_view camel = kOpInfo[i].camel;
      std::string s;
      for (size_t j = 0; j < camel.size(); ++j) {
        char c = camel[j];
        bool upper = c >= 'A' && c <= 'Z';
        if (upper && j > 0 && camel[j - 1] >= 'a' && camel[j - 1] <= 'z') s += '_';
        s += upper ? static_cast<char>(c - 'A' + 'a') : c;
      }
      out[i] = std::move(s);
    }
    return out;
  }();
  return names;
}

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

std::string_view op_name(Op op) {
  return snake_names()[static_cast<int>(op)];
}
int op_num_args(Op op) {
  return kOpInfo[static_cast<int>(op)].num_args;
}
unsigned op_flags_of(Op op) {
  return kOpInfo[static_cast<int>(op)].flags;
}

std::string_view error_message(ErrorKind kind) {
  size_t i = static_cast<size_t>(kind);
  return i < kErrorMessages.size() ? kErrorMessages[i] : std::string_view("Unknown run-time error");
}

std::string_view error_kind_name(ErrorKind kind) {
  size_t i = static_cast<size_t>(kind);
  return i < kErrorNames.size() ? kErrorNames[i] : std::string_view("Unknown");
}

int error_kind_count() {
  return static_cast<int>(kErrorMessages.size());
}

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
      default:
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

std::string print(const Function& fn) {
  std::ostringstream out;
  out << "function " << (fn.name.empty() ? "<anonymous>" : fn.name) << "(x[" << fn.num_inputs
      << "], a[" << fn.num_params << "]) slots=" << fn.num_slots;
  if (!fn.s_slots.empty()) {
    out << " s=[";
    for (size_t i = 0; i < fn.s_slots.size(); ++i) out << (i ? ", $" : "$") << fn.s_slots[i];
    out << "]";
  }
  out << "\n";
  // Slot initial values other than "undefined" (NaN), compactly.
  bool any_init = false;
  for (int s = 0; s < fn.num_slots && s < static_cast<int>(fn.slot_init.size()); ++s) {
    if (std::isnan(fn.slot_init[s])) continue;
    out << (any_init ? ", " : "  init ") << "$" << s << "=" << format_double(fn.slot_init[s]);
    any_init = true;
  }
  if (any_init) out << "\n";
  for (size_t t = 0; t < fn.tables.size(); ++t) {
    out << "  table T" << t << " [" << fn.tables[t].size() << " entries]\n";
  }

  int depth = 1;
  for (size_t i = 0; i < fn.insts.size(); ++i) {
    const Inst& in = fn.insts[i];
    if (in.op == Op::kElse || in.op == Op::kEndIf || in.op == Op::kEndLoop)
      depth = std::max(1, depth - 1);
    std::string line(static_cast<size_t>(depth) * 2, ' ');
    if (op_has_value(in.op)) line += "%" + std::to_string(i) + " = ";
    line += op_name(in.op);
    auto arg = [&](int k) {
      return "%" + (in.args[k] == kNoValue ? std::string("?") : std::to_string(in.args[k]));
    };
    switch (in.op) {
      case Op::kConst:
        line += " " + format_double(in.imm);
        break;
      case Op::kInput:
        line += " x[" + std::to_string(in.aux + 1) + "]";
        break;
      case Op::kParam:
        line += " a[" + std::to_string(in.aux + 1) + "]";
        break;
      case Op::kLoadSlot:
        line += " $" + std::to_string(in.aux);
        break;
      case Op::kStoreSlot:
        line += " $" + std::to_string(in.aux) + ", " + arg(0);
        break;
      case Op::kLoadIdx:
        line += " $" + std::to_string(in.aux) + "[" + format_double(in.imm) + "], " + arg(0);
        break;
      case Op::kStoreIdx:
        line += " $" + std::to_string(in.aux) + "[" + format_double(in.imm) + "], " + arg(0) +
                ", " + arg(1);
        break;
      case Op::kTableLoad:
        line += " T" + std::to_string(in.aux) + ", " + arg(0);
        break;
      case Op::kSurface:
        line += " S" + std::to_string(in.aux) + ", " + arg(0) + ", " + arg(1) + ", " + arg(2);
        break;
      case Op::kCheck:
        line += " " + arg(0) + ", " + std::string(error_kind_name(static_cast<ErrorKind>(in.aux)));
        break;
      default:
        for (int k = 0; k < op_num_args(in.op); ++k) line += (k ? ", " : " ") + arg(k);
        break;
    }
    if (in.loc.valid()) {
      if (line.size() < 40) line.resize(40, ' ');
      line += "  ; " + std::to_string(in.loc.line) + ":" + std::to_string(in.loc.col);
    }
    out << line << "\n";
    if (in.op == Op::kIf || in.op == Op::kElse || in.op == Op::kLoop) ++depth;
  }
  out << "  return %" << (fn.result == kNoValue ? std::string("?") : std::to_string(fn.result))
      << "\n";
  return out.str();
}

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
      default:
        break;
    }
  }
  HFRT_CHECK(stack.empty());
  return match;
}

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
        default:
          value[i] = op_has_value(in.op) && args_uniform;
          break;
      }
    }
  }
  return value;
}

std::vector<double> hoist_constants(Function* fn) {
  const size_t n = fn->insts.size();
  // Per value: may it become a parameter? Until a use says otherwise, a constant may.
  std::vector<uint8_t> ok(n, 0), used(n, 0);
  for (size_t i = 0; i < n; ++i) {
    ok[i] = fn->insts[i].op == Op::kConst && std::isfinite(fn->insts[i].imm);
  }
  for (const Inst& in : fn->insts) {
    bool arithmetic = false;
    switch (in.op) {
      case Op::kAdd:
      case Op::kSub:
      case Op::kMul:
      case Op::kDiv:
      case Op::kMin:
      case Op::kMax:
      case Op::kNeg:
      case Op::kStoreSlot:
        arithmetic = true;
        break;
      default:
        break;
    }
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

std::string structure_key(const Function& fn) {
  std::string key;
  auto put = [&key](const void* p, size_t size) { key.append(static_cast<const char*>(p), size); };
  auto put_int = [&](int64_t v) { put(&v, sizeof v); };
  auto put_double = [&](double v) { put(&v, sizeof v); };
  put_int(fn.num_inputs);
  put_int(fn.num_params);
  put_int(fn.hoisted_params_from);
  put_int(fn.num_slots);
  put_int(fn.result);
  put_int(int64_t(fn.insts.size()));
  for (const Inst& in : fn.insts) {
    put_int(int64_t(in.op));
    for (ValueId a : in.args) put_int(a);
    put_double(in.imm);
    put_int(in.aux);
    if (in.op != Op::kParam) {
      put_int(in.loc.line);
      put_int(in.loc.col);
    }
  }
  put_int(int64_t(fn.slot_init.size()));
  for (double v : fn.slot_init) put_double(v);
  put_int(int64_t(fn.s_slots.size()));
  for (int32_t s : fn.s_slots) put_int(s);
  put_int(int64_t(fn.tables.size()));
  for (const auto& t : fn.tables) {
    put_int(int64_t(t.size()));
    for (double v : t) put_double(v);
  }
  put_int(int64_t(fn.surfaces.size()));
  for (const auto& s : fn.surfaces) {
    const void* p = s.get();
    put(&p, sizeof p);
  }
  return key;
}

}  // namespace hfrt::jit
