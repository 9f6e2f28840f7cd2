// The embedding API (hfrt/model.h): front end -> lowering -> interpreter and/or LLVM JIT.

#include "hfrt/model.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <optional>

#include "base/check.h"
#include "base/file.h"
#include "base/limits.h"
#include "base/result.h"
#include "base/timer.h"
#include "geom/surface.h"
#include "ir/hoist_constants.h"
#include "ir/print.h"
#include "ir/structure_key.h"
#include "jit/driver.h"
#include "jit/engines.h"
#include "jit/gradient.h"
#include "jit/interpreter.h"
#include "jit/interval.h"
#include "jit/llvm_jit.h"
#include "jit/nvptx.h"
#include "jit/poly.h"
#include "jit/surface_ops.h"
#include "jit/tape.h"

namespace hfrt {

Limits to_limits(const ModelLimits& m) {
  Limits l;
  l.max_loop_iterations = m.max_loop_iterations;
  l.max_array_size = m.max_array_size;
  l.max_slots = m.max_slots;
  l.max_model_size = m.max_model_size;
  l.max_source_bytes = m.max_source_bytes;
  l.max_mesh_bytes = m.max_mesh_bytes;
  l.max_mesh_triangles = m.max_mesh_triangles;
  l.max_exact_curves = m.max_exact_curves;
  return l;
}

std::string check_model_limits(const ModelLimits& limits) {
  return check_limits(to_limits(limits));
}

namespace {

// The public defaults are the internal ones (base/limits.h keeps them for the layers below).
static_assert(ModelLimits{}.max_loop_iterations == Limits{}.max_loop_iterations);
static_assert(ModelLimits{}.max_array_size == Limits{}.max_array_size);
static_assert(ModelLimits{}.max_slots == Limits{}.max_slots);
static_assert(ModelLimits{}.max_model_size == Limits{}.max_model_size);
static_assert(ModelLimits{}.max_source_bytes == Limits{}.max_source_bytes);
static_assert(ModelLimits{}.max_mesh_bytes == Limits{}.max_mesh_bytes);
static_assert(ModelLimits{}.max_mesh_triangles == Limits{}.max_mesh_triangles);
static_assert(ModelLimits{}.max_exact_curves == Limits{}.max_exact_curves);

SourceDiagnostic convert(const lang::Diagnostic& d, const std::string& file) {
  SourceDiagnostic out;
  out.severity = d.severity == lang::Severity::kError     ? SourceDiagnostic::Severity::kError
                 : d.severity == lang::Severity::kWarning ? SourceDiagnostic::Severity::kWarning
                                                          : SourceDiagnostic::Severity::kNote;
  out.file = file;
  out.line = static_cast<int>(d.range.begin.line);
  out.col = static_cast<int>(d.range.begin.col);
  out.length = static_cast<int>(d.range.length);
  out.message = d.message;
  out.hint = d.hint;
  return out;
}

jit::Precision to_jit(Precision p) {
  return p == Precision::kF64 ? jit::Precision::kF64 : jit::Precision::kF32;
}

/// The parameters the code of `fn` is called with: its first `user_params` from `params` (0
/// where the user gave fewer), then the hoisted numbers `hoisted`; at least one.
std::vector<double> code_params(const jit::Function& fn, int user_params,
                                const std::vector<double>& params,
                                const std::vector<double>& hoisted) {
  const size_t n = static_cast<size_t>(std::max(fn.num_params, 1));
  const size_t user = static_cast<size_t>(user_params);
  std::vector<double> p(n, 0.0);
  for (size_t i = 0; i < user && i < params.size(); ++i) p[i] = params[i];
  for (size_t j = 0; j < hoisted.size() && user + j < n; ++j) p[user + j] = hoisted[j];
  return p;
}

/// One lowered object with its engines (jit/engines.h), shared read-only by the models
/// whose code it is (Model::share_code). The engines refer to fn, so it never moves.
struct Compiled {
  jit::Function fn;
  /// The object's own parameters a[]: fn.num_params less the hoisted numbers.
  int user_params = 0;
  /// The options that shape the code and fn's structure_key (Model::code_key).
  std::string key;
  /// The tapes of the interval and gradient engines (declared before them: it outlives them).
  std::optional<jit::TapeCache> tapes;
  std::optional<jit::ScalarEngine> scalar;
  std::optional<jit::IntervalEngine> interval;
  std::optional<jit::GradientEngine> gradient;
  std::optional<jit::PolyEngine> poly;
};

/// The size of the interval and gradient JIT code, in IR instructions, counting a dynamic
/// table or array access as one per element: those JITs expand such an access into a select
/// chain over every element (the scalar JIT indexes memory), and LLVM's code generation time
/// grows faster than linearly with the chains (lib_attributes.hf, 337 instructions with 30
/// noise-table loads, weight 62017: 45 s for the gradient JIT, over 100 s for the interval JIT).
int64_t domain_jit_weight(const jit::Function& fn) {
  int64_t weight = 0;
  for (const jit::Inst& in : fn.insts) {
    weight += 1;
    if (in.op == jit::Op::kTableLoad && in.aux >= 0 && size_t(in.aux) < fn.tables.size()) {
      weight += static_cast<int64_t>(fn.tables[in.aux].size());
    } else if (in.op == jit::Op::kLoadIdx || in.op == jit::Op::kStoreIdx) {
      weight += static_cast<int64_t>(in.imm);
    }
  }
  return weight;
}

}  // namespace

struct Model::Impl {
  ModelOptions options;
  std::shared_ptr<const lang::SourceFile> file;
  std::unique_ptr<lang::Program> program;
  std::vector<SourceDiagnostic> warnings;
  /// Shared by the models whose code it is (Model::share_code).
  std::shared_ptr<const Compiled> compiled;
  std::string object_name;
  std::vector<double> params;  ///< as set by the user
  /// The hoisted numbers of this model's source (ModelOptions::hoist_constants): parameters
  /// user_params + j of the code.
  std::vector<double> constants;
  bool shares_code = false;        ///< compiled is another model's (share_code)
  std::vector<double> params_f64;  ///< padded to num_params, then the hoisted numbers
  std::vector<float> params_f32;
  double time = 0;  ///< x[4] where the caller gives three coordinates (set_time)
  /// The polynomial domain's parameters (jit::poly_num_params): params_f64's first num_params,
  /// then x[4] = time and x[5..] = 0.
  std::vector<double> poly_args;
  ModelStats stats;

  void pad_params() {
    params_f64 = code_params(compiled->fn, compiled->user_params, params, constants);
    params_f32.assign(params_f64.begin(), params_f64.end());
    const jit::Function& fn = compiled->fn;
    poly_args.assign(size_t(std::max(jit::poly_num_params(fn), 1)), 0.0);
    std::copy(params_f64.begin(), params_f64.begin() + fn.num_params, poly_args.begin());
    if (fn.num_inputs > 3) poly_args[size_t(fn.num_params)] = time;
  }

  /// Makes a fresh Compiled of the lowered object `lowered` (its Function is moved in; JIT
  /// code per the eager options); its hoisted numbers go to `*hoisted`.
  std::unique_ptr<Compiled> build(jit::LoweredSource& lowered, std::string* error,
                                  std::vector<double>* hoisted) {
    auto c = std::make_unique<Compiled>();  // (the engines refer to c->fn: it never moves)
    c->fn = std::move(lowered.fn);
    stats.lower_ms = lowered.lower_ms;
    stats.ir_insts = static_cast<int>(c->fn.insts.size());
    c->user_params = c->fn.num_params;
    hoisted->clear();
    if (options.hoist_constants) *hoisted = jit::hoist_constants(&c->fn);
    const int64_t weight = domain_jit_weight(c->fn);
    stats.domain_jit_weight = weight;
    auto within = [&](int max_weight) { return max_weight < 0 || weight <= max_weight; };
    jit::EngineOptions eo;
    eo.use_jit = options.backend == Backend::kJit;
    eo.opt_level = options.opt_level;
    eo.lanes = options.lanes;
    eo.interval_lanes = options.interval_lanes;
    eo.interval_jit = eo.use_jit && within(options.interval_jit_max_insts);
    eo.gradient_jit = eo.use_jit && within(options.gradient_jit_max_insts);
    eo.background_interval_min_insts = options.background_interval_min_insts;
    eo.background_gradient_min_insts = options.background_gradient_min_insts;
    eo.background_point_min_insts = options.background_point_min_insts;
    c->tapes.emplace(c->fn);
    c->scalar.emplace(c->fn, eo, &*c->tapes);
    c->interval.emplace(c->fn, eo, &*c->tapes);
    c->gradient.emplace(c->fn, eo, &*c->tapes);
    c->poly.emplace(c->fn, eo);
    c->key = std::to_string(static_cast<int>(options.backend)) + ' ' +
             std::to_string(options.opt_level) + ' ' + std::to_string(options.lanes) + ' ' +
             std::to_string(options.interval_lanes) + ' ' + std::to_string(eo.interval_jit) +
             std::to_string(eo.gradient_jit) + '\n' + jit::structure_key(c->fn);
    if (eo.use_jit) {
      for (Precision p : {Precision::kF64, Precision::kF32}) {
        bool eager = p == Precision::kF64 ? options.eager_f64 : options.eager_f32;
        // A large object of exact arithmetic: its f32 code compiles in the background, the
        // tape VM answering with its bits meanwhile (ModelOptions::background_point_min_insts).
        // The tape's ops do not depend on the parameters: the hoisted numbers and zeros do.
        if (eager && p == Precision::kF32 &&
            c->scalar->compile_in_background_f32(
                code_params(c->fn, c->user_params, {}, *hoisted))) {
          continue;
        }
        if (eager && !c->scalar->code(to_jit(p))) {
          *error = c->scalar->error(to_jit(p));
          return nullptr;
        }
      }
    }
    return c;
  }
};

Model::Model(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Model::Model(Model&&) noexcept = default;
Model& Model::operator=(Model&&) noexcept = default;
Model::~Model() = default;

CompileResult Model::compile(std::string_view source, const ModelOptions& options,
                             std::string name) {
  CompileResult result;
  const Limits limits = to_limits(options.limits);
  if (std::string bad = check_limits(limits); !bad.empty()) {
    // Invalid options: an argument error, with no diagnostics.
    result.error = "ModelLimits::" + bad;
    return result;
  }
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->file = std::make_shared<const lang::SourceFile>(std::move(name), std::string(source));
  lang::DiagnosticSink sink(impl->file);
  jit::LoweredSource lowered = jit::compile_source(sink, options.object, limits);
  impl->stats.frontend_ms = lowered.frontend_ms;
  for (const lang::Diagnostic& d : sink.diagnostics()) {
    result.diagnostics.push_back(convert(d, impl->file->name()));
  }
  result.rendered = sink.render(false);
  if (!lowered.program) return result;
  impl->program = std::move(lowered.program);
  if (lowered.object < 0) {
    SourceDiagnostic d;
    d.file = impl->file->name();
    d.message = lowered.no_object;
    d.hint = lowered.no_object_hint;
    result.diagnostics.push_back(d);
    result.rendered += lang::render_brief(d.file, lang::Severity::kError, d.message, d.hint);
    return result;
  }
  if (!lowered.ok()) return result;
  impl->compiled = impl->build(lowered, &result.error, &impl->constants);
  if (!impl->compiled) return result;
  // The warnings of the lowering (the front end's are in CompileResult::diagnostics only).
  for (size_t i = lowered.frontend_diagnostics; i < result.diagnostics.size(); ++i) {
    impl->warnings.push_back(result.diagnostics[i]);
  }
  impl->object_name = impl->program->objects[lowered.object].name;
  impl->pad_params();
  result.model.emplace(Model(std::move(impl)));
  return result;
}

CompileResult Model::compile_file(const std::string& path, const ModelOptions& options) {
  // A pipe or a device is read too (a model may come from a process), up to the limit.
  Result<std::string> text = read_file_limited(path, options.limits.max_source_bytes,
                                               /*regular_only=*/false, "max_source_bytes");
  if (!text.ok()) {
    CompileResult r;
    r.error = text.error().message;
    if (!text.error().hint.empty()) r.error += " (" + text.error().hint + ")";
    return r;
  }
  return compile(text.value(), options, path);
}

std::vector<std::string> Model::object_names() const {
  std::vector<std::string> names;
  for (const lang::Object& o : impl_->program->objects) names.push_back(o.name);
  return names;
}

const std::string& Model::object_name() const {
  return impl_->object_name;
}

std::pair<int, int> Model::object_location() const {
  for (const lang::Object& o : impl_->program->objects) {
    if (o.name == impl_->object_name) {
      return {int(o.name_range.begin.line), int(o.name_range.begin.col)};
    }
  }
  return {0, 0};
}

bool Model::select_object(std::string_view name, std::string* error) {
  int index = impl_->program->find_object(name);
  if (index < 0) {
    if (error) *error = "no object named '" + std::string(name) + "'";
    return false;
  }
  std::string why;
  std::vector<SourceDiagnostic> warnings;
  std::vector<double> constants;
  lang::DiagnosticSink sink(impl_->file);
  jit::LoweredSource lowered;
  if (!jit::lower_into(*impl_->program, index, sink, &lowered, to_limits(impl_->options.limits))) {
    if (error) *error = sink.render(false);
    return false;
  }
  for (const lang::Diagnostic& d : sink.diagnostics()) {
    warnings.push_back(convert(d, impl_->file->name()));
  }
  auto compiled = impl_->build(lowered, &why, &constants);
  if (!compiled) {
    if (error) *error = why;
    return false;
  }
  impl_->compiled = std::move(compiled);  // frees the old object's code (its ResourceTrackers)
  impl_->constants = std::move(constants);
  impl_->shares_code = false;
  impl_->warnings = std::move(warnings);
  impl_->object_name = impl_->program->objects[index].name;
  impl_->pad_params();
  return true;
}

Backend Model::backend() const {
  return impl_->options.backend;
}
int Model::num_inputs() const {
  return impl_->compiled->fn.num_inputs;
}
int Model::num_params() const {
  return impl_->compiled->user_params;
}

const std::string& Model::code_key() const {
  return impl_->compiled->key;
}

bool Model::share_code(const Model& other) {
  if (impl_->compiled == other.impl_->compiled) return true;
  if (impl_->compiled->key != other.impl_->compiled->key) return false;
  impl_->compiled = other.impl_->compiled;
  impl_->shares_code = true;
  impl_->pad_params();
  return true;
}

bool Model::shares_code() const {
  return impl_->shares_code;
}
int Model::num_attributes() const {
  return static_cast<int>(impl_->compiled->fn.s_slots.size());
}

void Model::set_params(std::vector<double> a) {
  impl_->params = std::move(a);
  impl_->pad_params();
}
const std::vector<double>& Model::params() const {
  return impl_->params;
}

void Model::set_time(double t) {
  impl_->time = t;
  impl_->pad_params();
}
double Model::time() const {
  return impl_->time;
}

PointValue Model::eval(std::span<const double> x) const {
  const Compiled& c = *impl_->compiled;
  const int nx = c.fn.num_inputs;
  const size_t ns = c.fn.s_slots.size();
  PointValue out;
  auto explain = [&](const jit::EvalResult& r) {
    if (r.error) {
      out.error = std::string(jit::error_message(r.error->kind));
      out.error_line = static_cast<int>(r.error->loc.line);
      out.error_col = static_cast<int>(r.error->loc.col);
    }
  };
  const jit::JitFunction* code = c.scalar->code(jit::Precision::kF64);
  if (!code) {
    jit::EvalResult r = c.scalar->interpreter().eval(x, impl_->params_f64);
    out.f = r.value;
    out.s = r.s;
    explain(r);
    if (out.s.size() < ns) out.s.resize(ns, std::nan(""));
    return out;
  }
  std::vector<double> xs(static_cast<size_t>(std::max(nx, 1)), 0.0);
  for (int k = 0; k < nx && k < static_cast<int>(x.size()); ++k) xs[k] = x[k];
  out.s.assign(ns, 0.0);
  code->f64()(1, xs.data(), impl_->params_f64.data(), &out.f, ns ? out.s.data() : nullptr);
  if (std::isnan(out.f)) explain(c.scalar->interpreter().eval(x, impl_->params_f64));
  return out;
}

void Model::eval_batch(int64_t n, const double* xs, double* out_f, double* out_s) const {
  impl_->compiled->scalar->eval_batch(n, xs, impl_->params_f64, out_f, out_s);
}

void Model::eval_batch(int64_t n, const float* xs, float* out_f, float* out_s) const {
  impl_->compiled->scalar->eval_batch(n, xs, impl_->params_f32, impl_->params_f64, out_f, out_s);
}

void Model::eval_batch_sign(int64_t n, const float* xs, float* out_f) const {
  impl_->compiled->scalar->eval_batch_sign(n, xs, impl_->params_f32, impl_->params_f64, out_f);
}

bool Model::prepare(Precision precision, std::string* error) const {
  if (impl_->options.backend != Backend::kJit) return true;
  const jit::ScalarEngine& e = *impl_->compiled->scalar;
  if (e.code(to_jit(precision))) return true;
  if (error) *error = e.error(to_jit(precision));
  return false;
}

// --- Interval domain ------------------------------------------------------------------------

IntervalValue Model::eval_interval(std::span<const double> lo, std::span<const double> hi,
                                   std::vector<uint8_t>* choices) const {
  const Compiled& c = *impl_->compiled;
  const int nx = c.fn.num_inputs;
  // The box padded to the object's inputs (missing coordinates are the point 0), in
  // per-thread buffers, so that no call allocates.
  struct Scratch {
    std::vector<double> lo, hi;
  };
  thread_local Scratch sc;
  sc.lo.resize(static_cast<size_t>(std::max(nx, 1)));
  sc.hi.resize(sc.lo.size());
  for (int k = 0; k < nx; ++k) {
    double l = k < static_cast<int>(lo.size()) ? lo[k] : 0.0;
    double h = k < static_cast<int>(hi.size()) ? hi[k] : l;
    HFRT_CHECK_MSG(l <= h, "eval_interval: a box needs lo <= hi on every coordinate");
    sc.lo[k] = l;
    sc.hi[k] = h;
  }
  const Interval r = c.interval->eval(sc.lo, sc.hi, impl_->params_f64, choices);
  return {r.lo, r.hi, r.maybe_nan};
}

void Model::eval_interval_batch(int64_t n, const double* lo, const double* hi, double* out_lo,
                                double* out_hi, uint8_t* out_nan, uint8_t* choices) const {
  impl_->compiled->interval->eval_batch(n, lo, hi, impl_->params_f64, out_lo, out_hi, out_nan,
                                        choices);
}

DomainEngine Model::interval_engine() const {
  const jit::IntervalEngine& e = *impl_->compiled->interval;
  if (e.uses_jit()) return DomainEngine::kJit;
  return e.tape(impl_->params_f64) ? DomainEngine::kTapeVm : DomainEngine::kInterp;
}

bool Model::prepare_interval(std::string* error) const {
  const jit::IntervalEngine& e = *impl_->compiled->interval;
  if (!e.wants_jit() || e.code()) return true;
  if (error) *error = e.error();
  return false;
}

bool Model::start_interval_compile() const {
  return impl_->compiled->interval->compile_in_background(impl_->params_f64);
}

// --- Gradient domain ------------------------------------------------------------------------

GradientValue Model::eval_gradient(std::span<const double> x) const {
  const Compiled& c = *impl_->compiled;
  const int nx = c.fn.num_inputs;
  std::vector<double> p(static_cast<size_t>(std::max(nx, 1)), 0.0);
  for (int k = 0; k < nx && k < static_cast<int>(x.size()); ++k) p[k] = x[k];
  const jit::Dual d = c.gradient->eval(p, impl_->params_f64);
  GradientValue out;
  out.f = d.v;
  for (int k = 0; k < 3; ++k) out.d[k] = d.d[k];
  return out;
}

void Model::eval_gradient_batch(int64_t n, const double* xs, double* out) const {
  impl_->compiled->gradient->eval_batch(n, xs, impl_->params_f64, out);
}

void Model::eval_gradient_batch(int64_t n, const float* xs, float* out) const {
  impl_->compiled->gradient->eval_batch(n, xs, impl_->params_f64, out);
}

DomainEngine Model::gradient_engine(Precision precision) const {
  const jit::GradientEngine& e = *impl_->compiled->gradient;
  if (e.uses_jit(to_jit(precision))) return DomainEngine::kJit;
  return e.tape(to_jit(precision), impl_->params_f64) ? DomainEngine::kTapeVm
                                                      : DomainEngine::kInterp;
}

bool Model::start_point_compile() const {
  return impl_->compiled->scalar->compile_in_background_f32(impl_->params_f64);
}

bool Model::start_gradient_compile(Precision precision) const {
  return impl_->compiled->gradient->compile_in_background(to_jit(precision), impl_->params_f64);
}

bool Model::prepare_gradient(Precision precision, std::string* error) const {
  const jit::GradientEngine& e = *impl_->compiled->gradient;
  if (!e.wants_jit() || e.code(to_jit(precision))) return true;
  if (error) *error = e.error(to_jit(precision));
  return false;
}

// --- Polynomial domain ----------------------------------------------------------------------

AnalyticInfo Model::analytic_info() const {
  const jit::PolyAnalysis& p = impl_->compiled->poly->analysis();
  AnalyticInfo info;
  info.qualifies = p.qualifies;
  info.num_leaves = p.program.num_poly_leaves;
  info.num_surface_leaves = static_cast<int>(p.program.surfaces.size());
  info.max_degree = p.max_degree;
  info.reason = p.reason;
  info.line = static_cast<int>(p.loc.line);
  info.col = static_cast<int>(p.loc.col);
  return info;
}

namespace {
/// Every leaf of the polynomial program (the polynomial ones, then the surface leaves'
/// points) for one ray, into per-thread scratch.
const double* all_leaves(const Compiled& c, const std::vector<double>& a, const double o[3],
                         const double d[3]) {
  const jit::PolyAnalysis& p = c.poly->analysis();
  thread_local std::vector<double> scratch;
  scratch.resize(p.program.leaves.size() * jit::kPolyCoeffs + 1);
  c.poly->eval(o, d, a, scratch.data());
  return scratch.data();
}
}  // namespace

namespace {
/// A surface leaf's ray in the surface's own space, from the leaves' polynomials `all`
/// (all_leaves): false when it cannot be traced (not finite; a zero direction, where F is
/// constant on the ray).
bool leaf_ray(const double* all, const jit::PolySurfaceLeaf& s, geom::Ray* ray) {
  for (int k = 0; k < 3; ++k) {
    const double* coeffs = all + size_t(s.first_leaf + k) * jit::kPolyCoeffs;
    ray->org[k] = float(coeffs[0]);
    ray->dir[k] = float(coeffs[1]);
  }
  if (!is_finite(ray->org) || !is_finite(ray->dir)) return false;
  return !(ray->dir.x == 0 && ray->dir.y == 0 && ray->dir.z == 0);
}
}  // namespace

void Model::ray_polynomials(const double o[3], const double d[3], double* out) const {
  const Compiled& c = *impl_->compiled;
  const jit::PolyAnalysis& p = c.poly->analysis();
  HFRT_CHECK_MSG(p.qualifies, "ray_polynomials on an object that does not qualify: " << p.reason);
  if (p.program.surfaces.empty()) {
    c.poly->eval(o, d, impl_->poly_args, out);
    return;
  }
  // The surface leaves' points follow the polynomial leaves: the caller gets the latter only.
  const double* all = all_leaves(c, impl_->poly_args, o, d);
  std::copy(all, all + size_t(p.program.num_poly_leaves) * jit::kPolyCoeffs, out);
}

void Model::ray_surface_crossings(const double o[3], const double d[3], double t0, double t1,
                                  std::vector<double>* out) const {
  const Compiled& c = *impl_->compiled;
  const jit::PolyAnalysis& p = c.poly->analysis();
  HFRT_CHECK_MSG(p.qualifies, "ray_surface_crossings on an object that does not qualify");
  // The crossings also answer the sign queries that follow on this ray (jit/surface_ops.h).
  jit::ray_sides_clear();
  if (p.program.surfaces.empty() || !(t0 < t1)) return;
  const double* all = all_leaves(c, impl_->poly_args, o, d);
  thread_local std::vector<geom::Crossing> crossings;
  // Rays are traced in float: clamp an unbounded segment to what float holds.
  const float tmin = float(std::max(t0, -3e38)), tmax = float(std::min(t1, 3e38));
  for (const jit::PolySurfaceLeaf& s : p.program.surfaces) {
    geom::Ray ray;
    if (!leaf_ray(all, s, &ray)) continue;
    const geom::Surface& surface = *c.fn.surfaces[s.surface];
    jit::ray_sides_crossings(surface, ray, tmin, tmax, &crossings);
    for (const geom::Crossing& x : crossings) out->push_back(x.t);
  }
}

void Model::prefetch_ray_surface_crossings(const double* o, const double* d, const double* t0,
                                           const double* t1, size_t n) const {
  const Compiled& c = *impl_->compiled;
  const jit::PolyAnalysis& p = c.poly->analysis();
  HFRT_CHECK_MSG(p.qualifies, "prefetch_ray_surface_crossings on an object that does not qualify");
  thread_local std::vector<jit::PrefetchQuery> queries;
  queries.clear();
  if (!p.program.surfaces.empty()) {
    for (size_t i = 0; i < n; ++i) {
      // The rays, segments and filters of ray_surface_crossings, in its order.
      if (!(t0[i] < t1[i])) continue;
      const double* all = all_leaves(c, impl_->poly_args, o + 3 * i, d + 3 * i);
      const float tmin = float(std::max(t0[i], -3e38)), tmax = float(std::min(t1[i], 3e38));
      for (const jit::PolySurfaceLeaf& s : p.program.surfaces) {
        geom::Ray ray;
        if (leaf_ray(all, s, &ray))
          queries.push_back({&*c.fn.surfaces[s.surface], ray, tmin, tmax});
      }
    }
  }
  jit::ray_sides_prefetch(queries);
}

void Model::clear_prefetched_surface_crossings() {
  jit::ray_sides_prefetch_clear();
}

std::vector<OpenSurfaceLeaf> Model::open_surface_leaves() const {
  std::vector<OpenSurfaceLeaf> out;
  const Compiled& c = *impl_->compiled;
  const jit::PolyAnalysis& p = c.poly->analysis();
  if (!p.qualifies) return out;
  for (const jit::PolySurfaceLeaf& leaf : p.program.surfaces) {
    const geom::Surface& s = *c.fn.surfaces[leaf.surface];
    if (s.stats().patches > 0) continue;  // patches: never closed, by design
    const geom::SurfaceTopology topology = s.topology();
    if (topology.closed) continue;
    OpenSurfaceLeaf o;
    o.source = s.stats().source;
    o.boundary_edges = topology.boundary_edges;
    if (leaf.value < c.fn.insts.size()) {
      o.line = int(c.fn.insts[leaf.value].loc.line);
      o.col = int(c.fn.insts[leaf.value].loc.col);
    }
    out.push_back(std::move(o));
  }
  return out;
}

std::vector<SurfaceStats> Model::surface_stats() const {
  const jit::Function& fn = impl_->compiled->fn;
  std::vector<SurfaceStats> out;
  for (size_t i = 0; i < fn.surfaces.size(); ++i) {
    const geom::SurfaceStats st = fn.surfaces[i]->stats();
    SurfaceStats s;
    s.source = st.source;
    s.triangles = st.triangles;
    s.patches = st.patches;
    s.pieces = st.pieces;
    s.boundary_curves = st.boundary_curves;
    s.exact_field = st.exact_field;
    s.sealed_curves = st.sealed_curves;
    s.crack_gap = st.crack_gap;
    s.degenerate_skipped = st.degenerate_skipped;
    s.bvh_nodes = st.bvh_nodes;
    s.bvh_depth = st.bvh_depth;
    s.build_seconds = st.build_seconds;
    s.memory_bytes = st.memory_bytes;
    s.leaves = i < fn.surface_uses.size() ? fn.surface_uses[i] : 1;
    const geom::SurfaceTopology topology = fn.surfaces[i]->topology();
    s.closed = topology.closed;
    s.boundary_edges = topology.boundary_edges;
    out.push_back(std::move(s));
  }
  return out;
}

bool Model::prepare_polynomial(std::string* error) const {
  const jit::PolyEngine& e = *impl_->compiled->poly;
  if (!e.wants_jit() || !e.analysis().qualifies || e.code()) return true;
  if (error) *error = e.error();
  return false;
}

bool Model::device_ptx(std::string* ptx, std::string* error, const std::string& sm,
                       bool eval_only) const {
  jit::PtxOptions o;
  o.sm = sm;
  o.eval_only = eval_only;
  Result<std::string> r = jit::emit_ptx(impl_->compiled->fn, o);
  if (!r.ok()) {
    if (error) *error = r.error().message;
    return false;
  }
  *ptx = std::move(r).value();
  return true;
}

std::shared_ptr<const jit::HostKernels> Model::device_kernels_on_host(std::string* error) const {
  auto r = jit::HostKernels::compile(impl_->compiled->fn);
  if (!r.ok()) {
    if (error) *error = r.error().message;
    return nullptr;
  }
  return std::shared_ptr<const jit::HostKernels>(std::move(r).value());
}

std::vector<float> Model::code_params_f32() const {
  return impl_->params_f32;
}

std::shared_ptr<const jit::Tape> Model::tape(std::string* why) const {
  return jit::Tape::build(impl_->compiled->fn, impl_->params_f64, why);
}

std::string Model::ir_text() const {
  return ir::print(impl_->compiled->fn);
}

std::string Model::llvm_ir(Precision precision) const {
  if (impl_->options.backend != Backend::kJit) return "";
  return impl_->compiled->scalar->llvm_ir(to_jit(precision));
}

const std::vector<SourceDiagnostic>& Model::warnings() const {
  return impl_->warnings;
}

ModelStats Model::stats() const {
  ModelStats s = impl_->stats;
  const Compiled& c = *impl_->compiled;
  for (int k = 0; k < 2; ++k) {
    // Only report precisions already compiled (reading never compiles).
    const jit::JitFunction* code =
        c.scalar->peek(k == 0 ? jit::Precision::kF64 : jit::Precision::kF32);
    ModelStats::Jit& j = k == 0 ? s.jit_f64 : s.jit_f32;
    if (k == 1) j.background = c.scalar->background_f32();
    if (!code) continue;
    const jit::JitStats& js = code->stats();
    j.compiled = true;
    j.lanes = js.lanes;
    j.emit_ms = js.emit_ms;
    j.optimize_ms = js.optimize_ms;
    j.codegen_ms = js.codegen_ms;
    j.llvm_insts_before = js.llvm_insts_before;
    j.llvm_insts_after = js.llvm_insts_after;
    j.llvm_calls = js.llvm_calls;
    j.fast_codegen = js.fast_codegen;
  }
  auto domain = [](double compile_ms, int lanes, ModelStats::Domain* d) {
    d->compiled = true;
    d->lanes = lanes;
    d->compile_ms = compile_ms;
  };
  if (const jit::IntervalJit* code = c.interval->peek()) {
    domain(c.interval->compile_ms(), code->lanes(), &s.interval);
  }
  s.interval.background = c.interval->background();
  if (const jit::PolyJit* code = c.poly->peek()) {
    domain(c.poly->compile_ms(), code->lanes(), &s.polynomial);
  }
  if (const jit::GradientJit* code = c.gradient->peek(jit::Precision::kF64)) {
    domain(c.gradient->compile_ms(jit::Precision::kF64), code->lanes(), &s.gradient_f64);
  }
  if (const jit::GradientJit* code = c.gradient->peek(jit::Precision::kF32)) {
    domain(c.gradient->compile_ms(jit::Precision::kF32), code->lanes(), &s.gradient_f32);
  }
  s.gradient_f64.background = c.gradient->background(jit::Precision::kF64);
  s.gradient_f32.background = c.gradient->background(jit::Precision::kF32);
  return s;
}

}  // namespace hfrt
