#include "app/scene_job.h"

#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "app/model_field.h"
#include "app/render_job.h"
#include "base/timer.h"
#include "hfrt/model.h"
#include "render/sampling.h"
#include "render/texture.h"
#include "render/tiles.h"

namespace hfrt::app {
namespace {

/// One compiled model of the scene and its fields; objects that place the same model (file,
/// object name and parameters) share it.
struct CompiledModel {
  std::unique_ptr<Model> model;
  std::unique_ptr<ModelField> field;
  std::unique_ptr<WithoutIntervals> sampled;
  const render::Field* used = nullptr;  // render_field(): the field or its sampled view
  std::string file;                     // names the model in messages
  bool shared_code = false;
};

std::string params_key(const std::vector<double>& params) {
  std::string k;
  for (double v : params) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g,", v);
    k += buf;
  }
  return k;
}

std::string object_label(const scene::ObjectDesc& o, size_t index) {
  std::string label = o.file.empty() ? "object " + std::to_string(index + 1) + " (inline)" : o.file;
  if (o.name) label += " [" + *o.name + "]";
  return label;
}

}  // namespace

struct PreparedScene::Impl {
  scene::SceneDesc scene;
  SceneOverrides ov;
  render::TraceOptions base;  // everything but the camera (resolved per render)
  render::RootMode root = render::RootMode::kAuto;
  std::map<std::string, std::shared_ptr<const render::TextureImage>> textures;
  std::vector<CompiledModel> models;
  std::vector<size_t> model_of;   // per object
  std::vector<size_t> first_of;   // per model: the first object placing it (its params)
  std::vector<bool> keyed_model;  // per model: its params are keyed
  SceneJobResult compiled;        // compile figures and warnings, object reports
  // Settled by the first render (settle()): the framed extent and the auto roots.
  bool settled = false;
  bool frame = false;  // eye or look_at left to framing
  render::Box extent;
  std::vector<render::RootMode> roots;
  std::vector<std::string> why;

  /// The time at which the camera is framed and `--root auto` decided: the animation's first
  /// frame, so that any subset of frames sees the same camera and searches.
  double anchor(double t) const {
    return scene.animation.given ? scene.animation.frame_time(0) : t;
  }

  /// The scene at time t: keys applied, every model's time and keyed parameters set, objects
  /// placed, materials (with their textures) and lights.
  struct Frame {
    scene::SceneDesc scene;
    std::vector<render::SceneObject> objects;
    std::vector<render::Material> materials;
  };
  Frame at(double t) {
    Frame f;
    f.scene = scene::scene_at(scene, t);
    for (size_t m = 0; m < models.size(); ++m) {
      Model& model = *models[m].model;
      model.set_time(t);
      if (keyed_model[m]) model.set_params(f.scene.objects[first_of[m]].params);
    }
    f.materials.push_back(render::Material{});
    std::map<std::string, int> index;
    for (const auto& [name, mat] : f.scene.materials) {
      index[name] = int(f.materials.size());
      f.materials.push_back(mat);
      if (auto it = textures.find(name); it != textures.end())
        f.materials.back().texture_image = it->second;
    }
    for (size_t i = 0; i < f.scene.objects.size(); ++i) {
      const scene::ObjectDesc& o = f.scene.objects[i];
      const CompiledModel& cm = models[model_of[i]];
      render::SceneObject so;
      so.field = cm.used;
      so.bbox = o.bbox.value_or(render::RenderOptions{}.bbox);
      so.transform = scene::placement(o);
      so.material = o.material.empty() ? 0 : index.at(o.material);
      so.root = root;
      // --root interval on a field whose intervals are the interpreter's: the model's own.
      if (root == render::RootMode::kInterval && !cm.used->has_interval())
        so.field = cm.field.get();
      if (settled && root == render::RootMode::kAuto) so.root = roots[i];
      f.objects.push_back(so);
    }
    return f;
  }

  render::CameraRequest camera_request(const scene::SceneDesc& sc) const {
    render::CameraRequest req = sc.camera.request;
    if (ov.camera.eye) req.eye = ov.camera.eye;
    if (ov.camera.look_at) req.look_at = ov.camera.look_at;
    if (ov.camera.up) req.up = ov.camera.up;
    if (ov.camera.fov_deg) req.fov_deg = ov.camera.fov_deg, req.ortho_width.reset();
    if (ov.camera.ortho_width) req.ortho_width = ov.camera.ortho_width, req.fov_deg.reset();
    return req;
  }

  /// The camera of a frame; false with the error in `res` when it is degenerate.
  bool camera(const Frame& f, render::Camera* out, SceneJobResult* res) const {
    *out = render::resolve_camera(camera_request(f.scene), extent,
                                  float(base.width) / float(base.height));
    render::Vec3 view = out->look_at - out->eye;
    if (length(view) == 0) {
      res->status = SceneJobStatus::kUsageError;
      res->error = "the camera's eye and look_at are the same point";
      return false;
    }
    if (length(cross(normalize(view), normalize(out->up))) < 1e-6f) {
      res->status = SceneJobStatus::kUsageError;
      res->error = "the camera's up is parallel to the view direction; give another up";
      return false;
    }
    return true;
  }

  /// Frames the camera (when the scene leaves it to framing: every object's extent in its box,
  /// placed in the world, at the animation's first and last frames) and settles `--root auto`
  /// per object at the anchor time.
  bool settle(double t, SceneJobResult* res) {
    if (settled) return true;
    const double t0 = anchor(t);
    const render::CameraRequest req = camera_request(scene::scene_at(scene, t0));
    frame = !req.eye || !req.look_at;
    if (frame) {
      std::vector<double> times{t0};
      if (scene.animation.given && scene.animation.frames > 1)
        times.push_back(scene.animation.frame_time(scene.animation.frames - 1));
      for (double ft : times) {
        Frame f = at(ft);
        for (const render::SceneObject& so : f.objects) {
          render::Box e = render::find_extent(*so.field, so.bbox, so.field->has_interval() ? 6 : 5);
          extent.extend(so.transform.box_to_world(e));
        }
      }
    }
    if (extent.empty()) extent = render::Box{{-1, -1, -1}, {1, 1, 1}};
    Frame f = at(t0);
    render::Camera cam;
    if (!camera(f, &cam, res)) return false;
    roots.assign(f.objects.size(), root);
    why.assign(f.objects.size(), "");
    // `--root auto`, per object: analytic when the model qualifies, else the decision of the
    // single-model render (render::choose_root's probe, which tells whether the model's
    // enclosures are tight enough for intervals to pay) for the same camera, seen in the
    // object's own space.
    if (root == render::RootMode::kAuto) {
      const auto t_probe = Clock::now();
      for (size_t i = 0; i < f.objects.size(); ++i) {
        const render::SceneObject& so = f.objects[i];
        const CompiledModel& cm = models[model_of[i]];
        render::RenderOptions probe;
        probe.width = base.width;
        probe.height = base.height;
        probe.bbox = so.bbox;
        probe.threads = base.threads;
        probe.root = render::RootMode::kAuto;
        probe.camera = cam;
        probe.camera.eye = so.transform.point_to_object(cam.eye);
        probe.camera.look_at = so.transform.point_to_object(cam.look_at);
        probe.camera.up = normalize(so.transform.direction_to_object(cam.up));
        probe.camera.ortho_width = cam.ortho_width / so.transform.scale();
        const AnalyticInfo& info = cm.field->analytic_info();
        render::RootDecision d = settle_root(*so.field, &probe, &info, cm.file);
        roots[i] = probe.root;
        why[i] = d.why;
      }
      compiled.probe_ms = ms_since(t_probe);
    }
    settled = true;
    return true;
  }
};

PreparedScene::PreparedScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PreparedScene::~PreparedScene() = default;

const render::TraceOptions& PreparedScene::options() const {
  return impl_->base;
}
const scene::SceneDesc& PreparedScene::scene() const {
  return impl_->scene;
}

std::unique_ptr<PreparedScene> PreparedScene::prepare(const scene::SceneDesc& sc,
                                                      const SceneOverrides& ov,
                                                      SceneJobResult* res) {
  auto impl = std::make_unique<Impl>();
  Impl& p = *impl;
  p.scene = sc;
  p.ov = ov;
  render::TraceOptions& opt = p.base;

  // Render settings: command line over scene over defaults.
  std::array<int, 2> size =
      ov.size ? *ov.size : sc.render.size.value_or(std::array<int, 2>{512, 512});
  opt.width = size[0];
  opt.height = size[1];
  opt.spp = ov.spp ? *ov.spp : sc.render.spp.value_or(1);
  opt.adaptive = sc.render.adaptive.value_or(false) && !(sc.animation.shutter > 0);
  opt.max_depth = ov.max_depth ? *ov.max_depth : sc.render.max_depth.value_or(5);
  if (ov.background) {
    opt.background = *ov.background;
  } else if (sc.render.background) {
    opt.background = *sc.render.background;
  }
  opt.shadows = !ov.no_shadows;
  opt.threads = ov.threads;
  opt.aperture = sc.camera.aperture;
  opt.focus_distance = sc.camera.focus_distance.value_or(0.0f);
  if (ov.root) {
    p.root = *ov.root;
  } else if (sc.render.root) {
    // The reader accepts only the words of root_mode_name().
    bool known = render::parse_root_mode(*sc.render.root, &p.root);
    HFRT_CHECK_MSG(known, "scene reader let an unknown root mode through");
  }
  const render::RootMode root = p.root;

  // Textures, loaded once (materials are rebuilt per frame: their numbers may be keyed).
  for (const auto& [name, m] : sc.materials) {
    if (m.texture.empty()) continue;
    if (m.mapping == render::TextureMapping::kUv) {
      res->status = SceneJobStatus::kSourceError;
      res->error = sc.path + ": error: material '" + name +
                   "': mapping = \"uv\" needs texture coordinates, which HyperFun models do not "
                   "have\nhint: use planar, spherical, cylindrical or triplanar\n";
      return nullptr;
    }
    auto image = render::load_texture(m.texture);
    if (!image.ok()) {
      res->status = SceneJobStatus::kEnvironment;
      res->error = "material '" + name + "': " + image.error().message;
      return nullptr;
    }
    p.textures[name] = image.value();
  }

  // Compile: one model per (file or source, object name, parameters); models that differ only
  // in their parameters share the JIT code of the first (Model::share_code). An object whose
  // parameters are keyed has a model of its own (its parameters change per frame).
  ModelOptions mo;
  mo.backend = ov.interp_backend ? Backend::kInterp : Backend::kJit;
  mo.eager_f64 = false;
  mo.eager_f32 = true;
  std::map<std::string, size_t> by_key;       // source + name + params -> models index
  std::map<std::string, size_t> code_source;  // source + name -> first model
  p.model_of.resize(sc.objects.size());
  const auto t_compile = Clock::now();
  for (size_t i = 0; i < sc.objects.size(); ++i) {
    const scene::ObjectDesc& o = sc.objects[i];
    std::string base = (o.file.empty() ? "source:" + o.source : "file:" + o.file) + '\0' +
                       o.name.value_or("") + '\0';
    const bool keyed = i < sc.keyed_params.size() && sc.keyed_params[i];
    std::string key = base + (keyed ? "keyed:" + std::to_string(i) : params_key(o.params));
    if (auto it = by_key.find(key); it != by_key.end()) {
      p.model_of[i] = it->second;
      continue;
    }
    CompileResult c = compile_scene_object(sc, i, mo);
    if (!c.error.empty()) {
      res->status = SceneJobStatus::kEnvironment;
      res->error = c.error;
      return nullptr;
    }
    if (!c.ok()) {
      res->status = SceneJobStatus::kSourceError;
      res->error = c.rendered;
      return nullptr;
    }
    // Warnings of a model that compiled (located in its file, or in the scene file for an
    // inline source) are shown, not lost.
    if (!c.rendered.empty()) {
      std::string text = c.rendered;
      while (!text.empty() && text.back() == '\n') text.pop_back();
      res->warnings.push_back(text);
    }
    CompiledModel cm;
    cm.model = std::make_unique<Model>(std::move(*c.model));
    cm.file = o.file.empty() ? sc.path : o.file;
    if (auto it = code_source.find(base); it != code_source.end()) {
      cm.shared_code = cm.model->share_code(*p.models[it->second].model);
    } else {
      code_source[base] = p.models.size();
    }
    p.model_of[i] = p.models.size();
    by_key[key] = p.models.size();
    p.first_of.push_back(i);
    p.keyed_model.push_back(keyed);
    p.models.push_back(std::move(cm));
  }
  res->compilations = code_source.size();
  res->compile_ms = ms_since(t_compile);

  // Fields and code: the three evaluators of each compilation, compiled up front.
  const auto t_prepare = Clock::now();
  for (CompiledModel& cm : p.models) {
    cm.field = std::make_unique<ModelField>(*cm.model, cm.file);
    cm.sampled = std::make_unique<WithoutIntervals>(*cm.field);
    cm.used = &render_field(*cm.model, *cm.field, *cm.sampled, root);
    if (!cm.shared_code) {
      PreparedCode code = prepare_render_code(*cm.model);
      for (std::string& w : code.warnings) res->warnings.push_back(std::move(w));
    }
    if (root == render::RootMode::kAnalytic && !cm.field->has_ray_candidates()) {
      res->status = SceneJobStatus::kSourceError;
      res->error = analytic_root_diagnostic(cm.field->analytic_info(), cm.file);
      return nullptr;
    }
    const bool analytic = root == render::RootMode::kAnalytic ||
                          (root == render::RootMode::kAuto && cm.used->has_ray_candidates());
    if (analytic) {
      cm.field->prepare_render(render::RootMode::kAnalytic);
      for (std::string& w : open_surface_warnings(*cm.model, cm.file))
        res->warnings.push_back(std::move(w));
    }
  }
  res->prepare_ms = ms_since(t_prepare);

  std::vector<bool> model_placed(p.models.size(), false);
  for (size_t i = 0; i < sc.objects.size(); ++i) {
    const CompiledModel& cm = p.models[p.model_of[i]];
    SceneObjectReport rep;
    rep.name = object_label(sc.objects[i], i);
    rep.shared = cm.shared_code || model_placed[p.model_of[i]];
    model_placed[p.model_of[i]] = true;
    res->objects.push_back(rep);
  }
  p.compiled = *res;
  return std::unique_ptr<PreparedScene>(new PreparedScene(std::move(impl)));
}

namespace {

/// Adds one pass of a motion-blurred render to the running sums (colour and coverage summed;
/// depth and normal weighted by coverage), over the pixels of `tiles` (all when null).
void accumulate(const render::Image& pass, const render::TraceOptions& opt,
                const std::vector<size_t>* tiles, render::Image* sum, std::vector<float>* weight) {
  render::for_each_tile_pixel(opt.width, opt.height, opt.tile_size, tiles, [&](size_t i) {
    for (int c = 0; c < 3; ++c) sum->rgb[3 * i + c] += pass.rgb[3 * i + c];
    sum->alpha[i] += pass.alpha[i];
    if (pass.alpha[i] > 0 && std::isfinite(pass.depth[i])) {
      const float w = pass.alpha[i];
      sum->depth[i] = (*weight)[i] == 0 ? w * pass.depth[i] : sum->depth[i] + w * pass.depth[i];
      for (int c = 0; c < 3; ++c) sum->normal[3 * i + c] += w * pass.normal[3 * i + c];
      (*weight)[i] += w;
    }
  });
}

}  // namespace

SceneJobResult PreparedScene::render(double t, render::ProgressFn progress,
                                     const std::atomic<bool>* cancel, render::TraceResult* out,
                                     const std::vector<size_t>* tiles) {
  Impl& p = *impl_;
  SceneJobResult res = p.compiled;
  res.time = t;
  if (!p.settle(t, &res)) return res;
  res.probe_ms = p.compiled.probe_ms;
  for (size_t i = 0; i < res.objects.size(); ++i) res.objects[i].why = p.why[i];

  const scene::AnimationDesc& anim = p.scene.animation;
  const bool blur = anim.shutter > 0;
  const int passes = blur ? p.base.spp : 1;
  res.passes = passes;
  const size_t tiles_per_pass =
      tiles ? tiles->size() : render::tile_count(p.base.width, p.base.height, p.base.tile_size);
  const auto t_render = Clock::now();
  render::TraceResult pass;
  std::vector<float> weight;
  if (passes > 1) {
    if (out->image.width != p.base.width || out->image.height != p.base.height || !tiles)
      out->image.resize(p.base.width, p.base.height);
    weight.assign(out->image.pixels(), 0.0f);
    // The running sums start at zero over the pixels rendered.
    render::Image& img = out->image;
    const render::TraceOptions& o = p.base;
    render::for_each_tile_pixel(o.width, o.height, o.tile_size, tiles, [&img](size_t i) {
      for (int c = 0; c < 3; ++c) img.rgb[3 * i + c] = img.normal[3 * i + c] = 0;
      img.alpha[i] = 0;
      img.depth[i] = std::numeric_limits<float>::infinity();
    });
    out->stats = render::TraceStats{};
  }
  std::optional<Impl::Frame> frame_at_t;  // the frame at t itself (the one pass without blur)
  for (int j = 0; j < passes; ++j) {
    double tj = t;
    if (blur) {
      // Time stratum j of the shutter, jittered by a hash of (t, j): the same for every pixel
      // and every process.
      const uint64_t h = render::mix64(std::bit_cast<uint64_t>(t) ^ (uint64_t(j) << 1) ^ 0x6d62ull);
      tj = t + anim.shutter * (double(j) + double(render::unit_float(h))) / double(passes);
    }
    Impl::Frame f = p.at(tj);
    render::TraceOptions opt = p.base;
    opt.lights = p.ov.lights.empty() ? f.scene.lights : p.ov.lights;
    if (!p.camera(f, &opt.camera, &res)) return res;
    opt.cancel = cancel;
    opt.tiles = tiles;
    if (progress) {
      opt.progress = [&progress, j, tiles_per_pass, passes](size_t d, size_t) {
        progress(size_t(j) * tiles_per_pass + d, tiles_per_pass * size_t(passes));
      };
    }
    if (passes > 1) {
      opt.sample_begin = j;
      opt.sample_count = 1;
      render::trace_into(f.objects, f.materials, opt, &pass);
      accumulate(pass.image, opt, tiles, &out->image, &weight);
      out->stats.add(pass.stats);
    } else {
      render::trace_into(f.objects, f.materials, opt, out);
    }
    if (j == 0) res.options = opt;
    if (!blur) frame_at_t = std::move(f);
    if (cancel && cancel->load()) break;
  }
  if (passes > 1) {
    // Means: colour and coverage over the passes, depth and normal over the passes that hit.
    render::Image& img = out->image;
    const float inv = 1.0f / float(passes);
    const render::TraceOptions& o = p.base;
    render::for_each_tile_pixel(o.width, o.height, o.tile_size, tiles, [&](size_t i) {
      for (int c = 0; c < 3; ++c) img.rgb[3 * i + c] *= inv;
      img.alpha[i] *= inv;
      if (weight[i] > 0) {
        img.depth[i] /= weight[i];
        render::Vec3 nn = normalize(
            render::Vec3{img.normal[3 * i], img.normal[3 * i + 1], img.normal[3 * i + 2]});
        img.normal[3 * i] = nn.x;
        img.normal[3 * i + 1] = nn.y;
        img.normal[3 * i + 2] = nn.z;
      }
    });
    res.options.spp = p.base.spp;
  }
  res.render_ms = ms_since(t_render);
  // Where the objects are at t (and the models' time back at t after the blur passes).
  if (!frame_at_t) frame_at_t = p.at(t);
  const Impl::Frame& at_t = *frame_at_t;
  for (size_t i = 0; i < res.objects.size(); ++i) {
    res.objects[i].root = out->stats.root_used[i];
    res.objects[i].world_box = at_t.objects[i].transform.box_to_world(at_t.objects[i].bbox);
  }
  if (out->stats.cancelled) res.status = SceneJobStatus::kCancelled;
  return res;
}

SceneJobResult run_scene_job(const scene::SceneDesc& sc, const SceneOverrides& ov,
                             render::ProgressFn progress, const std::atomic<bool>* cancel,
                             render::TraceResult* out) {
  SceneJobResult res;
  std::unique_ptr<PreparedScene> prepared = PreparedScene::prepare(sc, ov, &res);
  if (!prepared) return res;
  const double t = ov.time ? *ov.time : sc.animation.frame_time(0);
  return prepared->render(t, std::move(progress), cancel, out);
}

CompileResult compile_scene_object(const scene::SceneDesc& sc, size_t i, ModelOptions mo) {
  const scene::ObjectDesc& o = sc.objects[i];
  mo.object = o.name.value_or("");
  // An inline source is compiled as the scene file's text at its place (object_source pads
  // it), so that its diagnostics point into the scene file.
  std::string name = o.file, text, env_error;
  if (o.file.empty() && !scene::object_source(o, sc.path, &text, &name, &env_error)) {
    CompileResult r;
    r.error = env_error;
    return r;
  }
  CompileResult compiled =
      o.file.empty() ? Model::compile(text, mo, name) : Model::compile_file(o.file, mo);
  if (compiled.ok()) {
    compiled.model->set_params(o.params);
  } else if (compiled.error.empty()) {
    char where[64];
    std::snprintf(where, sizeof where, ":%d:%d", o.pos.line, o.pos.column);
    compiled.rendered +=
        sc.path + where + ": note: in the model of this [[object]] (" + object_label(o, i) + ")\n";
  }
  return compiled;
}

std::string format_scene_stats(const SceneJobResult& job, const render::TraceStats& s) {
  std::ostringstream os;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "stats: scene: %zu objects, %zu compilations, compile %.1f ms, code %.1f ms, "
                "auto probes %.1f ms\n",
                job.objects.size(), job.compilations, job.compile_ms, job.prepare_ms, job.probe_ms);
  os << buf;
  for (size_t i = 0; i < job.objects.size(); ++i) {
    const SceneObjectReport& o = job.objects[i];
    std::snprintf(buf, sizeof buf,
                  "stats: object %zu: %s, root search %s%s%s%s, world box [%g %g %g]..[%g %g %g]\n",
                  i + 1, o.name.c_str(), render::root_mode_name(o.root),
                  o.why.empty() ? "" : " (auto: ", o.why.c_str(), o.why.empty() ? "" : ")",
                  o.world_box.lo.x, o.world_box.lo.y, o.world_box.lo.z, o.world_box.hi.x,
                  o.world_box.hi.y, o.world_box.hi.z);
    os << buf;
  }
  const render::TraceOptions& opt = job.options;
  std::snprintf(buf, sizeof buf,
                "stats: trace: %dx%d, %d spp%s, max depth %d, %.1f ms on %d threads\n", opt.width,
                opt.height, opt.spp, opt.adaptive ? " (adaptive)" : "", opt.max_depth,
                job.render_ms, s.threads);
  os << buf;
  std::snprintf(buf, sizeof buf,
                "stats: rays: %llu camera, %llu reflected/refracted, %llu shadow, %llu hits, "
                "%llu pixels refined\n",
                (unsigned long long)s.camera_rays, (unsigned long long)s.secondary_rays,
                (unsigned long long)s.shadow_rays, (unsigned long long)s.hits,
                (unsigned long long)s.refined_pixels);
  os << buf;
  std::snprintf(buf, sizeof buf,
                "stats: evals: %llu point calls (%llu points), %llu interval boxes, %llu gradient "
                "points, %llu candidate calls; thread-seconds: search %.2f, shade %.2f\n",
                (unsigned long long)s.evals.eval_calls, (unsigned long long)s.evals.eval_points,
                (unsigned long long)s.evals.interval_calls,
                (unsigned long long)s.evals.gradient_points,
                (unsigned long long)s.evals.candidate_calls, s.search_seconds, s.shade_seconds);
  os << buf;
  return os.str();
}

}  // namespace hfrt::app
