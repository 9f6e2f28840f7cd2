// The embedding API (hfrt/model.h): front end -> lowering -> interpreter and/or LLVM JIT.

#include "hfrt/model.h"

#include <chrono>
#include <cmath>
#include <mutex>

#include "jit/interpreter.h"
#include "jit/llvm_jit.h"
#include "lang/check.h"
#include "lang/frontend.h"
#include "lang/result.h"
#include "jit/lower.h"

namespace hfrt {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

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

/// One lowered object with its evaluators. The JIT code of each precision is compiled at
/// most once, on first use (or eagerly), and then shared read-only by all threads.
struct Compiled {
  jit::Function fn;
  std::unique_ptr<jit::Interpreter> interp;
  int opt_level = 2;
  int lanes = 0;
  struct JitSlot {
    std::once_flag once;
    std::unique_ptr<jit::JitFunction> code;
    std::string error;
  };
  mutable JitSlot jit[2];

  const jit::JitFunction* get(Precision p) const {
    JitSlot& slot = jit[p == Precision::kF64 ? 0 : 1];
    std::call_once(slot.once, [&] {
      jit::JitOptions options;
      options.opt_level = opt_level;
      options.lanes = lanes;
      auto r = jit::JitFunction::compile(fn, to_jit(p), options);
      if (r.ok()) {
        slot.code = std::move(r.value());
      } else {
        slot.error = r.error().message;
      }
    });
    return slot.code.get();
  }
};

}  // namespace

struct Model::Impl {
  ModelOptions options;
  std::shared_ptr<const lang::SourceFile> file;
  std::unique_ptr<lang::Program> program;
  std::vector<SourceDiagnostic> warnings;
  std::unique_ptr<Compiled> compiled;
  std::string object_name;
  std::vector<double> params;      ///< as set by the user
  std::vector<double> params_f64;  ///< padded to num_params
  std::vector<float> params_f32;
  ModelStats stats;

  void pad_params() {
    size_t n = static_cast<size_t>(std::max(compiled->fn.num_params, 1));
    params_f64.assign(n, 0.0);
    for (size_t i = 0; i < n && i < params.size(); ++i) params_f64[i] = params[i];
    params_f32.assign(params_f64.begin(), params_f64.end());
  }

  /// Lowers object `index` into a fresh Compiled (JIT code per the eager options).
  std::unique_ptr<Compiled> build(int index, std::vector<SourceDiagnostic>* diags,
                                  std::string* rendered, std::string* error) {
    auto c = std::make_unique<Compiled>();
    c->opt_level = options.opt_level;
    c->lanes = options.lanes;
    lang::DiagnosticSink sink(file);
    auto t0 = std::chrono::steady_clock::now();
    c->fn = jit::lower_object(*program, index, &sink);
    stats.lower_ms = ms_since(t0);
    stats.ir_insts = static_cast<int>(c->fn.insts.size());
    for (const lang::Diagnostic& d : sink.diagnostics()) {
      if (diags) diags->push_back(convert(d, file->name()));
    }
    if (rendered && !sink.diagnostics().empty()) *rendered += sink.render(false);
    c->interp = std::make_unique<jit::Interpreter>(c->fn);
    if (options.backend == Backend::kJit) {
      for (Precision p : {Precision::kF64, Precision::kF32}) {
        bool eager = p == Precision::kF64 ? options.eager_f64 : options.eager_f32;
        if (eager && !c->get(p)) {
          *error = c->jit[p == Precision::kF64 ? 0 : 1].error;
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
  auto impl = std::make_unique<Impl>();
  impl->options = options;
  impl->file = std::make_shared<const lang::SourceFile>(std::move(name), std::string(source));
  lang::DiagnosticSink sink(impl->file);
  auto t0 = std::chrono::steady_clock::now();
  impl->program = lang::compile_source(impl->file, sink);
  impl->stats.frontend_ms = ms_since(t0);
  for (const lang::Diagnostic& d : sink.diagnostics()) {
    result.diagnostics.push_back(convert(d, impl->file->name()));
  }
  result.rendered = sink.render(false);
  if (!impl->program) return result;

  int index = options.object.empty() ? impl->program->default_object()
                                     : impl->program->find_object(options.object);
  if (index < 0) {
    SourceDiagnostic d;
    d.file = impl->file->name();
    d.message = options.object.empty() ? "the file defines no object"
                                       : "no object named '" + options.object + "' in the file";
    std::string names;
    for (const lang::Object& o : impl->program->objects) names += (names.empty() ? "" : ", ") + o.name;
    if (!names.empty()) d.hint = "the objects are: " + names;
    result.diagnostics.push_back(d);
    result.rendered += impl->file->name() + ": error: " + d.message +
                       (d.hint.empty() ? "" : "\n  hint: " + d.hint) + "\n";
    return result;
  }
  size_t before = result.diagnostics.size();
  impl->compiled = impl->build(index, &result.diagnostics, &result.rendered, &result.error);
  if (!impl->compiled) return result;
  for (size_t i = before; i < result.diagnostics.size(); ++i) {
    impl->warnings.push_back(result.diagnostics[i]);
  }
  impl->object_name = impl->program->objects[index].name;
  impl->pad_params();
  result.model.emplace(Model(std::move(impl)));
  return result;
}

CompileResult Model::compile_file(const std::string& path, const ModelOptions& options) {
  Result<std::string> text = read_file(path);
  if (!text.ok()) {
    CompileResult r;
    r.error = text.error().message;
    return r;
  }
  return compile(text.value(), options, path);
}

std::vector<std::string> Model::object_names() const {
  std::vector<std::string> names;
  for (const lang::Object& o : impl_->program->objects) names.push_back(o.name);
  return names;
}

const std::string& Model::object_name() const { return impl_->object_name; }

bool Model::select_object(std::string_view name, std::string* error) {
  int index = impl_->program->find_object(name);
  if (index < 0) {
    if (error) *error = "no object named '" + std::string(name) + "'";
    return false;
  }
  std::string why;
  std::vector<SourceDiagnostic> warnings;
  auto compiled = impl_->build(index, &warnings, nullptr, &why);
  if (!compiled) {
    if (error) *error = why;
    return false;
  }
  impl_->compiled = std::move(compiled);  // frees the old object's code (its ResourceTrackers)
  impl_->warnings = std::move(warnings);
  impl_->object_name = impl_->program->objects[index].name;
  impl_->pad_params();
  return true;
}

Backend Model::backend() const { return impl_->options.backend; }
int Model::num_inputs() const { return impl_->compiled->fn.num_inputs; }
int Model::num_params() const { return impl_->compiled->fn.num_params; }
int Model::num_attributes() const { return static_cast<int>(impl_->compiled->fn.s_slots.size()); }

void Model::set_params(std::vector<double> a) {
  impl_->params = std::move(a);
  impl_->pad_params();
}
const std::vector<double>& Model::params() const { return impl_->params; }

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
  const jit::JitFunction* code =
      impl_->options.backend == Backend::kJit ? c.get(Precision::kF64) : nullptr;
  if (!code) {
    jit::EvalResult r = c.interp->eval(x, impl_->params_f64);
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
  if (std::isnan(out.f)) explain(c.interp->eval(x, impl_->params_f64));
  return out;
}

namespace {
template <typename T>
void interp_batch(const Compiled& c, const std::vector<double>& a, int64_t n, const T* xs,
                  T* out_f, T* out_s) {
  const int nx = c.fn.num_inputs;
  std::vector<double> x(static_cast<size_t>(std::max(nx, 0)));
  for (int64_t i = 0; i < n; ++i) {
    for (int k = 0; k < nx; ++k) x[k] = static_cast<double>(xs[k * n + i]);
    jit::EvalResult r = c.interp->eval(x, a);
    out_f[i] = static_cast<T>(r.value);
    if (out_s) {
      for (size_t k = 0; k < c.fn.s_slots.size(); ++k) {
        double v = r.error ? std::nan("") : (k < r.s.size() ? r.s[k] : std::nan(""));
        out_s[k * n + i] = static_cast<T>(v);
      }
    }
  }
}
}  // namespace

void Model::eval_batch(int64_t n, const double* xs, double* out_f, double* out_s) const {
  const Compiled& c = *impl_->compiled;
  const jit::JitFunction* code =
      impl_->options.backend == Backend::kJit ? c.get(Precision::kF64) : nullptr;
  if (code) {
    code->f64()(n, xs, impl_->params_f64.data(), out_f, out_s);
  } else {
    interp_batch(c, impl_->params_f64, n, xs, out_f, out_s);
  }
}

void Model::eval_batch(int64_t n, const float* xs, float* out_f, float* out_s) const {
  const Compiled& c = *impl_->compiled;
  const jit::JitFunction* code =
      impl_->options.backend == Backend::kJit ? c.get(Precision::kF32) : nullptr;
  if (code) {
    code->f32()(n, xs, impl_->params_f32.data(), out_f, out_s);
  } else {
    interp_batch(c, impl_->params_f64, n, xs, out_f, out_s);
  }
}

bool Model::prepare(Precision precision, std::string* error) const {
  if (impl_->options.backend != Backend::kJit) return true;
  const Compiled& c = *impl_->compiled;
  if (c.get(precision)) return true;
  if (error) *error = c.jit[precision == Precision::kF64 ? 0 : 1].error;
  return false;
}

std::string Model::ir_text() const { return jit::print(impl_->compiled->fn); }

std::string Model::llvm_ir(Precision precision) const {
  if (impl_->options.backend != Backend::kJit) return "";
  const jit::JitFunction* code = impl_->compiled->get(precision);
  return code ? code->llvm_ir() : "";
}

const std::vector<SourceDiagnostic>& Model::warnings() const { return impl_->warnings; }

ModelStats Model::stats() const {
  ModelStats s = impl_->stats;
  const Compiled& c = *impl_->compiled;
  for (int k = 0; k < 2; ++k) {
    // Only report precisions already compiled (reading the slot never compiles).
    const jit::JitFunction* code = c.jit[k].code.get();
    ModelStats::Jit& j = k == 0 ? s.jit_f64 : s.jit_f32;
    if (!code) continue;
    const jit::JitStats& js = code->stats();
    j.compiled = true;
    j.lanes = js.lanes;
    j.emit_ms = js.emit_ms;
    j.optimize_ms = js.optimize_ms;
    j.codegen_ms = js.codegen_ms;
    j.llvm_insts_before = js.llvm_insts_before;
    j.llvm_insts_after = js.llvm_insts_after;
  }
  return s;
}

}  // namespace hfrt
