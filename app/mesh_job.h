#pragma once
// One mesh of a compiled model, as `hfrt mesh` and the REPL's `:mesh` (and any embedder) do
// it: the model's field (ModelField), its point, interval and gradient code compiled up front,
// the region (the given box, or the solid's extent inside the default box), the mesher
// (mesher/mesher.h) and the file (mesher/mesh_io.h).

#include <functional>
#include <string>
#include <vector>

#include "hfrt/model.h"
#include "mesher/mesher.h"
#include "mesher/simplify.h"
#include "render/vec.h"
#include "scene/scene_file.h"

namespace hfrt::app {

/// What to mesh.
struct MeshJob {
  const Model* model = nullptr;
  /// Names the model in messages (a file name, "<session>" in the REPL).
  std::string file;
  /// The box the solid is capped at (hfrt render's --bbox; default -10..10 on every axis).
  render::Box bbox{{-10, -10, -10}, {10, 10, 10}};
  /// True when the user gave the box: it is meshed as given. Otherwise the grid spans the
  /// solid's extent inside `bbox` (found by intervals, widened by 2% on every side and kept
  /// inside `bbox`), so that --resolution counts cells across the solid, not across the box.
  bool bbox_given = false;
  int resolution = 128;  ///< cells along the longest side of the region (when cell is 0)
  float cell = 0;        ///< cell size; 0 = by resolution
  int threads = 0;       ///< 0 = all cores
  /// Fault in the heap the mesh's arrays will likely fill (~100 bytes per cell of the
  /// resolution squared, HeapPrefault) on a helper thread while the code compiles. Changes
  /// the process's malloc settings: for processes of their own (hfrt mesh).
  bool prefault_heap = false;
  bool colors = true;  ///< per-vertex colour from s[1..3] when the model has them
  /// > 0: simplify the mesh with this error bound (mesher/simplify.h), in model units.
  double simplify = 0;
  /// run_scene_mesh_job only: the time of the scene's models (x[4], Model::set_time); the
  /// caller applies the scene's keys (scene::scene_at). run_mesh_job takes the model's own.
  double time = 0;
  std::function<void(size_t done, size_t total)> progress;
  /// The same for the simplification (simplify_mesh's `progress`).
  std::function<void(size_t done, size_t total)> simplify_progress;
};

enum class MeshJobStatus {
  kOk,
  kNotThreeD,    ///< the object is not a function of x[1..3]
  kNoSurface,    ///< no part of the solid in the box: nothing to mesh
  kTooFine,      ///< --cell asks for more than kMaxMeshCells cells along a side (usage error)
  kSourceError,  ///< a scene's model does not compile (`error`: the located diagnostics)
  kEnvironment,  ///< a scene's model file cannot be read, a JIT cannot be created
};

/// The most cells along a side of the region (`--resolution` and `--cell` alike).
constexpr int kMaxMeshCells = 8192;

struct MeshJobResult {
  MeshJobStatus status = MeshJobStatus::kOk;
  /// For errors: the message, `FILE: error: ...` then a `  hint: ...` line (no final newline).
  std::string error;
  mesher::TriMesh mesh;
  mesher::MeshStats stats;
  mesher::SimplifyStats simplified;   ///< when MeshJob::simplify > 0
  render::Box region;                 ///< the box meshed
  double prepare_ms = 0;              ///< compiling the point, interval and gradient code
  double extent_ms = 0;               ///< finding the solid's extent (when bbox not given)
  std::vector<std::string> warnings;  ///< one line each (JIT fallbacks, NaN samples)
};

/// Meshes `job.model` (which must outlive the call and not change during it).
MeshJobResult run_mesh_job(const MeshJob& job);

/// Meshes every [[object]] of a scene file (`hfrt mesh scene.toml`): each model in its own box
/// with the settings of `settings` (resolution or cell size in model units, threads, colours,
/// simplification), placed in the world by its scale, rotation and translation, into one mesh
/// of several closed shells. Objects without a colour attribute take their material's colour
/// when another object is coloured. Objects with no surface in their box are skipped (a
/// warning); none at all is kNoSurface.
MeshJobResult run_scene_mesh_job(const scene::SceneDesc& scene, const MeshJob& settings);

/// The `stats: ...` lines of `hfrt mesh --stats` (each ending with a newline).
std::string format_mesh_stats(const MeshJobResult& result, double compile_ms, double write_ms);

}  // namespace hfrt::app
