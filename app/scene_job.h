#pragma once
// One render of a scene file (scene/scene_file.h): its objects compiled (objects that share a
// file, object name and backend share one compilation; the same model placed twice is one
// model, two instances), their fields, the camera framed over all of them, and the trace
// (render/tracer.h). `hfrt render scene.toml` and the REPL's `:scene` run it; a `.hf` file
// keeps going through the single-model render job (app/render_job.h).

#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hfrt/model.h"
#include "render/framing.h"
#include "render/image.h"
#include "render/renderer.h"
#include "render/tracer.h"
#include "scene/scene_file.h"

namespace hfrt::app {

/// What the command line says over a scene file: every set value replaces the scene's.
struct SceneOverrides {
  std::optional<std::array<int, 2>> size;
  std::optional<int> spp;
  std::optional<int> max_depth;
  std::optional<render::RootMode> root;
  std::optional<render::Vec3> background;
  /// Each part that is set replaces the scene's camera part.
  render::CameraRequest camera;
  /// Non-empty: these lights instead of the scene's.
  std::vector<render::Light> lights;
  bool no_shadows = false;
  int threads = 0;
  bool interp_backend = false;  ///< --backend interp
};

/// How a scene job ended.
enum class SceneJobStatus {
  kOk,
  kSourceError,  ///< a model does not compile, or no such object (`error`: located text)
  kEnvironment,  ///< a model file cannot be read, a JIT cannot be created
  kUsageError,   ///< a degenerate camera
  kCancelled,
};

/// Per object, what --stats prints.
struct SceneObjectReport {
  std::string name;  ///< file (and object name) or "object N (inline)"
  render::RootMode root = render::RootMode::kSign;
  bool shared = false;  ///< uses the compilation of an earlier object
  std::string why;      ///< `--root auto`: why this search (render::RootDecision::why)
  render::Box world_box;
};

struct SceneJobResult {
  SceneJobStatus status = SceneJobStatus::kOk;
  std::string error;
  std::vector<std::string> warnings;  ///< JIT failures (the interpreters took over)
  render::TraceOptions options;       ///< as traced: camera resolved
  std::vector<SceneObjectReport> objects;
  size_t compilations = 0;  ///< distinct models compiled
  double compile_ms = 0, prepare_ms = 0, probe_ms = 0, render_ms = 0;
};

/// Compiles and traces `scene` into `*out`. Never throws; every failure is a status.
/// `progress` and `cancel` are as in render::TraceOptions.
SceneJobResult run_scene_job(const scene::SceneDesc& scene, const SceneOverrides& overrides,
                             render::ProgressFn progress, const std::atomic<bool>* cancel,
                             render::TraceResult* out);

/// Compiles the model of one [[object]] of `scene` (its file, or its inline source at its place
/// in the scene file, so that diagnostics point there), with its object name and parameters
/// applied. `compiled.error` holds an environment failure, `compiled.rendered` the located
/// diagnostics (with a note naming the [[object]] when it does not compile).
CompileResult compile_scene_object(const scene::SceneDesc& scene, size_t index,
                                   ModelOptions options);

/// The `stats: ...` lines of `--stats` for a scene render (each ending with a newline).
std::string format_scene_stats(const SceneJobResult& job, const render::TraceStats& stats);

}  // namespace hfrt::app
