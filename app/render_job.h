#pragma once
// One render of a compiled model, as `hfrt render` and the REPL's `:render` (and any
// embedder) do it: the field (ModelField, or its sampled view for models whose interval
// evaluator is the interpreter), the evaluators compiled up front, the camera framed, the root
// search settled (render/root_choice.h), the render itself, and the figures `--stats` prints.
//
// The steps, in order (run_render_job does them all; the pieces stay public for tools that
// need only some, e.g. `hfrt emit --pov` frames a camera without rendering):
//  1. render_field(): the model's field, or the view without intervals;
//  2. prepare_render_code(): the point, interval and gradient code, compiled in parallel;
//  3. for --root analytic, analytic_root_diagnostic() when the model does not qualify;
//  4. frame_camera(): the camera from the request, framing the solid when eye or look-at is
//     not given, and the degenerate-camera checks;
//  5. settle_root(): the `--root auto` decision (the only step that may render a probe);
//  6. render, then format_render_stats() for `--stats`.

#include <functional>
#include <string>
#include <vector>

#include "app/model_field.h"
#include "hfrt/model.h"
#include "render/camera.h"
#include "render/field.h"
#include "render/framing.h"
#include "render/image.h"
#include "render/renderer.h"
#include "render/root_choice.h"

namespace hfrt::app {

/// The translated, validated options.
struct RenderSetup {
  render::RenderOptions options;  ///< everything but the camera (set by frame_camera())
  render::CameraRequest camera;
  render::AovSet aovs;
  std::vector<double> params;  ///< -a
  double time = 0;             ///< --time: x[4] (Model::set_time)
};

/// The field a render uses: the model's own, or (when the model's interval evaluator is the
/// interpreter, too slow for the renderer's many calls, and `root` is not kInterval) the view
/// without intervals, which frames by sampling and renders by the sign-change march.
/// With `pruned_tapes` (a `render::render` with RenderOptions::pruned_tapes and tile culling,
/// which run_render_job asks for) and `root` kAuto, a model whose intervals come from the tape
/// VM keeps its intervals: the renderer evaluates them on tapes pruned per tile slab.
/// `model_field` and `sampled` must outlive the returned reference.
const render::Field& render_field(const Model& model, const ModelField& model_field,
                                  const WithoutIntervals& sampled, render::RootMode root,
                                  bool pruned_tapes = false);

/// How the camera was found, for --stats.
struct FramingInfo {
  bool framed = false;              ///< the solid's extent was searched (no eye or no look-at)
  bool extent_by_interval = false;  ///< ... and found by intervals (else by sampling)
  render::Box extent;               ///< the box framed (the bbox when not framed)
  double ms = 0;
};

/// Resolves `camera` into `opt->camera` for opt's size and box: when eye or look-at is not
/// given, the solid's extent inside opt->bbox is found first (find_extent) and framed. False
/// with `*err` when the camera is degenerate (eye = look-at, up parallel to the view).
/// `known_extent`, when given, is used instead of searching the extent (the REPL reuses it
/// between renders of an unchanged model and box).
bool frame_camera(const render::Field& field, const render::CameraRequest& camera,
                  render::RenderOptions* opt, FramingInfo* info, std::string* err,
                  const render::Box* known_extent = nullptr);

/// Settles `--root auto` in `opt` (no-op for the other modes): the interval search (robust:
/// thin shells and tangent touches are not missed) with tile culling, unless the field has no
/// intervals or a small probe render (same camera and box, no shadows) shows that the model's
/// enclosures are too loose for intervals to pay; then the sign-change march without interval
/// culling. The probe counts evaluations, it does not time them, so the choice does not depend
/// on the machine or its load.
///
/// Before all that, `auto` takes the analytic search (exact roots of polynomial leaves) when
/// the field lists ray candidates (the model qualifies: Model::analytic_info()); when it does
/// not, `analytic` (if given, with the model's `file` name) supplies the reason for
/// RootDecision::analytic_fallback.
render::RootDecision settle_root(const render::Field& field, render::RenderOptions* opt,
                                 const AnalyticInfo* analytic = nullptr,
                                 const std::string& file = "");

/// For `--root analytic` on a model that does not qualify: the located diagnostic, in the
/// format of compile errors (`file:line:col: error: message`, the source line, a caret, a
/// hint), naming the first construct that is not polynomial. "" when the model qualifies.
std::string analytic_root_diagnostic(const AnalyticInfo& analytic, const std::string& file);

/// What `--stats` prints about one render.
struct RenderReport {
  double compile_ms = 0;
  double prepare_ms = 0;  ///< interval and gradient code
  std::string engines;    ///< describe_domain_engines()
  FramingInfo framing;
  bool auto_root = false;  ///< `--root auto` was asked
  render::RootDecision root;
  bool culled = false;  ///< tile culling by intervals was on
  render::RenderStats stats;
};

/// The `stats: ...` lines of `--stats` (each ending with a newline).
std::string format_render_stats(const RenderReport& report);

/// The view of a render that a caller may keep between renders of an unchanged model and
/// options (the REPL): the framed extent and the `--root auto` decision. Valid only while the
/// evaluators it chose exist (an edit may make the model non-polynomial, or too large for the
/// interval JIT): run_render_job checks has_interval and ray_candidates.
struct RenderView {
  render::Box extent;
  bool has_interval = false;
  bool ray_candidates = false;
  render::RootMode root = render::RootMode::kSign;
  bool tile_culling = true;
  std::string why;
};

/// What to render. `setup.options` carries everything of the render (size, box, lights,
/// threads, progress and cancel hooks); `setup.camera` the camera request.
struct RenderJob {
  const Model* model = nullptr;
  /// Names the model in messages and diagnostics (a file name, "<session>" in the REPL).
  std::string file;
  RenderSetup setup;
  /// A view kept from an earlier render of the same model and options, or null.
  const RenderView* view = nullptr;
  /// When set: a coarse picture (1/8 of the size, same camera, no shadows: about 1/64 of the
  /// work) is rendered first and passed here, so that a terminal shows something at once.
  std::function<void(const render::Image&)> on_coarse;
};

/// How a render job ended.
enum class RenderJobStatus {
  kOk,
  kSourceError,  ///< --root analytic on a model that does not qualify (`error`: located text)
  kUsageError,   ///< a degenerate camera (`error`: the message, without a prefix)
  kCancelled,    ///< RenderOptions::cancel was set
};

struct RenderJobResult {
  RenderJobStatus status = RenderJobStatus::kOk;
  std::string error;
  /// JIT failures (the interpreters took over), one line each.
  std::vector<std::string> warnings;
  render::RenderOptions options;  ///< as rendered: camera resolved, root settled
  RenderReport report;            ///< compile_ms is the caller's to fill
  RenderView view;                ///< the view of this render, for the next one
  double render_ms = 0;           ///< the ray tracing alone
};

/// Runs the job into `out` (whose image buffers are reused when their size fits:
/// render::render_into). Never throws; every failure is a status.
RenderJobResult run_render_job(const RenderJob& job, render::RenderResult* out);

}  // namespace hfrt::app
