// The command module of hfrt (libhfrt_cli.so): every subcommand on one CLI11 app. The `hfrt`
// executable (main.cpp) runs `check` and the top-level help itself and loads this module for
// everything else, so that LLVM, TBB and Open MPI are loaded only by the commands that use them.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hfrt/compile_cache.h"
#include "jit/driver.h"
#include "lang/diagnostics.h"
#include "tools/hfrt/commands.h"

namespace hfrt::tools {

bool report_no_object(const jit::LoweredSource& lowered, const std::string& file) {
  if (!lowered.program || lowered.object >= 0) return true;
  const std::string text =
      lang::render_brief(file, lang::Severity::kError, lowered.no_object, lowered.no_object_hint);
  std::fputs(text.c_str(), stderr);
  return false;
}

}  // namespace hfrt::tools

extern "C" __attribute__((visibility("default"))) int hfrt_cli_main(int argc, char** argv) {
  CLI::App app;
  bool no_cache = false;
  hfrt::tools::add_top_level(app, &no_cache);
  std::vector<std::pair<CLI::App*, hfrt::tools::CommandRunner>> commands;
  auto add = [&](hfrt::tools::CommandRunner (*reg)(CLI::App&)) {
    size_t before = app.get_subcommands({}).size();
    auto runner = reg(app);
    auto subs = app.get_subcommands({});
    if (subs.size() > before) {
      // `hfrt render ... --no-cache`: the subcommands pass the main options up.
      subs.back()->fallthrough();
      commands.emplace_back(subs.back(), std::move(runner));
    }
  };
  add(hfrt::tools::register_check);
  add(hfrt::tools::register_ir);
  add(hfrt::tools::register_eval);
  add(hfrt::tools::register_render);
  add(hfrt::tools::register_slice);
  add(hfrt::tools::register_repl);
  add(hfrt::tools::register_emit);
  add(hfrt::tools::register_mesh);
  add(hfrt::tools::register_gpu_cases);
  add(hfrt::tools::register_cache);
  if (std::optional<int> code = hfrt::tools::parse_command_line(app, argc, argv)) return *code;
  if (no_cache) hfrt::configure_compile_cache(false);
  for (auto& [sub, run] : commands) {
    if (sub->parsed()) return run();
  }
  return 2;
}
