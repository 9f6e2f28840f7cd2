#include "tools/hfrt/render_options.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "base/timer.h"
#include "lang/diagnostics.h"
#include "lang/source.h"

namespace hfrt::tools {
namespace {

bool parse_vec3(const std::string& text, render::Vec3* out) {
  std::vector<float> v;
  if (!parse_floats(text, &v, 3)) return false;
  *out = {v[0], v[1], v[2]};
  return true;
}

/// "dir:x,y,z[,intensity]" (direction towards the light) or "point:x,y,z[,intensity]".
bool parse_light(const std::string& text, render::Light* out) {
  size_t colon = text.find(':');
  if (colon == std::string::npos) return false;
  std::string kind = text.substr(0, colon);
  std::vector<float> v;
  if (!parse_floats(text.substr(colon + 1), &v) || (v.size() != 3 && v.size() != 4)) return false;
  if (kind == "dir" || kind == "directional") {
    out->kind = render::Light::Kind::kDirectional;
    if (v[0] == 0 && v[1] == 0 && v[2] == 0) return false;
  } else if (kind == "point") {
    out->kind = render::Light::Kind::kPoint;
  } else {
    return false;
  }
  out->v = {v[0], v[1], v[2]};
  float intensity = v.size() == 4 ? v[3] : 1.0f;
  if (!(intensity >= 0)) return false;
  out->color = {intensity, intensity, intensity};
  return true;
}

}  // namespace

bool parse_size(const std::string& text, int* w, int* h) {
  size_t x = text.find_first_of("xX");
  char* end = nullptr;
  long a = std::strtol(text.c_str(), &end, 10);
  long b = a;
  if (x == std::string::npos) {
    if (*end) return false;
  } else {
    if (end != text.c_str() + x) return false;
    b = std::strtol(text.c_str() + x + 1, &end, 10);
    if (*end || x + 1 == text.size()) return false;
  }
  if (a <= 0 || b <= 0 || a > 32768 || b > 32768) return false;
  *w = int(a);
  *h = int(b);
  return true;
}

void add_render_options(CLI::App& app, RenderCli* cli) {
  app.add_option("--size", cli->size, "image size WxH (default 512x512)");
  app.add_option("--bbox", cli->bbox,
                 "bounding box xmin,ymin,zmin,xmax,ymax,zmax (default -10..10)");
  app.add_option("--eye", cli->eye, "camera position x,y,z (default: framed three-quarter view)");
  app.add_option("--look-at", cli->look_at, "point looked at x,y,z (default: the solid's centre)");
  app.add_option("--up", cli->up, "camera up direction x,y,z (default 0,1,0)");
  app.add_option("--fov", cli->fov, "vertical field of view in degrees (default 35)");
  app.add_option("--ortho", cli->ortho, "orthographic camera with this view width");
  app.add_option("--root", cli->root, "root search: sign, interval, analytic or auto (default)");
  app.add_option("--spp", cli->spp, "samples per pixel, stratified and jittered (default 1)");
  app.add_option("--threads", cli->threads, "worker threads (default: all cores)");
  app.add_option("-a", cli->model.params, "parameter values a[1],a[2],... separated by commas");
  app.add_option("--time", cli->model.time,
                 "time: x[4] of an animated model; a scene's time (its keys and models)");
  app.add_option("--object", cli->model.object,
                 "object to render (default: my_model or the first)");
  app.add_option("--light", cli->lights,
                 "a light: dir:x,y,z[,intensity] (towards the light) or point:x,y,z[,intensity]; "
                 "repeatable (default: key and fill lights)");
  app.add_option("--step", cli->step, "sign-change marching step (default: bbox size / 512)");
  app.add_option("--epsilon", cli->epsilon, "root tolerance (default: bbox size * 1e-5)");
  app.add_option("--aov", cli->aov, "extra outputs: depth,normal");
  app.add_option("--background", cli->background, "background colour r,g,b (linear, 0..1)");
  app.add_flag("--no-shadows", cli->no_shadows, "no shadow rays");
  app.add_flag("--no-prune", cli->no_prune,
               "interval search: evaluate the whole program, not tapes pruned per tile slab "
               "(docs/rendering.md)");
  app.add_option("--backend", cli->model.backend, "evaluator: jit (default) or interp")
      ->check(CLI::IsMember({"jit", "interp"}));
  app.add_flag("--stats", cli->stats, "print time, Mrays/s and evaluator calls on stderr");
  app.add_option("--max-depth", cli->max_depth,
                 "scene files: reflection/refraction bounces (default: the scene's, or 5)");
}

const std::vector<std::string>& render_option_names() {
  static const std::vector<std::string> names = {
      "size",       "bbox",       "eye",     "look-at", "up",        "fov",  "ortho",   "root",
      "spp",        "threads",    "a",       "object",  "light",     "step", "epsilon", "aov",
      "background", "no-shadows", "backend", "stats",   "max-depth", "time", "no-prune"};
  return names;
}

bool render_option_is_flag(const std::string& name) {
  return name == "no-shadows" || name == "stats" || name == "no-prune";
}

bool parse_root_mode(const std::string& text, render::RootMode* mode) {
  return render::parse_root_mode(text, mode);
}

const char* root_mode_choices() {
  return "sign, interval, analytic or auto";
}

bool translate_render_options(const RenderCli& cli, app::RenderSetup* out, std::string* err) {
  app::RenderSetup s;
  render::RenderOptions& opt = s.options;
  auto fail = [err](std::string message) {
    *err = std::move(message);
    return false;
  };
  if (!parse_size(cli.size, &opt.width, &opt.height)) {
    return fail("--size expects WxH with positive integers, e.g. --size 512x512 (got '" + cli.size +
                "')");
  }
  if (!cli.bbox.empty()) {
    std::vector<float> b;
    if (parse_floats(cli.bbox, &b, 6)) {
      opt.bbox = {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
    } else if (parse_floats(cli.bbox, &b, 1) && b[0] > 0) {
      opt.bbox = {{-b[0], -b[0], -b[0]}, {b[0], b[0], b[0]}};
    } else {
      return fail("--bbox expects xmin,ymin,zmin,xmax,ymax,zmax (or one half-size), got '" +
                  cli.bbox + "'");
    }
    if (!(opt.bbox.lo.x < opt.bbox.hi.x && opt.bbox.lo.y < opt.bbox.hi.y &&
          opt.bbox.lo.z < opt.bbox.hi.z)) {
      return fail("--bbox: each min must be below its max (got '" + cli.bbox + "')");
    }
  }
  render::CameraRequest& cam = s.camera;
  render::Vec3 v;
  if (!cli.eye.empty()) {
    if (!parse_vec3(cli.eye, &v)) return fail("--eye expects x,y,z (got '" + cli.eye + "')");
    cam.eye = v;
  }
  if (!cli.look_at.empty()) {
    if (!parse_vec3(cli.look_at, &v))
      return fail("--look-at expects x,y,z (got '" + cli.look_at + "')");
    cam.look_at = v;
  }
  if (!cli.up.empty()) {
    if (!parse_vec3(cli.up, &v) || length(v) == 0) {
      return fail("--up expects a non-zero x,y,z (got '" + cli.up + "')");
    }
    cam.up = v;
  }
  if (cli.fov != 0) {
    if (!(cli.fov > 0 && cli.fov < 180)) return fail("--fov must be between 0 and 180 degrees");
    cam.fov_deg = cli.fov;
  }
  if (cli.ortho != 0) {
    if (!(cli.ortho > 0)) return fail("--ortho expects a positive view width");
    cam.ortho_width = cli.ortho;
  }
  if (!parse_root_mode(cli.root, &opt.root)) {
    return fail(std::string("--root expects ") + root_mode_choices() + " (got '" + cli.root + "')");
  }
  if (cli.spp < 1 || cli.spp > 4096) return fail("--spp expects 1..4096");
  if (cli.threads < 0) return fail("--threads expects a non-negative count (0: all cores)");
  opt.spp = cli.spp;
  opt.threads = cli.threads;
  if (cli.step < 0 || cli.epsilon < 0) return fail("--step and --epsilon must be positive");
  opt.step = cli.step;
  opt.epsilon = cli.epsilon;
  for (const std::string& l : cli.lights) {
    render::Light light;
    if (!parse_light(l, &light)) {
      return fail("--light expects dir:x,y,z[,intensity] or point:x,y,z[,intensity] (got '" + l +
                  "')");
    }
    opt.lights.push_back(light);
  }
  if (!cli.aov.empty()) {
    size_t pos = 0;
    while (pos <= cli.aov.size()) {
      size_t comma = cli.aov.find(',', pos);
      std::string name =
          cli.aov.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
      if (name == "depth") {
        s.aovs.depth = true;
      } else if (name == "normal") {
        s.aovs.normal = true;
      } else {
        return fail("--aov knows depth and normal (got '" + name + "')");
      }
      if (comma == std::string::npos) break;
      pos = comma + 1;
    }
  }
  if (!cli.background.empty()) {
    if (!parse_vec3(cli.background, &v)) {
      return fail("--background expects r,g,b in [0, 1] (got '" + cli.background + "')");
    }
    opt.background = v;
  }
  opt.shadows = !cli.no_shadows;
  opt.pruned_tapes = !cli.no_prune;
  if (cli.max_depth < -1 || cli.max_depth > 64) return fail("--max-depth expects 0..64");
  if (!parse_doubles(cli.model.params, &s.params)) {
    return fail("-a expects numbers separated by commas, e.g. -a 1,0.5 (got '" + cli.model.params +
                "')");
  }
  std::string time_error;
  if (!cli.model.time.empty() && !parse_time(cli.model.time, &s.time, &time_error)) {
    return fail(time_error);
  }
  if (cli.model.backend != "jit" && cli.model.backend != "interp") {
    return fail("--backend expects jit or interp (got '" + cli.model.backend + "')");
  }
  *out = std::move(s);
  return true;
}

}  // namespace hfrt::tools
