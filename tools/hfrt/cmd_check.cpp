// `hfrt check FILE... [--dump-ast]`: parse and check HyperFun files, print diagnostics.
// A FILE ending in .toml is a scene file (scene/scene_file.h): its first error is printed,
// located, or (when every model it uses passes the front end's checks too) a one-line summary
// of the scene on standard output.
//
// Exit codes: 0 = every file is fine (warnings allowed), 1 = some file has errors,
// 2 = some file could not be read.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "base/file.h"
#include "base/result.h"
#include "lang/frontend.h"
#include "scene/scene_file.h"
#include "tools/hfrt/commands.h"

namespace hfrt::tools {
namespace {

// Offsets in the front end are 32-bit; far below that, a "model" this large is a mistake.
constexpr size_t kMaxSourceBytes = size_t{256} << 20;

struct CheckOptions {
  std::vector<std::string> files;
  bool dump_ast = false;
};

/// Runs the front end (parse and semantic checks, no compilation) on every distinct model of
/// a scene and checks that the object each one names exists; prints the diagnostics. The
/// exit code: 0, 1 (errors), 2 (a model file that cannot be read).
int check_scene_models(const scene::SceneDesc& scene, bool color) {
  std::set<std::string> seen;
  int status = 0;
  for (const scene::ObjectDesc& o : scene.objects) {
    std::string text, name, error;
    if (!scene::object_source(o, scene.path, &text, &name, &error)) {
      std::fprintf(stderr, "hfrt: %s\n", error.c_str());
      status = 2;
      continue;
    }
    if (!seen.insert(name + '\n' + text + '\n' + o.name.value_or("")).second) continue;
    auto file = std::make_shared<const lang::SourceFile>(name, std::move(text));
    lang::DiagnosticSink diags(file);
    std::unique_ptr<lang::Program> prog = lang::parse_program(file, diags);
    lang::check_program(*prog, diags);
    std::fputs(diags.render(color).c_str(), stderr);
    if (diags.has_errors()) {
      if (status == 0) status = 1;
      continue;
    }
    scene::SceneError err;
    if (prog->select_object(o.name.value_or(""), &err.message, &err.hint) < 0) {
      err.pos = o.name ? o.name_pos : o.pos;
      const std::string kInTheFile = " in the file";  // say which file
      if (err.message.size() > kInTheFile.size() &&
          err.message.compare(err.message.size() - kInTheFile.size(), kInTheFile.size(),
                              kInTheFile) == 0)
        err.message.replace(err.message.size() - kInTheFile.size(), kInTheFile.size(),
                            " in " + name);
      std::fputs(err.render().c_str(), stderr);
      if (status == 0) status = 1;
    }
  }
  return status;
}

int run_check(const CheckOptions& opts) {
  const bool color = use_color(STDERR_FILENO);
  int status = 0;
  for (const std::string& path : opts.files) {
    if (path.size() > 5 && path.compare(path.size() - 5, 5, ".toml") == 0) {
      Result<std::string> text = read_file(path);
      if (!text) {
        std::fprintf(stderr, "hfrt: %s\n", text.error().message.c_str());
        status = 2;
        continue;
      }
      scene::SceneDesc scene;
      scene::SceneError err;
      if (!scene::parse_scene(*text, path, &scene, &err)) {
        std::fputs(err.render().c_str(), stderr);
        if (status == 0) status = 1;
        continue;
      }
      const int code = check_scene_models(scene, color);
      if (code == 0) std::printf("%s\n", scene::summary(scene).c_str());
      if (status == 0) status = code;
      continue;
    }
    Result<std::string> text = read_file(path);
    if (!text) {
      std::fprintf(stderr, "hfrt: %s\n", text.error().message.c_str());
      status = 2;
      continue;
    }
    if (text->size() > kMaxSourceBytes) {
      std::fprintf(stderr, "hfrt: '%s' is %zu bytes; hfrt reads source files up to %zu MiB\n",
                   path.c_str(), text->size(), kMaxSourceBytes >> 20);
      status = 2;
      continue;
    }
    auto file = std::make_shared<const lang::SourceFile>(path, std::move(text).value());
    lang::DiagnosticSink diags(file);
    std::unique_ptr<lang::Program> prog = lang::parse_program(file, diags);
    lang::check_program(*prog, diags);
    std::string rendered = diags.render(color);
    std::fputs(rendered.c_str(), stderr);
    if (diags.has_errors()) {
      if (status == 0) status = 1;
    }
    if (opts.dump_ast) {
      std::string dump = lang::dump_ast(*prog);
      std::fwrite(dump.data(), 1, dump.size(), stdout);
    }
  }
  std::fflush(stdout);
  return status;
}

}  // namespace

CommandRunner register_check(CLI::App& app) {
  auto opts = std::make_shared<CheckOptions>();
  CLI::App* cmd = add_command(app, "check");
  cmd->add_option("files", opts->files, "HyperFun source files (.hf) or scene files (.toml)")
      ->required();
  cmd->add_flag("--dump-ast", opts->dump_ast, "Print the checked syntax tree to stdout");
  return [opts] { return run_check(*opts); };
}

}  // namespace hfrt::tools
