#include "tools/hfrt/model_field.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>

namespace hfrt::tools {

namespace {

/// Per-thread packing buffers: the renderer calls from many threads at once.
struct Scratch {
  std::vector<float> xs;
  std::vector<double> xd, fd;
};
thread_local Scratch t_scratch;

}  // namespace

ModelField::ModelField(const Model& model, std::string file, float gradient_step)
    : model_(model), file_(std::move(file)), h_(gradient_step), dims_(model.num_inputs()) {}

void ModelField::eval(size_t n, const float* x, const float* y, const float* z,
                      float* out_f) const {
  if (n == 0) return;
  Scratch& sc = t_scratch;
  // x[1..3] from the point; any further coordinates (time, ...) are held at 0.
  sc.xs.assign(size_t(dims_) * n, 0.0f);
  const float* src[3] = {x, y, z};
  for (int k = 0; k < std::min(dims_, 3); ++k) std::copy(src[k], src[k] + n, &sc.xs[k * n]);
  model_.eval_batch(int64_t(n), sc.xs.data(), out_f, nullptr);
}

render::Interval ModelField::eval_interval(const render::Box&, bool* maybe_nan) const {
  // Never called: has_interval() is false until the public API exposes intervals.
  *maybe_nan = true;
  return {-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity()};
}

void ModelField::eval_gradient(size_t n, const float* x, const float* y, const float* z,
                               float* f, float* dx, float* dy, float* dz) const {
  if (n == 0) return;
  // FALLBACK: central differences of the f64 evaluator, one batch of 7n points (the point and
  // its 6 neighbours at +-h along each axis).
  Scratch& sc = t_scratch;
  const size_t m = 7 * n;
  sc.xd.assign(size_t(dims_) * m, 0.0);
  sc.fd.resize(m);
  const float* src[3] = {x, y, z};
  for (size_t i = 0; i < n; ++i) {
    for (int j = 0; j < 7; ++j) {
      size_t p = i * 7 + j;
      for (int k = 0; k < std::min(dims_, 3); ++k) {
        double v = src[k][i];
        if (j > 0 && (j - 1) / 2 == k) v += (j % 2 ? h_ : -h_);
        sc.xd[k * m + p] = v;
      }
    }
  }
  model_.eval_batch(int64_t(m), sc.xd.data(), sc.fd.data(), nullptr);
  double inv = 0.5 / h_;
  for (size_t i = 0; i < n; ++i) {
    const double* v = &sc.fd[i * 7];
    f[i] = float(v[0]);
    dx[i] = float((v[1] - v[2]) * inv);
    dy[i] = float((v[3] - v[4]) * inv);
    dz[i] = float((v[5] - v[6]) * inv);
  }
}

void ModelField::eval_attributes(size_t n, const float* x, const float* y, const float* z,
                                 float* out_s) const {
  if (n == 0 || model_.num_attributes() == 0) return;
  Scratch& sc = t_scratch;
  sc.xs.assign(size_t(dims_) * n, 0.0f);
  const float* src[3] = {x, y, z};
  for (int k = 0; k < std::min(dims_, 3); ++k) std::copy(src[k], src[k] + n, &sc.xs[k * n]);
  std::vector<float> f(n);
  model_.eval_batch(int64_t(n), sc.xs.data(), f.data(), out_s);
}

std::string ModelField::explain_nan(render::Vec3 p) const {
  PointValue v = model_.eval({double(p.x), double(p.y), double(p.z)});
  char where[160];
  std::snprintf(where, sizeof where, " (first at x=(%g, %g, %g))", p.x, p.y, p.z);
  if (v.ok()) return std::string("no value in single precision") + where;
  std::string text = v.error;
  if (v.error_line > 0) {
    text += " at " + file_ + ":" + std::to_string(v.error_line) + ":" + std::to_string(v.error_col);
  }
  return text + where;
}

bool parse_doubles(const std::string& text, std::vector<double>* out, size_t count) {
  out->clear();
  if (text.empty()) return count == 0;
  size_t pos = 0;
  while (true) {
    size_t comma = text.find(',', pos);
    std::string item = text.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
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
  auto t0 = std::chrono::steady_clock::now();
  CompileResult compiled = Model::compile_file(request.file, mo);
  LoadedModel loaded;
  loaded.compile_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
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
  return loaded;
}

}  // namespace hfrt::tools
