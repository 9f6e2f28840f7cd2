// Reading files whole (base/file.h).
#include "base/file.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "base/limits.h"

namespace hfrt {
namespace {

using FilePtr = std::unique_ptr<FILE, int (*)(FILE*)>;

// Appends up to `max_bytes` bytes (or everything when max_bytes < 0) of `f` to `text`; false
// when the file has more.
bool read_into(FILE* f, int64_t max_bytes, std::string* text) {
  char buf[1 << 16];
  for (;;) {
    size_t want = sizeof buf;
    if (max_bytes >= 0) {
      const int64_t left = max_bytes + 1 - static_cast<int64_t>(text->size());
      if (left <= 0) return false;
      if (static_cast<int64_t>(want) > left) want = static_cast<size_t>(left);
    }
    size_t n = std::fread(buf, 1, want, f);
    text->append(buf, n);
    if (max_bytes >= 0 && static_cast<int64_t>(text->size()) > max_bytes) return false;
    if (n < want) return true;
  }
}

Error bytes_over(const std::string& path, const std::string& size, int64_t max_bytes,
                 std::string_view limit_name) {
  return Error{
      path + ": is " + size + "more than the limit of " + std::to_string(max_bytes) + " bytes",
      limit_hint(limit_name)};
}

}  // namespace

Result<std::string> read_file(const std::string& path) {
  // C stdio rather than iostreams: it gives errno, which makes the message useful.
  FilePtr f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) return Error{"cannot open '" + path + "': " + std::strerror(errno)};
  std::string text;
  read_into(f.get(), -1, &text);
  if (std::ferror(f.get())) {
    // Reading a directory opens fine on Linux and fails here with EISDIR.
    return Error{"cannot read '" + path + "': " + std::strerror(errno)};
  }
  return text;
}

Result<std::string> read_file_limited(const std::string& path, int64_t max_bytes, bool regular_only,
                                      std::string_view limit_name) {
  FilePtr f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) return Error{"cannot open '" + path + "': " + std::strerror(errno)};
  struct stat st {};
  if (fstat(fileno(f.get()), &st) != 0) {
    return Error{"cannot read '" + path + "': " + std::strerror(errno)};
  }
  const bool regular = S_ISREG(st.st_mode);
  if (S_ISDIR(st.st_mode)) return Error{path + ": is a directory"};
  if (!regular && regular_only) {
    return Error{path +
                 ": is not a regular file (a device, a pipe or a socket, which may never "
                 "end)"};
  }
  if (regular && st.st_size > max_bytes) {
    return bytes_over(path, std::to_string(st.st_size) + " bytes, ", max_bytes, limit_name);
  }
  std::string text;
  if (regular) text.reserve(static_cast<size_t>(st.st_size));
  const bool complete = read_into(f.get(), max_bytes, &text);
  if (std::ferror(f.get())) return Error{"cannot read '" + path + "': " + std::strerror(errno)};
  // A file that grew while it was read, or a stream: its size is not known.
  if (!complete) return bytes_over(path, "", max_bytes, limit_name);
  return text;
}

}  // namespace hfrt
