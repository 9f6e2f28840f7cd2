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
#include <optional>
#include <string_view>
#include <vector>

#include "base/memory.h"
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
  if (info && command != "check") {
    // `hfrt mesh` and `hfrt render` run with malloc on transparent huge pages (one exec of
    // this small launcher; base/memory.h says why): a 512^3 mesh and its file took 0.7-1.1 s
    // less (blend, gyroid); a render's process 15-25 % less where it builds a mesh or patch
    // leaf's BVH (the teapot 0.26-0.32 -> 0.22-0.24 s, the armadillo 0.23-0.37 -> 0.17-0.27 s)
    // and no more on small models (csg 0.36-0.38 -> 0.34 s). The other commands allocate
    // little: there the 2 MiB pages' zeroing and the exec cost ~5 ms of CPU (`hfrt eval` 127 ->
    // 133 ms) for nothing. `hfrt repl` frees and allocates the same large buffers at every
    // render: its Session keeps them on malloc's heap instead (keep_large_blocks_on_heap).
    // A render also runs on one malloc arena: its threads allocate little while they trace, and
    // the teapot's process took 0.138-0.155 s with an arena per thread against 0.119-0.134 s
    // (perf stat -r 10, three rounds alternating; the surface's build frees its temporaries on a
    // TBB worker); the armadillo the same within the noise, c1_gear at --threads 8 0.23-0.25 ->
    // 0.20-0.21 s. A mesh is the same either way (512^3 blend and gyroid): left as it was.
    if (command == "mesh" || command == "render")
      hfrt::reexec_with_huge_page_malloc(argv, /*one_arena=*/command == "render");
    return run_module(argc, argv, command);
  }

  // `check`, the top-level help, and usage errors without a known subcommand. The other
  // subcommands appear with their descriptions only, as the help lists them.
  CLI::App app;
  bool no_cache = false;  // parsed for the help and usage; `check` compiles nothing
  hfrt::tools::add_top_level(app, &no_cache);
  hfrt::tools::CommandRunner check;
  for (const hfrt::tools::CommandInfo& c : hfrt::tools::kCommands) {
    if (c.name == "check") {
      check = hfrt::tools::register_check(app);
      app.get_subcommands({}).back()->fallthrough();
    } else {
      hfrt::tools::add_command(app, c.name);
    }
  }
  if (std::optional<int> code = hfrt::tools::parse_command_line(app, argc, argv)) return *code;
  return app.got_subcommand("check") ? check() : 2;
}
