#pragma once
// Field: how the renderer sees a model. The renderer never talks to the compiler or the JIT
// directly; app/ (app/model_field.h) adapts a compiled hfrt::Model to this interface, and tests
// implement it analytically (sphere, thin shell, torus). That keeps render/ free of LLVM and of
// jit/ internals, and testable against exact answers.
//
// Convention (HyperFun): the solid is F >= 0; F = 0 is the surface; F < 0 is outside. A point
// where F has no value (NaN: division by ~0, sqrt of a negative, ...) counts as outside.

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "base/interval.h"
#include "render/vec.h"

namespace hfrt::render {

/// The renderer's interval of F values: float bounds (lo, hi), filled by Field::eval_interval.
/// An evaluator that cannot bound F returns NaN ends; the renderer then treats the region as
/// "unknown" and subdivides it. (Whether F may be NaN travels separately, as `maybe_nan`.)
using Interval = BasicInterval<float>;

/// A program for F specialised to a box (a pruned tape, jit/tape.h), opaque to the renderer:
/// made and read only by the field's TapeEvaluator.
class FieldTape {
 public:
  virtual ~FieldTape() = default;
  /// Instructions the evaluator runs per point or box (statistics).
  virtual size_t length() const = 0;
};

/// The pruning evaluator of a field (Field::tape_evaluator): one per thread, with its own
/// scratch memory. The recursion of a renderer: eval_interval() over a box on the tape valid
/// there, prune_last() into the child tape for that box (shorter: every min/max the interval
/// decided is gone), recurse into sub-boxes with the child, eval() the points of a leaf.
class TapeEvaluator {
 public:
  virtual ~TapeEvaluator() = default;
  /// An empty tape for prune_last() to fill (its buffers are reused by later prunes).
  virtual std::unique_ptr<FieldTape> new_tape() = 0;
  /// As Field::eval_interval, on `tape` (the root tape or one pruned for a box containing
  /// `box`); remembers the decisions for prune_last().
  virtual Interval eval_interval(const FieldTape& tape, const Box& box, bool* maybe_nan) = 0;
  /// The child of `tape` for the box of the last eval_interval() call (which was on `tape`);
  /// false, with `child` unchanged, when the interval decided nothing (then `tape` itself
  /// is the box's tape).
  virtual bool prune_last(const FieldTape& tape, FieldTape* child) = 0;
  /// As Field::eval_intervals, on `tape`, for n boxes each inside the box `tape` was pruned
  /// for (the root tape: anywhere). Records no decisions: prune_last() refers to the last
  /// eval_interval() still.
  virtual void eval_intervals(const FieldTape& tape, size_t n, const Box* boxes, Interval* out,
                              bool* maybe_nan) {
    for (size_t i = 0; i < n; ++i) out[i] = eval_interval(tape, boxes[i], &maybe_nan[i]);
  }
  /// As Field::eval, on `tape` at points of the box it was pruned for.
  virtual void eval(const FieldTape& tape, size_t n, const float* x, const float* y, const float* z,
                    float* out_f) = 0;
};

/// The model as a function of a 3-D point. Implementations must be thread-safe: the renderer
/// calls every method concurrently from its worker threads (each call with its own buffers).
/// All batch methods take structure-of-arrays inputs of `n` points and never fail: a point
/// without a value yields NaN.
class Field {
 public:
  virtual ~Field() = default;

  /// F at n points.
  virtual void eval(size_t n, const float* x, const float* y, const float* z,
                    float* out_f) const = 0;

  /// Values with F's sign at n points (out_f[i] >= 0 where eval() gives F >= 0, NaN where it
  /// gives NaN; on a mesh or patch leaf's own surface, where F is 0, either side), for callers
  /// that only look at the side of a point: framing's samples. A field whose side is cheaper than
  /// its value overrides it (a mesh or patch leaf on a set-operation skeleton: a winding number
  /// instead of a distance query, see app::ModelField). The default is eval().
  virtual void eval_sides(size_t n, const float* x, const float* y, const float* z,
                          float* out_f) const {
    eval(n, x, y, z, out_f);
  }

  /// True when eval_interval() is available and sound (encloses F over the whole box) for
  /// this model. When false, eval_interval() is never called.
  virtual bool has_interval() const = 0;

  /// An interval enclosing F over every point of `box`. `*maybe_nan` is set to true when some
  /// point of the box may have no value (NaN); the renderer treats such points as outside,
  /// so a box with hi < 0 is empty even then.
  virtual Interval eval_interval(const Box& box, bool* maybe_nan) const = 0;

  /// eval_interval() of n boxes at once: out[i] and maybe_nan[i] for boxes[i], the same values.
  /// The renderer's searches batch their boxes, because the interval JIT evaluates a SIMD block
  /// of boxes for about the cost of one and the per-call cost is paid once.
  virtual void eval_intervals(size_t n, const Box* boxes, Interval* out, bool* maybe_nan) const {
    for (size_t i = 0; i < n; ++i) out[i] = eval_interval(boxes[i], &maybe_nan[i]);
  }

  /// F and its gradient at n points. The gradient points into the solid (F grows inside);
  /// the renderer uses -grad/|grad| as the outward surface normal.
  virtual void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f,
                             float* dx, float* dy, float* dz) const = 0;

  /// How many attributes s[1..k] the model computes (0 when the model has none). When k >= 3,
  /// s[1..3] are the RGB colour in [0, 1] of the surface point.
  virtual int num_attributes() const { return 0; }

  /// The attributes at n points, structure of arrays: out_s[i * n + j] is s[i+1] at point j.
  virtual void eval_attributes(size_t n, const float* x, const float* y, const float* z,
                               float* out_s) const {}

  /// Why F has no value at `p`, as one line of text (e.g. "division by zero at model.hf:3:7"),
  /// or "" when unknown. Called once per render, on the first NaN sample, to explain it.
  virtual std::string explain_nan(Vec3 p) const { return {}; }

  /// True when ray_candidates() is available: for any ray it lists a finite set of parameters
  /// that contains every crossing of F's zero set (analytic leaves of a set-operation
  /// skeleton). When false, ray_candidates() is never called.
  virtual bool has_ray_candidates() const { return false; }

  /// The whole program as a tape for TapeEvaluator, or null when the field has no pruning
  /// evaluator (then tape_evaluator() is never called). Its evaluations equal eval() and
  /// eval_interval() up to rounding: a pruned tape's value is the full tape's bit for bit in
  /// f64; in float it can differ only where rounding contradicts the f64 enclosure.
  virtual std::shared_ptr<const FieldTape> root_tape() const { return nullptr; }
  /// A new per-thread evaluator of this field's tapes.
  virtual std::unique_ptr<TapeEvaluator> tape_evaluator() const { return nullptr; }

  /// Appends to `out` (unsorted, may repeat) every candidate t in [t0, t1] for the ray o + t d:
  /// each parameter where F may change sign on the ray must be listed (to rounding).
  virtual void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const {}

  /// Prepares the ray_candidates() calls of n rays o[i] + t d[i], t in [t0[i], t1[i]], that
  /// follow on this thread in this order (some may be skipped), by tracing what they need
  /// together (the renderer: a tile's camera rays; a mesh leaf traces them in packets). Their
  /// results are the same with or without it. Replaces this thread's earlier preparation.
  virtual void prefetch_ray_candidates(const Vec3* o, const Vec3* d, const float* t0,
                                       const float* t1, size_t n) const {}
  /// Drops this thread's preparation (prefetch_ray_candidates) once its calls are done.
  virtual void clear_prefetched_ray_candidates() const {}
};

/// A view of another field: every call goes to `base` (the tape interface, root_tape() and
/// tape_evaluator(), excepted: a view that changes answers would no longer be what the tapes
/// equal). Views derive from it and override what they change (app::WithoutIntervals,
/// render::TapeRegions).
class FieldView : public Field {
 public:
  explicit FieldView(const Field& base) : base_(base) {}
  const Field& base() const { return base_; }

  void eval(size_t n, const float* x, const float* y, const float* z, float* out_f) const override {
    base_.eval(n, x, y, z, out_f);
  }
  void eval_sides(size_t n, const float* x, const float* y, const float* z,
                  float* out_f) const override {
    base_.eval_sides(n, x, y, z, out_f);
  }
  bool has_interval() const override { return base_.has_interval(); }
  Interval eval_interval(const Box& box, bool* maybe_nan) const override {
    return base_.eval_interval(box, maybe_nan);
  }
  void eval_intervals(size_t n, const Box* boxes, Interval* out, bool* maybe_nan) const override {
    base_.eval_intervals(n, boxes, out, maybe_nan);
  }
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f, float* dx,
                     float* dy, float* dz) const override {
    base_.eval_gradient(n, x, y, z, f, dx, dy, dz);
  }
  int num_attributes() const override { return base_.num_attributes(); }
  void eval_attributes(size_t n, const float* x, const float* y, const float* z,
                       float* out_s) const override {
    base_.eval_attributes(n, x, y, z, out_s);
  }
  std::string explain_nan(Vec3 p) const override { return base_.explain_nan(p); }
  bool has_ray_candidates() const override { return base_.has_ray_candidates(); }
  void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const override {
    base_.ray_candidates(o, d, t0, t1, out);
  }
  void prefetch_ray_candidates(const Vec3* o, const Vec3* d, const float* t0, const float* t1,
                               size_t n) const override {
    base_.prefetch_ray_candidates(o, d, t0, t1, n);
  }
  void clear_prefetched_ray_candidates() const override { base_.clear_prefetched_ray_candidates(); }

 private:
  const Field& base_;
};

}  // namespace hfrt::render
