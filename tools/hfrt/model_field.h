#pragma once
// The adapter from a compiled hfrt::Model (the public API, jit/include/hfrt/model.h) to the
// renderer's Field interface (render/field.h), plus the model loading and list parsing that
// `hfrt render` and `hfrt slice` share.
//
// FALLBACK, to be replaced: the public API does not expose the interval and gradient
// evaluators yet, so has_interval() is false (the renderer then uses the sign-change search
// and sampling for framing) and the gradient is taken by central differences of the f64
// scalar evaluator. When Model gains interval/gradient entry points, only this file changes.

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
  /// `gradient_step` is the central-difference step in world units.
  ModelField(const Model& model, std::string file, float gradient_step);

  void eval(size_t n, const float* x, const float* y, const float* z, float* out_f) const override;
  bool has_interval() const override { return false; }
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
  double h_;
  int dims_;
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

/// Parses "v1,v2,..." (exactly `count` numbers when count > 0). False when malformed.
bool parse_doubles(const std::string& text, std::vector<double>* out, size_t count = 0);
bool parse_floats(const std::string& text, std::vector<float>* out, size_t count = 0);

}  // namespace hfrt::tools
