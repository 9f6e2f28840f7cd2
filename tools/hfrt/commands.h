#pragma once
// Each subcommand registers itself on the CLI11 app and returns the exit code through `run`.

#include <functional>
#include <string>

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

/// True when the stream is a terminal and colour is not disabled (NO_COLOR, TERM=dumb).
bool use_color(int fd);

/// When the source compiled but has no such object (jit::compile_source), prints the located
/// error (`FILE: error: no object named 'x' in the file`, then a hint listing the objects) to
/// stderr and returns false; true otherwise.
bool report_no_object(const jit::LoweredSource& lowered, const std::string& file);

}  // namespace hfrt::tools
