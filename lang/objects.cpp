// Splitting HyperFun text into object definitions (objects.h).
#include "lang/objects.h"

#include <algorithm>
#include <cctype>

namespace hfrt::lang {

int brace_delta(std::string_view line) {
  int d = 0;
  for (size_t i = 0; i < line.size(); ++i) {
    if (line.compare(i, 2, "--") == 0) break;
    if (line[i] == '{') ++d;
    if (line[i] == '}') --d;
  }
  return d;
}

/// The name of the object a definition defines: its first identifier (comments skipped).
std::string defined_object_name(std::string_view text) {
  size_t i = 0;
  while (i < text.size()) {
    if (std::isspace(static_cast<unsigned char>(text[i]))) {
      ++i;
    } else if (text.compare(i, 2, "--") == 0) {
      while (i < text.size() && text[i] != '\n') ++i;
    } else {
      break;
    }
  }
  size_t b = i;
  while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '_'))
    ++i;
  return std::string(text.substr(b, i - b));
}

/// Splits a file into object definitions: each ends where its braces balance.
std::vector<std::string> split_objects(std::string_view text) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  bool opened = false;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t nl = text.find('\n', pos);
    std::string_view line =
        text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos + 1);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    cur += line;
    int d = brace_delta(line);
    if (line.find('{') != std::string_view::npos) opened = true;
    depth += d;
    if (opened && depth <= 0) {
      out.push_back(cur);
      cur.clear();
      depth = 0;
      opened = false;
    }
  }
  if (opened && std::any_of(cur.begin(), cur.end(),
                            [](char c) { return !std::isspace(static_cast<unsigned char>(c)); }))
    out.push_back(cur);
  return out;
}

}  // namespace hfrt::lang
