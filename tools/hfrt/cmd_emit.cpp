// `hfrt emit --pov MODEL.hf [-o OUT.pov] [--function-only] [--name IDENT]
//      [--max-gradient G] [--accuracy A] [every `hfrt render` option]`
//
// `hfrt emit --pov SCENE.toml [-o OUT.pov] [--max-gradient G] [--accuracy A]`
//
// Writes the model as POV-Ray 3.7 SDL (jit/pov_emit.h): by default a complete scene that
// renders what `hfrt render` renders with the same options — the same camera (framed the
// same way when --eye/--look-at are not given), the same lights, box, image size and
// background — as an `isosurface` of the emitted function; with --function-only just the
// `#declare` of the function. See docs/pov.md. A scene file (scene/scene_file.h) is written
// whole: every object its isosurface with its box, placement and material, and the scene's
// camera, lights, background and depth (scene/pov_scene.h; docs/emit.md).
//
// Exit codes: 0 = written, 1 = the model has compile errors or a construct POV-Ray functions
// cannot express (located diagnostics on stderr), 2 = usage or environment error.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "app/model_field.h"
#include "base/file.h"
#include "base/result.h"
#include "gpu/kernel_abi.h"
#include "ir/ir.h"
#include "jit/driver.h"
#include "jit/pov_emit.h"
#include "render/camera.h"
#include "scene/pov_scene.h"
#include "scene/scene_file.h"
#include "tools/hfrt/commands.h"
#include "tools/hfrt/render_options.h"

namespace hfrt::tools {
namespace {

struct EmitCli {
  RenderCli render;  // model file, -o, and the render options (camera, lights, box, ...)
  bool pov = false;
  bool function_only = false;
  std::string name;
  float max_gradient = 0;    // 0: estimated from hfrt's gradient evaluator
  float accuracy = 0;        // 0: bbox size * 1e-5, hfrt's default root tolerance
  bool transparent = false;  // background with transmit 1 (coverage in alpha with +UA)
  bool ptx = false;          // --ptx: the GPU kernels (docs/gpu.md)
  std::string sm = "sm_60";  // --sm: the PTX's GPU architecture
};

int usage_error(const std::string& message) {
  std::fprintf(stderr, "hfrt emit: %s\n", message.c_str());
  return 2;
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string vec(render::Vec3 v) {
  return "<" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + ">";
}

/// The largest |grad F| over a 48^3 grid of the box, by hfrt's gradient evaluator: a default
/// max_gradient for POV-Ray (which needs an upper bound of the gradient along its rays).
float estimate_max_gradient(const render::Field& field, const render::Box& box) {
  constexpr int kN = 48;
  std::vector<float> xs, ys, zs;
  xs.reserve(kN * kN);
  ys.reserve(kN * kN);
  zs.reserve(kN * kN);
  std::vector<float> f(kN * kN), dx(kN * kN), dy(kN * kN), dz(kN * kN);
  const render::Vec3 s = box.size();
  float best = 0;
  for (int k = 0; k < kN; ++k) {
    xs.clear();
    ys.clear();
    zs.clear();
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        xs.push_back(box.lo.x + s.x * (i + 0.5f) / kN);
        ys.push_back(box.lo.y + s.y * (j + 0.5f) / kN);
        zs.push_back(box.lo.z + s.z * (k + 0.5f) / kN);
      }
    field.eval_gradient(xs.size(), xs.data(), ys.data(), zs.data(), f.data(), dx.data(), dy.data(),
                        dz.data());
    for (size_t p = 0; p < xs.size(); ++p) {
      float g = std::sqrt(dx[p] * dx[p] + dy[p] * dy[p] + dz[p] * dz[p]);
      if (std::isfinite(g)) best = std::max(best, g);
    }
  }
  return best;
}

/// The POV-Ray scene around the declared function `name` (F >= 0 is the solid; POV-Ray's
/// isosurface is where the function is below the threshold, hence -F).
std::string scene_text(const render::RenderOptions& opt, const std::string& name,
                       float max_gradient, float accuracy, bool transparent) {
  const render::Camera& cam = opt.camera;
  render::CameraFrame frame(cam, opt.width, opt.height);
  const float aspect = float(opt.width) / float(opt.height);
  float half_w, half_h;
  if (frame.orthographic()) {
    half_w = cam.ortho_width * 0.5f;
    half_h = half_w / aspect;
  } else {
    half_h = std::tan(cam.fov_deg * 0.5f * float(M_PI) / 180.0f);
    half_w = half_h * aspect;
  }
  std::string s;
  s += "global_settings { assumed_gamma 1.0 }\n";
  // POV-Ray's perspective ray through the pixel centre (px, py) is direction + (px/W - 0.5)
  // right + (0.5 - py/H) up; with these vectors it is hfrt's ray (render/camera.cpp). The
  // vectors are given explicitly (no look_at, no angle), so POV-Ray's left-handed conventions
  // do not apply and x, y, z mean the same in both programs.
  s += "camera {\n  ";
  s += frame.orthographic() ? "orthographic" : "perspective";
  s += "\n  location " + vec(frame.eye()) + "\n  direction " + vec(frame.forward()) + "\n  right " +
       vec(frame.right() * (2 * half_w)) + "\n  up " + vec(frame.up() * (2 * half_h)) + "\n}\n";
  std::vector<render::Light> lights =
      opt.lights.empty() ? render::default_lights(frame) : opt.lights;
  const render::Vec3 centre = opt.bbox.center();
  const float far = 1e4f * std::max(1.0f, opt.bbox.max_extent());
  for (const render::Light& l : lights) {
    s += "light_source {\n";
    if (l.kind == render::Light::Kind::kDirectional) {
      // A parallel light: the direction towards the light is l.v.
      s += "  " + vec(centre + normalize(l.v) * far) + " color rgb " + vec(l.color) +
           "\n  parallel point_at " + vec(centre) + "\n";
    } else {
      s += "  " + vec(l.v) + " color rgb " + vec(l.color) + "\n";
    }
    if (!opt.shadows) s += "  shadowless\n";
    s += "}\n";
  }
  // Transparent: POV-Ray's +UA then writes coverage to alpha, as hfrt's EXR does.
  s += transparent ? "background { rgbt <" + num(opt.background.x) + ", " + num(opt.background.y) +
                         ", " + num(opt.background.z) + ", 1> }\n"
                   : "background { rgb " + vec(opt.background) + " }\n";
  s += "isosurface {\n  function { -" + name + "(x, y, z) }\n";
  s += "  contained_by { box { " + vec(opt.bbox.lo) + ", " + vec(opt.bbox.hi) + " } }\n";
  s +=
      "  threshold 0\n  max_gradient " + num(max_gradient) + "\n  accuracy " + num(accuracy) + "\n";
  // hfrt shades Blinn-Phong: ambient 0.12, diffuse 1, specular 0.25 with exponent 48.
  s += "  pigment { rgb " + vec(opt.albedo) + " }\n";
  s += "  finish { ambient 0.12 diffuse 1 specular 0.25 roughness " + num(1.0 / 48) + " }\n}\n";
  return s;
}

bool is_scene_file(const std::string& path) {
  return path.size() > 5 && path.compare(path.size() - 5, 5, ".toml") == 0;
}

/// Writes `out` to -o (or standard output); the exit code.
int write_output(const std::string& output, const std::string& out, const char* what) {
  if (output.empty() || output == "-") {
    std::fwrite(out.data(), 1, out.size(), stdout);
    std::fflush(stdout);
    return 0;
  }
  std::ofstream f(output, std::ios::binary);
  f << out;
  f.close();
  if (!f) {
    std::fprintf(stderr, "hfrt: cannot write %s\n", output.c_str());
    return 2;
  }
  std::fprintf(stderr, "hfrt: wrote %s (%s)\n", output.c_str(), what);
  return 0;
}

/// One compiled model of a scene (objects with the same file or source, name and parameters
/// share it).
struct SceneModel {
  std::string function;  // POV identifier of the declared function
  std::optional<Model> model;
};

/// `hfrt emit --pov SCENE.toml`: every object of the scene as an isosurface, with its
/// material, and the scene's camera, lights and settings.
int run_emit_scene(EmitCli& cli, const CLI::App& sub) {
  const bool color = use_color(STDERR_FILENO);
  // The scene file sets the camera, size, lights and the rest: render options would be
  // ignored, which must not happen silently.
  // --size, --spp and --max-depth replace the scene's values, as for `hfrt render scene.toml`.
  static const std::set<std::string> kSceneOptions = {
      "pov",           "output", "max-gradient", "accuracy", "transparent-background",
      "function-only", "help",   "size",         "spp",      "max-depth"};
  for (const CLI::Option* o : sub.get_options()) {
    if (o->count() == 0 || o->get_positional()) continue;
    const std::vector<std::string>& longs = o->get_lnames();
    if (!longs.empty() && kSceneOptions.count(longs[0])) continue;
    const std::string shown = longs.empty() ? o->get_name() : "--" + longs[0];
    return usage_error(shown + " does not apply to a scene file: set it in the scene (see " +
                       "docs/scenes.md)");
  }
  if (cli.max_gradient < 0) return usage_error("--max-gradient must be positive");
  if (cli.accuracy < 0) return usage_error("--accuracy must be positive");
  const std::string& path = cli.render.model.file;
  scene::SceneDesc desc;
  scene::SceneError serr;
  if (!scene::read_scene_file(path, &desc, &serr)) {
    std::fputs(serr.render().c_str(), stderr);
    return 1;
  }

  const render::RenderOptions defaults;
  std::string decls;
  std::map<std::string, SceneModel> models;  // by file or source, object name and params
  std::set<std::string> identifiers;
  std::vector<scene::PovObject> objects;
  std::vector<const SceneModel*> object_models;
  for (const scene::ObjectDesc& o : desc.objects) {
    std::string key = (o.file.empty() ? "source\n" + o.source : "file\n" + o.file) + "\n" +
                      o.name.value_or("") + "\n";
    for (double a : o.params) key += num(a) + ",";
    auto [it, fresh] = models.try_emplace(key);
    SceneModel& sm = it->second;
    if (fresh) {
      // The text as the compiler sees it; inline sources are placed where they stand in the
      // scene file, so that their diagnostics name its lines and columns.
      std::string name, text, error;
      if (!scene::object_source(o, path, &text, &name, &error)) {
        std::fprintf(stderr, "hfrt: %s\n", error.c_str());
        return 2;
      }
      auto file = std::make_shared<const lang::SourceFile>(name, text);
      lang::DiagnosticSink diags(file);
      jit::LoweredSource lowered = jit::compile_source(diags, o.name.value_or(""));
      if (!lowered.program || !report_no_object(lowered, name)) {
        std::fputs(diags.render(color).c_str(), stderr);
        return 1;
      }
      jit::PovEmitOptions po;
      const std::string base =
          jit::pov_identifier("hf_" + lowered.program->objects[lowered.object].name);
      po.name = base;
      for (int n = 2; identifiers.count(po.name); ++n) po.name = base + "_" + std::to_string(n);
      identifiers.insert(po.name);
      po.params = o.params;
      jit::PovFunction pov;
      const bool ok = lowered.ok() && jit::emit_pov_function(lowered.fn, po, &pov, &diags);
      std::fputs(diags.render(color).c_str(), stderr);
      if (!ok || diags.has_errors()) return 1;
      decls += "\n// " + po.name + ": " + (o.file.empty() ? "inline source" : o.file) +
               ", object " + lowered.program->objects[lowered.object].name + " (" +
               std::to_string(pov.expression_nodes) + " POV operations)\n" + pov.text;
      sm.function = po.name;
      if (!cli.function_only) {
        ModelOptions mo;
        mo.object = o.name.value_or("");
        mo.eager_f64 = false;
        mo.eager_f32 = true;
        CompileResult compiled = Model::compile(text, mo, name);
        std::fputs(compiled.rendered.c_str(), stderr);
        if (!compiled.error.empty() || !compiled.ok()) {
          if (!compiled.error.empty()) std::fprintf(stderr, "hfrt: %s\n", compiled.error.c_str());
          return 1;
        }
        sm.model = std::move(compiled.model);
        sm.model->set_params(o.params);
      }
    }
    scene::PovObject po;
    po.function = sm.function;
    po.bbox = o.bbox.value_or(defaults.bbox);
    po.material = o.material.empty() ? render::Material{} : desc.materials.at(o.material);
    po.translate = o.translate;
    po.rotate_deg = o.rotate_deg;
    po.scale = o.scale;
    po.comment = "[[object]] at " + path + ":" + std::to_string(o.pos.line) +
                 (o.material.empty() ? "" : ", material \"" + o.material + "\"");
    objects.push_back(po);
    object_models.push_back(&sm);
  }

  std::string out = "#version 3.7;\n// Written by `hfrt emit --pov` from " + path + ": " +
                    std::to_string(desc.objects.size()) + " objects, " +
                    std::to_string(models.size()) + " functions.\n";
  out += "// Each function is F (F >= 0 is the solid; the isosurfaces use -F).\n";
  out += decls;
  if (cli.function_only) return write_output(cli.render.output, out, "functions");

  // Boxes (for parallel lights) and, when the camera is not fully given, the solids' extent.
  scene::PovSceneSettings ps;
  ps.width = desc.render.size ? (*desc.render.size)[0] : defaults.width;
  ps.height = desc.render.size ? (*desc.render.size)[1] : defaults.height;
  if (sub.count("--size") > 0 && !parse_size(cli.render.size, &ps.width, &ps.height)) {
    return usage_error("--size expects WxH with positive integers, e.g. --size 512x512 (got '" +
                       cli.render.size + "')");
  }
  if (sub.count("--spp") > 0 && (cli.render.spp < 1 || cli.render.spp > 4096)) {
    return usage_error("--spp expects 1..4096");
  }
  if (cli.render.max_depth < -1 || cli.render.max_depth > 64) {
    return usage_error("--max-depth expects 0..64");
  }
  const render::CameraRequest& request = desc.camera.request;
  const bool framed = !request.eye || !request.look_at;
  render::Box extent;
  for (size_t i = 0; i < objects.size(); ++i) {
    const Model& model = *object_models[i]->model;
    app::ModelField model_field(model, path);
    app::WithoutIntervals sampled(model_field);
    const render::Field& field =
        app::render_field(model, model_field, sampled, render::RootMode::kAuto);
    const render::Box box = objects[i].bbox;
    extent.extend(
        scene::world_box(desc.objects[i], framed ? render::find_extent(field, box) : box));
    objects[i].max_gradient = cli.max_gradient > 0
                                  ? cli.max_gradient
                                  : std::max(1e-3f, 1.2f * estimate_max_gradient(field, box));
    objects[i].accuracy = cli.accuracy > 0 ? cli.accuracy : box.max_extent() * 1e-5f;
  }
  ps.extent = extent;
  ps.camera = render::resolve_camera(request, extent, float(ps.width) / float(ps.height));
  const render::Camera& c = ps.camera;
  if (length(c.look_at - c.eye) <= 0 || length(cross(normalize(c.look_at - c.eye), c.up)) < 1e-6f) {
    return usage_error(
        "the scene's camera is degenerate (eye = look-at, or up parallel to the "
        "view)");
  }
  ps.aperture = desc.camera.aperture;
  ps.focus_distance = desc.camera.focus_distance.value_or(length(c.look_at - c.eye));
  ps.spp = sub.count("--spp") > 0 ? cli.render.spp : desc.render.spp.value_or(1);
  ps.max_depth =
      cli.render.max_depth >= 0 ? cli.render.max_depth : desc.render.max_depth.value_or(5);
  ps.background = desc.render.background.value_or(defaults.background);
  ps.transparent_background = cli.transparent;
  ps.lights = desc.lights;
  if (ps.lights.empty())
    ps.lights = render::default_lights(render::CameraFrame(c, ps.width, ps.height));

  out += "\n// The scene: " + std::to_string(ps.width) + "x" + std::to_string(ps.height) +
         ", render with  povray +W" + std::to_string(ps.width) + " +H" + std::to_string(ps.height);
  if (ps.spp > 1 && ps.aperture <= 0) {
    // hfrt's spp samples per pixel as POV-Ray's supersampling of method 1 (n x n rays).
    const int n = std::max(2, int(std::lround(std::sqrt(double(ps.spp)))));
    out += " +A0.0 +AM1 +R" + std::to_string(n);
  }
  out += "\n";
  out += scene::pov_scene_text(ps, objects);
  return write_output(cli.render.output, out, "scene");
}

/// `hfrt emit --ptx`: the kernels of gpu/kernel_abi.h for NVIDIA GPUs (docs/gpu.md).
int run_emit_ptx(const EmitCli& cli) {
  if (is_scene_file(cli.render.model.file)) {
    return usage_error("--ptx takes a .hf model (scene files render on the CPU)");
  }
  if (cli.sm.rfind("sm_", 0) != 0 || cli.sm.size() < 5) {
    return usage_error("--sm expects a GPU architecture such as sm_60, sm_80 or sm_90 (got '" +
                       cli.sm + "')");
  }
  int code = 0;
  auto loaded = load_model(cli.render.model, /*eager_f32=*/false, &code);
  if (!loaded) return code;
  const Model& model = *loaded->model;
  std::string ptx, error;
  if (!model.device_ptx(&ptx, &error, cli.sm)) {
    std::fprintf(stderr, "hfrt emit: %s: %s\n", cli.render.model.file.c_str(), error.c_str());
    return 1;
  }
  std::string out = "// Written by `hfrt emit --ptx` from " + cli.render.model.file + ", object " +
                    model.object_name() + " (" + std::to_string(model.num_inputs()) +
                    " coordinates, " + std::to_string(model.num_params()) +
                    " parameters a[]).\n"
                    "// Kernels (gpu/kernel_abi.h, docs/gpu.md): " +
                    gpu::kEvalEntry + "(n, xs, a, out_f, out_s), one point per thread; " +
                    gpu::kRenderEntry + "(params, a, out), one pixel per thread.\n";
  return write_output(cli.render.output, out + ptx, ("PTX for " + cli.sm).c_str());
}

int run_emit(EmitCli& cli, const CLI::App& sub) {
  const bool color = use_color(STDERR_FILENO);
  if (cli.pov && cli.ptx) return usage_error("choose one output language: --pov or --ptx");
  if (cli.ptx) return run_emit_ptx(cli);
  if (!cli.pov) return usage_error("choose the output language: --pov or --ptx");
  if (is_scene_file(cli.render.model.file)) return run_emit_scene(cli, sub);
  app::RenderSetup setup;
  std::string err;
  if (!translate_render_options(cli.render, &setup, &err)) return usage_error(err);
  if (cli.max_gradient < 0) return usage_error("--max-gradient must be positive");
  if (cli.accuracy < 0) return usage_error("--accuracy must be positive");

  // The IR, as `hfrt ir` shows it.
  const ModelRequest& req = cli.render.model;
  const Limits limits = to_limits(req.limits);
  Result<std::string> text =
      read_file_limited(req.file, limits.max_source_bytes, false, "max_source_bytes");
  if (!text) {
    std::fprintf(stderr, "hfrt: %s\n", text.error().message.c_str());
    if (!text.error().hint.empty()) std::fprintf(stderr, "hint: %s\n", text.error().hint.c_str());
    return 2;
  }
  auto file = std::make_shared<const lang::SourceFile>(req.file, std::move(text).value());
  lang::DiagnosticSink diags(file);
  jit::LoweredSource lowered = jit::compile_source(diags, req.object, limits);
  if (!lowered.program || !report_no_object(lowered, req.file)) {
    std::fputs(diags.render(color).c_str(), stderr);
    return 1;
  }
  const int index = lowered.object;
  const lang::Program* prog = lowered.program.get();
  const ir::Function& fn = lowered.fn;
  jit::PovEmitOptions po;
  po.name = jit::pov_identifier(cli.name.empty() ? "hf_" + prog->objects[index].name : cli.name);
  if (!cli.name.empty() && po.name != cli.name) {
    return usage_error("--name '" + cli.name + "' is not a usable POV-Ray identifier (try '" +
                       po.name + "')");
  }
  po.params = setup.params;
  jit::PovFunction pov;
  // Lowering errors (a mesh or patch file that does not load) stop before emitting.
  const bool ok = lowered.ok() && jit::emit_pov_function(fn, po, &pov, &diags);
  std::fputs(diags.render(color).c_str(), stderr);
  if (!ok || diags.has_errors()) return 1;

  std::string out = "// Written by `hfrt emit --pov` from " + req.file + ", object " +
                    prog->objects[index].name + ".\n";
  out += "// " + po.name + "(x, y, z) = F; F >= 0 is the solid (POV-Ray's isosurface wants -F).\n";
  out += "// " + std::to_string(fn.insts.size()) + " IR instructions -> " +
         std::to_string(pov.expression_nodes) + " POV operations, " + std::to_string(pov.helpers) +
         " helper functions for shared values";
  if (pov.dropped_checks)
    out += "; " + std::to_string(pov.dropped_checks) + " run-time error checks not written";
  out += ".\n";
  if (pov.undefined_reads) {
    out += "// Warning: " + std::to_string(pov.undefined_reads) +
           " reads of variables that may be unassigned are written as 0.\n";
  }
  if (!cli.function_only) out = "#version 3.7;\n" + out;
  out += pov.text;

  if (!cli.function_only) {
    render::RenderOptions& opt = setup.options;
    float max_gradient = cli.max_gradient;
    const bool framed = !setup.camera.eye || !setup.camera.look_at;
    if (framed || max_gradient == 0) {
      // The same camera as `hfrt render` (framing needs the compiled model), and a gradient
      // estimate for POV-Ray's max_gradient.
      int code = 0;
      auto loaded = load_model(req, /*eager_f32=*/true, &code);
      if (!loaded) return code;
      const Model& model = *loaded->model;
      app::ModelField model_field(model, req.file);
      app::WithoutIntervals sampled_field(model_field);
      const render::Field& field = app::render_field(model, model_field, sampled_field, opt.root);
      app::FramingInfo framing;
      if (!app::frame_camera(field, setup.camera, &opt, &framing, &err)) return usage_error(err);
      if (max_gradient == 0) {
        max_gradient = std::max(1e-3f, 1.2f * estimate_max_gradient(field, opt.bbox));
      }
    } else {
      // Eye and look-at given: no framing, so no need to compile the model.
      render::Camera& c = opt.camera;
      c = render::resolve_camera(setup.camera, opt.bbox, float(opt.width) / float(opt.height));
      if (length(c.look_at - c.eye) <= 0 ||
          length(cross(normalize(c.look_at - c.eye), c.up)) < 1e-6f) {
        return usage_error("the camera is degenerate (eye = look-at, or up parallel to the view)");
      }
    }
    const float accuracy = cli.accuracy > 0 ? cli.accuracy : opt.bbox.max_extent() * 1e-5f;
    out += "\n// The scene of `hfrt render` with the same options: " + std::to_string(opt.width) +
           "x" + std::to_string(opt.height) + " (render with +W" + std::to_string(opt.width) +
           " +H" + std::to_string(opt.height) + ").\n";
    out += scene_text(opt, po.name, max_gradient, accuracy, cli.transparent);
  }

  if (cli.render.output.empty() || cli.render.output == "-") {
    std::fwrite(out.data(), 1, out.size(), stdout);
    std::fflush(stdout);
    return 0;
  }
  std::ofstream f(cli.render.output, std::ios::binary);
  f << out;
  f.close();
  if (!f) {
    std::fprintf(stderr, "hfrt: cannot write %s\n", cli.render.output.c_str());
    return 2;
  }
  std::fprintf(stderr, "hfrt: wrote %s (%s)\n", cli.render.output.c_str(),
               cli.function_only ? "function" : "scene");
  return 0;
}

}  // namespace

CommandRunner register_emit(CLI::App& app) {
  auto cli = std::make_shared<EmitCli>();
  CLI::App* sub = add_command(app, "emit");
  sub->add_option("model", cli->render.model.file, "HyperFun model file, or a scene file (.toml)")
      ->required();
  sub->add_flag("--pov", cli->pov, "POV-Ray 3.7 SDL");
  sub->add_flag("--ptx", cli->ptx,
                "PTX for NVIDIA GPUs: the point evaluator and ray caster kernels (docs/gpu.md)");
  sub->add_option("--sm", cli->sm, "--ptx: the GPU architecture (default sm_60)");
  sub->add_option("-o,--output", cli->render.output, "output file (default: standard output)");
  sub->add_flag("--function-only", cli->function_only,
                "write only the #declare of the function, not a scene");
  sub->add_option("--name", cli->name, "POV-Ray identifier of the function (default hf_OBJECT)");
  sub->add_option("--max-gradient", cli->max_gradient,
                  "isosurface max_gradient (default: 1.2 x the largest |grad F| sampled by hfrt)");
  sub->add_option("--accuracy", cli->accuracy, "isosurface accuracy (default: bbox size * 1e-5)");
  sub->add_flag("--transparent-background", cli->transparent,
                "background with transmit 1: with POV-Ray's +UA, alpha is the coverage");
  add_render_options(*sub, &cli->render);
  add_limit_options(*sub, &cli->render.model.limits);
  return [cli, sub] { return run_emit(*cli, *sub); };
}

}  // namespace hfrt::tools
