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

/// Above this many interval evaluations per primary ray (probe average, the search the render
/// runs: march first, then the batched proof), the interval root search costs clearly more
/// than the sign-change march, and `auto` takes the march. Measured at 512x512 on 2 cores: the
/// FRep-Designer-Bench models need 7-9 per ray (interval search 1.0-1.7x the march's time),
/// the default example 38 (0.65 s against 0.33 s for the march), blend.hf 213 (29 s against
/// 0.6 s: hfBlendUni's displacement term keeps its enclosures loose near the surface).
constexpr double kAutoMaxIntervalEvalsPerRay = 24;
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
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f, float* dx,
                     float* dy, float* dz) const override {
    field_.eval_gradient(n, x, y, z, f, dx, dy, dz);
  }
  uint64_t calls() const { return calls_.load(); }

 private:
  const render::Field& field_;
  uint64_t budget_;
  mutable std::atomic<uint64_t> calls_{0};
};

/// The interval-or-march probe of settle_root(). Returns the reason, for the user.
std::string probe_auto_root(const render::Field& field, render::RenderOptions* opt) {
  render::RenderOptions probe = *opt;
  const float scale = float(kAutoProbeSize) / float(std::max(opt->width, opt->height));
  if (scale < 1) {
    probe.width = std::max(1, int(std::lround(float(opt->width) * scale)));
    probe.height = std::max(1, int(std::lround(float(opt->height) * scale)));
  }
  probe.spp = 1;
  probe.shadows = false;
  probe.root = render::RootMode::kInterval;
  probe.interval_march_first = true;  // the search the render runs (batched, march first)
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
  app.add_option("--backend", cli->model.backend, "evaluator: jit (default) or interp")
      ->check(CLI::IsMember({"jit", "interp"}));
  app.add_flag("--stats", cli->stats, "print time, Mrays/s and evaluator calls on stderr");
}

const std::vector<std::string>& render_option_names() {
  static const std::vector<std::string> names = {
      "size",    "bbox", "eye",        "look-at",    "up",      "fov",   "ortho",
      "root",    "spp",  "threads",    "a",          "object",  "light", "step",
      "epsilon", "aov",  "background", "no-shadows", "backend", "stats"};
  return names;
}

bool render_option_is_flag(const std::string& name) {
  return name == "no-shadows" || name == "stats";
}

bool parse_root_mode(const std::string& text, render::RootMode* mode) {
  if (text == "sign") {
    *mode = render::RootMode::kSign;
  } else if (text == "interval") {
    *mode = render::RootMode::kInterval;
  } else if (text == "auto") {
    *mode = render::RootMode::kAuto;
  } else if (text == "analytic") {
    *mode = render::RootMode::kAnalytic;
  } else {
    return false;
  }
  return true;
}

const char* root_mode_choices() {
  return "sign, interval, analytic or auto";
}

bool translate_render_options(const RenderCli& cli, RenderSetup* out, std::string* err) {
  RenderSetup s;
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
  if (!parse_doubles(cli.model.params, &s.params)) {
    return fail("-a expects numbers separated by commas, e.g. -a 1,0.5 (got '" + cli.model.params +
                "')");
  }
  if (cli.model.backend != "jit" && cli.model.backend != "interp") {
    return fail("--backend expects jit or interp (got '" + cli.model.backend + "')");
  }
  *out = std::move(s);
  return true;
}

const render::Field& render_field(const Model& model, const ModelField& model_field,
                                  const WithoutIntervals& sampled, render::RootMode root) {
  // The interval interpreter (models above ModelOptions::interval_jit_max_insts) is too slow
  // for the renderer's many calls: such models are framed by sampling and rendered by the
  // sign-change march, unless the user asks for --root interval.
  const bool fast_intervals = model.interval_engine() == DomainEngine::kJit;
  if (root == render::RootMode::kInterval || fast_intervals) return model_field;
  return sampled;
}

bool frame_camera(const render::Field& field, const render::CameraRequest& camera,
                  render::RenderOptions* opt, FramingInfo* info, std::string* err,
                  const render::Box* known_extent) {
  auto t0 = std::chrono::steady_clock::now();
  info->framed = !camera.eye || !camera.look_at;
  info->extent_by_interval = false;
  info->extent = opt->bbox;
  if (info->framed) {
    if (known_extent) {
      info->extent = *known_extent;
    } else {
      // Sampling costs (2^depth + 1)^3 point evaluations: a coarser grid keeps slow models usable.
      info->extent = render::find_extent(field, opt->bbox, field.has_interval() ? 6 : 5,
                                         &info->extent_by_interval);
    }
  }
  opt->camera =
      render::resolve_camera(camera, info->extent, float(opt->width) / float(opt->height));
  info->ms = ms_since(t0);
  render::Vec3 view = opt->camera.look_at - opt->camera.eye;
  if (length(view) == 0) {
    *err = "--eye and --look-at are the same point";
    return false;
  }
  if (length(cross(normalize(view), normalize(opt->camera.up))) < 1e-6f) {
    *err = "--up is parallel to the view direction; give another --up";
    return false;
  }
  return true;
}

RootDecision settle_root(const render::Field& field, render::RenderOptions* opt,
                         const AnalyticInfo* analytic, const std::string& file) {
  RootDecision d;
  if (opt->root != render::RootMode::kAuto) return d;
  if (field.has_ray_candidates()) {
    // Exact roots, no step, no probe: every leaf is a polynomial of degree <= 4 on a ray.
    char buf[160];
    if (analytic && analytic->num_surface_leaves > 0) {
      std::snprintf(buf, sizeof buf,
                    "analytic: %d polynomial leaves of degree <= %d, %d mesh/patch leaves",
                    analytic->num_leaves, analytic->max_degree, analytic->num_surface_leaves);
    } else if (analytic) {
      std::snprintf(buf, sizeof buf, "analytic: %d polynomial leaves of degree <= %d",
                    analytic->num_leaves, analytic->max_degree);
    } else {
      std::snprintf(buf, sizeof buf, "analytic: polynomial leaves");
    }
    d.why = buf;
    opt->root = render::RootMode::kAnalytic;
    return d;
  }
  if (analytic && !analytic->qualifies) {
    d.analytic_fallback =
        analytic->reason.empty() ? "not a set operation of polynomial leaves" : analytic->reason;
    if (analytic->line > 0) {
      d.analytic_fallback += " at " + file + ":" + std::to_string(analytic->line) + ":" +
                             std::to_string(analytic->col);
    }
  }
  if (!field.has_interval()) {
    d.why = "the interval evaluator of this model is the interpreter, too slow per ray";
    opt->root = render::RootMode::kSign;
    return d;
  }
  auto t0 = std::chrono::steady_clock::now();
  d.why = probe_auto_root(field, opt);
  d.probed = true;
  d.probe_ms = ms_since(t0);
  return d;
}

std::string analytic_root_diagnostic(const AnalyticInfo& analytic, const std::string& file) {
  if (analytic.qualifies) return "";
  lang::Diagnostic diag;
  diag.severity = lang::Severity::kError;
  diag.message = "--root analytic: the model is not a set operation of polynomial leaves: " +
                 (analytic.reason.empty() ? std::string("unsupported construct") : analytic.reason);
  diag.hint =
      "the analytic search needs min/max/|/&/\\ over polynomials of degree <= 4 in x "
      "(quadrics, tori, planes, blocks, moved by shifts, rotations and scales); use "
      "--root auto, interval or sign for this model";
  std::string text;
  if (analytic.line > 0) {
    std::ifstream in(file, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
    diag.range.begin.line = uint32_t(analytic.line);
    diag.range.begin.col = uint32_t(std::max(analytic.col, 1));
  }
  lang::SourceFile source(file, std::move(text));
  return lang::render_diagnostic(source, diag, /*color=*/false);
}

std::string format_render_stats(const RenderReport& r) {
  const render::RenderStats& st = r.stats;
  const render::EvalCounters& e = st.evals;
  std::string out;
  char buf[512];
  double mrays = double(st.primary_rays + st.shadow_rays) / std::max(st.seconds, 1e-9) * 1e-6;
  std::snprintf(buf, sizeof buf,
                "stats: compile %.1f ms (+ %.1f ms interval and gradient code: %s)\n", r.compile_ms,
                r.prepare_ms, r.engines.c_str());
  out += buf;
  char probe[64] = "";
  if (r.auto_root) std::snprintf(probe, sizeof probe, ", auto probe %.1f ms", r.root.probe_ms);
  std::snprintf(buf, sizeof buf, "stats: framing %.1f ms%s%s, render %.3f s on %d threads\n",
                r.framing.ms,
                r.framing.framed ? (r.framing.extent_by_interval ? " (intervals)" : " (sampling)")
                                 : " (camera given)",
                probe, st.seconds, st.threads);
  out += buf;
  std::snprintf(buf, sizeof buf,
                "stats: %llu primary + %llu shadow rays, %.2f Mrays/s, %llu hits\n",
                (unsigned long long)st.primary_rays, (unsigned long long)st.shadow_rays, mrays,
                (unsigned long long)st.hits);
  out += buf;
  std::snprintf(buf, sizeof buf,
                "stats: evaluator calls: point %llu (%llu points), interval %llu, gradient %llu "
                "(%llu points), attributes %llu; %llu interval searches finished by marching\n",
                (unsigned long long)e.eval_calls, (unsigned long long)e.eval_points,
                (unsigned long long)e.interval_calls, (unsigned long long)e.gradient_calls,
                (unsigned long long)e.gradient_points, (unsigned long long)e.attribute_calls,
                (unsigned long long)e.interval_fallbacks);
  out += buf;
  std::string tiles =
      r.culled ? std::to_string(st.tiles_empty) + " empty by intervals" : "no interval culling";
  std::snprintf(buf, sizeof buf,
                "stats: tiles %zu (%s); thread time: culling %.3f s, root search %.3f s, "
                "shading %.3f s\n",
                st.tiles, tiles.c_str(), st.cull_seconds, st.search_seconds, st.shade_seconds);
  out += buf;
  if (st.root_used == render::RootMode::kAnalytic) {
    std::snprintf(buf, sizeof buf, "stats: analytic candidates: %llu calls, %.2f per call\n",
                  (unsigned long long)e.candidate_calls,
                  double(e.candidates) / double(std::max<uint64_t>(e.candidate_calls, 1)));
    out += buf;
  }
  out += std::string("root: ") + render::root_mode_name(st.root_used) + "\n";
  if (!r.root.analytic_fallback.empty()) {
    out += "root fallback: not analytic: " + r.root.analytic_fallback + "\n";
  }
  return out;
}

}  // namespace hfrt::tools
