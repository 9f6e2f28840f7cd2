// The C API (hfrt/hfrt.h) over the C++ API (hfrt/model.h, hfrt/render.h). Every entry point
// validates its arguments, runs inside guard() (no exception crosses into C) and records
// failures in the calling thread's LastError.

#include <cmath>
#include <cstddef>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <new>
#include <shared_mutex>
#include <string>
#include <utility>
#include <vector>

#include "hfrt/hfrt.h"
#include "hfrt/model.h"
#include "hfrt/render.h"

#ifndef HFRT_VERSION_STRING
#error "HFRT_VERSION_STRING must be defined by the build (capi/CMakeLists.txt)"
#endif

/// The handle: a compiled model, the lock that lets set_params run beside evaluations
/// (Model::set_params is not thread-safe by itself), and the strings the API hands out.
struct hfrt_model {
  explicit hfrt_model(hfrt::Model m) : model(std::move(m)) {}
  hfrt::Model model;
  mutable std::shared_mutex mutex;
  std::string file;
  std::vector<hfrt::SourceDiagnostic> warnings;
};

namespace {
/// The int a C enum field holds, read without loading it as the C++ enum type (which is
/// undefined for values outside the enumerators' range: C callers may store any int).
template <typename E>
int enum_bits(const E& field) {
  static_assert(sizeof(E) == sizeof(int));
  int v;
  std::memcpy(&v, &field, sizeof v);
  return v;
}
}  // namespace

namespace {

struct LastError {
  hfrt_status status = HFRT_OK;
  std::string message;
  std::string function;
  std::string file;
  int32_t line = 0, column = 0;
  std::vector<hfrt::SourceDiagnostic> diagnostics;
};

thread_local LastError t_error;

/// Records an error and returns its status.
hfrt_status fail(hfrt_status status, const char* function, std::string message,
                 std::string file = "", int32_t line = 0, int32_t column = 0) {
  LastError& e = t_error;
  e.status = status;
  e.function = function;
  e.message = std::move(message);
  e.file = file.empty() ? function : std::move(file);
  e.line = line;
  e.column = column;
  e.diagnostics.clear();
  return status;
}

/// An argument error: "function: message".
hfrt_status bad_arg(const char* function, const std::string& message) {
  return fail(HFRT_ERROR_INVALID_ARGUMENT, function, std::string(function) + ": " + message);
}

/// Runs `body` (which returns an hfrt_status), turning any exception into a status.
template <typename Body>
hfrt_status guard(const char* function, Body&& body) noexcept {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return fail(HFRT_ERROR_INTERNAL, function, std::string(function) + ": out of memory");
  } catch (const std::exception& e) {
    return fail(HFRT_ERROR_INTERNAL, function, std::string(function) + ": " + e.what());
  } catch (...) {
    return fail(HFRT_ERROR_INTERNAL, function, std::string(function) + ": unknown exception");
  }
}

void export_diagnostic(const hfrt::SourceDiagnostic& d, hfrt_diagnostic* out) {
  switch (d.severity) {
    case hfrt::SourceDiagnostic::Severity::kError:
      out->severity = HFRT_SEVERITY_ERROR;
      break;
    case hfrt::SourceDiagnostic::Severity::kWarning:
      out->severity = HFRT_SEVERITY_WARNING;
      break;
    case hfrt::SourceDiagnostic::Severity::kNote:
      out->severity = HFRT_SEVERITY_NOTE;
      break;
  }
  out->file = d.file.c_str();
  out->line = d.line;
  out->column = d.col;
  out->length = d.length;
  out->message = d.message.c_str();
  out->hint = d.hint.c_str();
}

/// Checks that a buffer of `len` elements holds `rows` * `n` values; "" when it does.
std::string check_len(const char* what, const void* ptr, int64_t len, int64_t rows, int64_t n) {
  if (rows > 0 && n > std::numeric_limits<int64_t>::max() / rows) {
    return std::string(what) + ": n = " + std::to_string(n) + " is too large";
  }
  const int64_t need = rows * n;
  if (need > 0 && ptr == nullptr) return std::string(what) + " is NULL";
  if (len < need) {
    return std::string(what) + " has " + std::to_string(len) + " elements, " +
           std::to_string(rows) + " x " + std::to_string(n) + " = " + std::to_string(need) +
           " are needed";
  }
  return "";
}

hfrt_status compile(const char* function, const std::string& source_or_path, bool is_file,
                    const char* name, const hfrt_compile_options* options, hfrt_model** out) {
  hfrt::ModelOptions mo;
  std::vector<double> params;
  if (options != nullptr) {
    // The fields up to `backend` are the first version's; the limits came later.
    if (options->struct_size < offsetof(hfrt_compile_options, max_loop_iterations)) {
      return bad_arg(function,
                     "options->struct_size is wrong (initialise with hfrt_compile_options_init)");
    }
    if (options->object != nullptr) mo.object = options->object;
    if (options->num_params < 0) return bad_arg(function, "options->num_params is negative");
    if (options->num_params > 0 && options->params == nullptr) {
      return bad_arg(function, "options->params is NULL but num_params > 0");
    }
    params.assign(options->params, options->params + options->num_params);
    // A C caller may store any int in an enum field; in C++ loading one outside the enum's
    // values is undefined (UBSan: "not a valid value"), so the field is read as its int.
    const int precision = enum_bits(options->precision);
    if (precision != HFRT_PRECISION_F64 && precision != HFRT_PRECISION_F32) {
      return bad_arg(function, "options->precision is not an hfrt_precision");
    }
    mo.eager_f64 = precision == HFRT_PRECISION_F64;
    mo.eager_f32 = precision == HFRT_PRECISION_F32;
    if (options->backend != HFRT_BACKEND_JIT && options->backend != HFRT_BACKEND_INTERP) {
      return bad_arg(function, "options->backend is not an hfrt_backend");
    }
    mo.backend =
        options->backend == HFRT_BACKEND_INTERP ? hfrt::Backend::kInterp : hfrt::Backend::kJit;
    if (options->struct_size >= offsetof(hfrt_compile_options, max_exact_curves)) {
      hfrt::ModelLimits& l = mo.limits;
      l.max_loop_iterations = options->max_loop_iterations;
      l.max_array_size = options->max_array_size;
      l.max_slots = options->max_slots;
      l.max_model_size = options->max_model_size;
      l.max_source_bytes = options->max_source_bytes;
      l.max_mesh_bytes = options->max_mesh_bytes;
      l.max_mesh_triangles = options->max_mesh_triangles;
      if (options->struct_size >= sizeof(hfrt_compile_options))
        l.max_exact_curves = options->max_exact_curves;
      const std::string bad = hfrt::check_model_limits(l);
      if (!bad.empty()) return bad_arg(function, "options->" + bad);
    }
  }
  hfrt::CompileResult r =
      is_file ? hfrt::Model::compile_file(source_or_path, mo)
              : hfrt::Model::compile(source_or_path, mo, name ? std::string(name) : "<input>");
  const std::string file = is_file ? source_or_path : (name ? name : "<input>");
  if (!r.ok()) {
    if (!r.error.empty()) {
      return fail(is_file && r.diagnostics.empty() ? HFRT_ERROR_IO : HFRT_ERROR_INTERNAL, function,
                  r.error, file);
    }
    // The first error diagnostic locates the failure.
    const hfrt::SourceDiagnostic* first = nullptr;
    for (const auto& d : r.diagnostics) {
      if (d.severity == hfrt::SourceDiagnostic::Severity::kError) {
        first = &d;
        break;
      }
    }
    hfrt_status status = HFRT_ERROR_COMPILE;
    // A missing object is reported by a diagnostic without a location (jit/model.cpp).
    if (first != nullptr && first->line == 0 && !mo.object.empty() &&
        &*first == &r.diagnostics.back()) {
      status = HFRT_ERROR_NO_OBJECT;
    }
    fail(status, function, r.rendered, first ? first->file : file, first ? first->line : 0,
         first ? first->col : 0);
    t_error.diagnostics = std::move(r.diagnostics);
    return status;
  }
  hfrt::Model& m = *r.model;
  if (int64_t(params.size()) > m.num_params()) {
    return bad_arg(function, "options->num_params = " + std::to_string(params.size()) +
                                 " but the object '" + m.object_name() + "' has a[" +
                                 std::to_string(m.num_params()) + "]");
  }
  if (!params.empty()) m.set_params(params);
  auto handle = std::make_unique<hfrt_model>(std::move(m));
  handle->file = file;
  handle->warnings = handle->model.warnings();
  *out = handle.release();
  return HFRT_OK;
}

/// The status of a render (hfrt::render_model, hfrt::render_scene_file), its error recorded;
/// `file` locates a source error.
hfrt_status render_status(const char* fn, const hfrt::RenderOutcome& r, const std::string& file) {
  switch (r.status) {
    case hfrt::RenderOutcome::Status::kOk:
      return HFRT_OK;
    case hfrt::RenderOutcome::Status::kInvalidSettings:
      return bad_arg(fn, r.error);
    case hfrt::RenderOutcome::Status::kSourceError:
      return fail(HFRT_ERROR_RENDER, fn, r.error, file);
    case hfrt::RenderOutcome::Status::kRenderError:
      break;
  }
  return fail(HFRT_ERROR_RENDER, fn, std::string(fn) + ": " + r.error);
}

}  // namespace

extern "C" {

const char* hfrt_version(void) {
  return HFRT_VERSION_STRING;
}

const char* hfrt_status_name(hfrt_status status) {
  switch (status) {
    case HFRT_OK:
      return "HFRT_OK";
    case HFRT_ERROR_INVALID_ARGUMENT:
      return "HFRT_ERROR_INVALID_ARGUMENT";
    case HFRT_ERROR_COMPILE:
      return "HFRT_ERROR_COMPILE";
    case HFRT_ERROR_IO:
      return "HFRT_ERROR_IO";
    case HFRT_ERROR_NO_OBJECT:
      return "HFRT_ERROR_NO_OBJECT";
    case HFRT_ERROR_RENDER:
      return "HFRT_ERROR_RENDER";
    case HFRT_ERROR_INTERNAL:
      return "HFRT_ERROR_INTERNAL";
  }
  return "HFRT_ERROR_UNKNOWN";
}

hfrt_status hfrt_last_error_status(void) {
  return t_error.status;
}

const char* hfrt_last_error_message(void) {
  return t_error.message.c_str();
}

void hfrt_last_error_location(const char** file, int32_t* line, int32_t* column) {
  if (file) *file = t_error.file.c_str();
  if (line) *line = t_error.line;
  if (column) *column = t_error.column;
}

const char* hfrt_last_error_function(void) {
  return t_error.function.c_str();
}

int32_t hfrt_last_error_diagnostic_count(void) {
  return int32_t(t_error.diagnostics.size());
}

hfrt_status hfrt_last_error_diagnostic(int32_t index, hfrt_diagnostic* out) {
  static const char* kFn = "hfrt_last_error_diagnostic";
  LastError& e = t_error;
  // A misuse of this call must not clobber the diagnostics being read: only the status,
  // message and function change.
  auto misuse = [&](std::string message) {
    e.status = HFRT_ERROR_INVALID_ARGUMENT;
    e.function = kFn;
    e.message = std::string(kFn) + ": " + message;
    return HFRT_ERROR_INVALID_ARGUMENT;
  };
  if (out == nullptr) return misuse("out is NULL");
  if (index < 0 || size_t(index) >= e.diagnostics.size()) {
    return misuse("index " + std::to_string(index) + " is out of range (0.." +
                  std::to_string(e.diagnostics.size()) + ")");
  }
  export_diagnostic(e.diagnostics[size_t(index)], out);
  return HFRT_OK;
}

void hfrt_compile_options_init(hfrt_compile_options* options) {
  if (options == nullptr) return;
  std::memset(options, 0, sizeof *options);
  options->struct_size = sizeof *options;
  options->precision = HFRT_PRECISION_F64;
  options->backend = HFRT_BACKEND_JIT;
  const hfrt::ModelLimits d;
  options->max_loop_iterations = d.max_loop_iterations;
  options->max_array_size = d.max_array_size;
  options->max_slots = d.max_slots;
  options->max_model_size = d.max_model_size;
  options->max_source_bytes = d.max_source_bytes;
  options->max_mesh_bytes = d.max_mesh_bytes;
  options->max_mesh_triangles = d.max_mesh_triangles;
  options->max_exact_curves = d.max_exact_curves;
}

hfrt_status hfrt_model_compile_source(const char* source, const char* name,
                                      const hfrt_compile_options* options, hfrt_model** out) {
  static const char* kFn = "hfrt_model_compile_source";
  return guard(kFn, [&]() -> hfrt_status {
    if (out == nullptr) return bad_arg(kFn, "out is NULL");
    *out = nullptr;
    if (source == nullptr) return bad_arg(kFn, "source is NULL");
    return compile(kFn, source, false, name, options, out);
  });
}

hfrt_status hfrt_model_compile_file(const char* path, const hfrt_compile_options* options,
                                    hfrt_model** out) {
  static const char* kFn = "hfrt_model_compile_file";
  return guard(kFn, [&]() -> hfrt_status {
    if (out == nullptr) return bad_arg(kFn, "out is NULL");
    *out = nullptr;
    if (path == nullptr) return bad_arg(kFn, "path is NULL");
    return compile(kFn, path, true, nullptr, options, out);
  });
}

void hfrt_model_free(hfrt_model* model) {
  delete model;
}

hfrt_status hfrt_model_info(const hfrt_model* model, int32_t* num_inputs, int32_t* num_params,
                            int32_t* num_attributes) {
  static const char* kFn = "hfrt_model_info";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (num_inputs) *num_inputs = model->model.num_inputs();
    if (num_params) *num_params = model->model.num_params();
    if (num_attributes) *num_attributes = model->model.num_attributes();
    return HFRT_OK;
  });
}

const char* hfrt_model_object_name(const hfrt_model* model) {
  return model ? model->model.object_name().c_str() : "";
}

int32_t hfrt_model_diagnostic_count(const hfrt_model* model) {
  return model ? int32_t(model->warnings.size()) : 0;
}

hfrt_status hfrt_model_diagnostic(const hfrt_model* model, int32_t index, hfrt_diagnostic* out) {
  static const char* kFn = "hfrt_model_diagnostic";
  if (model == nullptr) return bad_arg(kFn, "model is NULL");
  if (out == nullptr) return bad_arg(kFn, "out is NULL");
  if (index < 0 || size_t(index) >= model->warnings.size()) {
    return bad_arg(kFn, "index " + std::to_string(index) + " is out of range (0.." +
                            std::to_string(model->warnings.size()) + ")");
  }
  export_diagnostic(model->warnings[size_t(index)], out);
  return HFRT_OK;
}

hfrt_status hfrt_model_set_params(hfrt_model* model, const double* params, int32_t count) {
  static const char* kFn = "hfrt_model_set_params";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (count < 0) return bad_arg(kFn, "count is negative");
    if (count > 0 && params == nullptr) return bad_arg(kFn, "params is NULL but count > 0");
    if (count > model->model.num_params()) {
      return bad_arg(kFn, std::to_string(count) + " values for the object '" +
                              model->model.object_name() + "', which has a[" +
                              std::to_string(model->model.num_params()) + "]");
    }
    std::vector<double> a(params, params + count);
    std::unique_lock lock(model->mutex);
    model->model.set_params(std::move(a));
    return HFRT_OK;
  });
}

hfrt_status hfrt_model_set_time(hfrt_model* model, double time) {
  static const char* kFn = "hfrt_model_set_time";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (!std::isfinite(time)) return bad_arg(kFn, "time is not a finite number");
    std::unique_lock lock(model->mutex);
    model->model.set_time(time);
    return HFRT_OK;
  });
}

hfrt_status hfrt_model_eval_f64(const hfrt_model* model, int64_t n, const double* xs,
                                int64_t xs_len, double* out_f, int64_t f_len, double* out_s,
                                int64_t s_len) {
  static const char* kFn = "hfrt_model_eval_f64";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (n < 0) return bad_arg(kFn, "n is negative");
    const hfrt::Model& m = model->model;
    std::string bad = check_len("xs", xs, xs_len, m.num_inputs(), n);
    if (bad.empty()) bad = check_len("out_f", out_f, f_len, 1, n);
    if (bad.empty() && out_s) bad = check_len("out_s", out_s, s_len, m.num_attributes(), n);
    if (!bad.empty()) return bad_arg(kFn, bad);
    if (n == 0) return HFRT_OK;
    std::shared_lock lock(model->mutex);
    m.eval_batch(n, xs, out_f, m.num_attributes() > 0 ? out_s : nullptr);
    return HFRT_OK;
  });
}

hfrt_status hfrt_model_eval_f32(const hfrt_model* model, int64_t n, const float* xs, int64_t xs_len,
                                float* out_f, int64_t f_len, float* out_s, int64_t s_len) {
  static const char* kFn = "hfrt_model_eval_f32";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (n < 0) return bad_arg(kFn, "n is negative");
    const hfrt::Model& m = model->model;
    std::string bad = check_len("xs", xs, xs_len, m.num_inputs(), n);
    if (bad.empty()) bad = check_len("out_f", out_f, f_len, 1, n);
    if (bad.empty() && out_s) bad = check_len("out_s", out_s, s_len, m.num_attributes(), n);
    if (!bad.empty()) return bad_arg(kFn, bad);
    if (n == 0) return HFRT_OK;
    std::shared_lock lock(model->mutex);
    m.eval_batch(n, xs, out_f, m.num_attributes() > 0 ? out_s : nullptr);
    return HFRT_OK;
  });
}

hfrt_status hfrt_model_eval_interval(const hfrt_model* model, int64_t n, const double* lo,
                                     const double* hi, int64_t bounds_len, double* out_lo,
                                     double* out_hi, uint8_t* out_maybe_nan, int64_t out_len) {
  static const char* kFn = "hfrt_model_eval_interval";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (n < 0) return bad_arg(kFn, "n is negative");
    const hfrt::Model& m = model->model;
    const int k = m.num_inputs();
    std::string bad = check_len("lo", lo, bounds_len, k, n);
    if (bad.empty()) bad = check_len("hi", hi, bounds_len, k, n);
    if (bad.empty()) bad = check_len("out_lo", out_lo, out_len, 1, n);
    if (bad.empty()) bad = check_len("out_hi", out_hi, out_len, 1, n);
    if (!bad.empty()) return bad_arg(kFn, bad);
    for (int64_t j = 0; j < int64_t(k) * n; ++j) {
      if (!(lo[j] <= hi[j])) {  // also rejects NaN bounds
        return bad_arg(kFn, "box " + std::to_string(j % n) + ", coordinate " +
                                std::to_string(j / n + 1) + ": lo = " + std::to_string(lo[j]) +
                                " is not <= hi = " + std::to_string(hi[j]));
      }
    }
    if (n == 0) return HFRT_OK;
    std::vector<uint8_t> nan_scratch;
    if (out_maybe_nan == nullptr) {
      nan_scratch.resize(size_t(n));
      out_maybe_nan = nan_scratch.data();
    }
    std::shared_lock lock(model->mutex);
    m.eval_interval_batch(n, lo, hi, out_lo, out_hi, out_maybe_nan);
    return HFRT_OK;
  });
}

hfrt_status hfrt_model_gradient_f64(const hfrt_model* model, int64_t n, const double* xs,
                                    int64_t xs_len, double* out, int64_t out_len) {
  static const char* kFn = "hfrt_model_gradient_f64";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (n < 0) return bad_arg(kFn, "n is negative");
    const hfrt::Model& m = model->model;
    std::string bad = check_len("xs", xs, xs_len, m.num_inputs(), n);
    if (bad.empty()) bad = check_len("out", out, out_len, 4, n);
    if (!bad.empty()) return bad_arg(kFn, bad);
    if (n == 0) return HFRT_OK;
    std::shared_lock lock(model->mutex);
    m.eval_gradient_batch(n, xs, out);
    return HFRT_OK;
  });
}

void hfrt_render_options_init(hfrt_render_options* options) {
  if (options == nullptr) return;
  std::memset(options, 0, sizeof *options);
  const hfrt::RenderSettings d;
  options->struct_size = sizeof *options;
  options->width = d.width;
  options->height = d.height;
  options->up[1] = 1;
  for (int i = 0; i < 6; ++i) options->bbox[i] = d.bbox[size_t(i)];
  options->root = HFRT_ROOT_AUTO;
  options->spp = d.spp;
  options->threads = d.threads;
  options->shadows = d.shadows;
  for (int i = 0; i < 3; ++i) options->background[i] = d.background[size_t(i)];
}

hfrt_status hfrt_render_model(const hfrt_model* model, const hfrt_render_options* options,
                              float* rgba, int64_t rgba_len) {
  static const char* kFn = "hfrt_render_model";
  return guard(kFn, [&]() -> hfrt_status {
    if (model == nullptr) return bad_arg(kFn, "model is NULL");
    if (options == nullptr) return bad_arg(kFn, "options is NULL");
    if (options->struct_size < sizeof(hfrt_render_options)) {
      return bad_arg(kFn,
                     "options->struct_size is wrong (initialise with hfrt_render_options_init)");
    }
    if (rgba == nullptr) return bad_arg(kFn, "rgba is NULL");
    if (rgba_len < 0) return bad_arg(kFn, "rgba_len is negative");
    hfrt::RenderSettings s;
    s.width = options->width;
    s.height = options->height;
    auto v3 = [](const double* v) { return std::array<double, 3>{v[0], v[1], v[2]}; };
    if (options->has_eye) s.eye = v3(options->eye);
    if (options->has_look_at) s.look_at = v3(options->look_at);
    if (options->has_up) s.up = v3(options->up);
    if (options->fov_deg != 0) s.fov_deg = options->fov_deg;
    if (options->ortho_width != 0) s.ortho_width = options->ortho_width;
    for (int i = 0; i < 6; ++i) s.bbox[size_t(i)] = options->bbox[i];
    switch (enum_bits(options->root)) {  // any int a C caller stored (see enum_bits)
      case HFRT_ROOT_AUTO:
        s.root = hfrt::RootSearch::kAuto;
        break;
      case HFRT_ROOT_SIGN:
        s.root = hfrt::RootSearch::kSign;
        break;
      case HFRT_ROOT_INTERVAL:
        s.root = hfrt::RootSearch::kInterval;
        break;
      case HFRT_ROOT_ANALYTIC:
        s.root = hfrt::RootSearch::kAnalytic;
        break;
      default:
        return bad_arg(kFn, "options->root is not an hfrt_root_search");
    }
    s.spp = options->spp;
    s.threads = options->threads;
    s.shadows = options->shadows != 0;
    s.background = v3(options->background);
    std::shared_lock lock(model->mutex);
    hfrt::RenderOutcome r =
        hfrt::render_model(model->model, s, rgba, size_t(rgba_len), model->file);
    return render_status(kFn, r, model->file);
  });
}

hfrt_status hfrt_render_scene_file(const char* path, int32_t width, int32_t height, int32_t threads,
                                   float* rgba, int64_t rgba_len) {
  static const char* kFn = "hfrt_render_scene_file";
  return guard(kFn, [&]() -> hfrt_status {
    if (path == nullptr) return bad_arg(kFn, "path is NULL");
    if (rgba == nullptr) return bad_arg(kFn, "rgba is NULL");
    if (rgba_len < 0) return bad_arg(kFn, "rgba_len is negative");
    hfrt::RenderOutcome r =
        hfrt::render_scene_file(path, width, height, rgba, size_t(rgba_len), threads);
    return render_status(kFn, r, path);
  });
}

}  // extern "C"
