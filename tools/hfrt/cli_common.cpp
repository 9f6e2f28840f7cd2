// use_color (commands.h), for the launcher's `check` (main.cpp) and the command module
// (cli_main.cpp).
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "tools/hfrt/commands.h"

namespace hfrt::tools {

bool use_color(int fd) {
  if (std::getenv("NO_COLOR")) return false;
  const char* term = std::getenv("TERM");
  if (term && std::string(term) == "dumb") return false;
  return isatty(fd);
}
}  // namespace hfrt::tools
