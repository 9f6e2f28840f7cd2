#include "tools/hfrt/model_field.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <thread>

namespace hfrt::tools {

namespace {

/// Per-thread packing buffers: the renderer calls from many threads at once.
struct Scratch {
  std::vector<float> xs, out;
};
thread_local Scratch t_scratch;

/// The float nearest to v on the side of -inf / +inf (so [down(lo), up(hi)] still encloses
/// [lo, hi] after the conversion to float).
float round_down(double v) {
  float f = static_cast<float>(v);
  return static_cast<double>(f) > v ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float round_up(double v) {
  float f = static_cast<float>(v);
  return static_cast<double>(f) < v ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

/// Packs up to three coordinate arrays into the structure-of-arrays layout of the model
/// (x[1..3]; any further coordinates, e.g. time, are held at 0).
void pack(int dims, size_t n, const float* x, const float* y, const float* z,
          std::vector<float>* xs) {
  xs->assign(size_t(std::max(dims, 1)) * n, 0.0f);
  const float* src[3] = {x, y, z};
  for (int k = 0; k < std::min(dims, 3); ++k) std::copy(src[k], src[k] + n, xs->data() + k * n);
}

}  // namespace

ModelField::ModelField(const Model& model, std::string file)
    : model_(model), file_(std::move(file)), dims_(model.num_inputs()) {}

void ModelField::eval(size_t n, const float* x, const float* y, const float* z,
                      float* out_f) const {
  if (n == 0) return;
  Scratch& sc = t_scratch;
  pack(dims_, n, x, y, z, &sc.xs);
  model_.eval_batch(int64_t(n), sc.xs.data(), out_f, nullptr);
}

render::Interval ModelField::eval_interval(const render::Box& box, bool* maybe_nan) const {
  // Float box corners are exact in double; the f64 enclosure is rounded outwards.
  const double lo[3] = {box.lo.x, box.lo.y, box.lo.z};
  const double hi[3] = {box.hi.x, box.hi.y, box.hi.z};
  IntervalValue r = model_.eval_interval(lo, hi);
  *maybe_nan = r.maybe_nan;
  if (r.maybe_nan && r.hi >= 0 && (std::isinf(r.lo) || std::isinf(r.hi))) {
    // An enclosure with NaN possible and an infinite bound that reaches 0 (an interval loop
    // that gave up, e.g. the Newton iterations of hfDEllipsoid: [-inf, 0] even over a point)
    // does not shrink with the box, so it says nothing about where the surface is. Report it
    // as unknown (NaN ends): the renderer then subdivides and samples, instead of taking a
    // piece that still reaches 0 at the tolerance for a thin feature (which would fill the
    // whole box with a false solid).
    const float nan = std::numeric_limits<float>::quiet_NaN();
    return {nan, nan};
  }
  return {round_down(r.lo), round_up(r.hi)};
}

void ModelField::eval_gradient(size_t n, const float* x, const float* y, const float* z,
                               float* f, float* dx, float* dy, float* dz) const {
  if (n == 0) return;
  Scratch& sc = t_scratch;
  pack(dims_, n, x, y, z, &sc.xs);
  sc.out.resize(4 * n);
  model_.eval_gradient_batch(int64_t(n), sc.xs.data(), sc.out.data());
  std::copy(&sc.out[0], &sc.out[n], f);
  std::copy(&sc.out[n], &sc.out[2 * n], dx);
  std::copy(&sc.out[2 * n], &sc.out[3 * n], dy);
  std::copy(&sc.out[3 * n], &sc.out[4 * n], dz);
}

void ModelField::eval_attributes(size_t n, const float* x, const float* y, const float* z,
                                 float* out_s) const {
  if (n == 0 || model_.num_attributes() == 0) return;
  Scratch& sc = t_scratch;
  pack(dims_, n, x, y, z, &sc.xs);
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

double prepare_render_code(const Model& model, bool interval, bool gradient) {
  auto t0 = std::chrono::steady_clock::now();
  std::string interval_error, gradient_error;
  bool interval_ok = true, gradient_ok = true;
  {
    // The process-wide LLJIT accepts modules from several threads (one context each).
    std::thread worker;
    if (interval && gradient) {
      worker = std::thread([&] { interval_ok = model.prepare_interval(&interval_error); });
    } else if (interval) {
      interval_ok = model.prepare_interval(&interval_error);
    }
    if (gradient) gradient_ok = model.prepare_gradient(Precision::kF32, &gradient_error);
    if (worker.joinable()) worker.join();
  }
  if (!interval_ok) {
    std::fprintf(stderr, "hfrt: warning: interval JIT failed (%s); using the interval interpreter\n",
                 interval_error.c_str());
  }
  if (!gradient_ok) {
    std::fprintf(stderr, "hfrt: warning: gradient JIT failed (%s); using the gradient interpreter\n",
                 gradient_error.c_str());
  }
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string describe_domain_engines(const Model& model) {
  ModelStats st = model.stats();
  auto one = [&](const char* name, DomainEngine engine, const ModelStats::Domain& d) {
    char buf[160];
    if (engine == DomainEngine::kJit && d.compiled) {
      std::snprintf(buf, sizeof buf, "%s JIT (%d lanes, %.1f ms)", name, d.lanes, d.compile_ms);
    } else if (engine == DomainEngine::kJit) {
      std::snprintf(buf, sizeof buf, "%s JIT (not compiled)", name);
    } else {
      std::snprintf(buf, sizeof buf, "%s interpreter", name);
    }
    return std::string(buf);
  };
  return one("interval", model.interval_engine(), st.interval) + ", " +
         one("gradient f32", model.gradient_engine(Precision::kF32), st.gradient_f32);
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
