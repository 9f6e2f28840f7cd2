#pragma once
// What the launcher's huge-page malloc (base/memory.h, tools/hfrt/main.cpp) makes a command's
// --stats say on this machine, for the CLI tests of the commands that use it.

#include <fstream>
#include <string>

namespace hfrt::testing {

inline constexpr const char* kMallocHugePagesLine =
    "stats: memory: malloc on transparent huge pages";
inline constexpr const char* kMallocDefaultPagesLine =
    "stats: memory: malloc on the kernel's default pages";

/// The kernel's transparent-huge-page mode line ("always [madvise] never").
inline std::string thp_mode() {
  std::ifstream mode_file("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(mode_file, mode);
  return mode;
}

/// The memory line a command on huge-page malloc prints: huge pages where the kernel's mode is
/// madvise (elsewhere the launcher changes nothing).
inline const char* expected_malloc_line() {
  return thp_mode().find("[madvise]") != std::string::npos ? kMallocHugePagesLine
                                                           : kMallocDefaultPagesLine;
}

}  // namespace hfrt::testing
