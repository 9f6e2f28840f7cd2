#pragma once
// The render options of `hfrt render`, shared with the REPL (`:render OUT [options]`,
// `:set OPTION VALUE`): one option struct, one CLI11 registration and one translation into
// render::RenderOptions, so that both accept the same options with the same validation and the
// same error texts.
//
// The steps, in the order a render takes them:
//  1. add_render_options(): the options on a CLI11 app (as typed: strings, numbers, flags);
//  2. translate_render_options(): validation and translation into render::RenderOptions, the
//     camera request, the AOVs and the parameters (no model needed); the `--root` word is
//     parsed by parse_root_mode();
//  3. (compile the model, pick the field: render_field())
//  4. frame_camera(): the camera from the request, framing the solid when eye or look-at is
//     not given, and the degenerate-camera checks;
//  5. settle_root(): the `--root auto` decision (the only step that may render a probe);
//  6. render, then format_render_stats() for `--stats`.

#include <string>
#include <vector>

#include "hfrt/model.h"
#include "render/camera.h"
#include "render/field.h"
#include "render/framing.h"
#include "render/image.h"
#include "render/renderer.h"
#include "tools/hfrt/model_field.h"

namespace CLI {
class App;
}

namespace hfrt::tools {

/// The render options as typed on the command line (CLI11 stores into these). Empty strings
/// and zeros mean "the default" (framed camera, default lights, ...).
struct RenderCli {
  ModelRequest model;  ///< the model file (a positional of `hfrt render`), --object, -a, --backend
  std::string output;  ///< -o (registered by `hfrt render` only; the REPL takes OUT itself)
  std::string size = "512x512";
  std::string bbox;
  std::string eye, look_at, up;
  float fov = 0;
  float ortho = 0;
  std::string root = "auto";
  int spp = 1;
  int threads = 0;
  std::vector<std::string> lights;
  float step = 0, epsilon = 0;
  std::string aov;
  std::string background;
  bool no_shadows = false;
  bool stats = false;
};

/// Registers every render option (all but the model file and -o) on `app`, storing into `cli`
/// (which must outlive the parse).
void add_render_options(CLI::App& app, RenderCli* cli);

/// The names of the options add_render_options() registers, without dashes ("size", "a",
/// "no-shadows", ...), for the REPL's `:set` and completion.
const std::vector<std::string>& render_option_names();
/// True for the options that take no value (--no-shadows, --stats).
bool render_option_is_flag(const std::string& name);

/// The translated, validated options.
struct RenderSetup {
  render::RenderOptions options;  ///< everything but the camera (set by frame_camera())
  render::CameraRequest camera;
  render::AovSet aovs;
  std::vector<double> params;  ///< -a
};

/// Parses a `--root` word into `mode`; false when it is not a root mode.
bool parse_root_mode(const std::string& text, render::RootMode* mode);
/// What parse_root_mode() accepts, for error texts ("sign, interval, analytic or auto").
const char* root_mode_choices();

/// Parses "WxH" (or "N" for NxN); false when malformed or not positive.
bool parse_size(const std::string& text, int* w, int* h);

/// Validates `cli` and translates it into `out`. On a usage error returns false with the
/// message in `*err`, naming the option (e.g. "--size expects WxH with positive integers, e.g.
/// --size 512x512 (got '0x5')"), without a prefix: the caller adds "hfrt render: " or "hfrt: ".
bool translate_render_options(const RenderCli& cli, RenderSetup* out, std::string* err);

/// The field a render uses: the model's own, or (when the model's interval evaluator is the
/// interpreter, too slow for the renderer's many calls, and `root` is not kInterval) the view
/// without intervals, which frames by sampling and renders by the sign-change march.
/// `model_field` and `sampled` must outlive the returned reference.
const render::Field& render_field(const Model& model, const ModelField& model_field,
                                  const WithoutIntervals& sampled, render::RootMode root);

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

/// The `--root auto` decision, for the user and --stats.
struct RootDecision {
  std::string why;      ///< empty unless opt->root was kAuto
  bool probed = false;  ///< a probe render was made
  double probe_ms = 0;
  /// When `auto` could not take the analytic search: why the model does not qualify, with its
  /// location ("'sin' is not a polynomial at model.hf:3:9"); empty otherwise.
  std::string analytic_fallback;
};

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
RootDecision settle_root(const render::Field& field, render::RenderOptions* opt,
                         const AnalyticInfo* analytic = nullptr, const std::string& file = "");

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
  RootDecision root;
  bool culled = false;  ///< tile culling by intervals was on
  render::RenderStats stats;
};

/// The `stats: ...` lines of `--stats` (each ending with a newline).
std::string format_render_stats(const RenderReport& report);

}  // namespace hfrt::tools
