#pragma once
// The logic of `hfrt repl`, without any terminal I/O: a Session takes input lines (HyperFun
// object definitions and `:commands`) and returns what to print. The terminal front end
// (repl.cpp) adds line editing, history and the inline preview; tests drive a Session directly.
//
// The session's objects are kept as one HyperFun source text (all objects in definition
// order, a redefined object replaced in place), so an object may call earlier ones. Compiled
// models are cached by (source text, object): only a change recompiles.

#include <atomic>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "app/render_job.h"
#include "hfrt/model.h"
#include "render/framing.h"
#include "render/image.h"
#include "render/renderer.h"
#include "scene/scene_file.h"
#include "tools/hfrt/preview.h"  // ansi_preview() and the other inline previews
#include "tools/hfrt/render_options.h"

namespace hfrt::tools {

/// What one complete input produced. `out` goes to stdout, `err` to stderr (both end with a
/// newline when non-empty).
struct SessionResult {
  bool ok = true;
  std::string out;
  std::string err;
  bool quit = false;       ///< `:quit`
  bool rendered = false;   ///< a new image is in Session::last_image()
  std::string watch_file;  ///< `:watch FILE`: the front end polls FILE (see Session::watch_step)
};

/// The render settings a session remembers between `:render` calls, translated from the
/// options as typed (Session::render_cli()) by translate_render_options().
struct SessionRenderSettings {
  render::RenderOptions options;
  render::CameraRequest camera;
};

/// Where the time of the last compile and the last `:render` went (for `:stats` and the
/// benchmark), in ms.
struct SessionTimings {
  double compile = 0;  ///< the last compile that was not served by the cache (parse, lowering)
  double prepare = 0;  ///< the JIT of the rendered model's point, interval and gradient code
  double frame = 0;    ///< finding the solid's extent and the camera
  double probe = 0;    ///< the `--root auto` probe
  double render = 0;   ///< the ray tracing
  double write = 0;    ///< encoding and writing the image
};

class Session {
 public:
  Session();

  /// Feeds one input line. Returns nullopt while a multi-line definition is still open (its
  /// braces do not balance yet); then the result of the complete input.
  std::optional<SessionResult> feed_line(std::string_view line);
  /// True inside an unfinished multi-line definition (the front end shows a continuation prompt).
  bool pending() const { return !pending_.empty(); }
  /// Drops an unfinished multi-line definition (Ctrl-C at the continuation prompt).
  void discard_pending() {
    pending_.clear();
    pending_depth_ = 0;
  }

  /// Runs one complete input (a definition or a command).
  SessionResult run(std::string_view input);

  /// The image of the last successful `:render`, or null.
  const render::Image* last_image() const { return last_image_ ? &*last_image_ : nullptr; }
  /// The current object's name ("" when none).
  const std::string& current() const { return current_; }
  /// The objects in definition order (name, definition text).
  const std::vector<std::pair<std::string, std::string>>& objects() const { return objects_; }
  /// The whole session source (what is compiled).
  std::string source() const;
  const SessionRenderSettings& render_settings() const { return settings_; }
  /// The render options as typed (`:render` options and `:set`), as `hfrt render` has them.
  const RenderCli& render_cli() const { return cli_; }

  /// Cancellation: while this flag is true a running (or starting) `:render` stops at the next
  /// tile and fails with "render cancelled", leaving the previous image. It may be set from
  /// any thread or from a signal handler (a lock-free atomic store); the session clears it when
  /// the command that saw it returns, so a cancel never outlives one command.
  std::atomic<bool>& cancel_flag() { return cancel_; }

  /// When set, `:render` first renders a coarse picture (1/8 of the size, same camera, no
  /// shadows: about 1/64 of the work) and passes it here before the full render, so that a
  /// terminal shows something at once and then the refined picture. Not where the full one
  /// comes quickly anyway: when the last render of the same object and options ray traced in
  /// under kQuickRenderMs on the code this model runs (a numbers-only edit), the full
  /// picture follows the coarse one within a blink, and the coarse render only delays it
  /// (c1_gear: ~4.5 ms of a ~100 ms edit).
  std::function<void(const render::Image&)> on_coarse;
  static constexpr double kQuickRenderMs = 200;
  /// A new definition that differs from a cached one only in numbers reuses its compiled
  /// code (Model::share_code). Off: every new definition compiles its own, as an edit of the
  /// structure does (benchmarks of that path).
  bool share_code = true;
  /// Number of compiles that were not served by the cache (for tests and `:stats`).
  int compiles() const { return compiles_; }
  /// How many of those compiles reused the code of an earlier model (Model::share_code):
  /// edits that changed only numbers.
  int code_shares() const { return code_shares_; }
  const SessionTimings& timings() const { return timings_; }

  /// For `:watch`: reloads FILE and re-renders with the remembered output (when there was a
  /// `:render`). Called by the front end when FILE's modification time changes.
  SessionResult watch_step(const std::string& file);

  /// Command names, for completion (with the leading ':').
  static const std::vector<std::string>& command_names();
  /// Render option names accepted by `:render` and `:set` (without "--"): those of `hfrt
  /// render` (render_option_names()) and the `:set` spellings "shadows".
  static std::vector<std::string> option_names();

 private:
  SessionResult dispatch(std::string_view input);
  SessionResult define(std::string_view text);
  SessionResult cmd_load(const std::vector<std::string>& args);
  SessionResult cmd_eval(const std::vector<std::string>& args);
  SessionResult cmd_render(const std::vector<std::string>& args);
  SessionResult cmd_set(const std::vector<std::string>& args);
  SessionResult cmd_show() const;
  SessionResult cmd_objects() const;
  SessionResult cmd_stats() const;
  /// `:scene FILE [OUT]`, `:scene -o OUT` and `:set KEY.PATH VALUE` (session_scene.cpp).
  SessionResult cmd_scene(const std::vector<std::string>& args);
  SessionResult cmd_scene_set(const std::vector<std::string>& args);
  SessionResult render_scene(const std::string& out);
  /// `:mesh OUT [RESOLUTION]`: app::run_mesh_job on the current object, written to OUT.
  SessionResult cmd_mesh(const std::vector<std::string>& args);

  /// The compiled current object, compiling (or taking from the cache) as needed. On a
  /// compile error fills `err` with the diagnostics.
  const Model* model_for(const std::string& source, const std::string& object, std::string* err,
                         int line_offset, std::string_view file);
  /// Parses render options (command-line words, e.g. {"--size", "64x64"}) over the remembered
  /// ones with the `hfrt render` parser, then translates them all; on success they become the
  /// remembered ones, else `err` holds the message and nothing changes.
  bool apply_options(const std::vector<std::string>& words, std::string* err);
  /// Renders the current (or --object) model to `out` with the remembered options.
  SessionResult render_to(const std::string& out);

  std::string pending_;
  int pending_depth_ = 0;
  std::vector<std::pair<std::string, std::string>> objects_;
  std::string current_;
  std::map<std::pair<std::string, std::string>, Model> cache_;
  std::deque<std::pair<std::string, std::string>> cache_order_;  ///< oldest first
  int compiles_ = 0;
  int code_shares_ = 0;
  RenderCli cli_;
  app::RenderSetup setup_;
  /// The view of the last render, kept while the same object is edited with the same options:
  /// its framed extent and the `--root auto` decision. Edits are then seen from the same
  /// camera (what changed is what moved in the picture), and the framing and auto probe are
  /// not paid again. Any option change (`:set`, options on `:render`) or another object
  /// frames anew. view_key_ is the object and the options it was made for ("" = none).
  std::string view_key_;
  /// The ray tracing time of the last render of view_key_ (+inf after a cancelled one).
  double view_render_ms_ = std::numeric_limits<double>::infinity();
  /// The model that render ran and its code's key (Model::code_key).
  const Model* view_model_ = nullptr;
  std::string view_code_key_;
  app::RenderView view_;
  SessionRenderSettings settings_;
  std::atomic<bool> cancel_{false};
  std::string last_output_;
  std::optional<render::Image> last_image_;
  /// The buffers of the render before last, reused by the next one (render::render_into).
  render::Image spare_image_;
  double last_compile_ms_ = 0, last_render_ms_ = 0;
  SessionTimings timings_;
  int evals_ = 0, renders_ = 0;
  /// The loaded scene (`:scene`): its path, its text with the `:set` edits, and what it reads
  /// as; the output of its last render ("" before one).
  std::string scene_path_, scene_text_, scene_output_;
  std::optional<scene::SceneDesc> scene_;
};

}  // namespace hfrt::tools
