// Model options and loading for the commands (model_request.h).
#include "tools/hfrt/model_request.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

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

std::optional<LoadedModel> load_model(const ModelRequest& request, bool eager_f32, int* exit_code) {
  ModelOptions mo;
  mo.object = request.object;
  mo.backend = request.backend == "interp" ? Backend::kInterp : Backend::kJit;
  mo.eager_f64 = false;
  mo.eager_f32 = eager_f32;
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
