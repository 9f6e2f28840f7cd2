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
//  3. (compile the model, pick the field: app::render_field())
//  4. app::frame_camera(): the camera from the request, framing the solid when eye or look-at is
//     not given, and the degenerate-camera checks;
//  5. app::settle_root(): the `--root auto` decision (the only step that may render a probe);
//  6. render, then app::format_render_stats() for `--stats`.

#include <string>
#include <vector>

#include "app/render_job.h"
#include "hfrt/model.h"
#include "render/camera.h"
#include "render/field.h"
#include "render/framing.h"
#include "render/image.h"
#include "render/renderer.h"
#include "tools/hfrt/model_request.h"

namespace CLI {
class App;
}

namespace hfrt::tools {

using app::RenderSetup;

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
  bool no_prune = false;  ///< --no-prune: the whole program's intervals everywhere
  bool stats = false;
  int max_depth = -1;          ///< scene files only; -1: the scene's value
  std::string device = "cpu";  ///< --device (registered by `hfrt render` only)
};

/// Registers every render option (all but the model file and -o) on `app`, storing into `cli`
/// (which must outlive the parse).
void add_render_options(CLI::App& app, RenderCli* cli);

/// The names of the options add_render_options() registers, without dashes ("size", "a",
/// "no-shadows", ...), for the REPL's `:set` and completion.
const std::vector<std::string>& render_option_names();
/// True for the options that take no value (--no-shadows, --stats).
bool render_option_is_flag(const std::string& name);

/// Parses a `--root` word into `mode`; false when it is not a root mode.
bool parse_root_mode(const std::string& text, render::RootMode* mode);
/// What parse_root_mode() accepts, for error texts ("sign, interval, analytic or auto").
const char* root_mode_choices();

/// Parses "WxH" (or "N" for NxN); false when malformed or not positive.
bool parse_size(const std::string& text, int* w, int* h);

/// Validates `cli` and translates it into `out`. On a usage error returns false with the
/// message in `*err`, naming the option (e.g. "--size expects WxH with positive integers, e.g.
/// --size 512x512 (got '0x5')"), without a prefix: the caller adds "hfrt render: " or "hfrt: ".
bool translate_render_options(const RenderCli& cli, app::RenderSetup* out, std::string* err);

}  // namespace hfrt::tools
