// `hfrt cache info|clear`: the compile cache on disk (hfrt/compile_cache.h, docs/compile_cache.md).

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "hfrt/compile_cache.h"
#include "tools/hfrt/commands.h"

namespace hfrt::tools {

CommandRunner register_cache(CLI::App& app) {
  auto action = std::make_shared<std::string>();
  CLI::App* sub = add_command(app, "cache");
  sub->add_option("action", *action, "info or clear")
      ->required()
      ->check(CLI::IsMember({"info", "clear"}));
  return [action] {
    const std::string dir = compile_cache_dir();
    if (*action == "clear") {
      std::string error;
      const long removed = clear_compile_cache(&error);
      if (removed < 0) {
        std::fprintf(stderr, "hfrt cache: %s\n", error.c_str());
        return 2;
      }
      std::printf("hfrt cache: removed %ld entr%s from %s\n", removed, removed == 1 ? "y" : "ies",
                  dir.empty() ? "(no folder)" : dir.c_str());
      return 0;
    }
    uint64_t entries = 0, bytes = 0;
    compile_cache_usage(&entries, &bytes);
    std::printf("folder: %s\nenabled: %s\nentries: %llu\nbytes: %llu\n",
                dir.empty() ? "(none: set HFRT_CACHE_DIR, XDG_CACHE_HOME or HOME)" : dir.c_str(),
                compile_cache_enabled() ? "yes" : "no (HFRT_NO_CACHE or --no-cache)",
                (unsigned long long)entries, (unsigned long long)bytes);
    return 0;
  };
}

}  // namespace hfrt::tools
