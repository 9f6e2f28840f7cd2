#pragma once
// The adapter from a compiled hfrt::Model (the public API, jit/include/hfrt/model.h) to the
// renderer's Field interface (render/field.h): app/ is the layer that joins the compiler and
// the renderer, below the command line and anything else that renders models.
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
#include "render/renderer.h"

namespace hfrt::app {

class ModelField final : public render::Field {
 public:
  /// `model` must outlive the field and must not be changed (object, params) while rendering.
  /// `file` names the model in explain_nan().
  ModelField(const Model& model, std::string file);

  void eval(size_t n, const float* x, const float* y, const float* z, float* out_f) const override;
  bool has_interval() const override { return true; }
  /// With mesh or patch leaves on a set-operation skeleton (analytic_info().qualifies), the
  /// sign-only code (Model::eval_batch_sign: +1/-1 per such leaf, a winding number instead of
  /// a distance query); otherwise eval(). Framing samples through it: examples/teapot.hf's
  /// framing took 0.56-0.68 s of closest-point searches, now 28 ms (the same frame).
  void eval_sides(size_t n, const float* x, const float* y, const float* z,
                  float* out_f) const override;
  render::Interval eval_interval(const render::Box& box, bool* maybe_nan) const override;
  void eval_intervals(size_t n, const render::Box* boxes, render::Interval* out,
                      bool* maybe_nan) const override;
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f, float* dx,
                     float* dy, float* dz) const override;
  int num_attributes() const override { return model_.num_attributes(); }
  void eval_attributes(size_t n, const float* x, const float* y, const float* z,
                       float* out_s) const override;
  std::string explain_nan(render::Vec3 p) const override;
  /// True when the model qualifies for analytic roots (Model::analytic_info()).
  bool has_ray_candidates() const override { return analytic_.qualifies; }
  /// The real roots in [t0, t1] of every leaf polynomial (Model::ray_polynomials), found by
  /// render::solve_polynomial after t is mapped to s in [-1, 1] over [t0, t1] (so that the
  /// solver sees coefficients of one scale, whatever the box size and distance), and the
  /// crossings of the mesh and patch leaves (Model::ray_surface_crossings).
  void ray_candidates(render::Vec3 o, render::Vec3 d, float t0, float t1,
                      std::vector<double>* out) const override;
  /// The mesh and patch leaves' crossings of the rays, traced together
  /// (Model::prefetch_ray_surface_crossings); nothing for models without such leaves.
  void prefetch_ray_candidates(const render::Vec3* o, const render::Vec3* d, const float* t0,
                               const float* t1, size_t n) const override;
  void clear_prefetched_ray_candidates() const override;
  /// The model's analysis, taken once at construction (why it does or does not qualify).
  const AnalyticInfo& analytic_info() const { return analytic_; }
  /// For a render with the analytic root search, which only looks at F's sign: eval() then
  /// uses Model::eval_batch_sign when the model has mesh or patch leaves on its skeleton
  /// (a winding number per leaf instead of a distance query). Set before rendering.
  void set_sign_only_eval(bool on) {
    sign_only_ = on && analytic_.qualifies && analytic_.num_surface_leaves > 0;
  }
  /// Builds the object's tape (jit/tape.h) for the pruning evaluator: root_tape() and
  /// tape_evaluator() then serve `hfrt slice`'s pruned recursion. False, with `why`, for
  /// objects without a tape (control flow, tables, meshes); they keep the other evaluators.
  /// Call before rendering, after the parameters are set.
  bool prepare_tapes(std::string* why = nullptr);
  std::shared_ptr<const render::FieldTape> root_tape() const override { return root_tape_; }
  std::unique_ptr<render::TapeEvaluator> tape_evaluator() const override;

  /// Before a render with `root` (as settled): for the analytic search, compiles the
  /// polynomial code now rather than inside the first worker's first ray, and switches eval()
  /// to the sign-only path (compiling it too, by one evaluation). Nothing for other methods.
  void prepare_render(render::RootMode root);

 private:
  const Model& model_;
  std::string file_;
  int dims_;
  AnalyticInfo analytic_;
  bool sign_only_ = false;
  std::shared_ptr<const render::FieldTape> root_tape_;
};

/// A view of a Field without its interval evaluator (has_interval() false; everything else
/// forwarded): the renderer then frames by sampling and neither culls nor bisects. For models
/// whose interval evaluator is the interpreter, too slow for the renderer's many calls.
class WithoutIntervals final : public render::FieldView {
 public:
  explicit WithoutIntervals(const render::Field& field) : render::FieldView(field) {}
  bool has_interval() const override { return false; }
};

/// Compiles now, on three threads at once (instead of on first use inside the render threads)
/// the three evaluators a render needs: f32 points, intervals and f32 gradients. After an
/// edit this is most of the compile latency, and the three LLVM compiles are independent (the
/// process-wide LLJIT takes modules from several threads). A JIT failure is not fatal (the
/// interpreters take over): each becomes a warning line ("hfrt: warning: interval JIT failed
/// (...); using the interval interpreter").
struct PreparedCode {
  double ms = 0;                      ///< wall time
  std::vector<std::string> warnings;  ///< one line each, without a newline
};
/// `interval` and `gradient` choose those domains (`hfrt slice` needs no gradients). The code
/// of large objects compiles in the background (Model::start_point_compile,
/// start_interval_compile, start_gradient_compile): the tape VM answers with the same bits.
PreparedCode prepare_render_code(const Model& model, bool interval = true, bool gradient = true);

/// The warnings for an interval or gradient JIT that failed in the background
/// (Model::start_interval_compile, start_gradient_compile; the tape VM answered instead), one
/// line each; empty when none did. Read after the work that used them.
std::vector<std::string> background_compile_warnings(const Model& model);

/// One line describing the engines of the interval and gradient domains with their compile
/// times, e.g. "interval JIT (4 lanes, 85.2 ms), gradient f32 JIT (8 lanes, 40.1 ms)".
std::string describe_domain_engines(const Model& model);

/// For a render with the analytic root search: one warning per mesh leaf whose mesh is not
/// closed (Model::open_surface_leaves), located at the leaf's call, e.g.
/// "m.hf:4:9: warning: the mesh 'cup.off' is not closed (12 boundary edges): inside and
/// outside come from a winding number at every ray candidate (slower than from the ray's
/// crossings)".
std::vector<std::string> open_surface_warnings(const Model& model, const std::string& file);

/// The mesh and patch surfaces of the model for --stats, one line each (triangles, patches,
/// BVH nodes, build time, memory, leaves sharing it) and a total; "" without surfaces.
std::string describe_surfaces(const Model& model);

}  // namespace hfrt::app
