// Built-in function table lookups.
#include "lang/builtins.h"

#include <array>

#include "base/check.h"
#include "lang/names.h"

namespace hfrt::lang {
namespace {

struct BuiltinInfo {
  std::string_view name;
  int arity;
};

constexpr std::array kBuiltins = {
#define HFRT_X(e, s, n) BuiltinInfo{s, n},
    HFRT_BUILTINS(HFRT_X)
#undef HFRT_X
};

const BuiltinInfo& info(Builtin b) {
  auto i = static_cast<size_t>(b);
  HFRT_CHECK_LT(i, kBuiltins.size());
  return kBuiltins[i];
}

}  // namespace

std::optional<Builtin> find_builtin(std::string_view name) {
  for (size_t i = 0; i < kBuiltins.size(); ++i) {
    if (same_name(kBuiltins[i].name, name)) return static_cast<Builtin>(i);
  }
  return std::nullopt;
}

std::string_view builtin_name(Builtin b) {
  return info(b).name;
}
int builtin_arity(Builtin b) {
  return info(b).arity;
}

}  // namespace hfrt::lang
