// The IR's op table and names (see ir.h, ir_ops.h).
#include "ir/ir.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "base/check.h"

namespace hfrt::ir {

namespace {

// The columns of ir_ops.h agree with each other, for every op (a new op's row is checked
// when it is added): the kinds computed from arguments are exactly the ops with a vector lane
// and a polynomial rule, are pure values with arguments, and only they are traced; the C
// function names are given exactly for the lanes that call one; kCtl is the kind Ctl.
constexpr bool columns_agree(Op op) {
  const bool arith = op_is_arith(op);
  const OpLane lane = op_lane(op);
  const bool calls = lane == OpLane::kIntrinsic || lane == OpLane::kLibm || lane == OpLane::kHelper;
  const unsigned f = op_flags_of(op);
  return arith == (lane != OpLane::kNone) && arith == (op_poly_rule(op) != OpPolyRule::kNA) &&
         (!arith || (op_is_pure(op) && op_has_value(op) && op_num_args(op) > 0)) &&
         calls == (op_libm_name(op, false) != nullptr) &&
         calls == (op_libm_name(op, true) != nullptr) && (!(f & op_flags::kTraced) || arith) &&
         ((f & op_flags::kCtl) != 0) == (op_kind(op) == OpKind::kCtl);
}
#define HFRT_X(name, ...) \
  static_assert(columns_agree(Op::k##name), "ir_ops.h: the columns of " #name " disagree");
HFRT_IR_OPS(HFRT_X)
#undef HFRT_X

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
      std::string_view camel = detail::kOpInfo[i].camel;
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

}  // namespace

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string_view op_name(Op op) {
  return snake_names()[static_cast<int>(op)];
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

}  // namespace hfrt::ir
