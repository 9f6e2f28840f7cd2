// `hfrt render MODEL.hf -o OUT.png [--size WxH] [--bbox xmin,ymin,zmin,xmax,ymax,zmax]
//      [--eye x,y,z] [--look-at x,y,z] [--up x,y,z] [--fov DEG] [--ortho WIDTH]
//      [--root sign|interval|auto] [--spp N] [--threads N] [-a v1,...] [--object NAME]
//      [--light KIND:x,y,z[,intensity]]... [--step S] [--epsilon E] [--aov depth,normal]
//      [--background r,g,b] [--no-shadows] [--backend jit|interp] [--stats]`
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

#include "render/framing.h"
#include "render/image.h"
#include "render/progress.h"
#include "render/renderer.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/model_field.h"
#include "tools/hfrt/render_options.h"

namespace hfrt::tools {
namespace {

// The options, their validation and the `--root auto` decision are shared with the REPL:
// render_options.h.

int usage_error(const std::string& message) {
  std::fprintf(stderr, "hfrt render: %s\n", message.c_str());
  return 2;
}

int run_render(const RenderCli& cli) {
  RenderSetup setup;
  std::string err;
  if (!translate_render_options(cli, &setup, &err)) return usage_error(err);
  render::RenderOptions& opt = setup.options;

  int code = 0;
  auto loaded = load_model(cli.model, /*eager_f32=*/true, &code);
  if (!loaded) return code;
  const Model& model = *loaded->model;
  ModelField model_field(model, cli.model.file);
  // Intervals serve framing and tile culling even with --root sign.
  const double prepare_ms = prepare_render_code(model, /*interval=*/true, /*gradient=*/true);
  WithoutIntervals sampled_field(model_field);
  const render::Field& field = render_field(model, model_field, sampled_field, opt.root);

  // --root analytic on a model that does not qualify is an error in the model's source (like a
  // compile error: exit 1, located), not a usage error.
  if (opt.root == render::RootMode::kAnalytic) {
    std::string diag = analytic_root_diagnostic(model_field.analytic_info(), cli.model.file);
    if (!diag.empty()) {
      std::fputs(diag.c_str(), stderr);
      return 1;
    }
  }

  FramingInfo framing;
  if (!frame_camera(field, setup.camera, &opt, &framing, &err)) return usage_error(err);
  const RootDecision root = settle_root(field, &opt, &model_field.analytic_info(), cli.model.file);
  // The analytic search samples only F's sign: mesh and patch leaves then cost a winding
  // number instead of a distance query.
  model_field.prepare_render(opt.root);

  render::ProgressBar bar("rendering", isatty(STDERR_FILENO) != 0);
  opt.progress = [&bar](size_t done, size_t total) { bar.update(done, total); };
  render::RenderResult result = render::render(field, opt);
  bar.finish();

  auto written = render::write_image(result.image, cli.output, setup.aovs);
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
    return 2;
  }
  const render::RenderStats& st = result.stats;
  std::string why = root.why.empty() ? "" : " (auto: " + root.why + ")";
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
    RenderReport report;
    report.compile_ms = loaded->compile_ms;
    report.prepare_ms = prepare_ms;
    report.engines = describe_domain_engines(model);
    report.framing = framing;
    report.auto_root = cli.root == "auto";
    report.root = root;
    report.culled = opt.tile_culling && field.has_interval();
    report.stats = st;
    std::fputs(format_render_stats(report).c_str(), stderr);
    std::fputs(describe_surfaces(model).c_str(), stderr);
  }
  return 0;
}

}  // namespace

CommandRunner register_render(CLI::App& app) {
  auto cli = std::make_shared<RenderCli>();
  CLI::App* sub =
      app.add_subcommand("render", "ray trace a model to an image (PNG, EXR, TIFF, JPEG)");
  sub->add_option("model", cli->model.file, "HyperFun model file")->required();
  sub->add_option("-o,--output", cli->output, "output image; the format follows the extension")
      ->required();
  add_render_options(*sub, cli.get());
  return [cli] { return run_render(*cli); };
}

}  // namespace hfrt::tools
