// `hfrt mesh MODEL.hf -o OUT.{stl,obj,ply,glb} [--resolution N | --cell S]
//      [--bbox x0,y0,z0,x1,y1,z1] [--object NAME] [-a v1,...] [--time T] [--simplify E]
//      [--threads N]
//      [--backend jit|interp] [--no-color] [--stats]`
//
// Polygonises the solid (F >= 0) into a watertight, oriented triangle mesh (app/mesh_job.h,
// mesher/mesher.h; docs/meshing.md) and writes it in the format of OUT's extension.
//
// Exit codes: 0 = done, 1 = compile errors or no surface, 2 = usage or environment error.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "app/mesh_job.h"
#include "base/timer.h"
#include "mesher/mesh_io.h"
#include "render/progress.h"
#include "scene/scene_file.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/model_request.h"

namespace hfrt::tools {
namespace {

struct MeshCli {
  ModelRequest model;
  std::string output;
  int resolution = 128;
  float cell = 0;
  std::string bbox;
  int threads = 0;
  bool no_color = false;
  double simplify = 0;
  bool stats = false;
};

int usage_error(const std::string& message) {
  std::fprintf(stderr, "hfrt mesh: %s\n", message.c_str());
  return 2;
}

int run_mesh(const MeshCli& cli) {
  app::MeshJob job;
  if (cli.resolution < 1 || cli.resolution > app::kMaxMeshCells) {
    return usage_error("--resolution expects a cell count from 1 to 8192 (got " +
                       std::to_string(cli.resolution) + ")");
  }
  if (!(cli.cell >= 0) || !std::isfinite(cli.cell)) {
    return usage_error("--cell expects a positive cell size");
  }
  if (cli.threads < 0) return usage_error("--threads expects a non-negative count (0: all cores)");
  if (!(cli.simplify >= 0) || !std::isfinite(cli.simplify)) {
    return usage_error("--simplify expects a positive error bound (a distance in model units)");
  }
  if (!cli.bbox.empty()) {
    std::vector<float> b;
    if (parse_floats(cli.bbox, &b, 6)) {
      job.bbox = {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
    } else if (parse_floats(cli.bbox, &b, 1) && b[0] > 0) {
      job.bbox = {{-b[0], -b[0], -b[0]}, {b[0], b[0], b[0]}};
    } else {
      return usage_error("--bbox expects xmin,ymin,zmin,xmax,ymax,zmax (or one half-size), got '" +
                         cli.bbox + "'");
    }
    if (!(job.bbox.lo.x < job.bbox.hi.x && job.bbox.lo.y < job.bbox.hi.y &&
          job.bbox.lo.z < job.bbox.hi.z)) {
      return usage_error("--bbox: each min must be below its max (got '" + cli.bbox + "')");
    }
    job.bbox_given = true;
  }
  if (!mesher::mesh_format_for(cli.output)) {
    return usage_error(cli.output + ": unknown mesh format '" +
                       std::filesystem::path(cli.output).extension().string() + "' (expected " +
                       mesher::mesh_formats_list() + ")");
  }
  {
    // Unwritable output: say so before meshing, not after.
    std::filesystem::path dir = std::filesystem::path(cli.output).parent_path();
    if (dir.empty()) dir = ".";
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec) || access(dir.c_str(), W_OK) != 0) {
      std::fprintf(
          stderr, "hfrt: %s: cannot write: %s\n", cli.output.c_str(),
          std::filesystem::is_directory(dir, ec) ? "permission denied" : "no such directory");
      return 2;
    }
  }
  job.resolution = cli.resolution;
  job.cell = cli.cell;
  job.threads = cli.threads;
  job.prefault_heap = true;  // a process of its own
  job.colors = !cli.no_color;
  job.simplify = cli.simplify;

  render::ProgressBar bar("meshing", isatty(STDERR_FILENO) != 0);
  job.progress = [&bar](size_t done, size_t total) { bar.update(done, total); };
  // (The simplification's bar starts when the meshing's is done.)
  render::ProgressBar simplify_bar("simplifying", isatty(STDERR_FILENO) != 0);
  job.simplify_progress = [&bar, &simplify_bar](size_t done, size_t total) {
    bar.finish();
    simplify_bar.update(done, total);
  };
  app::MeshJobResult result;
  double compile_ms = 0;
  const std::string& file = cli.model.file;
  if (file.size() > 5 && file.compare(file.size() - 5, 5, ".toml") == 0) {
    // A scene file: every [[object]] in its own box, placed (app::run_scene_mesh_job).
    if (!cli.bbox.empty() || !cli.model.object.empty() || !cli.model.params.empty()) {
      return usage_error(
          "--bbox, --object and -a apply to a .hf model; in a scene file set them on the "
          "[[object]] (bbox, name, params)");
    }
    scene::SceneDesc desc;
    scene::SceneError serr;
    if (!scene::read_scene_file(file, &desc, &serr)) {
      std::fputs(serr.render().c_str(), stderr);
      return 1;
    }
    // Time: --time, else the animation's first frame (as `hfrt render` takes it).
    job.time = desc.animation.frame_time(0);
    std::string time_error;
    if (!cli.model.time.empty() && !parse_time(cli.model.time, &job.time, &time_error)) {
      return usage_error(time_error);
    }
    desc = scene::scene_at(desc, job.time);
    result = app::run_scene_mesh_job(desc, job);
  } else {
    int code = 0;
    auto loaded = load_model(cli.model, /*eager_f32=*/true, &code);
    if (!loaded) return code;
    compile_ms = loaded->compile_ms;
    job.model = &*loaded->model;
    job.file = cli.model.file;
    result = app::run_mesh_job(job);
  }
  bar.finish();
  for (const std::string& w : result.warnings) std::fprintf(stderr, "%s\n", w.c_str());
  if (result.status != app::MeshJobStatus::kOk) {
    if (result.status == app::MeshJobStatus::kEnvironment) {
      std::fprintf(stderr, "hfrt: %s\n", result.error.c_str());
      return 2;
    }
    std::fputs(result.error.c_str(), stderr);
    if (!result.error.empty() && result.error.back() != '\n') std::fputc('\n', stderr);
    return result.status == app::MeshJobStatus::kTooFine ? 2 : 1;
  }
  const auto t0 = Clock::now();
  auto written = mesher::write_mesh(cli.output, result.mesh);
  const double write_ms = ms_since(t0);
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
    return 2;
  }
  std::fprintf(stderr, "hfrt: wrote %s (%zu vertices, %zu triangles%s, %.2f s)\n",
               cli.output.c_str(), result.mesh.vertices.size(), result.mesh.triangles.size(),
               result.mesh.colors.empty() ? "" : ", coloured", result.stats.seconds_total);
  if (cli.stats) {
    std::fputs(app::format_mesh_stats(result, compile_ms, write_ms).c_str(), stderr);
  }
  return 0;
}

}  // namespace

CommandRunner register_mesh(CLI::App& app) {
  auto cli = std::make_shared<MeshCli>();
  CLI::App* sub = add_command(app, "mesh");
  sub->add_option("model", cli->model.file,
                  "HyperFun model file, or a scene file (.toml): every object, placed")
      ->required();
  sub->add_option("-o,--output", cli->output,
                  "output mesh: .stl, .obj, .ply or .glb (colours in .ply and .obj)")
      ->required();
  auto* res = sub->add_option("--resolution", cli->resolution,
                              "cells along the longest side of the region (default 128)");
  auto* cell = sub->add_option("--cell", cli->cell, "cell size (instead of --resolution)");
  res->excludes(cell);
  sub->add_option("--bbox", cli->bbox,
                  "box xmin,ymin,zmin,xmax,ymax,zmax (or one half-size) the solid is capped at; "
                  "default: the solid's extent inside -10..10");
  sub->add_option("--object", cli->model.object, "object to mesh (default: my_model or the first)");
  sub->add_option("-a", cli->model.params, "parameter values a[1],a[2],... separated by commas");
  sub->add_option("--time", cli->model.time, "time: x[4] of an animated model (default 0)");
  sub->add_option("--simplify", cli->simplify,
                  "merge triangles while every vertex stays within ERROR (model units) of the "
                  "tangent planes it replaces: fewer triangles on flat regions");
  sub->add_option("--threads", cli->threads, "worker threads (default: all cores)");
  sub->add_option("--backend", cli->model.backend, "evaluator: jit (default) or interp")
      ->check(CLI::IsMember({"jit", "interp"}));
  sub->add_flag("--no-color", cli->no_color,
                "no per-vertex colours even when the model has s[1..3]");
  sub->add_flag("--stats", cli->stats, "print the grid, the octree, counts and times on stderr");
  add_limit_options(*sub, &cli->model.limits);
  return [cli] { return run_mesh(*cli); };
}

}  // namespace hfrt::tools
