#pragma once
// HyperFun text as a list of object definitions, before any parsing: the REPL keeps its
// session as such a list (a redefined object replaces its old text in place) and needs to know
// when a typed definition is complete. Brace counting, `--` comments skipped; no other syntax.

#include <string>
#include <string_view>
#include <vector>

namespace hfrt::lang {

/// The change in brace depth of a line of HyperFun (comments `--` skipped).
int brace_delta(std::string_view line);

/// The name of the object a definition defines: its first identifier (comments skipped).
std::string defined_object_name(std::string_view text);

/// Splits a file into object definitions: each ends where its braces balance. Text after the
/// last balanced definition is kept when it opened a brace (an unfinished definition, which
/// the parser then reports), dropped when it is only blank.
std::vector<std::string> split_objects(std::string_view text);

}  // namespace hfrt::lang
