// The IR printer (print.h).
#include "ir/print.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/regions.h"

namespace hfrt::ir {

using namespace op_flags;

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
      case Op::kIf:
      case Op::kElse:
      case Op::kEndIf:
      case Op::kLoop:
      case Op::kLoopTest:
      case Op::kEndLoop:
        HFRT_OP_CASES_ARITH
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

}  // namespace hfrt::ir
