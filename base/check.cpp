// HFRT_CHECK failure handler: a broken invariant is a bug in hfrt, never a user error.
#include "base/check.h"

#include <cstdio>
#include <cstdlib>

namespace hfrt {

void check_failed(const char* file, int line, const std::string& what) {
  std::fflush(stdout);
  std::fprintf(stderr, "hfrt: internal error: %s:%d: %s\n", file, line, what.c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace hfrt
