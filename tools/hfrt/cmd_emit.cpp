// `hfrt emit --pov MODEL.hf [-o OUT.pov] [--function-only] [--name IDENT]
//      [--max-gradient G] [--accuracy A] [every `hfrt render` option]`
//
// Writes the model as POV-Ray 3.7 SDL (jit/pov_emit.h): by default a complete scene that
// renders what `hfrt render` renders with the same options — the same camera (framed the
// same way when --eye/--look-at are not given), the same lights, box, image size and
// background — as an `isosurface` of the emitted function; with --function-only just the
// `#declare` of the function. See docs/pov.md.
//
// Exit codes: 0 = written, 1 = the model has compile errors or a construct POV-Ray functions
// cannot express (located diagnostics on stderr), 2 = usage or environment error.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "app/model_field.h"
#include "base/file.h"
#include "base/result.h"
#include "ir/ir.h"
#include "jit/driver.h"
#include "jit/pov_emit.h"
#include "render/camera.h"
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

int run_emit(EmitCli& cli) {
  const bool color = use_color(STDERR_FILENO);
  if (!cli.pov) return usage_error("choose the output language: --pov (the only one so far)");
  app::RenderSetup setup;
  std::string err;
  if (!translate_render_options(cli.render, &setup, &err)) return usage_error(err);
  if (cli.max_gradient < 0) return usage_error("--max-gradient must be positive");
  if (cli.accuracy < 0) return usage_error("--accuracy must be positive");

  // The IR, as `hfrt ir` shows it.
  const ModelRequest& req = cli.render.model;
  Result<std::string> text = read_file(req.file);
  if (!text) {
    std::fprintf(stderr, "hfrt: %s\n", text.error().message.c_str());
    return 2;
  }
  auto file = std::make_shared<const lang::SourceFile>(req.file, std::move(text).value());
  lang::DiagnosticSink diags(file);
  jit::LoweredSource lowered = jit::compile_source(diags, req.object);
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
  CLI::App* sub = app.add_subcommand(
      "emit", "write a model in another renderer's language (--pov: a POV-Ray isosurface scene)");
  sub->add_option("model", cli->render.model.file, "HyperFun model file")->required();
  sub->add_flag("--pov", cli->pov, "POV-Ray 3.7 SDL");
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
  return [cli] { return run_emit(*cli); };
}

}  // namespace hfrt::tools
