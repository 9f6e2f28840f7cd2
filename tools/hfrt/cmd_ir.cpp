// `hfrt ir FILE [--object NAME] [--poly]`: print the IR of one object (default: the model, i.e.
// `my_model` if present, else the first object) after lowering, folding and sharing.
//
// Exit codes: 0 = printed, 1 = the file has errors or no such object, 2 = unreadable file.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "base/file.h"
#include "base/result.h"
#include "ir/ir.h"
#include "ir/print.h"
#include "jit/driver.h"
#include "jit/poly.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/model_request.h"

namespace hfrt::tools {
namespace {

struct IrOptions {
  std::string file;
  std::string object;
  bool poly = false;
  ModelLimits limits;
};

int run_ir(const IrOptions& opts) {
  const bool color = use_color(STDERR_FILENO);
  const Limits limits = to_limits(opts.limits);
  Result<std::string> text =
      read_file_limited(opts.file, limits.max_source_bytes, false, "max_source_bytes");
  if (!text) {
    std::fprintf(stderr, "hfrt: %s\n", text.error().message.c_str());
    if (!text.error().hint.empty()) std::fprintf(stderr, "hint: %s\n", text.error().hint.c_str());
    return 2;
  }
  auto file = std::make_shared<const lang::SourceFile>(opts.file, std::move(text).value());
  lang::DiagnosticSink diags(file);
  jit::LoweredSource lowered = jit::compile_source(diags, opts.object, limits);
  // Errors and warnings of the front end and of the lowering (library argument sizes, a mesh
  // or patch file that does not load, ...).
  std::fputs(diags.render(color).c_str(), stderr);
  if (!report_no_object(lowered, opts.file) || !lowered.ok()) return 1;
  const ir::Function& fn = lowered.fn;
  std::string out = ir::print(fn);
  if (opts.poly) {
    // The polynomial domain's program (analytic ray tracing), or why the object has none.
    const jit::PolyAnalysis analysis = jit::analyze_polynomial(fn);
    if (analysis.qualifies) {
      out += "; polynomial program\n" + jit::print(analysis.program);
    } else {
      out += "; not analytic: " + analysis.reason;
      if (analysis.loc.line > 0) {
        out += " at " + opts.file + ":" + std::to_string(analysis.loc.line) + ":" +
               std::to_string(analysis.loc.col);
      }
      out += "\n";
    }
  }
  std::fwrite(out.data(), 1, out.size(), stdout);
  std::fflush(stdout);
  return 0;
}

}  // namespace

CommandRunner register_ir(CLI::App& app) {
  auto opts = std::make_shared<IrOptions>();
  CLI::App* cmd = add_command(app, "ir");
  cmd->add_option("file", opts->file, "HyperFun source file (.hf)")->required();
  cmd->add_option("--object", opts->object,
                  "Object to print (default: my_model if present, else the first object)");
  cmd->add_flag("--poly", opts->poly,
                "Also print the polynomial program of the analytic root search (or why the "
                "object has none)");
  add_limit_options(*cmd, &opts->limits);
  return [opts] { return run_ir(*opts); };
}

}  // namespace hfrt::tools
