// Reading files whole (base/file.h).
#include "base/file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

namespace hfrt {

Result<std::string> read_file(const std::string& path) {
  // C stdio rather than iostreams: it gives errno, which makes the message useful.
  std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) return Error{"cannot open '" + path + "': " + std::strerror(errno)};
  std::string text;
  char buf[1 << 16];
  for (;;) {
    size_t n = std::fread(buf, 1, sizeof buf, f.get());
    text.append(buf, n);
    if (n < sizeof buf) break;
  }
  if (std::ferror(f.get())) {
    // Reading a directory opens fine on Linux and fails here with EISDIR.
    return Error{"cannot read '" + path + "': " + std::strerror(errno)};
  }
  return text;
}

}  // namespace hfrt
