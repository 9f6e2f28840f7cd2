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
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "render/framing.h"
#include "render/image.h"
#include "render/progress.h"
#include "render/renderer.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/model_field.h"

namespace hfrt::tools {
namespace {

struct RenderCli {
  ModelRequest model;
  std::string output;
  std::string size = "512x512";
  std::string bbox;
  std::string eye, look_at, up;
  float fov = 0;
  float ortho = 0;
  std::string root = "auto";
  int spp = 1;
  int threads = 0;
  std::vector<std::string> lights;
  float step = 0, epsilon = 0;
  std::string aov;
  std::string background;
  bool no_shadows = false;
  bool stats = false;
};

int usage_error(const std::string& message) {
  std::fprintf(stderr, "hfrt render: %s\n", message.c_str());
  return 2;
}

}  // namespace

/// Parses "WxH" (or "N" for NxN); false when malformed or not positive.
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

/// Above this many interval evaluations per primary ray (probe average), the interval root
/// search costs many times the sign-change march, and `auto` takes the march. Measured at
/// 512x512 on 2 cores: a sphere needs ~10 per ray (interval search 2.5x the march's time), a
/// torus ~50 (6x), the default example (R-function blends, whose enclosures are loose: the
/// dependency problem of f1 + f2 + sqrt(f1^2 + f2^2)) ~400 (60x: 88 s instead of 1.5 s).
constexpr double kAutoMaxIntervalEvalsPerRay = 64;
constexpr int kAutoProbeSize = 24;  ///< the probe image's larger side, in pixels

/// The field seen by the probe render: counts interval evaluations and, past the budget,
/// answers "empty" to every further one, so that a model with loose enclosures costs the probe
/// no more than the budget (the probe's image is thrown away).
class ProbeField final : public render::Field {
 public:
  ProbeField(const render::Field& field, uint64_t budget) : field_(field), budget_(budget) {}
  void eval(size_t n, const float* x, const float* y, const float* z, float* out_f) const override {
    field_.eval(n, x, y, z, out_f);
  }
  bool has_interval() const override { return true; }
  render::Interval eval_interval(const render::Box& box, bool* maybe_nan) const override {
    if (calls_.fetch_add(1, std::memory_order_relaxed) >= budget_) {
      *maybe_nan = false;
      return {-1, -1};
    }
    return field_.eval_interval(box, maybe_nan);
  }
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f,
                     float* dx, float* dy, float* dz) const override {
    field_.eval_gradient(n, x, y, z, f, dx, dy, dz);
  }
  uint64_t calls() const { return calls_.load(); }

 private:
  const render::Field& field_;
  uint64_t budget_;
  mutable std::atomic<uint64_t> calls_{0};
};

/// Settles `--root auto` in `opt`: the interval search (robust: thin shells and tangent
/// touches are not missed) with tile culling, unless a small probe render (same camera and
/// box, no shadows) shows that the model's enclosures are too loose for intervals to pay;
/// then the sign-change march without interval culling (which would cull nothing and cost
/// interval evaluations per tile and per shadow ray). The probe counts evaluations, it does
/// not time them, so the choice does not depend on the machine or its load. Returns the
/// reason, for the user.
std::string settle_auto_root(const render::Field& field, render::RenderOptions* opt) {
  render::RenderOptions probe = *opt;
  const float scale = float(kAutoProbeSize) / float(std::max(opt->width, opt->height));
  if (scale < 1) {
    probe.width = std::max(1, int(std::lround(float(opt->width) * scale)));
    probe.height = std::max(1, int(std::lround(float(opt->height) * scale)));
  }
  probe.spp = 1;
  probe.shadows = false;
  probe.root = render::RootMode::kInterval;
  probe.progress = nullptr;
  probe.threads = opt->threads;
  const uint64_t rays = uint64_t(probe.width) * uint64_t(probe.height);
  const uint64_t budget = uint64_t(kAutoMaxIntervalEvalsPerRay * double(rays)) + 1;
  ProbeField counted(field, budget);
  render::render(counted, probe);
  char buf[220];
  if (counted.calls() > budget) {
    std::snprintf(buf, sizeof buf,
                  "loose interval enclosures, over %.0f interval evaluations per ray in a %dx%d "
                  "probe; --root interval forces the interval search",
                  kAutoMaxIntervalEvalsPerRay, probe.width, probe.height);
    opt->root = render::RootMode::kSign;
    opt->tile_culling = false;
    return buf;
  }
  std::snprintf(buf, sizeof buf, "interval evaluator, %.0f evaluations per ray in a %dx%d probe",
                double(counted.calls()) / double(std::max<uint64_t>(rays, 1)), probe.width,
                probe.height);
  opt->root = render::RootMode::kInterval;
  return buf;
}

int run_render(const RenderCli& cli) {
  render::RenderOptions opt;
  if (!parse_size(cli.size, &opt.width, &opt.height)) {
    return usage_error("--size expects WxH with positive integers, e.g. --size 512x512 (got '" +
                       cli.size + "')");
  }
  if (!cli.bbox.empty()) {
    std::vector<float> b;
    if (parse_floats(cli.bbox, &b, 6)) {
      opt.bbox = {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}};
    } else if (parse_floats(cli.bbox, &b, 1) && b[0] > 0) {
      opt.bbox = {{-b[0], -b[0], -b[0]}, {b[0], b[0], b[0]}};
    } else {
      return usage_error("--bbox expects xmin,ymin,zmin,xmax,ymax,zmax (or one half-size), got '" +
                         cli.bbox + "'");
    }
    if (!(opt.bbox.lo.x < opt.bbox.hi.x && opt.bbox.lo.y < opt.bbox.hi.y &&
          opt.bbox.lo.z < opt.bbox.hi.z)) {
      return usage_error("--bbox: each min must be below its max (got '" + cli.bbox + "')");
    }
  }
  render::CameraRequest cam;
  render::Vec3 v;
  if (!cli.eye.empty()) {
    if (!parse_vec3(cli.eye, &v)) return usage_error("--eye expects x,y,z (got '" + cli.eye + "')");
    cam.eye = v;
  }
  if (!cli.look_at.empty()) {
    if (!parse_vec3(cli.look_at, &v)) return usage_error("--look-at expects x,y,z (got '" + cli.look_at + "')");
    cam.look_at = v;
  }
  if (!cli.up.empty()) {
    if (!parse_vec3(cli.up, &v) || length(v) == 0) {
      return usage_error("--up expects a non-zero x,y,z (got '" + cli.up + "')");
    }
    cam.up = v;
  }
  if (cli.fov != 0) {
    if (!(cli.fov > 0 && cli.fov < 180)) return usage_error("--fov must be between 0 and 180 degrees");
    cam.fov_deg = cli.fov;
  }
  if (cli.ortho != 0) {
    if (!(cli.ortho > 0)) return usage_error("--ortho expects a positive view width");
    cam.ortho_width = cli.ortho;
  }
  if (cli.root == "sign") {
    opt.root = render::RootMode::kSign;
  } else if (cli.root == "interval") {
    opt.root = render::RootMode::kInterval;
  } else if (cli.root == "auto") {
    opt.root = render::RootMode::kAuto;
  } else {
    return usage_error("--root expects sign, interval or auto (got '" + cli.root + "')");
  }
  if (cli.spp < 1 || cli.spp > 4096) return usage_error("--spp expects 1..4096");
  if (cli.threads < 0) return usage_error("--threads expects a non-negative count (0: all cores)");
  opt.spp = cli.spp;
  opt.threads = cli.threads;
  if (cli.step < 0 || cli.epsilon < 0) return usage_error("--step and --epsilon must be positive");
  opt.step = cli.step;
  opt.epsilon = cli.epsilon;
  for (const std::string& l : cli.lights) {
    render::Light light;
    if (!parse_light(l, &light)) {
      return usage_error("--light expects dir:x,y,z[,intensity] or point:x,y,z[,intensity] (got '" +
                         l + "')");
    }
    opt.lights.push_back(light);
  }
  render::AovSet aovs;
  if (!cli.aov.empty()) {
    size_t pos = 0;
    while (pos <= cli.aov.size()) {
      size_t comma = cli.aov.find(',', pos);
      std::string name = cli.aov.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
      if (name == "depth") {
        aovs.depth = true;
      } else if (name == "normal") {
        aovs.normal = true;
      } else {
        return usage_error("--aov knows depth and normal (got '" + name + "')");
      }
      if (comma == std::string::npos) break;
      pos = comma + 1;
    }
  }
  if (!cli.background.empty()) {
    if (!parse_vec3(cli.background, &v)) {
      return usage_error("--background expects r,g,b in [0, 1] (got '" + cli.background + "')");
    }
    opt.background = v;
  }
  opt.shadows = !cli.no_shadows;

  int code = 0;
  auto loaded = load_model(cli.model, /*eager_f32=*/true, &code);
  if (!loaded) return code;
  const Model& model = *loaded->model;
  ModelField model_field(model, cli.model.file);
  // Intervals serve framing and tile culling even with --root sign.
  const double prepare_ms = prepare_render_code(model, /*interval=*/true, /*gradient=*/true);
  // The interval interpreter (models above ModelOptions::interval_jit_max_insts) is too slow
  // for the renderer's many calls: such models are framed by sampling and rendered by the
  // sign-change march, unless the user asks for --root interval.
  const bool fast_intervals = model.interval_engine() == DomainEngine::kJit;
  WithoutIntervals sampled_field(model_field);
  const render::Field& field = opt.root == render::RootMode::kInterval || fast_intervals
                                   ? static_cast<const render::Field&>(model_field)
                                   : sampled_field;

  auto t_frame = std::chrono::steady_clock::now();
  bool framed = !cam.eye || !cam.look_at;
  render::Box extent = opt.bbox;
  bool extent_by_interval = false;
  // Sampling costs (2^depth + 1)^3 point evaluations: a coarser grid keeps slow models usable.
  if (framed) {
    extent = render::find_extent(field, opt.bbox, field.has_interval() ? 6 : 5, &extent_by_interval);
  }
  opt.camera = render::resolve_camera(cam, extent, float(opt.width) / float(opt.height));
  double frame_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_frame).count();
  render::Vec3 view = opt.camera.look_at - opt.camera.eye;
  if (length(view) == 0) return usage_error("--eye and --look-at are the same point");
  if (length(cross(normalize(view), normalize(opt.camera.up))) < 1e-6f) {
    return usage_error("--up is parallel to the view direction; give another --up");
  }

  std::string auto_why;
  double probe_ms = 0;
  if (opt.root == render::RootMode::kAuto) {
    if (!field.has_interval()) {
      auto_why = "the interval evaluator of this model is the interpreter, too slow per ray";
      opt.root = render::RootMode::kSign;
    } else {
      auto t_probe = std::chrono::steady_clock::now();
      auto_why = settle_auto_root(field, &opt);
      probe_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_probe)
                     .count();
    }
  }

  render::ProgressBar bar("rendering", isatty(STDERR_FILENO) != 0);
  opt.progress = [&bar](size_t done, size_t total) { bar.update(done, total); };
  render::RenderResult result = render::render(field, opt);
  bar.finish();

  auto written = render::write_image(result.image, cli.output, aovs);
  if (!written.ok()) {
    std::fprintf(stderr, "hfrt: %s\n", written.error().message.c_str());
    return 2;
  }
  const render::RenderStats& st = result.stats;
  std::string why = auto_why.empty() ? "" : " (auto: " + auto_why + ")";
  std::fprintf(stderr, "hfrt: wrote %s (%dx%d, %d spp, root search %s%s)\n",
               cli.output.c_str(), opt.width, opt.height, opt.spp,
               render::root_mode_name(st.root_used), why.c_str());
  for (size_t i = 1; i < written.value().size(); ++i) {
    std::fprintf(stderr, "hfrt: wrote %s\n", written.value()[i].c_str());
  }
  if (st.evals.nan_samples > 0) {
    std::fprintf(stderr, "hfrt: warning: F has no value at %llu samples (counted as outside)%s%s\n",
                 (unsigned long long)st.evals.nan_samples, st.nan_explanation.empty() ? "" : ": ",
                 st.nan_explanation.c_str());
  }
  if (cli.stats) {
    const render::EvalCounters& e = st.evals;
    double mrays = double(st.primary_rays + st.shadow_rays) / std::max(st.seconds, 1e-9) * 1e-6;
    std::fprintf(stderr, "stats: compile %.1f ms (+ %.1f ms interval and gradient code: %s)\n",
                 loaded->compile_ms, prepare_ms, describe_domain_engines(model).c_str());
    char probe[64] = "";
    if (cli.root == "auto") std::snprintf(probe, sizeof probe, ", auto probe %.1f ms", probe_ms);
    std::fprintf(stderr, "stats: framing %.1f ms%s%s, render %.3f s on %d threads\n", frame_ms,
                 framed ? (extent_by_interval ? " (intervals)" : " (sampling)") : " (camera given)",
                 probe, st.seconds, st.threads);
    std::fprintf(stderr, "stats: %llu primary + %llu shadow rays, %.2f Mrays/s, %llu hits\n",
                 (unsigned long long)st.primary_rays, (unsigned long long)st.shadow_rays, mrays,
                 (unsigned long long)st.hits);
    std::fprintf(stderr,
                 "stats: evaluator calls: point %llu (%llu points), interval %llu, gradient %llu "
                 "(%llu points), attributes %llu; %llu interval searches finished by marching\n",
                 (unsigned long long)e.eval_calls, (unsigned long long)e.eval_points,
                 (unsigned long long)e.interval_calls, (unsigned long long)e.gradient_calls,
                 (unsigned long long)e.gradient_points, (unsigned long long)e.attribute_calls,
                 (unsigned long long)e.interval_fallbacks);
    const bool culled = opt.tile_culling && field.has_interval();
    std::fprintf(stderr,
                 "stats: tiles %zu (%s); thread time: culling %.3f s, root search %.3f s, "
                 "shading %.3f s\n",
                 st.tiles,
                 culled ? (std::to_string(st.tiles_empty) + " empty by intervals").c_str()
                        : "no interval culling",
                 st.cull_seconds, st.search_seconds, st.shade_seconds);
  }
  return 0;
}

}  // namespace

CommandRunner register_render(CLI::App& app) {
  auto cli = std::make_shared<RenderCli>();
  CLI::App* sub = app.add_subcommand("render", "ray trace a model to an image (PNG, EXR, TIFF, JPEG)");
  sub->add_option("model", cli->model.file, "HyperFun model file")->required();
  sub->add_option("-o,--output", cli->output, "output image; the format follows the extension")->required();
  sub->add_option("--size", cli->size, "image size WxH (default 512x512)");
  sub->add_option("--bbox", cli->bbox, "bounding box xmin,ymin,zmin,xmax,ymax,zmax (default -10..10)");
  sub->add_option("--eye", cli->eye, "camera position x,y,z (default: framed three-quarter view)");
  sub->add_option("--look-at", cli->look_at, "point looked at x,y,z (default: the solid's centre)");
  sub->add_option("--up", cli->up, "camera up direction x,y,z (default 0,1,0)");
  sub->add_option("--fov", cli->fov, "vertical field of view in degrees (default 35)");
  sub->add_option("--ortho", cli->ortho, "orthographic camera with this view width");
  sub->add_option("--root", cli->root, "root search: sign, interval or auto (default)");
  sub->add_option("--spp", cli->spp, "samples per pixel, stratified and jittered (default 1)");
  sub->add_option("--threads", cli->threads, "worker threads (default: all cores)");
  sub->add_option("-a", cli->model.params, "parameter values a[1],a[2],... separated by commas");
  sub->add_option("--object", cli->model.object, "object to render (default: my_model or the first)");
  sub->add_option("--light", cli->lights,
                  "a light: dir:x,y,z[,intensity] (towards the light) or point:x,y,z[,intensity]; "
                  "repeatable (default: key and fill lights)");
  sub->add_option("--step", cli->step, "sign-change marching step (default: bbox size / 512)");
  sub->add_option("--epsilon", cli->epsilon, "root tolerance (default: bbox size * 1e-5)");
  sub->add_option("--aov", cli->aov, "extra outputs: depth,normal");
  sub->add_option("--background", cli->background, "background colour r,g,b (linear, 0..1)");
  sub->add_flag("--no-shadows", cli->no_shadows, "no shadow rays");
  sub->add_option("--backend", cli->model.backend, "evaluator: jit (default) or interp")
      ->check(CLI::IsMember({"jit", "interp"}));
  sub->add_flag("--stats", cli->stats, "print time, Mrays/s and evaluator calls on stderr");
  return [cli] { return run_render(*cli); };
}

}  // namespace hfrt::tools
