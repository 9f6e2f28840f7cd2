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
#include <filesystem>
#include <memory>
#include <string>

#include "app/gpu_render.h"
#include "app/render_job.h"
#include "app/scene_job.h"
#include "app/sequence.h"
#include "base/timer.h"
#include "cluster/cluster.h"
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

/// The options of frame sequences (scene files only).
struct SequenceCli {
  std::string frames;  ///< --frames A:B
  std::string shard;   ///< --shard K/N
  std::string video;   ///< --video out.mp4
  int fps = 24;
  bool resume = false;
};

/// Prints a scene job's failure (on rank 0 only: every rank fails the same way) and returns the
/// exit code; 0 when it did not fail.
int scene_failure(const app::SceneJobResult& done, const std::string& file, bool speak) {
  auto say = [&](const std::string& text) {
    if (speak) std::fputs(text.c_str(), stderr);
  };
  switch (done.status) {
    case app::SceneJobStatus::kOk:
    case app::SceneJobStatus::kCancelled:
      return 0;
    case app::SceneJobStatus::kSourceError:
      say(done.error);
      return 1;
    case app::SceneJobStatus::kEnvironment:
      say("hfrt: " + done.error + "\n");
      return 2;
    case app::SceneJobStatus::kUsageError:
      say(file + ": error: " + done.error + "\n");
      return 1;
  }
  return 2;
}

/// `hfrt render scene.toml`: the scene file's values, with every option given on the command
/// line taking their place (`given` tells which were). With a frame pattern in -o, the frames
/// of the scene's [animation]; under mpirun, split across the ranks (cluster/cluster.h).
int run_scene(const RenderCli& cli, const SequenceCli& seq, const CLI::App& given) {
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
  app::FramePattern pattern;
  if (!app::parse_frame_pattern(cli.output, &pattern, &err)) return usage_error(err);
  const bool sequence = pattern.width > 0;
  const bool time_given = given.count("--time") > 0;
  if (!sequence) {
    for (const char* opt : {"--frames", "--shard", "--resume", "--video"}) {
      if (given.count(opt) > 0) {
        return usage_error(std::string(opt) +
                           " renders a sequence: give -o a frame number pattern, e.g. -o "
                           "out/frame_####.png");
      }
    }
  } else if (time_given) {
    return usage_error("--time renders one frame; -o " + cli.output +
                       " names a sequence (choose its frames with --frames A:B)");
  }
  if (seq.fps < 1 || seq.fps > 1000) return usage_error("--fps expects 1..1000 frames a second");
  int shard_k = 0, shard_n = 1;
  if (!seq.shard.empty() && !app::parse_shard(seq.shard, &shard_k, &shard_n, &err))
    return usage_error(err);
  if (!seq.video.empty() && !seq.shard.empty()) {
    return usage_error(
        "--video with --shard: each shard has only part of the frames; encode "
        "the video when every shard is done");
  }
  if (!seq.video.empty() && app::find_on_path("ffmpeg").empty()) {
    return usage_error(
        "--video needs ffmpeg, which is not on PATH (Debian: apt-get install "
        "ffmpeg)");
  }

  auto joined = cluster::Cluster::join();
  if (!joined.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", joined.error().message.c_str());
    return 2;
  }
  cluster::Cluster& cl = *joined.value();
  const bool speak = cl.root();  // every rank computes the same verdicts; rank 0 says them

  scene::SceneDesc desc;
  scene::SceneError serr;
  if (!scene::read_scene_file(cli.model.file, &desc, &serr)) {
    if (speak) std::fputs(serr.render().c_str(), stderr);
    return 1;
  }
  int first = 0, last = desc.animation.frames - 1;
  if (sequence && !seq.frames.empty() &&
      !app::parse_frame_range(seq.frames, desc.animation.frames, &first, &last, &err)) {
    if (speak) usage_error(err);
    return 2;
  }
  app::SceneOverrides ov;
  const render::RenderOptions& o = setup.options;
  if (given.count("--size") > 0) ov.size = std::array<int, 2>{o.width, o.height};
  if (given.count("--spp") > 0) ov.spp = o.spp;
  if (given.count("--root") > 0) ov.root = o.root;
  if (given.count("--background") > 0) ov.background = o.background;
  if (cli.max_depth >= 0) ov.max_depth = cli.max_depth;
  if (time_given) ov.time = setup.time;
  ov.camera = setup.camera;
  ov.lights = o.lights;
  ov.no_shadows = cli.no_shadows;
  ov.threads = o.threads;
  ov.interp_backend = cli.model.backend == "interp";

  app::SceneJobResult prepared_res;
  std::unique_ptr<app::PreparedScene> prepared =
      app::PreparedScene::prepare(desc, ov, &prepared_res);
  for (const std::string& w : prepared_res.warnings) {
    if (speak) std::fprintf(stderr, "%s\n", w.c_str());
  }
  if (!prepared) return scene_failure(prepared_res, cli.model.file, speak);

  if (!sequence) {
    const double t = ov.time ? *ov.time : desc.animation.frame_time(0);
    render::ProgressBar bar("rendering", speak && isatty(STDERR_FILENO) != 0);
    render::TraceResult result;
    app::SceneJobResult done = cl.render_image(
        *prepared, t, &result, [&bar](size_t d, size_t total) { bar.update(d, total); });
    if (int code = scene_failure(done, cli.model.file, speak)) return code;
    bar.finish();
    if (!cl.root()) return 0;
    auto written = app::write_image_atomic(result.image, cli.output, setup.aovs);
    if (!written.ok()) {
      std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
      return 2;
    }
    const render::TraceOptions& opt = done.options;
    std::fprintf(stderr, "hfrt: wrote %s (%dx%d, %d spp, %zu objects, max depth %d%s)\n",
                 cli.output.c_str(), opt.width, opt.height, opt.spp, done.objects.size(),
                 opt.max_depth,
                 cl.size() > 1 ? (", " + std::to_string(cl.size()) + " processes").c_str() : "");
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

  // A sequence: rank 0 plans (so that --resume sees the disk once, before anyone writes) and
  // every rank renders every size-th frame of the plan.
  std::vector<int> plan, skipped;
  if (cl.root()) {
    std::error_code ec;
    const std::filesystem::path folder = std::filesystem::path(pattern.prefix).parent_path();
    if (!folder.empty()) std::filesystem::create_directories(folder, ec);
    plan = app::plan_frames(first, last, shard_k, shard_n, seq.resume, pattern, &skipped);
    if (!skipped.empty()) {
      std::fprintf(stderr, "hfrt: --resume: %zu frame%s already written, %zu to render\n",
                   skipped.size(), skipped.size() == 1 ? "" : "s", plan.size());
    }
  }
  cl.broadcast(&plan);
  std::vector<int> mine;
  for (size_t i = size_t(cl.rank()); i < plan.size(); i += size_t(cl.size()))
    mine.push_back(plan[i]);
  app::SequenceProgress progress(mine.size());
  int code = 0;
  for (int f : mine) {
    const double t = desc.animation.frame_time(f);
    render::TraceResult result;
    const auto t0 = Clock::now();
    app::SceneJobResult done = prepared->render(t, nullptr, nullptr, &result);
    if ((code = scene_failure(done, cli.model.file, speak)) != 0) break;
    const std::string path = app::frame_path(pattern, f);
    auto written = app::write_image_atomic(result.image, path, setup.aovs);
    if (!written.ok()) {
      std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
      code = 2;
      break;
    }
    std::string line = progress.frame_done(f, path, ms_since(t0) / 1000.0);
    if (cl.size() > 1) line.insert(4, "[rank " + std::to_string(cl.rank()) + "]");
    std::fprintf(stderr, "%s\n", line.c_str());
  }
  code = cl.max_all(code);
  if (code != 0) return code;
  if (cl.root()) {
    std::fprintf(stderr, "hfrt: frames %d..%d of %s: %zu rendered%s\n", first, last,
                 cli.output.c_str(), plan.size(),
                 shard_n > 1 ? (" (shard " + seq.shard + ")").c_str() : "");
  }
  if (!seq.video.empty() && cl.root()) {
    auto video = app::encode_video(pattern, first, last, seq.fps, seq.video);
    if (!video.ok()) {
      std::fprintf(stderr, "hfrt: %s\n", video.error().message.c_str());
      return 2;
    }
    std::fprintf(stderr, "hfrt: wrote %s (%d frames at %d fps)\n", seq.video.c_str(),
                 last - first + 1, seq.fps);
  }
  return 0;
}

/// `hfrt render --device cuda|cuda-host`: the generated kernels (docs/gpu.md).
int run_render_on_device(const RenderCli& cli, app::RenderJob& job, app::Device device,
                         double compile_ms) {
  render::RenderResult result;
  app::DeviceJobResult done = app::run_device_render_job(job, device, &result);
  if (done.status != app::RenderJobStatus::kOk) {
    if (!done.environment) return usage_error(done.error);
    std::fprintf(stderr, "hfrt: --device %s: %s\n", app::device_name(device), done.error.c_str());
    return 2;
  }
  auto written = render::write_image(result.image, cli.output, job.setup.aovs);
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
    return 2;
  }
  std::fprintf(stderr, "hfrt: wrote %s (%dx%d, 1 spp, --device %s: %s, kernel %.2f ms)\n",
               cli.output.c_str(), done.options.width, done.options.height,
               app::device_name(device), done.run.device.c_str(), done.run.kernel_ms);
  for (size_t i = 1; i < written.value().size(); ++i) {
    std::fprintf(stderr, "hfrt: wrote %s\n", written.value()[i].c_str());
  }
  if (cli.stats) {
    std::fprintf(stderr,
                 "stats: compile %.1f ms (model), device code %.1f ms, kernel %.3f ms, "
                 "transfers %.3f ms\n",
                 compile_ms, done.run.compile_ms, done.run.kernel_ms, done.run.transfer_ms);
  }
  return 0;
}

int run_render(const RenderCli& cli) {
  app::RenderJob job;
  std::string err;
  if (!translate_render_options(cli, &job.setup, &err)) return usage_error(err);
  app::Device device = app::Device::kCpu;
  if (!app::parse_device(cli.device, &device)) {
    return usage_error("--device expects cpu, cuda or cuda-host (got '" + cli.device + "')");
  }

  int code = 0;
  auto loaded = load_model(cli.model, /*eager_f32=*/device == app::Device::kCpu, &code);
  if (!loaded) return code;
  job.model = &*loaded->model;
  job.file = cli.model.file;
  if (device != app::Device::kCpu) {
    return run_render_on_device(cli, job, device, loaded->compile_ms);
  }

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
  CLI::App* sub = add_command(app, "render");
  sub->add_option("model", cli->model.file, "HyperFun model file, or a scene file (.toml)")
      ->required();
  sub->add_option("-o,--output", cli->output, "output image; the format follows the extension")
      ->required();
  add_render_options(*sub, cli.get());
  add_limit_options(*sub, &cli->model.limits);
  auto seq = std::make_shared<SequenceCli>();
  sub->add_option("--frames", seq->frames,
                  "scene files: the frames A:B (or A) of the [animation] to render; -o needs a "
                  "#### frame number");
  sub->add_flag("--resume", seq->resume, "scene sequences: skip frames already written");
  sub->add_option("--shard", seq->shard,
                  "scene sequences: render every N-th frame from the K-th (K/N), for job arrays");
  sub->add_option("--video", seq->video, "scene sequences: also encode the frames with ffmpeg");
  sub->add_option("--fps", seq->fps, "frames a second of --video (default 24)");
  sub->add_option("--device", cli->device,
                  "cpu (default), cuda (an NVIDIA GPU: the model's generated kernels) or "
                  "cuda-host (those kernels compiled for this CPU); docs/gpu.md");
  return [cli, seq, sub] {
    if (is_scene_file(cli->model.file)) {
      if (cli->device != "cpu") {
        return usage_error("--device " + cli->device +
                           " renders .hf models; scene files render on the CPU");
      }
      return run_scene(*cli, *seq, *sub);
    }
    for (const char* opt : {"--frames", "--shard", "--resume", "--video", "--fps"}) {
      if (sub->count(opt) > 0) {
        return usage_error(std::string(opt) +
                           " renders the frames of a scene file's [animation]; for a .hf model "
                           "render one time with --time T (or place it in a scene)");
      }
    }
    return run_render(*cli);
  };
}

}  // namespace hfrt::tools
