#pragma once
// The adapter from a compiled hfrt::Model (the public API, jit/include/hfrt/model.h) to the
// renderer's Field interface (render/field.h), plus the model loading and list parsing that
// `hfrt render` and `hfrt slice` share.
//
// Which evaluator serves which Field method:
//  - eval: the f32 batch evaluator (Model::eval_batch), the renderer's hot loop;
//  - eval_interval: Model::eval_interval (f64, outward rounded to float bounds), the interval
//    JIT or, for large objects and the interp backend, the interval interpreter;
//  - eval_gradient: Model::eval_gradient_batch in f32 (automatic differentiation);
//  - eval_attributes / explain_nan: the scalar evaluators.
// has_interval() is true for every model: the interval evaluator is sound for every op (see
// jit/interval.h), so the renderer may cull tiles and search roots by bisection.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hfrt/model.h"
#include "render/field.h"

namespace hfrt::tools {

class ModelField final : public render::Field {
 public:
  /// `model` must outlive the field and must not be changed (object, params) while rendering.
  /// `file` names the model in explain_nan().
  ModelField(const Model& model, std::string file);

  void eval(size_t n, const float* x, const float* y, const float* z, float* out_f) const override;
  bool has_interval() const override { return true; }
  render::Interval eval_interval(const render::Box& box, bool* maybe_nan) const override;
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f,
                     float* dx, float* dy, float* dz) const override;
  int num_attributes() const override { return model_.num_attributes(); }
  void eval_attributes(size_t n, const float* x, const float* y, const float* z,
                       float* out_s) const override;
  std::string explain_nan(render::Vec3 p) const override;

 private:
  const Model& model_;
  std::string file_;
  int dims_;
};

/// A view of a Field without its interval evaluator (has_interval() false; everything else
/// forwarded): the renderer then frames by sampling and neither culls nor bisects. For models
/// whose interval evaluator is the interpreter, too slow for the renderer's many calls.
class WithoutIntervals final : public render::Field {
 public:
  explicit WithoutIntervals(const render::Field& field) : field_(field) {}
  void eval(size_t n, const float* x, const float* y, const float* z, float* out_f) const override {
    field_.eval(n, x, y, z, out_f);
  }
  bool has_interval() const override { return false; }
  render::Interval eval_interval(const render::Box& box, bool* maybe_nan) const override {
    return field_.eval_interval(box, maybe_nan);
  }
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f,
                     float* dx, float* dy, float* dz) const override {
    field_.eval_gradient(n, x, y, z, f, dx, dy, dz);
  }
  int num_attributes() const override { return field_.num_attributes(); }
  void eval_attributes(size_t n, const float* x, const float* y, const float* z,
                       float* out_s) const override {
    field_.eval_attributes(n, x, y, z, out_s);
  }
  std::string explain_nan(render::Vec3 p) const override { return field_.explain_nan(p); }

 private:
  const render::Field& field_;
};

/// Options common to the commands that compile a model.
struct ModelRequest {
  std::string file;
  std::string object;
  std::string params;  ///< "v1,v2,..." for a[1..]
  std::string backend = "jit";
};

/// A compiled model ready for rendering, with its compile time.
struct LoadedModel {
  std::optional<Model> model;
  double compile_ms = 0;
};

/// Compiles the model and applies --object and -a. On failure prints the reason (diagnostics
/// for source errors) and returns nullopt with `*exit_code` = 1 (compile errors) or 2 (usage
/// or environment).
std::optional<LoadedModel> load_model(const ModelRequest& request, bool eager_f32, int* exit_code);

/// Compiles now (instead of on first use inside the render threads) the code a render needs
/// beyond the scalar f32 evaluator: the interval evaluator when `interval`, the f32 gradient
/// evaluator when `gradient`. The two JIT compiles run in parallel. Returns the wall time in
/// ms. A JIT failure is not fatal (the interpreters take over); it is printed as a warning.
double prepare_render_code(const Model& model, bool interval, bool gradient);

/// One line describing the engines of the interval and gradient domains with their compile
/// times, e.g. "interval JIT (4 lanes, 85.2 ms), gradient f32 JIT (8 lanes, 40.1 ms)".
std::string describe_domain_engines(const Model& model);

/// Parses "v1,v2,..." (exactly `count` numbers when count > 0). False when malformed.
bool parse_doubles(const std::string& text, std::vector<double>* out, size_t count = 0);
bool parse_floats(const std::string& text, std::vector<float>* out, size_t count = 0);

}  // namespace hfrt::tools
