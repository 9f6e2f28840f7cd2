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

}  // namespace

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

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

}  // namespace hfrt::ir
