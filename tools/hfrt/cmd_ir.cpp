// `hfrt ir FILE [--object NAME]`: print the IR of one object (default: the model, i.e.
// `my_model` if present, else the first object) after lowering, folding and sharing.
//
// Exit codes: 0 = printed, 1 = the file has errors or no such object, 2 = unreadable file.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "jit/ir.h"
#include "jit/lower.h"
#include "lang/frontend.h"
#include "lang/result.h"
#include "tools/hfrt/commands.h"

namespace hfrt::tools {
namespace {

struct IrOptions {
  std::string file;
  std::string object;
};

int run_ir(const IrOptions& opts) {
  const bool color = use_color(STDERR_FILENO);
  Result<std::string> text = read_file(opts.file);
  if (!text) {
    std::fprintf(stderr, "hfrt: %s\n", text.error().message.c_str());
    return 2;
  }
  auto file = std::make_shared<const lang::SourceFile>(opts.file, std::move(text).value());
  lang::DiagnosticSink diags(file);
  std::unique_ptr<lang::Program> prog = lang::compile_source(file, diags);
  if (!prog) {
    std::fputs(diags.render(color).c_str(), stderr);
    return 1;
  }
  int index = opts.object.empty() ? prog->default_object() : prog->find_object(opts.object);
  if (index < 0) {
    std::string names;
    for (const lang::Object& o : prog->objects) names += (names.empty() ? "" : ", ") + o.name;
    std::fprintf(stderr, "hfrt: %s has no object named '%s' (objects: %s)\n", opts.file.c_str(),
                 opts.object.c_str(), names.c_str());
    return 1;
  }
  jit::Function fn = jit::lower_object(*prog, index, &diags);
  // Warnings of the front end and of the lowering (library argument sizes, ...).
  std::fputs(diags.render(color).c_str(), stderr);
  // Errors of the lowering: a mesh or patch file that does not load (issue 10).
  if (diags.has_errors()) return 1;
  std::string out = jit::print(fn);
  std::fwrite(out.data(), 1, out.size(), stdout);
  std::fflush(stdout);
  return 0;
}

}  // namespace

CommandRunner register_ir(CLI::App& app) {
  auto opts = std::make_shared<IrOptions>();
  CLI::App* cmd =
      app.add_subcommand("ir", "Print the intermediate representation of a HyperFun object");
  cmd->add_option("file", opts->file, "HyperFun source file (.hf)")->required();
  cmd->add_option("--object", opts->object,
                  "Object to print (default: my_model if present, else the first object)");
  return [opts] { return run_ir(*opts); };
}

}  // namespace hfrt::tools
