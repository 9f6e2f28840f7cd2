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
  /// --time: the time rendered by run_scene_job (default: the animation's start, or 0).
  std::optional<double> time;
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
  double time = 0;  ///< the time rendered
  int passes = 1;   ///< motion-blur passes (1: none)
};

/// A scene compiled once for many renders: the frames of an animation, the time strata of
/// motion blur, the tiles of a render split across processes. Each model is compiled once; a
/// render at time t applies the scene's keys (scene::scene_at), gives every model its time
/// (x[4], Model::set_time) and its keyed parameters (Model::set_params): numbers, never a
/// recompile. The camera, when the scene leaves eye or look_at to framing, is framed once (over
/// the solids at the animation's first and last frames), and `--root auto` is settled once, so
/// that every frame, any subset of frames and any subset of tiles see the same camera and
/// search: a render is a function of (t, tiles) only.
class PreparedScene {
 public:
  /// Compiles the scene's models and loads its textures. Null with res->status and res->error
  /// when that fails; else res gets the compile figures and warnings.
  static std::unique_ptr<PreparedScene> prepare(const scene::SceneDesc& scene,
                                                const SceneOverrides& overrides,
                                                SceneJobResult* res);
  ~PreparedScene();

  /// Renders time `t` into `*out`. With the animation's shutter > 0 (motion blur), sample s of
  /// each pixel (of the spp) is traced at time t + shutter (s + u_s) / spp (u_s in [0, 1) a
  /// hash of t and s): one pass per sample, the passes averaged, so that time strata follow
  /// the pixel strata. `tiles` (may be null) restricts the render to those tiles
  /// (render::TraceOptions::tiles); the other pixels of `out` are left as they were.
  SceneJobResult render(double t, render::ProgressFn progress, const std::atomic<bool>* cancel,
                        render::TraceResult* out, const std::vector<size_t>* tiles = nullptr);

  /// The render settings (size, spp, tile size ...) every render uses.
  const render::TraceOptions& options() const;
  const scene::SceneDesc& scene() const;

 private:
  struct Impl;
  explicit PreparedScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Compiles and traces `scene` at time overrides.time (default: the animation's start) into
/// `*out`: PreparedScene::prepare, then render. Never throws; every failure is a status.
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
