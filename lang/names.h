#pragma once
// Case-insensitive name handling: HyperFun compares identifiers, keywords and function names
// without case, while diagnostics print names as written.

#include <string>
#include <string_view>

namespace hfrt::lang {

/// ASCII lower-case copy of `name` (the language is ASCII; other bytes pass through).
inline std::string fold_case(std::string_view name) {
  std::string out(name);
  for (char& c : out) {
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  }
  return out;
}

/// True when `a` and `b` are the same name for HyperFun.
inline bool same_name(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

}  // namespace hfrt::lang
