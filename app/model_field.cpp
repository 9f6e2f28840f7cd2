#include "app/model_field.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <thread>

#include "base/timer.h"
#include "jit/tape.h"
#include "jit/tape_vm.h"
#include "render/poly_solve.h"

namespace hfrt::app {

namespace {

/// Per-thread packing buffers: the renderer calls from many threads at once.
struct Scratch {
  std::vector<float> xs, out;
};
thread_local Scratch t_scratch;

/// The float nearest to v on the side of -inf / +inf (so [down(lo), up(hi)] still encloses
/// [lo, hi] after the conversion to float).
/// (The neighbour is taken by its bits and selected without a branch: whether the conversion
/// rounded up or down is a coin toss per bound, and the renderer converts millions a frame.)
float round_down(double v) {
  float f = static_cast<float>(v);
  int32_t i = std::bit_cast<int32_t>(f);
  // The next float towards -inf: +-0 -> -denorm_min, +inf -> FLT_MAX (-inf is never taken).
  int32_t below = f == 0 ? int32_t(0x80000001u) : (i < 0 ? i + 1 : i - 1);
  int32_t take = -int32_t(static_cast<double>(f) > v);  // all ones or zero: no branch
  return std::bit_cast<float>((below & take) | (i & ~take));
}
float round_up(double v) {
  float f = static_cast<float>(v);
  int32_t i = std::bit_cast<int32_t>(f);
  // The next float towards +inf: +-0 -> denorm_min, -inf -> -FLT_MAX (+inf is never taken).
  int32_t above = f == 0 ? int32_t(1) : (i < 0 ? i - 1 : i + 1);
  int32_t take = -int32_t(static_cast<double>(f) < v);
  return std::bit_cast<float>((above & take) | (i & ~take));
}

/// The f64 enclosure rounded outwards to float bounds (NaN bounds for an unknown one).
/// Inline: the renderer converts millions of enclosures a frame.
inline render::Interval to_render_interval(const IntervalValue& r, bool* maybe_nan) {
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

/// `v` holds at least `size` elements; it never shrinks. (resize() to a call's own size
/// value-initialised the tail again whenever a larger call followed a smaller one: the
/// renderer's batches vary from one box or point to thousands, and the memsets were ~4 % of a
/// small model's render, callgrind of s3_blend.)
template <typename T>
T* at_least(std::vector<T>& v, size_t size) {
  if (v.size() < size) v.resize(size);
  return v.data();
}

/// Packs up to three coordinate arrays into the structure-of-arrays layout of the model
/// (x[1..3]; x[4] is the model's time, further coordinates are held at 0).
void pack(int dims, double time, size_t n, const float* x, const float* y, const float* z,
          std::vector<float>* xs) {
  const size_t rows = size_t(std::max(dims, 1));
  float* out = at_least(*xs, rows * n);
  const float* src[3] = {x, y, z};
  const size_t given = size_t(std::clamp(dims, 0, 3));
  for (size_t k = 0; k < given; ++k) std::copy(src[k], src[k] + n, out + k * n);
  if (dims > 3) std::fill_n(out + 3 * n, n, float(time));
  const size_t set = dims > 3 ? 4 : given;
  if (rows > set) std::fill(out + set * n, out + rows * n, 0.0f);
}

/// The points in the model's layout (eval_batch: x[k+1] of point i at xs[k n + i]): x itself
/// when the caller's arrays already are its rows, consecutive rows of n in one buffer (the
/// mesher's batches), and the model takes just x, y and z; otherwise packed into *xs. Why:
/// the copies were ~2 % of a 512^3 mesh.
const float* points_in_layout(int dims, double time, size_t n, const float* x, const float* y,
                              const float* z, std::vector<float>* xs) {
  if (dims == 3 && y == x + n && z == y + n) return x;
  pack(dims, time, n, x, y, z, xs);
  return xs->data();
}

/// A batch of boxes in the layout of the batched interval evaluators (Model's and the tape
/// VM's), and its enclosures converted back to the renderer's.
struct BoxBatch {
  std::vector<double> lo, hi, out_lo, out_hi;
  std::vector<uint8_t> out_nan;

  /// The boxes' bounds as `rows` structure-of-arrays rows of n: their first `coords`
  /// coordinates (x, y, z), then x[4] = `time` (a point) in row 3, any further rows 0. Sizes
  /// the enclosure arrays for n boxes.
  void pack(size_t n, const render::Box* boxes, size_t rows, size_t coords, double time) {
    double* const lo_all = at_least(lo, rows * n);
    double* const hi_all = at_least(hi, rows * n);
    for (size_t k = 0; k < coords; ++k) {
      double* l = lo_all + k * n;
      double* h = hi_all + k * n;
      for (size_t i = 0; i < n; ++i) {
        l[i] = boxes[i].lo[int(k)];
        h[i] = boxes[i].hi[int(k)];
      }
    }
    for (size_t k = coords; k < rows; ++k) {
      const double v = k == 3 ? time : 0.0;
      std::fill_n(lo_all + k * n, n, v);
      std::fill_n(hi_all + k * n, n, v);
    }
    at_least(out_lo, n);
    at_least(out_hi, n);
    at_least(out_nan, n);
  }

  /// The n enclosures rounded outwards to the renderer's float bounds.
  void unpack(size_t n, render::Interval* out, bool* maybe_nan) const {
    for (size_t i = 0; i < n; ++i) {
      // Field by field: a whole render::Interval built on the stack and copied out was read
      // back as one 8-byte load after two 4-byte stores, a store-forwarding stall per box (40 %
      // of this function's time in `perf annotate` of an s3_blend render).
      const render::Interval r =
          to_render_interval({out_lo[i], out_hi[i], out_nan[i] != 0}, &maybe_nan[i]);
      out[i].lo = r.lo;
      out[i].hi = r.hi;
      out[i].maybe_nan = r.maybe_nan;
    }
  }
};

}  // namespace

/// A jit::Tape as the renderer's opaque FieldTape.
struct ModelTape final : render::FieldTape {
  jit::Tape tape;
  size_t length() const override { return tape.length(); }
};

/// The tape VMs behind render::TapeEvaluator: x, y, z and x[4] = time as the tape's inputs.
class ModelTapeEvaluator final : public render::TapeEvaluator {
 public:
  ModelTapeEvaluator(int dims, double time) : dims_(dims), time_(time) {}

  std::unique_ptr<render::FieldTape> new_tape() override { return std::make_unique<ModelTape>(); }

  render::Interval eval_interval(const render::FieldTape& tape, const render::Box& box,
                                 bool* maybe_nan) override {
    // Float box corners are exact in double; the f64 enclosure is rounded outwards.
    const Interval in[4] = {{box.lo.x, box.hi.x, false},
                            {box.lo.y, box.hi.y, false},
                            {box.lo.z, box.hi.z, false},
                            Interval::point(time_)};
    const Interval r =
        vm_.eval_interval(static_cast<const ModelTape&>(tape).tape, {in, dims_ > 3 ? 4u : 3u});
    return to_render_interval({r.lo, r.hi, r.maybe_nan}, maybe_nan);
  }

  void eval_intervals(const render::FieldTape& tape, size_t n, const render::Box* boxes,
                      render::Interval* out, bool* maybe_nan) override {
    if (n == 0) return;
    // The tape's inputs: x, y, z (and the time, a point).
    const size_t k = dims_ > 3 ? 4 : 3;
    batch_.pack(n, boxes, k, 3, time_);
    const double *lo[4], *hi[4];
    for (size_t c = 0; c < k; ++c) {
      lo[c] = batch_.lo.data() + c * n;
      hi[c] = batch_.hi.data() + c * n;
    }
    vm_.eval_intervals(static_cast<const ModelTape&>(tape).tape, n, {lo, k}, {hi, k},
                       batch_.out_lo.data(), batch_.out_hi.data(), batch_.out_nan.data());
    batch_.unpack(n, out, maybe_nan);
  }

  bool prune_last(const render::FieldTape& tape, render::FieldTape* child) override {
    return vm_.prune_last(static_cast<const ModelTape&>(tape).tape,
                          &static_cast<ModelTape*>(child)->tape);
  }

  void eval(const render::FieldTape& tape, size_t n, const float* x, const float* y, const float* z,
            float* out_f) override {
    if (n == 0) return;
    const float* in[4] = {x, y, z, nullptr};
    size_t k = 3;
    if (dims_ > 3) {
      time_lanes_.assign(n, float(time_));
      in[3] = time_lanes_.data();
      k = 4;
    }
    vm_.eval<float>(static_cast<const ModelTape&>(tape).tape, n, {in, k}, out_f);
  }

 private:
  int dims_;
  double time_;
  jit::TapeVm vm_;
  std::vector<float> time_lanes_;
  BoxBatch batch_;
};

bool ModelField::prepare_tapes(std::string* why) {
  std::shared_ptr<const jit::Tape> tape = model_.tape(why);
  if (!tape) {
    root_tape_.reset();
    return false;
  }
  auto root = std::make_shared<ModelTape>();
  root->tape = *tape;
  root_tape_ = std::move(root);
  return true;
}

std::unique_ptr<render::TapeEvaluator> ModelField::tape_evaluator() const {
  if (!root_tape_) return nullptr;
  return std::make_unique<ModelTapeEvaluator>(dims_, model_.time());
}

ModelField::ModelField(const Model& model, std::string file)
    : model_(model),
      file_(std::move(file)),
      dims_(model.num_inputs()),
      analytic_(model.analytic_info()) {}

void ModelField::ray_candidates(render::Vec3 o, render::Vec3 d, float t0, float t1,
                                std::vector<double>* out) const {
  if (!analytic_.qualifies || !(t0 <= t1)) return;
  const int n = analytic_.num_leaves;
  thread_local std::vector<double> coeffs;
  coeffs.resize(size_t(n) * 5);
  const double od[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
  model_.ray_polynomials(od, dd, coeffs.data());
  const bool finite = std::isfinite(t0) && std::isfinite(t1);
  // t = mid + half s: the segment becomes s in [-1, 1]; p(t) = sum c_j (mid + half s)^j.
  const double mid = finite ? 0.5 * (double(t0) + double(t1)) : 0.0;
  const double half = finite ? std::max(0.5 * (double(t1) - double(t0)), 1e-30) : 1.0;
  const double slack = 1e-9;  // roots a rounding error outside the segment still count
  for (int i = 0; i < n; ++i) {
    const double* c = &coeffs[size_t(i) * 5];
    double s[5] = {c[0], c[1], c[2], c[3], c[4]};
    if (finite) {
      // Taylor shift to mid (Horner-like synthetic division), then scale by half^k.
      for (int k = 0; k < 5; ++k) {
        for (int j = 3; j >= k; --j) s[j] += mid * s[j + 1];
      }
      double h = 1;
      for (int k = 0; k < 5; ++k, h *= half) s[k] *= h;
    }
    double roots[4];
    const int count = render::solve_polynomial(s, roots);
    for (int r = 0; r < count; ++r) {
      if (finite) {
        if (roots[r] < -1 - slack || roots[r] > 1 + slack) continue;
        out->push_back(std::clamp(mid + half * roots[r], double(t0), double(t1)));
      } else if (roots[r] >= t0 && roots[r] <= t1) {
        out->push_back(roots[r]);
      }
    }
  }
  // Mesh and patch leaves: their crossings with the ray, traced in their own space.
  if (analytic_.num_surface_leaves > 0) model_.ray_surface_crossings(od, dd, t0, t1, out);
}

void ModelField::prefetch_ray_candidates(const render::Vec3* o, const render::Vec3* d,
                                         const float* t0, const float* t1, size_t n) const {
  if (!analytic_.qualifies || analytic_.num_surface_leaves == 0) return;
  // The same doubles as ray_candidates passes to Model::ray_surface_crossings.
  thread_local std::vector<double> od, dd, a, b;
  od.resize(3 * n), dd.resize(3 * n), a.resize(n), b.resize(n);
  for (size_t i = 0; i < n; ++i) {
    od[3 * i] = o[i].x, od[3 * i + 1] = o[i].y, od[3 * i + 2] = o[i].z;
    dd[3 * i] = d[i].x, dd[3 * i + 1] = d[i].y, dd[3 * i + 2] = d[i].z;
    a[i] = t0[i], b[i] = t1[i];
  }
  model_.prefetch_ray_surface_crossings(od.data(), dd.data(), a.data(), b.data(), n);
}

void ModelField::clear_prefetched_ray_candidates() const {
  if (analytic_.num_surface_leaves > 0) Model::clear_prefetched_surface_crossings();
}

void ModelField::eval(size_t n, const float* x, const float* y, const float* z,
                      float* out_f) const {
  if (n == 0) return;
  if (sign_only_) return eval_sides(n, x, y, z, out_f);
  Scratch& sc = t_scratch;
  model_.eval_batch(int64_t(n), points_in_layout(dims_, model_.time(), n, x, y, z, &sc.xs), out_f,
                    nullptr);
}

void ModelField::eval_sides(size_t n, const float* x, const float* y, const float* z,
                            float* out_f) const {
  if (n == 0) return;
  if (!(analytic_.qualifies && analytic_.num_surface_leaves > 0)) return eval(n, x, y, z, out_f);
  Scratch& sc = t_scratch;
  model_.eval_batch_sign(int64_t(n), points_in_layout(dims_, model_.time(), n, x, y, z, &sc.xs),
                         out_f);
}

render::Interval ModelField::eval_interval(const render::Box& box, bool* maybe_nan) const {
  // Float box corners are exact in double; the f64 enclosure is rounded outwards.
  // x[4] is the model's time: a point interval for a still frame.
  const double t = model_.time();
  const double lo[4] = {box.lo.x, box.lo.y, box.lo.z, t};
  const double hi[4] = {box.hi.x, box.hi.y, box.hi.z, t};
  const size_t k = dims_ > 3 ? 4 : 3;
  return to_render_interval(model_.eval_interval({lo, k}, {hi, k}), maybe_nan);
}

void ModelField::eval_intervals(size_t n, const render::Box* boxes, render::Interval* out,
                                bool* maybe_nan) const {
  if (n == 0) return;
  thread_local BoxBatch sc;
  // Structure of arrays over the model's coordinates; x[4] is the time (a point), any
  // further ones are held at 0.
  sc.pack(n, boxes, size_t(std::max(dims_, 1)), size_t(std::clamp(dims_, 0, 3)), model_.time());
  model_.eval_interval_batch(int64_t(n), sc.lo.data(), sc.hi.data(), sc.out_lo.data(),
                             sc.out_hi.data(), sc.out_nan.data());
  sc.unpack(n, out, maybe_nan);
}

void ModelField::eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f,
                               float* dx, float* dy, float* dz) const {
  if (n == 0) return;
  Scratch& sc = t_scratch;
  const float* xs = points_in_layout(dims_, model_.time(), n, x, y, z, &sc.xs);
  if (dx == f + n && dy == dx + n && dz == dy + n) {
    model_.eval_gradient_batch(int64_t(n), xs, f);  // the caller's arrays are its rows
    return;
  }
  const float* out = at_least(sc.out, 4 * n);
  model_.eval_gradient_batch(int64_t(n), xs, sc.out.data());
  std::copy(out, out + n, f);
  std::copy(out + n, out + 2 * n, dx);
  std::copy(out + 2 * n, out + 3 * n, dy);
  std::copy(out + 3 * n, out + 4 * n, dz);
}

void ModelField::eval_attributes(size_t n, const float* x, const float* y, const float* z,
                                 float* out_s) const {
  if (n == 0 || model_.num_attributes() == 0) return;
  Scratch& sc = t_scratch;
  pack(dims_, model_.time(), n, x, y, z, &sc.xs);
  std::vector<float> f(n);
  model_.eval_batch(int64_t(n), sc.xs.data(), f.data(), out_s);
}

std::string ModelField::explain_nan(render::Vec3 p) const {
  PointValue v = model_.eval({double(p.x), double(p.y), double(p.z), model_.time()});
  char where[160];
  std::snprintf(where, sizeof where, " (first at x=(%g, %g, %g))", p.x, p.y, p.z);
  if (v.ok()) return std::string("no value in single precision") + where;
  std::string text = v.error;
  if (v.error_line > 0) {
    text += " at " + file_ + ":" + std::to_string(v.error_line) + ":" + std::to_string(v.error_col);
  }
  return text + where;
}

PreparedCode prepare_render_code(const Model& model, bool interval, bool gradient) {
  const auto t0 = Clock::now();
  std::string errors[3];
  bool ok[3] = {true, true, true};
  {
    std::thread interval_worker, gradient_worker;
    // A large object's interval and gradient code compile in the background while the tape VM
    // answers with the same bits (Model::start_interval_compile, start_gradient_compile): the
    // render starts once the point code is ready, and each JIT takes over when it is.
    if (interval && !model.start_interval_compile())
      interval_worker = std::thread([&] { ok[1] = model.prepare_interval(&errors[1]); });
    if (gradient && !model.start_gradient_compile(Precision::kF32)) {
      gradient_worker =
          std::thread([&] { ok[2] = model.prepare_gradient(Precision::kF32, &errors[2]); });
    }
    // The same for the point code of a large object of exact arithmetic.
    if (!model.start_point_compile()) ok[0] = model.prepare(Precision::kF32, &errors[0]);
    if (interval_worker.joinable()) interval_worker.join();
    if (gradient_worker.joinable()) gradient_worker.join();
  }
  PreparedCode out;
  const char* what[3] = {"point", "interval", "gradient"};
  for (int i = 0; i < 3; ++i) {
    if (!ok[i]) {
      out.warnings.push_back(std::string("hfrt: warning: ") + what[i] + " JIT failed (" +
                             errors[i] + "); using the " + what[i] + " interpreter");
    }
  }
  out.ms = ms_since(t0);
  return out;
}

std::vector<std::string> background_compile_warnings(const Model& model) {
  const ModelStats st = model.stats();
  std::vector<std::string> out;
  auto add = [&](const char* what, bool background, DomainEngine engine) {
    if (!background || engine == DomainEngine::kJit) return;
    out.push_back(std::string("hfrt: warning: ") + what +
                  " JIT failed (compiled in the background); the tape VM answered instead");
  };
  add("interval", st.interval.background, model.interval_engine());
  add("gradient", st.gradient_f32.background, model.gradient_engine(Precision::kF32));
  return out;
}

std::string describe_domain_engines(const Model& model) {
  ModelStats st = model.stats();
  auto one = [&](const char* name, DomainEngine engine, const ModelStats::Domain& d) {
    char buf[160];
    if (engine == DomainEngine::kJit && d.compiled && model.shares_code()) {
      std::snprintf(buf, sizeof buf,
                    "%s JIT (%d lanes, shared: compiled for an earlier edit in %.1f ms)", name,
                    d.lanes, d.compile_ms);
    } else if (engine == DomainEngine::kJit && d.compiled && d.background) {
      std::snprintf(buf, sizeof buf,
                    "%s JIT (%d lanes, %.1f ms in the background, the tape VM until then)", name,
                    d.lanes, d.compile_ms);
    } else if (engine == DomainEngine::kJit && d.compiled) {
      std::snprintf(buf, sizeof buf, "%s JIT (%d lanes, %.1f ms)", name, d.lanes, d.compile_ms);
    } else if (engine == DomainEngine::kJit && d.background) {
      std::snprintf(buf, sizeof buf, "%s JIT (compiling in the background; the tape VM until then)",
                    name);
    } else if (engine == DomainEngine::kJit) {
      std::snprintf(buf, sizeof buf, "%s JIT (not compiled)", name);
    } else if (engine == DomainEngine::kTapeVm) {
      std::snprintf(buf, sizeof buf, "%s tape VM", name);
    } else {
      std::snprintf(buf, sizeof buf, "%s interpreter", name);
    }
    return std::string(buf);
  };
  std::string point;
  if (st.jit_f32.background) {
    // (Only when it was compiled in the background: otherwise the point code is the
    // "compile" figure's.)
    ModelStats::Domain d;
    d.compiled = st.jit_f32.compiled;
    d.lanes = st.jit_f32.lanes;
    d.compile_ms = st.jit_f32.emit_ms + st.jit_f32.optimize_ms + st.jit_f32.codegen_ms;
    d.background = true;
    point = one("point f32", DomainEngine::kJit, d) + ", ";
  }
  std::string out = point + one("interval", model.interval_engine(), st.interval) + ", " +
                    one("gradient f32", model.gradient_engine(Precision::kF32), st.gradient_f32);
  // The polynomial code of the analytic search (ModelField::prepare_render, before the render).
  if (st.polynomial.compiled) {
    char buf[96];
    std::snprintf(buf, sizeof buf, ", polynomial JIT (%.1f ms)", st.polynomial.compile_ms);
    out += buf;
  }
  return out;
}

std::vector<std::string> open_surface_warnings(const Model& model, const std::string& file) {
  std::vector<std::string> out;
  for (const OpenSurfaceLeaf& o : model.open_surface_leaves()) {
    std::string where = file;
    if (o.line > 0) where += ":" + std::to_string(o.line) + ":" + std::to_string(o.col);
    out.push_back(where + ": warning: the mesh '" + o.source + "' is not closed (" +
                  std::to_string(o.boundary_edges) +
                  " boundary edges): inside and outside come from a winding number at every ray "
                  "candidate (slower than from the ray's crossings)");
  }
  return out;
}

std::string describe_surfaces(const Model& model) {
  const std::vector<SurfaceStats> surfaces = model.surface_stats();
  if (surfaces.empty()) return "";
  std::string out;
  int leaves = 0, shared = 0;
  for (const SurfaceStats& s : surfaces) {
    char buf[512];
    // What the field is made of: a mesh's triangles, a patch set's tessellation, or (the
    // exact field) the patches' pieces and open borders.
    char what[256];
    if (s.patches > 0 && s.exact_field) {
      char sealed[96] = "";
      if (s.sealed_curves > 0)
        std::snprintf(sealed, sizeof sealed, ", %zu sealed in cracks up to %.2g wide",
                      s.sealed_curves, s.crack_gap);
      std::snprintf(what, sizeof what,
                    "%zu patches, %zu pieces, exact field (%zu open border curves%s, no "
                    "tessellation)",
                    s.patches, s.pieces, s.boundary_curves, sealed);
    } else if (s.patches > 0) {
      // Tessellated because the boundary has too many curves for the exact field
      // (PatchSurface::Options::max_exact_curves): say how many.
      char curves[96] = "";
      if (s.boundary_curves > 0)
        std::snprintf(curves, sizeof curves,
                      ", %zu open border curves (too many for the exact field)", s.boundary_curves);
      std::snprintf(what, sizeof what,
                    "%zu triangles (field tessellation), %zu patches, %zu pieces, %zu degenerate "
                    "skipped%s",
                    s.triangles, s.patches, s.pieces, s.degenerate_skipped, curves);
    } else {
      std::snprintf(what, sizeof what, "%zu triangles, %zu degenerate skipped", s.triangles,
                    s.degenerate_skipped);
    }
    std::snprintf(
        buf, sizeof buf,
        "  surface %s: %s, %zu BVH nodes (depth %d), built in %.1f ms, %.1f MiB, used by %d "
        "leaf%s%s\n",
        s.source.c_str(), what, s.bvh_nodes, s.bvh_depth, s.build_seconds * 1e3,
        double(s.memory_bytes) / (1 << 20), s.leaves, s.leaves == 1 ? "" : "s",
        s.patches > 0 ? ""
        : s.closed    ? ", closed"
                   : (", open: " + std::to_string(s.boundary_edges) + " boundary edges").c_str());
    out += buf;
    leaves += s.leaves;
    if (s.leaves > 1) shared += s.leaves - 1;
  }
  char buf[200];
  std::snprintf(buf, sizeof buf, "  surfaces: %zu loaded, %d leaves, %d shared instances\n",
                surfaces.size(), leaves, shared);
  return out + buf;
}

void ModelField::prepare_render(render::RootMode root) {
  if (root != render::RootMode::kAnalytic) return;
  model_.prepare_polynomial();
  set_sign_only_eval(true);
  if (sign_only_) {
    std::vector<float> origin(size_t(std::max(model_.num_inputs(), 1)), 0.0f);
    if (origin.size() > 3) origin[3] = float(model_.time());
    float f = 0;
    model_.eval_batch_sign(1, origin.data(), &f);
  }
}

}  // namespace hfrt::app
