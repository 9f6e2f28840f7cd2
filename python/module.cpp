// The `hfrt._hfrt` extension module: hfrt::Model (hfrt/model.h) and hfrt::render_model
// (hfrt/render.h) for Python with NumPy arrays. python/hfrt/__init__.py is the public face
// (hfrt.Model, hfrt.render, hfrt.CompileError); this file only binds.
//
// Arrays: points are (n, k) arrays of float64 or float32 (other dtypes are converted to
// float64). The evaluators take structures of arrays; an F-contiguous (n, k) array is one and
// is passed as it is; any other layout (the usual C-contiguous one) is read in blocks of
// kBlock points into a small per-call buffer, never copied as a whole. Results are new arrays
// of the input's precision. The GIL is released while hfrt computes.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <string>
#include <vector>

#include "hfrt/model.h"
#include "hfrt/render.h"

namespace py = pybind11;

namespace hfrt::python {
namespace {

constexpr py::ssize_t kBlock = 2048;

py::object g_compile_error;  // hfrt.CompileError, registered by __init__.py

/// A compiled model with the lock that lets set_params run beside evaluations in other
/// threads (Model::set_params is not thread-safe by itself).
struct PyModel {
  std::optional<Model> model;
  mutable std::shared_mutex mutex;
  std::string file;
  std::vector<SourceDiagnostic> warnings;

  const Model& m() const { return *model; }
};

py::dict diagnostic_dict(const SourceDiagnostic& d) {
  py::dict out;
  const char* sev = d.severity == SourceDiagnostic::Severity::kError     ? "error"
                    : d.severity == SourceDiagnostic::Severity::kWarning ? "warning"
                                                                         : "note";
  out["severity"] = sev;
  out["file"] = d.file;
  out["line"] = d.line;
  out["column"] = d.col;
  out["length"] = d.length;
  out["message"] = d.message;
  out["hint"] = d.hint;
  return out;
}

[[noreturn]] void raise_compile_error(const CompileResult& r) {
  py::list diags;
  for (const auto& d : r.diagnostics) diags.append(diagnostic_dict(d));
  py::object err = g_compile_error(r.rendered, diags);
  PyErr_SetObject(g_compile_error.ptr(), err.ptr());
  throw py::error_already_set();
}

std::shared_ptr<PyModel> compile(const std::string& text, bool is_file, const std::string& name,
                                 const std::string& object, const std::vector<double>& params,
                                 const std::string& backend, const std::string& precision,
                                 const std::map<std::string, int64_t>& limits) {
  ModelOptions mo;
  mo.object = object;
  // The limits on hostile input (docs/limits.md), by the names of ModelLimits' fields.
  const std::map<std::string, int64_t ModelLimits::*> fields = {
      {"max_loop_iterations", &ModelLimits::max_loop_iterations},
      {"max_array_size", &ModelLimits::max_array_size},
      {"max_slots", &ModelLimits::max_slots},
      {"max_model_size", &ModelLimits::max_model_size},
      {"max_source_bytes", &ModelLimits::max_source_bytes},
      {"max_mesh_bytes", &ModelLimits::max_mesh_bytes},
      {"max_mesh_triangles", &ModelLimits::max_mesh_triangles},
      {"max_exact_curves", &ModelLimits::max_exact_curves}};
  for (const auto& [key, value] : limits) {
    auto it = fields.find(key);
    if (it == fields.end()) throw py::type_error("unknown limit '" + key + "'");
    mo.limits.*(it->second) = value;
  }
  if (backend == "jit") {
    mo.backend = Backend::kJit;
  } else if (backend == "interp") {
    mo.backend = Backend::kInterp;
  } else {
    throw py::value_error("backend must be 'jit' or 'interp' (got '" + backend + "')");
  }
  if (precision == "f64") {
    mo.eager_f64 = true;
  } else if (precision == "f32") {
    mo.eager_f64 = false;
    mo.eager_f32 = true;
  } else {
    throw py::value_error("precision must be 'f64' or 'f32' (got '" + precision + "')");
  }
  CompileResult r;
  {
    py::gil_scoped_release release;
    r = is_file ? Model::compile_file(text, mo) : Model::compile(text, mo, name);
  }
  if (!r.ok()) {
    if (!r.error.empty()) {
      if (r.error.rfind("ModelLimits::", 0) == 0) throw py::value_error(r.error);
      if (is_file && r.diagnostics.empty()) {
        PyErr_SetString(PyExc_FileNotFoundError, r.error.c_str());
        throw py::error_already_set();
      }
      throw std::runtime_error(r.error);
    }
    raise_compile_error(r);
  }
  if (params.size() > size_t(r.model->num_params())) {
    throw py::value_error("params has " + std::to_string(params.size()) +
                          " values but the object '" + r.model->object_name() + "' has a[" +
                          std::to_string(r.model->num_params()) + "]");
  }
  auto out = std::make_shared<PyModel>();
  out->model.emplace(std::move(*r.model));
  if (!params.empty()) out->model->set_params(params);
  out->file = is_file ? text : name;
  out->warnings = out->model->warnings();
  return out;
}

/// The (n, k) view of `points` for a model with `k` inputs: a 2-D array with k columns, or a
/// 1-D array of k values (one point). Throws ValueError otherwise.
py::ssize_t check_points(const py::array& points, int k, const char* what, bool* single) {
  *single = points.ndim() == 1;
  if (points.ndim() == 1) {
    if (points.shape(0) != k) {
      throw py::value_error(std::string(what) + " has " + std::to_string(points.shape(0)) +
                            " values but the model takes x[" + std::to_string(k) + "]");
    }
    return 1;
  }
  if (points.ndim() != 2) {
    throw py::value_error(std::string(what) + " must be an (n, " + std::to_string(k) +
                          ") array (got " + std::to_string(points.ndim()) + " dimensions)");
  }
  if (points.shape(1) != k) {
    throw py::value_error(std::string(what) + " has " + std::to_string(points.shape(1)) +
                          " columns but the model takes x[" + std::to_string(k) + "]");
  }
  return points.shape(0);
}

/// Feeds an (n, k) array of T to `eval(m, xs_soa, first)` block by block (or all at once when
/// the array is already a structure of arrays). `eval` gets the block length, the SoA
/// coordinates and the first point's index.
template <typename T, typename Eval>
void for_blocks(const py::array_t<T>& a, py::ssize_t n, int k, bool single, Eval&& eval) {
  if (n == 0) return;
  const T* base = a.data();
  const py::ssize_t s0 = single ? 0 : a.strides(0) / py::ssize_t(sizeof(T));
  const py::ssize_t s1 =
      single ? a.strides(0) / py::ssize_t(sizeof(T)) : a.strides(1) / py::ssize_t(sizeof(T));
  if (k == 0 || (s0 == 1 && (k == 1 || s1 == n))) {  // SoA already (F-contiguous)
    eval(n, base, py::ssize_t(0));
    return;
  }
  std::vector<T> buf(size_t(kBlock) * size_t(k));
  for (py::ssize_t start = 0; start < n; start += kBlock) {
    const py::ssize_t m = std::min(kBlock, n - start);
    // One sequential pass over the rows (the input is read once, in memory order; the
    // block's k columns stay in L1/L2 for the evaluator).
    const T* src = base + start * s0;
    T* dst = buf.data();
    if (k == 3 && s1 == 1) {
      T* dy = dst + m;
      T* dz = dy + m;
      for (py::ssize_t i = 0; i < m; ++i, src += s0) {
        dst[i] = src[0];
        dy[i] = src[1];
        dz[i] = src[2];
      }
    } else {
      for (py::ssize_t i = 0; i < m; ++i, src += s0) {
        for (int c = 0; c < k; ++c) dst[size_t(c) * size_t(m) + size_t(i)] = src[c * s1];
      }
    }
    eval(m, buf.data(), start);
  }
}

/// Scatters an SoA block (rows x m, row-major) into the (n, rows) C-contiguous `out` at row
/// `start`.
template <typename T>
void scatter(const T* soa, py::ssize_t m, int rows, T* out, py::ssize_t start) {
  for (int c = 0; c < rows; ++c) {
    for (py::ssize_t i = 0; i < m; ++i) out[(start + i) * rows + c] = soa[c * m + i];
  }
}

/// The `out=` array of eval: a writable, C-contiguous 1-D array of n values of the points'
/// dtype, used as it is (no copy, no allocation: a caller that evaluates many batches reuses
/// one buffer and skips the page faults of a fresh array). A TypeError or ValueError otherwise.
template <typename T>
py::array_t<T> out_array(const py::object& out, py::ssize_t n) {
  if (!py::isinstance<py::array>(out)) throw py::type_error("eval: out must be a NumPy array");
  py::array a = py::reinterpret_borrow<py::array>(out);
  if (!a.dtype().is(py::dtype::of<T>())) {
    throw py::type_error(std::string("eval: out must have the points' dtype (") +
                         (sizeof(T) == 4 ? "float32" : "float64") + ")");
  }
  if (a.ndim() != 1 || a.shape(0) != n) {
    throw py::value_error("eval: out must have shape (" + std::to_string(n) + ",)");
  }
  if (!(a.flags() & py::array::c_style) || !a.writeable()) {
    throw py::value_error("eval: out must be contiguous and writable");
  }
  return py::reinterpret_borrow<py::array_t<T>>(a);
}

template <typename T>
py::object eval_typed(const PyModel& pm, const py::array& points, bool attributes,
                      const py::object& out) {
  const Model& m = pm.m();
  const int k = m.num_inputs();
  const int ns = m.num_attributes();
  bool single = false;
  const py::ssize_t n = check_points(points, k, "points", &single);
  auto a = py::array_t<T>::ensure(points);  // same dtype: no copy
  if (!out.is_none() && single) throw py::value_error("eval: out is for arrays of points");
  py::array_t<T> f = out.is_none() ? py::array_t<T>(n) : out_array<T>(out, n);
  // The attributes' array only when they are asked for (it is ns times the size of f).
  py::array_t<T> s({attributes ? n : py::ssize_t(0), py::ssize_t(ns)});
  T* fp = f.mutable_data();
  T* sp = s.mutable_data();
  {
    py::gil_scoped_release release;
    std::shared_lock lock(pm.mutex);
    std::vector<T> sblock;
    for_blocks<T>(a, n, k, single, [&](py::ssize_t len, const T* xs, py::ssize_t first) {
      if (attributes && ns > 0) {
        sblock.resize(size_t(len) * size_t(ns));
        m.eval_batch(len, xs, fp + first, sblock.data());
        scatter(sblock.data(), len, ns, sp, first);
      } else {
        m.eval_batch(len, xs, fp + first);
      }
    });
  }
  if (single) {
    py::object value = py::float_(double(fp[0]));
    if (!attributes) return value;
    return py::make_tuple(value, s[py::int_(0)]);
  }
  if (!attributes) return f;
  return py::make_tuple(f, s);
}

bool is_f32(const py::array& a) {
  return a.dtype().is(py::dtype::of<float>());
}

py::array as_float_array(const py::object& o) {
  if (py::isinstance<py::array>(o)) {
    py::array a = py::reinterpret_borrow<py::array>(o);
    if (a.dtype().is(py::dtype::of<double>()) || is_f32(a)) return a;
  }
  return py::array_t<double, py::array::forcecast>::ensure(o);
}

py::object model_eval(const PyModel& pm, const py::object& points, bool attributes,
                      const py::object& out) {
  py::array a = as_float_array(points);
  if (!a) throw py::type_error("points must be convertible to a float array");
  if (is_f32(a)) return eval_typed<float>(pm, a, attributes, out);
  return eval_typed<double>(pm, a, attributes, out);
}

py::tuple model_eval_interval(const PyModel& pm, const py::object& lo_obj,
                              const py::object& hi_obj) {
  const Model& m = pm.m();
  const int k = m.num_inputs();
  auto lo = py::array_t<double, py::array::forcecast>::ensure(lo_obj);
  auto hi = py::array_t<double, py::array::forcecast>::ensure(hi_obj);
  if (!lo || !hi) throw py::type_error("lo and hi must be convertible to float arrays");
  bool single = false, single_hi = false;
  const py::ssize_t n = check_points(lo, k, "lo", &single);
  const py::ssize_t n_hi = check_points(hi, k, "hi", &single_hi);
  if (n != n_hi || single != single_hi) {
    throw py::value_error("lo and hi must have the same shape");
  }
  // SoA copies of the bounds (checked lo <= hi: a box with lo > hi is an input error).
  std::vector<double> l(size_t(n) * size_t(k)), h(l.size());
  auto gather = [&](const py::array_t<double>& a, std::vector<double>* out) {
    for_blocks<double>(a, n, k, single, [&](py::ssize_t len, const double* xs, py::ssize_t first) {
      for (int c = 0; c < k; ++c) {
        for (py::ssize_t i = 0; i < len; ++i) (*out)[size_t(c * n + first + i)] = xs[c * len + i];
      }
    });
  };
  gather(lo, &l);
  gather(hi, &h);
  for (size_t j = 0; j < l.size(); ++j) {
    if (!(l[j] <= h[j])) {
      throw py::value_error("box " + std::to_string(j % size_t(n)) + ", coordinate " +
                            std::to_string(j / size_t(n) + 1) + ": lo = " + std::to_string(l[j]) +
                            " is not <= hi = " + std::to_string(h[j]));
    }
  }
  py::array_t<double> out_lo(n), out_hi(n);
  py::array_t<bool> out_nan(n);
  double* olo = out_lo.mutable_data();
  double* ohi = out_hi.mutable_data();
  bool* onan = out_nan.mutable_data();
  if (n > 0) {
    py::gil_scoped_release release;
    std::vector<uint8_t> nan(static_cast<size_t>(n));
    std::shared_lock lock(pm.mutex);
    m.eval_interval_batch(n, l.data(), h.data(), olo, ohi, nan.data());
    for (py::ssize_t i = 0; i < n; ++i) onan[i] = nan[size_t(i)] != 0;
  }
  if (single) return py::make_tuple(olo[0], ohi[0], bool(onan[0]));
  return py::make_tuple(out_lo, out_hi, out_nan);
}

template <typename T>
py::array gradient_typed(const PyModel& pm, const py::array& points) {
  const Model& m = pm.m();
  const int k = m.num_inputs();
  bool single = false;
  const py::ssize_t n = check_points(points, k, "points", &single);
  auto a = py::array_t<T>::ensure(points);
  py::array_t<T> g({n, py::ssize_t(4)});
  T* gp = g.mutable_data();
  {
    py::gil_scoped_release release;
    std::shared_lock lock(pm.mutex);
    std::vector<T> block;
    for_blocks<T>(a, n, k, single, [&](py::ssize_t len, const T* xs, py::ssize_t first) {
      block.resize(size_t(len) * 4);
      m.eval_gradient_batch(len, xs, block.data());
      scatter(block.data(), len, 4, gp, first);
    });
  }
  if (single) return g[py::int_(0)];
  return g;
}

py::array model_gradient(const PyModel& pm, const py::object& points) {
  py::array a = as_float_array(points);
  if (is_f32(a)) return gradient_typed<float>(pm, a);
  return gradient_typed<double>(pm, a);
}

void model_set_params(PyModel& pm, const std::vector<double>& params) {
  if (params.size() > size_t(pm.m().num_params())) {
    throw py::value_error("set_params: " + std::to_string(params.size()) +
                          " values but the object '" + pm.m().object_name() + "' has a[" +
                          std::to_string(pm.m().num_params()) + "]");
  }
  std::unique_lock lock(pm.mutex);
  pm.model->set_params(params);
}

void model_set_time(PyModel& pm, double t) {
  if (!std::isfinite(t)) throw py::value_error("set_time: time is not a finite number");
  std::unique_lock lock(pm.mutex);
  pm.model->set_time(t);
}

std::array<double, 3> vec3(const py::handle& o, const char* what) {
  auto v = o.cast<std::vector<double>>();
  if (v.size() != 3) throw py::value_error(std::string(what) + " must have 3 values");
  return {v[0], v[1], v[2]};
}

RootSearch parse_root(const std::string& root) {
  if (root == "auto") return RootSearch::kAuto;
  if (root == "sign") return RootSearch::kSign;
  if (root == "interval") return RootSearch::kInterval;
  if (root == "analytic") return RootSearch::kAnalytic;
  throw py::value_error("root must be 'auto', 'sign', 'interval' or 'analytic' (got '" + root +
                        "')");
}

/// A render's image, or its error as a Python exception (ValueError for bad settings,
/// CompileError for located source errors, RuntimeError otherwise); warnings become Python
/// RuntimeWarnings.
py::array render_result(const RenderOutcome& r, py::array out) {
  for (const std::string& w : r.warnings) {
    PyErr_WarnEx(PyExc_RuntimeWarning, w.c_str(), 1);
  }
  switch (r.status) {
    case RenderOutcome::Status::kOk:
      return out;
    case RenderOutcome::Status::kInvalidSettings:
      throw py::value_error(r.error);
    case RenderOutcome::Status::kSourceError: {
      py::object err = g_compile_error(r.error, py::list());
      PyErr_SetObject(g_compile_error.ptr(), err.ptr());
      throw py::error_already_set();
    }
    case RenderOutcome::Status::kRenderError:
      break;
  }
  throw std::runtime_error(r.error);
}

py::array render(const PyModel& pm, int width, int height, const py::dict& camera,
                 const py::object& bbox, const std::string& root, int spp, int threads,
                 bool shadows, const py::object& background) {
  RenderSettings s;
  s.width = width;
  s.height = height;
  for (auto item : camera) {
    const std::string key = item.first.cast<std::string>();
    if (key == "eye") {
      s.eye = vec3(item.second, "camera['eye']");
    } else if (key == "look_at") {
      s.look_at = vec3(item.second, "camera['look_at']");
    } else if (key == "up") {
      s.up = vec3(item.second, "camera['up']");
    } else if (key == "fov") {
      s.fov_deg = item.second.cast<double>();
    } else if (key == "ortho") {
      s.ortho_width = item.second.cast<double>();
    } else {
      throw py::value_error("camera: unknown key '" + key +
                            "' (known: eye, look_at, up, fov, ortho)");
    }
  }
  if (!bbox.is_none()) {
    auto b = bbox.cast<std::vector<double>>();
    if (b.size() == 1) b = {-b[0], -b[0], -b[0], b[0], b[0], b[0]};
    if (b.size() != 6) throw py::value_error("bbox must have 6 values (or one half-size)");
    for (size_t i = 0; i < 6; ++i) s.bbox[i] = b[i];
  }
  s.root = parse_root(root);
  s.spp = spp;
  s.threads = threads;
  s.shadows = shadows;
  if (!background.is_none()) s.background = vec3(background, "background");
  if (width < 1 || height < 1) throw py::value_error("size must be positive");
  py::array_t<float> out({py::ssize_t(height), py::ssize_t(width), py::ssize_t(4)});
  float* p = out.mutable_data();
  const size_t len = size_t(width) * size_t(height) * 4;
  RenderOutcome r;
  {
    py::gil_scoped_release release;
    std::shared_lock lock(pm.mutex);
    r = render_model(pm.m(), s, p, len, pm.file);
  }
  return render_result(r, std::move(out));
}

/// hfrt.render of a scene file: the scene's settings, the caller's size and threads.
py::array render_scene(const std::string& path, int width, int height, int threads) {
  if (width < 1 || height < 1) throw py::value_error("size must be positive");
  py::array_t<float> out({py::ssize_t(height), py::ssize_t(width), py::ssize_t(4)});
  float* p = out.mutable_data();
  const size_t len = size_t(width) * size_t(height) * 4;
  RenderOutcome r;
  {
    py::gil_scoped_release release;
    r = render_scene_file(path, width, height, p, len, threads);
  }
  return render_result(r, std::move(out));
}

}  // namespace
}  // namespace hfrt::python

PYBIND11_MODULE(_hfrt, mod) {
  using namespace hfrt::python;
  mod.doc() = "hfrt: compile and evaluate HyperFun FRep models (use the hfrt package)";
  mod.def("_set_compile_error", [](py::object type) { g_compile_error = std::move(type); });
  mod.def("_compile", &compile, py::arg("text"), py::arg("is_file"), py::arg("name"),
          py::arg("object"), py::arg("params"), py::arg("backend"), py::arg("precision"),
          py::arg("limits"));

  py::class_<PyModel, std::shared_ptr<PyModel>>(mod, "_Model")
      .def_property_readonly("num_inputs", [](const PyModel& p) { return p.m().num_inputs(); })
      .def_property_readonly("num_params", [](const PyModel& p) { return p.m().num_params(); })
      .def_property_readonly("num_attributes",
                             [](const PyModel& p) { return p.m().num_attributes(); })
      .def_property_readonly("object_name", [](const PyModel& p) { return p.m().object_name(); })
      .def_property_readonly("object_names", [](const PyModel& p) { return p.m().object_names(); })
      .def_property_readonly("file", [](const PyModel& p) { return p.file; })
      .def_property_readonly("params",
                             [](const PyModel& p) {
                               std::shared_lock lock(p.mutex);
                               return p.m().params();
                             })
      .def_property_readonly("diagnostics",
                             [](const PyModel& p) {
                               py::list out;
                               for (const auto& d : p.warnings) out.append(diagnostic_dict(d));
                               return out;
                             })
      .def("eval", &model_eval, py::arg("points"), py::arg("attributes") = false,
           py::arg("out") = py::none())
      .def("eval_interval", &model_eval_interval, py::arg("lo"), py::arg("hi"))
      .def("gradient", &model_gradient, py::arg("points"))
      .def("set_params", &model_set_params, py::arg("params"))
      .def("set_time", &model_set_time, py::arg("time"))
      .def_property_readonly("time", [](const PyModel& p) { return p.m().time(); })
      .def("render", &render, py::arg("width"), py::arg("height"), py::arg("camera"),
           py::arg("bbox"), py::arg("root"), py::arg("spp"), py::arg("threads"), py::arg("shadows"),
           py::arg("background"));

  mod.def("_render_scene", &render_scene, py::arg("path"), py::arg("width"), py::arg("height"),
          py::arg("threads"));

  mod.def(
      "write_image",
      [](const std::string& path,
         const py::array_t<float, py::array::c_style | py::array::forcecast>& rgba) {
        if (rgba.ndim() != 3 || rgba.shape(2) != 4) {
          throw py::value_error("write_image expects an (h, w, 4) array");
        }
        std::string err =
            hfrt::write_rgba_image(path, int(rgba.shape(1)), int(rgba.shape(0)), rgba.data());
        if (!err.empty()) throw std::runtime_error(err);
      },
      py::arg("path"), py::arg("rgba"));
}
