// hfrt — compile and render HyperFun models.
//
// This executable is a launcher. It runs `hfrt check` and the top-level help and usage errors
// itself, with the front end and the scene reader only, and hands every other subcommand to the
// command module libhfrt_cli.so (cli_main.cpp, loaded with base/module.h), which links the JIT
// (LLVM), the renderer, TBB and Open MPI. Loading and relocating those costs ~25 ms of CPU and
// ~50 MiB per process, which an editor that runs `hfrt check` on every save should not pay
// (issue 25; bench/startup/startup.py measures it).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <string_view>
#include <vector>

#include "base/module.h"
#include "tools/hfrt/command_table.h"
#include "tools/hfrt/commands.h"

namespace {

/// The subcommand named on the command line: the first argument that is not an option (the
/// top-level options, -h/--help and --no-cache, take no value), or "" when there is none.
std::string_view subcommand_of(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    std::string_view a = argv[i];
    if (a == "--") return "";
    if (!a.empty() && a[0] != '-') return a;
  }
  return "";
}

/// Runs a subcommand of the command module.
int run_module(int argc, char** argv, std::string_view command) {
  // RTLD_GLOBAL: Open MPI's components, which it loads itself, resolve their symbols in
  // libmpi and libopen-pal through the global scope.
  auto entry = hfrt::module_symbol("cli", "hfrt_cli_main", hfrt::ModuleScope::kGlobal);
  if (!entry.ok()) {
    std::fprintf(stderr, "hfrt: cannot run '%.*s': %s\nhint: %s\n", int(command.size()),
                 command.data(), entry.error().message.c_str(), entry.error().hint.c_str());
    return 2;
  }
  using MainFn = int (*)(int, char**);
  return reinterpret_cast<MainFn>(entry.value())(argc, argv);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string_view command = subcommand_of(argc, argv);
  const hfrt::tools::CommandInfo* info = hfrt::tools::find_command(command);
  if (info && command != "check") return run_module(argc, argv, command);

  // `check`, the top-level help, and usage errors without a known subcommand. The other
  // subcommands appear with their descriptions only, as the help lists them.
  CLI::App app{hfrt::tools::kAppDescription};
  app.require_subcommand(1);
  bool no_cache = false;
  app.add_flag("--no-cache", no_cache, hfrt::tools::kNoCacheHelp);
  hfrt::tools::CommandRunner check;
  for (const hfrt::tools::CommandInfo& c : hfrt::tools::kCommands) {
    if (c.name == "check") {
      check = hfrt::tools::register_check(app);
      app.get_subcommands({}).back()->fallthrough();
    } else {
      CLI::App* sub = app.add_subcommand(std::string(c.name), std::string(c.description));
      if (c.hidden) sub->group("");
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Help and version requests exit 0; every usage error exits 2 (as in cli_main.cpp).
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  return app.got_subcommand("check") ? check() : 2;
}
