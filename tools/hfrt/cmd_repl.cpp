// `hfrt repl [MODEL.hf]`: an interactive session (see session.h and repl.cpp).
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "tools/hfrt/commands.h"

namespace hfrt::tools {

int run_repl(const std::string& model_file);  // repl.cpp

CommandRunner register_repl(CLI::App& app) {
  auto file = std::make_shared<std::string>();
  CLI::App* sub = add_command(app, "repl");
  sub->add_option("model", *file, "HyperFun model file to :load first");
  return [file] { return run_repl(*file); };
}

}  // namespace hfrt::tools
