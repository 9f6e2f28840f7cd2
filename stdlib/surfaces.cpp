// The mesh and Bézier patch leaves (an hfrt extension, issue 10, docs/meshes.md):
//   hfMesh(x, "file")            a triangle mesh (OFF, OBJ, PLY, STL)
//   hfTriangles(x, V, T)         an inline mesh: 3 coordinates per vertex, 3 one-based indices
//   hfBezierSurface(x, "f.bpt")  Bézier patches in the BPT format
//   hfBezierPatches(x, P)        inline bicubic patches, 48 numbers per patch
// Each loads (at compile time) a geom::Surface and emits one kSurface op at the point
// (x[1], x[2], x[3]). Loading failures are located compile errors. Surfaces are shared: a
// process-wide cache maps a file (or inline data) to one immutable Surface, so every leaf and
// every model that uses it refers to the same BVH (instancing).
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <vector>

#include "geom/bezier.h"
#include "geom/mesh.h"
#include "geom/mesh_surface.h"
#include "geom/patch_surface.h"
#include "ir/builder.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

namespace fs = std::filesystem;

/// Loaded surfaces by key; weak, so a surface lives as long as some Function uses it.
class SurfaceCache {
 public:
  using Build = std::function<Result<std::shared_ptr<const geom::Surface>>()>;

  Result<std::shared_ptr<const geom::Surface>> get(const std::string& key, const Build& build) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = cache_.find(key);
      if (it != cache_.end()) {
        if (auto s = it->second.lock()) return s;
      }
    }
    // Built outside the lock (a large mesh takes a while; other keys need not wait). Two
    // threads loading the same key at once both build; the second one's copy is kept.
    Result<std::shared_ptr<const geom::Surface>> built = build();
    if (!built.ok()) return built;
    std::lock_guard<std::mutex> lock(mutex_);
    cache_[key] = built.value();
    return built;
  }

 private:
  std::mutex mutex_;
  std::map<std::string, std::weak_ptr<const geom::Surface>> cache_;
};

SurfaceCache& cache() {
  static SurfaceCache* c = new SurfaceCache;  // never destroyed: used until exit
  return *c;
}

/// Whether the source is a file on disk (else: the REPL, `Model::compile` of a string).
bool is_model_file(const lang::SourceFile* source) {
  std::error_code ec;
  return source != nullptr && fs::is_regular_file(fs::path(source->name()), ec);
}

/// The file argument relative to the model file's folder; for source that is not a file on
/// disk, relative to the current directory.
fs::path resolve(const std::string& file, const lang::SourceFile* source) {
  fs::path p(file);
  if (p.is_absolute() || !is_model_file(source)) return p;
  return fs::path(source->name()).parent_path() / p;
}

/// A cache key that changes when the file does (so the REPL reloads an edited file).
std::string file_key(const char* kind, const fs::path& path) {
  std::error_code ec;
  fs::path canonical = fs::weakly_canonical(path, ec);
  std::ostringstream key;
  key << kind << ':' << (ec ? path.string() : canonical.string());
  auto size = fs::file_size(path, ec);
  if (!ec) key << ':' << size;
  auto time = fs::last_write_time(path, ec);
  if (!ec) key << ':' << time.time_since_epoch().count();
  return key.str();
}

std::string data_key(const char* kind, const std::vector<double>& a, const std::vector<double>& b) {
  std::string key(kind);
  key += ':' + std::to_string(a.size()) + ':';
  key.append(reinterpret_cast<const char*>(a.data()), a.size() * sizeof(double));
  key.append(reinterpret_cast<const char*>(b.data()), b.size() * sizeof(double));
  return key;
}

/// The compile-time values of array argument i, or false (with an error) when some element
/// is not a constant (inline meshes and patches are built when the model compiles).
bool constant_array(Call& c, int i, const char* what, std::vector<double>* out) {
  const ir::Function& fn = c.builder().function();
  out->clear();
  for (int k = 0; k < c.size(i); ++k) {
    V v = c.at(i, k);
    const ir::Inst& in = fn.insts.at(v.id);
    if (in.op != Op::kConst) {
      c.error(i,
              std::string(c.name()) + ": the " + what + " array '" + c.arg_text(i) +
                  "' is not constant (element " + std::to_string(k + 1) +
                  " is computed when the model is evaluated)",
              "the surface is built when the model compiles: assign the array with a literal, "
              "e.g. " +
                  c.arg_text(i) + " = [0, 0, 0, 1, 0, 0, 0, 1, 0];");
      return false;
    }
    out->push_back(in.imm);
  }
  return true;
}

// The limit's default is the surface's own.
static_assert(Limits{}.max_exact_curves == int64_t(geom::PatchSurface::Options{}.max_exact_curves));

/// A patch set's surface options from the limits: the open border curves its exact field
/// takes (Limits::max_exact_curves).
geom::PatchSurface::Options patch_options(const Limits& limits) {
  geom::PatchSurface::Options o;
  o.max_exact_curves = size_t(limits.max_exact_curves);
  return o;
}

/// An error when the field's tessellation of the patches (PatchSurface) would have more
/// triangles than limits.max_mesh_triangles.
std::optional<Error> check_patch_count(const geom::PatchSet& set, const Limits& limits) {
  const int64_t n = geom::PatchSurface::Options{}.field_tessellation;
  const int64_t per_patch = 2 * n * n;
  const int64_t patches = static_cast<int64_t>(set.patches.size());
  if (patches <= limits.max_mesh_triangles / per_patch) return std::nullopt;
  return Error{set.source + ": " + std::to_string(patches) + " patches tessellate into " +
                   std::to_string(patches * per_patch) + " triangles (" +
                   std::to_string(per_patch) + " per patch), more than the limit of " +
                   std::to_string(limits.max_mesh_triangles),
               limit_hint("max_mesh_triangles")};
}

}  // namespace

V lower_surface(Call& c) {
  const Limits& limits = c.limits();
  const lang::SourceFile* source = c.builder().function().source.get();
  const std::string name(c.name());
  if (c.size(0) < 3) {
    // The front end reports this; stay safe for IR built by hand.
    c.error(0, name + ": the point array has fewer than 3 elements");
    return c.nan();
  }
  Result<std::shared_ptr<const geom::Surface>> surface = Error{"unreachable"};
  std::string hint;
  using Built = Result<std::shared_ptr<const geom::Surface>>;
  switch (c.fn()) {
    case LibraryFn::kMesh:
    case LibraryFn::kBezierSurface: {
      const bool mesh = c.fn() == LibraryFn::kMesh;
      const fs::path path = resolve(c.text(1), source);
      const fs::path folder = fs::path(is_model_file(source) ? source->name() : "").parent_path();
      hint = std::string(mesh ? "hfMesh reads OFF, OBJ, PLY and STL files"
                              : "hfBezierSurface reads BPT files") +
             (is_model_file(source)
                  ? "; a relative path starts at the model file's folder" +
                        (folder.empty() ? std::string() : " ('" + folder.string() + "')")
                  : std::string("; a relative path starts at the current directory (the source "
                                "is not a file)"));
      // The limits are part of the key: a file loaded under larger ones is not reused.
      const std::string key = file_key(mesh ? "mesh" : "bpt", path) + ':' +
                              std::to_string(limits.max_mesh_bytes) + ':' +
                              std::to_string(limits.max_mesh_triangles) +
                              (mesh ? "" : ':' + std::to_string(limits.max_exact_curves));
      surface = cache().get(key, [&]() -> Built {
        if (mesh) {
          Result<geom::TriangleMesh> m = geom::load_mesh(path.string(), limits);
          if (!m.ok()) return m.error();
          return std::shared_ptr<const geom::Surface>(geom::MeshSurface::build(m.value()));
        }
        Result<geom::PatchSet> p = geom::load_bpt(path.string(), limits);
        if (!p.ok()) return p.error();
        if (auto e = check_patch_count(p.value(), limits)) return *e;
        return std::shared_ptr<const geom::Surface>(
            geom::PatchSurface::build(p.value(), patch_options(limits)));
      });
      break;
    }
    case LibraryFn::kTriangles: {
      std::vector<double> v, t;
      if (!constant_array(c, 1, "vertex", &v) || !constant_array(c, 2, "triangle", &t)) {
        return c.nan();
      }
      hint = "V holds 3 coordinates per vertex, T 3 one-based vertex indices per triangle";
      surface = cache().get(data_key("triangles", v, t), [&]() -> Built {
        Result<geom::TriangleMesh> m = geom::mesh_from_arrays(v, t, name);
        if (!m.ok()) return m.error();
        return std::shared_ptr<const geom::Surface>(geom::MeshSurface::build(m.value()));
      });
      break;
    }
    case LibraryFn::kBezierPatches: {
      std::vector<double> p;
      if (!constant_array(c, 1, "control point", &p)) return c.nan();
      hint = "P holds 48 numbers per bicubic patch: 16 control points, row by row";
      surface =
          cache().get(data_key("patches", p, {}) + ':' + std::to_string(limits.max_exact_curves),
                      [&]() -> Built {
                        Result<geom::PatchSet> set = geom::patches_from_array(p, name);
                        if (!set.ok()) return set.error();
                        if (auto e = check_patch_count(set.value(), limits)) return *e;
                        return std::shared_ptr<const geom::Surface>(
                            geom::PatchSurface::build(set.value(), patch_options(limits)));
                      });
      break;
    }
    default:
      HFRT_CHECK_MSG(false, "lower_surface: " << name);
  }
  if (!surface.ok()) {
    std::string message = surface.error().message;
    if (!surface.error().hint.empty()) hint = surface.error().hint;
    // Inline data messages already start with the function's name.
    if (message.rfind(name, 0) != 0) message = name + ": " + message;
    c.error(-1, message, hint);
    return c.nan();
  }
  const V x = c.at(0, 0), y = c.at(0, 1), z = c.at(0, 2);
  IrBuilder& b = c.builder();
  const int index = b.add_surface(surface.value());
  return {&b, b.surface(index, x.id, y.id, z.id)};
}

}  // namespace hfrt::stdlib::detail
