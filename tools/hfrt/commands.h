#pragma once
// Each subcommand registers itself on the CLI11 app and returns the exit code through `run`.

#include <functional>
#include <optional>
#include <string>
#include <string_view>

namespace CLI {
class App;
}
namespace hfrt::jit {
struct LoweredSource;
}

namespace hfrt::tools {

/// A registered subcommand: `run` is called when the user picked it and returns the exit code.
using CommandRunner = std::function<int()>;

CommandRunner register_check(CLI::App& app);
CommandRunner register_ir(CLI::App& app);
CommandRunner register_eval(CLI::App& app);
CommandRunner register_render(CLI::App& app);
CommandRunner register_slice(CLI::App& app);
CommandRunner register_repl(CLI::App& app);
CommandRunner register_emit(CLI::App& app);
CommandRunner register_mesh(CLI::App& app);
CommandRunner register_gpu_cases(CLI::App& app);
CommandRunner register_cache(CLI::App& app);

/// Adds subcommand `name` of command_table.h's kCommands to `app`, with the table's description,
/// hidden from the help when the table says so. Both front ends (the launcher main.cpp and the
/// command module cli_main.cpp) name their subcommands through it, so their help agrees.
CLI::App* add_command(CLI::App& app, std::string_view name);

/// The top level both front ends share: kAppDescription, one subcommand required, and
/// `--no-cache` into `*no_cache`.
void add_top_level(CLI::App& app, bool* no_cache);

/// Parses the command line. Returns the exit code when parsing ended the run (help printed: 0;
/// a usage error printed: 2, never CLI11's own per-error codes, which would leak 100+ codes to
/// scripts), or nullopt when a subcommand is to run.
std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv);

/// True when the stream is a terminal and colour is not disabled (NO_COLOR, TERM=dumb).
bool use_color(int fd);

/// When the source compiled but has no such object (jit::compile_source), prints the located
/// error (`FILE: error: no object named 'x' in the file`, then a hint listing the objects) to
/// stderr and returns false; true otherwise.
bool report_no_object(const jit::LoweredSource& lowered, const std::string& file);

}  // namespace hfrt::tools
