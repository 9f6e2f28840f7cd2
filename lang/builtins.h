#pragma once
// The built-in functions of the language, listed once.

#include <optional>
#include <string_view>

namespace hfrt::lang {

// X(enum_name, spelled_name, arity)
#define HFRT_BUILTINS(X) \
  X(kSqrt, "sqrt", 1)    \
  X(kExp, "exp", 1)      \
  X(kLog, "log", 1)      \
  X(kLogd, "logd", 1)    \
  X(kSin, "sin", 1)      \
  X(kCos, "cos", 1)      \
  X(kTan, "tan", 1)      \
  X(kAsin, "asin", 1)    \
  X(kAcos, "acos", 1)    \
  X(kAtan, "atan", 1)    \
  X(kAbs, "abs", 1)      \
  X(kSinh, "sinh", 1)    \
  X(kCosh, "cosh", 1)    \
  X(kTanh, "tanh", 1)    \
  X(kSign, "sign", 1)    \
  X(kCeil, "ceil", 1)    \
  X(kFloor, "floor", 1)  \
  X(kInt, "int", 1)      \
  X(kFrac, "frac", 1)    \
  X(kMax, "max", 2)      \
  X(kMin, "min", 2)      \
  X(kAtan2, "atan2", 2)  \
  X(kMod, "mod", 2)

enum class Builtin {
#define HFRT_X(e, s, n) e,
  HFRT_BUILTINS(HFRT_X)
#undef HFRT_X
};

/// The builtin with this name, compared case-insensitively.
std::optional<Builtin> find_builtin(std::string_view name);
std::string_view builtin_name(Builtin b);
int builtin_arity(Builtin b);

}  // namespace hfrt::lang
