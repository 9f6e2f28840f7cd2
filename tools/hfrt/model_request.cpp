// Model options and loading for the commands (model_request.h).
#include "tools/hfrt/model_request.h"

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

#include "base/limits.h"
#include "base/timer.h"

namespace hfrt::tools {

bool parse_doubles(const std::string& text, std::vector<double>* out, size_t count) {
  out->clear();
  if (text.empty()) return count == 0;
  size_t pos = 0;
  while (true) {
    size_t comma = text.find(',', pos);
    std::string item =
        text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    char* end = nullptr;
    double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(v)) return false;
    out->push_back(v);
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return count == 0 || out->size() == count;
}

bool parse_floats(const std::string& text, std::vector<float>* out, size_t count) {
  std::vector<double> d;
  bool ok = parse_doubles(text, &d, count);
  out->assign(d.begin(), d.end());
  return ok;
}

bool parse_time(const std::string& text, double* out, std::string* err) {
  std::vector<double> v;
  if (!parse_doubles(text, &v, 1)) {
    *err = "--time expects a number, e.g. --time 0.5 (got '" + text + "')";
    return false;
  }
  *out = v[0];
  return true;
}

void add_limit_options(CLI::App& app, ModelLimits* limits) {
  const ModelLimits d;
  auto add = [&](const char* name, int64_t* field, int64_t def, int64_t max, const char* what) {
    app.add_option(name, *field, std::string(what) + " (default " + std::to_string(def) + ")")
        ->check(CLI::Range(int64_t{1}, max))
        ->group("Limits (docs/limits.md)");
  };
  constexpr int64_t kNoMax = std::numeric_limits<int64_t>::max();
  add("--max-loop-iterations", &limits->max_loop_iterations, d.max_loop_iterations,
      kMaxLoopIterationsCap,
      "while-loop iterations per point, all loops together; beyond: no value");
  add("--max-array-size", &limits->max_array_size, d.max_array_size, kNoMax,
      "elements of one array (header or 'array' declaration)");
  add("--max-slots", &limits->max_slots, d.max_slots, kNoMax,
      "variables and array elements of the model, inlined object calls included");
  add("--max-model-size", &limits->max_model_size, d.max_model_size, kNoMax,
      "operations of the model once object calls are inlined");
  add("--max-source-bytes", &limits->max_source_bytes, d.max_source_bytes, kNoMax,
      "bytes of the model file");
  add("--max-mesh-bytes", &limits->max_mesh_bytes, d.max_mesh_bytes, kNoMax,
      "bytes of a mesh or patch file (hfMesh, hfBezierSurface)");
  add("--max-mesh-triangles", &limits->max_mesh_triangles, d.max_mesh_triangles, kNoMax,
      "triangles (and vertices) of one mesh or patch tessellation");
  add("--max-exact-curves", &limits->max_exact_curves, d.max_exact_curves, kNoMax,
      "open border curves of a patch set for its exact field; beyond, a tessellated one");
}

std::optional<LoadedModel> load_model(const ModelRequest& request, bool eager_f32, int* exit_code) {
  ModelOptions mo;
  mo.object = request.object;
  mo.backend = request.backend == "interp" ? Backend::kInterp : Backend::kJit;
  mo.eager_f64 = false;
  mo.eager_f32 = eager_f32;
  mo.limits = request.limits;
  std::vector<double> params;
  if (!parse_doubles(request.params, &params)) {
    std::fprintf(stderr, "hfrt: -a expects numbers separated by commas, e.g. -a 1,0.5 (got '%s')\n",
                 request.params.c_str());
    *exit_code = 2;
    return std::nullopt;
  }
  double time = 0;
  std::string time_error;
  if (!request.time.empty() && !parse_time(request.time, &time, &time_error)) {
    std::fprintf(stderr, "hfrt: %s\n", time_error.c_str());
    *exit_code = 2;
    return std::nullopt;
  }
  const auto t0 = Clock::now();
  CompileResult compiled = Model::compile_file(request.file, mo);
  LoadedModel loaded;
  loaded.compile_ms = ms_since(t0);
  if (!compiled.error.empty()) {
    std::fprintf(stderr, "hfrt: %s\n", compiled.error.c_str());
    *exit_code = 2;
    return std::nullopt;
  }
  std::fputs(compiled.rendered.c_str(), stderr);
  if (!compiled.ok()) {
    *exit_code = 1;
    return std::nullopt;
  }
  loaded.model = std::move(compiled.model);
  loaded.model->set_params(params);
  loaded.model->set_time(time);
  if (!request.time.empty() && loaded.model->num_inputs() < 4) {
    std::fprintf(stderr,
                 "hfrt: note: --time has no effect: object '%s' declares %d coordinates (time is "
                 "x[4])\n",
                 loaded.model->object_name().c_str(), loaded.model->num_inputs());
  }
  return loaded;
}

}  // namespace hfrt::tools
