// `hfrt render MODEL.hf -o OUT.png [--size WxH] [--bbox xmin,ymin,zmin,xmax,ymax,zmax]
//      [--eye x,y,z] [--look-at x,y,z] [--up x,y,z] [--fov DEG] [--ortho WIDTH]
//      [--root sign|interval|auto] [--spp N] [--threads N] [-a v1,...] [--object NAME]
//      [--light KIND:x,y,z[,intensity]]... [--step S] [--epsilon E] [--aov depth,normal]
//      [--background r,g,b] [--no-shadows] [--backend jit|interp] [--stats]`
//
// `hfrt render SCENE.toml -o OUT.png [the same options]`: a scene file (docs/scenes.md) of
// several objects with materials and lights, traced recursively (render/tracer.h); the options
// given on the command line replace the scene's values.
//
// Ray traces the model (tile-parallel, render/renderer.h) and writes the image; the format
// follows the extension (PNG, EXR, TIFF, JPEG). Without --eye/--look-at the solid's extent
// inside the bounding box is found first and framed from a three-quarter view.
//
// Exit codes: 0 = done, 1 = the model has compile errors (diagnostics on stderr),
// 2 = usage or environment error (bad option, unreadable model, unwritable image).

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "app/render_job.h"
#include "app/scene_job.h"
#include "render/framing.h"
#include "render/image.h"
#include "render/progress.h"
#include "render/renderer.h"
#include "scene/scene_file.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/render_options.h"

namespace hfrt::tools {
namespace {

// The options, their validation and the `--root auto` decision are shared with the REPL:
// render_options.h.

int usage_error(const std::string& message) {
  std::fprintf(stderr, "hfrt render: %s\n", message.c_str());
  return 2;
}

bool is_scene_file(const std::string& path) {
  return path.size() > 5 && path.compare(path.size() - 5, 5, ".toml") == 0;
}

/// `hfrt render scene.toml`: the scene file's values, with every option given on the command
/// line taking their place (`given` tells which were).
int run_scene(const RenderCli& cli, const CLI::App& given) {
  app::RenderSetup setup;
  std::string err;
  if (!translate_render_options(cli, &setup, &err)) return usage_error(err);
  for (const char* model_only : {"--bbox", "-a", "--object", "--step", "--epsilon"}) {
    if (given.count(model_only) > 0) {
      return usage_error(std::string(model_only) +
                         " applies to a .hf model; in a scene file set it on the [[object]] "
                         "(bbox, params, name)");
    }
  }
  scene::SceneDesc desc;
  scene::SceneError serr;
  if (!scene::read_scene_file(cli.model.file, &desc, &serr)) {
    std::fputs(serr.render().c_str(), stderr);
    return 1;
  }
  app::SceneOverrides ov;
  const render::RenderOptions& o = setup.options;
  if (given.count("--size") > 0) ov.size = std::array<int, 2>{o.width, o.height};
  if (given.count("--spp") > 0) ov.spp = o.spp;
  if (given.count("--root") > 0) ov.root = o.root;
  if (given.count("--background") > 0) ov.background = o.background;
  if (cli.max_depth >= 0) ov.max_depth = cli.max_depth;
  ov.camera = setup.camera;
  ov.lights = o.lights;
  ov.no_shadows = cli.no_shadows;
  ov.threads = o.threads;
  ov.interp_backend = cli.model.backend == "interp";

  render::ProgressBar bar("rendering", isatty(STDERR_FILENO) != 0);
  render::TraceResult result;
  app::SceneJobResult done = app::run_scene_job(
      desc, ov, [&bar](size_t d, size_t total) { bar.update(d, total); }, nullptr, &result);
  for (const std::string& w : done.warnings) std::fprintf(stderr, "%s\n", w.c_str());
  switch (done.status) {
    case app::SceneJobStatus::kOk:
    case app::SceneJobStatus::kCancelled:
      break;
    case app::SceneJobStatus::kSourceError:
      std::fputs(done.error.c_str(), stderr);
      return 1;
    case app::SceneJobStatus::kEnvironment:
      std::fprintf(stderr, "hfrt: %s\n", done.error.c_str());
      return 2;
    case app::SceneJobStatus::kUsageError:
      std::fprintf(stderr, "%s: error: %s\n", cli.model.file.c_str(), done.error.c_str());
      return 1;
  }
  bar.finish();
  auto written = render::write_image(result.image, cli.output, setup.aovs);
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
    return 2;
  }
  const render::TraceOptions& opt = done.options;
  std::fprintf(stderr, "hfrt: wrote %s (%dx%d, %d spp, %zu objects, max depth %d)\n",
               cli.output.c_str(), opt.width, opt.height, opt.spp, done.objects.size(),
               opt.max_depth);
  for (size_t i = 1; i < written.value().size(); ++i) {
    std::fprintf(stderr, "hfrt: wrote %s\n", written.value()[i].c_str());
  }
  if (result.stats.evals.nan_samples > 0) {
    std::fprintf(stderr, "hfrt: warning: F has no value at %llu samples (counted as outside)\n",
                 (unsigned long long)result.stats.evals.nan_samples);
  }
  if (cli.stats) std::fputs(app::format_scene_stats(done, result.stats).c_str(), stderr);
  return 0;
}

int run_render(const RenderCli& cli) {
  app::RenderJob job;
  std::string err;
  if (!translate_render_options(cli, &job.setup, &err)) return usage_error(err);

  int code = 0;
  auto loaded = load_model(cli.model, /*eager_f32=*/true, &code);
  if (!loaded) return code;
  job.model = &*loaded->model;
  job.file = cli.model.file;

  render::ProgressBar bar("rendering", isatty(STDERR_FILENO) != 0);
  job.setup.options.progress = [&bar](size_t done, size_t total) { bar.update(done, total); };
  render::RenderResult result;
  app::RenderJobResult done = app::run_render_job(job, &result);
  for (const std::string& w : done.warnings) std::fprintf(stderr, "%s\n", w.c_str());
  // --root analytic on a model that does not qualify: located, like a compile error (exit 1).
  if (done.status == app::RenderJobStatus::kSourceError) {
    std::fputs(done.error.c_str(), stderr);
    return 1;
  }
  if (done.status == app::RenderJobStatus::kUsageError) return usage_error(done.error);
  bar.finish();

  const render::RenderOptions& opt = done.options;
  auto written = render::write_image(result.image, cli.output, job.setup.aovs);
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
    return 2;
  }
  const render::RenderStats& st = result.stats;
  const std::string& auto_why = done.report.root.why;
  std::string why = auto_why.empty() ? "" : " (auto: " + auto_why + ")";
  std::fprintf(stderr, "hfrt: wrote %s (%dx%d, %d spp, root search %s%s)\n", cli.output.c_str(),
               opt.width, opt.height, opt.spp, render::root_mode_name(st.root_used), why.c_str());
  for (size_t i = 1; i < written.value().size(); ++i) {
    std::fprintf(stderr, "hfrt: wrote %s\n", written.value()[i].c_str());
  }
  if (st.evals.nan_samples > 0) {
    std::fprintf(stderr, "hfrt: warning: F has no value at %llu samples (counted as outside)%s%s\n",
                 (unsigned long long)st.evals.nan_samples, st.nan_explanation.empty() ? "" : ": ",
                 st.nan_explanation.c_str());
  }
  if (cli.stats) {
    app::RenderReport report = done.report;
    report.compile_ms = loaded->compile_ms;
    std::fputs(app::format_render_stats(report).c_str(), stderr);
    std::fputs(app::describe_surfaces(*job.model).c_str(), stderr);
  }
  return 0;
}

}  // namespace

CommandRunner register_render(CLI::App& app) {
  auto cli = std::make_shared<RenderCli>();
  CLI::App* sub =
      app.add_subcommand("render", "ray trace a model to an image (PNG, EXR, TIFF, JPEG)");
  sub->add_option("model", cli->model.file, "HyperFun model file, or a scene file (.toml)")
      ->required();
  sub->add_option("-o,--output", cli->output, "output image; the format follows the extension")
      ->required();
  add_render_options(*sub, cli.get());
  return [cli, sub] {
    return is_scene_file(cli->model.file) ? run_scene(*cli, *sub) : run_render(*cli);
  };
}

}  // namespace hfrt::tools
