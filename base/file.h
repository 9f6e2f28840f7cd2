#pragma once
// Reading files whole. A file that cannot be read is an environment failure: a Result, never
// an abort (the caller decides whether it is a usage error or a diagnostic).

#include <string>

#include "base/result.h"

namespace hfrt {

/// Reads a whole file (binary-safe). The error names the path and says why (errno text).
Result<std::string> read_file(const std::string& path);

}  // namespace hfrt
