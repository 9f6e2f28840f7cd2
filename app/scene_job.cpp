#include "app/scene_job.h"

#include <cstdio>
#include <map>
#include <sstream>

#include "app/model_field.h"
#include "app/render_job.h"
#include "base/timer.h"
#include "hfrt/model.h"
#include "render/texture.h"

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

SceneJobResult run_scene_job(const scene::SceneDesc& sc, const SceneOverrides& ov,
                             render::ProgressFn progress, const std::atomic<bool>* cancel,
                             render::TraceResult* out) {
  SceneJobResult res;
  render::TraceOptions& opt = res.options;

  // Render settings: command line over scene over defaults.
  std::array<int, 2> size =
      ov.size ? *ov.size : sc.render.size.value_or(std::array<int, 2>{512, 512});
  opt.width = size[0];
  opt.height = size[1];
  opt.spp = ov.spp ? *ov.spp : sc.render.spp.value_or(1);
  opt.adaptive = sc.render.adaptive.value_or(false);
  opt.max_depth = ov.max_depth ? *ov.max_depth : sc.render.max_depth.value_or(5);
  if (ov.background) {
    opt.background = *ov.background;
  } else if (sc.render.background) {
    opt.background = *sc.render.background;
  }
  opt.lights = ov.lights.empty() ? sc.lights : ov.lights;
  opt.shadows = !ov.no_shadows;
  opt.threads = ov.threads;
  opt.progress = std::move(progress);
  opt.cancel = cancel;
  opt.aperture = sc.camera.aperture;
  opt.focus_distance = sc.camera.focus_distance.value_or(0.0f);
  render::RootMode root = render::RootMode::kAuto;
  if (ov.root) {
    root = *ov.root;
  } else if (sc.render.root) {
    // The reader accepts only the words of root_mode_name().
    bool known = render::parse_root_mode(*sc.render.root, &root);
    HFRT_CHECK_MSG(known, "scene reader let an unknown root mode through");
  }

  // Materials: index 0 is the default material, then the scene's by name.
  std::vector<render::Material> materials{render::Material{}};
  std::map<std::string, int> material_index;
  for (const auto& [name, m] : sc.materials) {
    material_index[name] = int(materials.size());
    materials.push_back(m);
    if (m.texture.empty()) continue;
    if (m.mapping == render::TextureMapping::kUv) {
      res.status = SceneJobStatus::kSourceError;
      res.error = sc.path + ": error: material '" + name +
                  "': mapping = \"uv\" needs texture coordinates, which HyperFun models do not "
                  "have\nhint: use planar, spherical, cylindrical or triplanar\n";
      return res;
    }
    auto image = render::load_texture(m.texture);
    if (!image.ok()) {
      res.status = SceneJobStatus::kEnvironment;
      res.error = "material '" + name + "': " + image.error().message;
      return res;
    }
    materials.back().texture_image = image.value();
  }

  // Compile: one model per (file or source, object name, parameters); models that differ only
  // in their parameters share the JIT code of the first (Model::share_code).
  ModelOptions mo;
  mo.backend = ov.interp_backend ? Backend::kInterp : Backend::kJit;
  mo.eager_f64 = false;
  mo.eager_f32 = true;
  std::vector<CompiledModel> models;
  std::map<std::string, size_t> by_key;       // source + name + params -> models index
  std::map<std::string, size_t> code_source;  // source + name -> first model
  std::vector<size_t> model_of(sc.objects.size());
  const auto t_compile = Clock::now();
  for (size_t i = 0; i < sc.objects.size(); ++i) {
    const scene::ObjectDesc& o = sc.objects[i];
    std::string base = (o.file.empty() ? "source:" + o.source : "file:" + o.file) + '\0' +
                       o.name.value_or("") + '\0';
    std::string key = base + params_key(o.params);
    if (auto it = by_key.find(key); it != by_key.end()) {
      model_of[i] = it->second;
      continue;
    }
    CompileResult compiled = compile_scene_object(sc, i, mo);
    if (!compiled.error.empty()) {
      res.status = SceneJobStatus::kEnvironment;
      res.error = compiled.error;
      return res;
    }
    if (!compiled.ok()) {
      res.status = SceneJobStatus::kSourceError;
      res.error = compiled.rendered;
      return res;
    }
    const std::string name = o.file.empty() ? sc.path : o.file;
    CompiledModel cm;
    cm.model = std::make_unique<Model>(std::move(*compiled.model));
    cm.file = name;
    if (auto it = code_source.find(base); it != code_source.end()) {
      cm.shared_code = cm.model->share_code(*models[it->second].model);
    } else {
      code_source[base] = models.size();
    }
    model_of[i] = models.size();
    by_key[key] = models.size();
    models.push_back(std::move(cm));
  }
  res.compilations = code_source.size();
  res.compile_ms = ms_since(t_compile);

  // Fields and code: the three evaluators of each compilation, compiled up front.
  const auto t_prepare = Clock::now();
  for (CompiledModel& cm : models) {
    cm.field = std::make_unique<ModelField>(*cm.model, cm.file);
    cm.sampled = std::make_unique<WithoutIntervals>(*cm.field);
    cm.used = &render_field(*cm.model, *cm.field, *cm.sampled, root);
    if (!cm.shared_code) {
      PreparedCode code = prepare_render_code(*cm.model);
      for (std::string& w : code.warnings) res.warnings.push_back(std::move(w));
    }
    if (root == render::RootMode::kAnalytic && !cm.field->has_ray_candidates()) {
      res.status = SceneJobStatus::kSourceError;
      res.error = analytic_root_diagnostic(cm.field->analytic_info(), cm.file);
      return res;
    }
    const bool analytic = root == render::RootMode::kAnalytic ||
                          (root == render::RootMode::kAuto && cm.used->has_ray_candidates());
    if (analytic) cm.field->prepare_render(render::RootMode::kAnalytic);
  }
  res.prepare_ms = ms_since(t_prepare);

  // The placed objects.
  std::vector<render::SceneObject> objects;
  std::vector<bool> model_placed(models.size(), false);
  for (size_t i = 0; i < sc.objects.size(); ++i) {
    const scene::ObjectDesc& o = sc.objects[i];
    const CompiledModel& cm = models[model_of[i]];
    render::SceneObject so;
    so.field = cm.used;
    so.bbox = o.bbox.value_or(render::RenderOptions{}.bbox);
    so.transform = scene::placement(o);
    so.material = o.material.empty() ? 0 : material_index.at(o.material);
    // --root interval on a field whose intervals are the interpreter's: the model's own.
    so.root = root;
    if (root == render::RootMode::kInterval && !cm.used->has_interval()) so.field = cm.field.get();
    objects.push_back(so);
    SceneObjectReport rep;
    rep.name = object_label(o, i);
    rep.shared = cm.shared_code || model_placed[model_of[i]];
    model_placed[model_of[i]] = true;
    rep.world_box = so.transform.box_to_world(so.bbox);
    res.objects.push_back(rep);
  }

  // The camera: the scene's, completed by framing every object's solid when eye or look-at
  // is missing (each object's extent in its box, placed in the world).
  render::CameraRequest req = sc.camera.request;
  if (ov.camera.eye) req.eye = ov.camera.eye;
  if (ov.camera.look_at) req.look_at = ov.camera.look_at;
  if (ov.camera.up) req.up = ov.camera.up;
  if (ov.camera.fov_deg) req.fov_deg = ov.camera.fov_deg, req.ortho_width.reset();
  if (ov.camera.ortho_width) req.ortho_width = ov.camera.ortho_width, req.fov_deg.reset();
  render::Box extent;
  if (!req.eye || !req.look_at) {
    for (const render::SceneObject& so : objects) {
      render::Box e = render::find_extent(*so.field, so.bbox, so.field->has_interval() ? 6 : 5);
      extent.extend(so.transform.box_to_world(e));
    }
  }
  if (extent.empty()) extent = render::Box{{-1, -1, -1}, {1, 1, 1}};
  opt.camera = render::resolve_camera(req, extent, float(opt.width) / float(opt.height));
  render::Vec3 view = opt.camera.look_at - opt.camera.eye;
  if (length(view) == 0) {
    res.status = SceneJobStatus::kUsageError;
    res.error = "the camera's eye and look_at are the same point";
    return res;
  }
  if (length(cross(normalize(view), normalize(opt.camera.up))) < 1e-6f) {
    res.status = SceneJobStatus::kUsageError;
    res.error = "the camera's up is parallel to the view direction; give another up";
    return res;
  }

  // `--root auto`, per object: analytic when the model qualifies, else the decision of the
  // single-model render (render::choose_root's probe, which tells whether the model's
  // enclosures are tight enough for intervals to pay) for the same camera, seen in the object's
  // own space.
  if (root == render::RootMode::kAuto) {
    const auto t_probe = Clock::now();
    for (size_t i = 0; i < objects.size(); ++i) {
      render::SceneObject& so = objects[i];
      const CompiledModel& cm = models[model_of[i]];
      render::RenderOptions probe;
      probe.width = opt.width;
      probe.height = opt.height;
      probe.bbox = so.bbox;
      probe.threads = opt.threads;
      probe.root = render::RootMode::kAuto;
      probe.camera = opt.camera;
      probe.camera.eye = so.transform.point_to_object(opt.camera.eye);
      probe.camera.look_at = so.transform.point_to_object(opt.camera.look_at);
      probe.camera.up = normalize(so.transform.direction_to_object(opt.camera.up));
      probe.camera.ortho_width = opt.camera.ortho_width / so.transform.scale();
      const AnalyticInfo& info = cm.field->analytic_info();
      render::RootDecision d = settle_root(*so.field, &probe, &info, cm.file);
      so.root = probe.root;
      res.objects[i].why = d.why;
    }
    res.probe_ms = ms_since(t_probe);
  }

  const auto t_render = Clock::now();
  render::trace_into(objects, materials, opt, out);
  res.render_ms = ms_since(t_render);
  for (size_t i = 0; i < res.objects.size(); ++i) res.objects[i].root = out->stats.root_used[i];
  if (out->stats.cancelled) res.status = SceneJobStatus::kCancelled;
  return res;
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
