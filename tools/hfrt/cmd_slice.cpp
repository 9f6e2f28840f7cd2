// `hfrt slice MODEL.hf -o OUT.png [--size WxH] [--bbox x0,y0,x1,y1] [--z Z] [-a v1,...]
//      [--object NAME] [--threads N] [--backend jit|interp] [--no-prune] [--stats]`
//
// Renders a 2-D model, or the z = Z slice of a 3-D one, as an inside/outside image: white
// where F >= 0, black where F < 0 or F has no value; x grows to the right, y upwards.
// Tile-parallel (render/slice.h); whole tiles are settled by the interval evaluator when the
// model has one. Straight-line models (no if / while, tables or meshes) take the pruned path:
// the tape VMs of jit/tape_vm.h with a tape pruned per block (docs/tape_vm.md), which needs no
// LLVM compile at all; --no-prune (or --backend interp) keeps the compiled evaluators.
//
// Exit codes: 0 = done, 1 = compile errors, 2 = usage or environment error.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "app/gpu_render.h"
#include "app/model_field.h"
#include "render/image.h"
#include "render/progress.h"
#include "render/slice.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/model_request.h"

namespace hfrt::tools {

bool parse_size(const std::string& text, int* w, int* h);  // cmd_render.cpp

namespace {

struct SliceCli {
  ModelRequest model;
  std::string output;
  std::string size = "1024x1024";
  std::string bbox;
  float z = 0;
  int threads = 0;
  bool stats = false;
  bool no_prune = false;       ///< --no-prune
  std::string device = "cpu";  ///< --device
};

int usage_error(const std::string& message) {
  std::fprintf(stderr, "hfrt slice: %s\n", message.c_str());
  return 2;
}

int run_slice(const SliceCli& cli) {
  render::SliceOptions opt;
  if (!parse_size(cli.size, &opt.width, &opt.height)) {
    return usage_error("--size expects WxH with positive integers, e.g. --size 1024x1024 (got '" +
                       cli.size + "')");
  }
  if (!cli.bbox.empty()) {
    std::vector<float> b;
    if (!parse_floats(cli.bbox, &b, 4) || !(b[0] < b[2] && b[1] < b[3])) {
      return usage_error("--bbox expects x0,y0,x1,y1 with x0 < x1 and y0 < y1 (got '" + cli.bbox +
                         "')");
    }
    opt.x0 = b[0], opt.y0 = b[1], opt.x1 = b[2], opt.y1 = b[3];
  }
  if (!std::isfinite(cli.z)) return usage_error("--z expects a number");
  if (cli.threads < 0) return usage_error("--threads expects a non-negative count (0: all cores)");
  opt.z = cli.z;
  opt.threads = cli.threads;

  app::Device device = app::Device::kCpu;
  if (!app::parse_device(cli.device, &device)) {
    return usage_error("--device expects cpu, cuda or cuda-host (got '" + cli.device + "')");
  }

  // The pruned path needs no compiled code: the f32 JIT is compiled only without it.
  const bool try_prune =
      !cli.no_prune && cli.model.backend != "interp" && device == app::Device::kCpu;
  int code = 0;
  auto loaded = load_model(cli.model, /*eager_f32=*/!try_prune, &code);
  if (!loaded) return code;
  if (device != app::Device::kCpu) {
    render::SliceResult res;
    auto ran = app::slice_on_device(*loaded->model, opt, device, &res);
    if (!ran.ok()) {
      std::fprintf(stderr, "hfrt: --device %s: %s\n", app::device_name(device),
                   ran.error().message.c_str());
      return 2;
    }
    std::vector<float> pixels(res.inside.begin(), res.inside.end());
    auto written = render::write_pixels(cli.output, res.width, res.height, 1, pixels, false);
    if (!written.ok()) {
      std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
      return 2;
    }
    std::fprintf(stderr, "hfrt: wrote %s (%dx%d, z = %g, %.1f%% inside, --device %s: %s)\n",
                 cli.output.c_str(), res.width, res.height, opt.z,
                 100.0 * double(res.stats.pixels_inside) / double(res.inside.size()),
                 app::device_name(device), ran.value().device.c_str());
    if (cli.stats) {
      std::fprintf(stderr, "stats: device code %.1f ms, kernel %.3f ms, transfers %.3f ms\n",
                   ran.value().compile_ms, ran.value().kernel_ms, ran.value().transfer_ms);
    }
    return 0;
  }
  app::ModelField field(*loaded->model, cli.model.file);
  std::string no_tape;
  const bool pruned = try_prune && field.prepare_tapes(&no_tape);
  opt.prune = pruned;
  double prepare_ms = 0;
  if (!pruned) {
    if (try_prune) {
      std::string error;
      if (!loaded->model->prepare(Precision::kF32, &error)) {
        std::fprintf(stderr, "hfrt: warning: f32 JIT failed (%s); using the interpreter\n",
                     error.c_str());
      }
    }
    const app::PreparedCode prepared =
        app::prepare_render_code(*loaded->model, field.has_interval(), /*gradient=*/false);
    for (const std::string& w : prepared.warnings) std::fprintf(stderr, "%s\n", w.c_str());
    prepare_ms = prepared.ms;
  }

  render::ProgressBar bar("slicing", isatty(STDERR_FILENO) != 0);
  opt.progress = [&bar](size_t done, size_t total) { bar.update(done, total); };
  render::SliceResult res = render::render_slice(field, opt);
  bar.finish();

  std::vector<float> pixels(res.inside.begin(), res.inside.end());
  auto written = render::write_pixels(cli.output, res.width, res.height, 1, pixels, false);
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
    return 2;
  }
  const render::SliceStats& st = res.stats;
  std::fprintf(stderr, "hfrt: wrote %s (%dx%d, z = %g, %.1f%% inside)\n", cli.output.c_str(),
               res.width, res.height, opt.z,
               100.0 * double(st.pixels_inside) / double(res.inside.size()));
  if (st.evals.nan_samples > 0) {
    std::fprintf(stderr, "hfrt: warning: F has no value at %llu pixels (shown as outside)%s%s\n",
                 (unsigned long long)st.evals.nan_samples, st.nan_explanation.empty() ? "" : ": ",
                 st.nan_explanation.c_str());
  }
  if (cli.stats && st.pruned) {
    std::fprintf(stderr,
                 "stats: compile %.1f ms (pruned tape VM, no JIT), slice %.3f s on %d threads\n",
                 loaded->compile_ms, st.seconds, st.threads);
    std::fprintf(stderr, "stats: tape length: root %zu", st.root_tape_length);
    for (size_t l = 0; l < st.tapes_by_level.size(); ++l) {
      if (st.tapes_by_level[l] == 0) continue;
      std::fprintf(stderr, "; level %zu: %.1f (%llu tapes)", l,
                   double(st.tape_length_by_level[l]) / double(st.tapes_by_level[l]),
                   (unsigned long long)st.tapes_by_level[l]);
    }
    std::fprintf(stderr, "\n");
  } else if (cli.stats) {
    if (try_prune)
      std::fprintf(stderr, "stats: no pruned path: the model has %s\n", no_tape.c_str());
    std::fprintf(
        stderr,
        "stats: compile %.1f ms (+ %.1f ms interval code: %s), slice %.3f s on %d threads\n",
        loaded->compile_ms, prepare_ms, app::describe_domain_engines(*loaded->model).c_str(),
        st.seconds, st.threads);
    std::fprintf(stderr,
                 "stats: evaluator calls: point %llu (%llu points), interval %llu; %llu pixels "
                 "settled by intervals\n",
                 (unsigned long long)st.evals.eval_calls, (unsigned long long)st.evals.eval_points,
                 (unsigned long long)st.evals.interval_calls,
                 (unsigned long long)st.pixels_by_interval);
  }
  return 0;
}

}  // namespace

CommandRunner register_slice(CLI::App& app) {
  auto cli = std::make_shared<SliceCli>();
  CLI::App* sub = add_command(app, "slice");
  sub->add_option("model", cli->model.file, "HyperFun model file")->required();
  sub->add_option("-o,--output", cli->output, "output image; the format follows the extension")
      ->required();
  sub->add_option("--size", cli->size, "image size WxH (default 1024x1024)");
  sub->add_option("--bbox", cli->bbox, "region x0,y0,x1,y1 (default -10,-10,10,10)");
  sub->add_option("--z", cli->z, "z of the slice for 3-D models (default 0)");
  sub->add_option("--threads", cli->threads, "worker threads (default: all cores)");
  sub->add_option("-a", cli->model.params, "parameter values a[1],a[2],... separated by commas");
  sub->add_option("--time", cli->model.time, "time: x[4] of an animated model (default 0)");
  sub->add_option("--object", cli->model.object,
                  "object to render (default: my_model or the first)");
  sub->add_option("--backend", cli->model.backend, "evaluator: jit (default) or interp")
      ->check(CLI::IsMember({"jit", "interp"}));
  sub->add_flag("--stats", cli->stats, "print time and evaluator calls on stderr");
  sub->add_flag("--no-prune", cli->no_prune,
                "evaluate with the compiled code, not the pruned tape VM (docs/tape_vm.md)");
  sub->add_option("--device", cli->device,
                  "cpu (default), cuda (an NVIDIA GPU: the model's generated kernel) or "
                  "cuda-host (that kernel compiled for this CPU); docs/gpu.md");
  add_limit_options(*sub, &cli->model.limits);
  return [cli] { return run_slice(*cli); };
}

}  // namespace hfrt::tools
