#pragma once
// Reading files whole. A file that cannot be read is an environment failure: a Result, never
// an abort (the caller decides whether it is a usage error or a diagnostic).

#include <cstdint>
#include <string>
#include <string_view>

#include "base/result.h"

namespace hfrt {

/// Reads a whole file (binary-safe). The error names the path and says why (errno text).
Result<std::string> read_file(const std::string& path);

/// Reads a whole file of at most `max_bytes` bytes, so that a huge or endless input (a 1 GB
/// file, /dev/zero) costs neither the time nor the memory of reading it. A regular file's
/// size is checked before reading; another kind of file (a device, a pipe) is refused when
/// `regular_only`, else read until it ends or passes the limit. Errors: the read_file ones,
/// "PATH: is a directory", "PATH: is not a regular file (...)" and "PATH: is N bytes, more
/// than the limit of M bytes", the last with the hint of `limit_name` (limit_hint).
Result<std::string> read_file_limited(const std::string& path, int64_t max_bytes, bool regular_only,
                                      std::string_view limit_name);

}  // namespace hfrt
