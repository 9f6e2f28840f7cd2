// What the launcher (main.cpp) and the command module (cli_main.cpp) share: the top level of
// the command line, subcommands named from command_table.h, and use_color (commands.h).
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "base/check.h"
#include "tools/hfrt/command_table.h"
#include "tools/hfrt/commands.h"

namespace hfrt::tools {

CLI::App* add_command(CLI::App& app, std::string_view name) {
  const CommandInfo* info = find_command(name);
  HFRT_CHECK(info);  // every subcommand is in the table
  CLI::App* sub = app.add_subcommand(std::string(info->name), std::string(info->description));
  if (info->hidden) sub->group("");  // a developer's command: not in the help
  return sub;
}

void add_top_level(CLI::App& app, bool* no_cache) {
  app.description(kAppDescription);
  app.require_subcommand(1);
  app.add_flag("--no-cache", *no_cache, kNoCacheHelp);
}

std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  return std::nullopt;
}

bool use_color(int fd) {
  if (std::getenv("NO_COLOR")) return false;
  const char* term = std::getenv("TERM");
  if (term && std::string(term) == "dumb") return false;
  return isatty(fd);
}

}  // namespace hfrt::tools
