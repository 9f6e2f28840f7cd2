#pragma once
// The logic of `hfrt repl`, without any terminal I/O: a Session takes input lines (HyperFun
// object definitions and `:commands`) and returns what to print. The terminal front end
// (repl.cpp) adds line editing, history and the inline preview; tests drive a Session directly.
//
// The session's objects are kept as one HyperFun source text (all objects in definition
// order, a redefined object replaced in place), so an object may call earlier ones. Compiled
// models are cached by (source text, object): only a change recompiles.

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "hfrt/model.h"
#include "render/framing.h"
#include "render/image.h"
#include "render/renderer.h"

namespace hfrt::tools {

/// What one complete input produced. `out` goes to stdout, `err` to stderr (both end with a
/// newline when non-empty).
struct SessionResult {
  bool ok = true;
  std::string out;
  std::string err;
  bool quit = false;           ///< `:quit`
  bool rendered = false;       ///< a new image is in Session::last_image()
  std::string watch_file;      ///< `:watch FILE`: the front end polls FILE (see Session::watch_step)
};

/// The render settings a session remembers between `:render` calls.
struct SessionRenderSettings {
  render::RenderOptions options;
  render::CameraRequest camera;
};

class Session {
 public:
  Session();

  /// Feeds one input line. Returns nullopt while a multi-line definition is still open (its
  /// braces do not balance yet); then the result of the complete input.
  std::optional<SessionResult> feed_line(std::string_view line);
  /// True inside an unfinished multi-line definition (the front end shows a continuation prompt).
  bool pending() const { return !pending_.empty(); }

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
  /// Number of compiles that were not served by the cache (for tests and `:stats`).
  int compiles() const { return compiles_; }

  /// For `:watch`: reloads FILE and re-renders with the remembered output (when there was a
  /// `:render`). Called by the front end when FILE's modification time changes.
  SessionResult watch_step(const std::string& file);

  /// Command names, for completion (with the leading ':').
  static const std::vector<std::string>& command_names();
  /// Render option names accepted by `:render` and `:set` (without "--").
  static std::vector<std::string> option_names();

 private:
  SessionResult define(std::string_view text);
  SessionResult cmd_load(const std::vector<std::string>& args);
  SessionResult cmd_eval(const std::vector<std::string>& args);
  SessionResult cmd_render(const std::vector<std::string>& args);
  SessionResult cmd_set(const std::vector<std::string>& args);
  SessionResult cmd_show() const;
  SessionResult cmd_objects() const;
  SessionResult cmd_stats() const;

  /// The compiled current object, compiling (or taking from the cache) as needed. On a
  /// compile error fills `err` with the diagnostics.
  const Model* model_for(const std::string& source, const std::string& object, std::string* err,
                         int line_offset, std::string_view file);
  /// Applies one render option (name without "--"); false with `err` when invalid.
  bool apply_option(const std::string& name, const std::string& value, std::string* err);

  std::string pending_;
  int pending_depth_ = 0;
  std::vector<std::pair<std::string, std::string>> objects_;
  std::string current_;
  std::map<std::pair<std::string, std::string>, Model> cache_;
  int compiles_ = 0;
  SessionRenderSettings settings_;
  std::string last_output_;
  std::optional<render::Image> last_image_;
  double last_compile_ms_ = 0, last_render_ms_ = 0;
  int evals_ = 0, renders_ = 0;
};

/// The change in brace depth of a line of HyperFun (comments `--` skipped).
int brace_delta(std::string_view line);

/// The image as 24-bit colour ANSI half blocks (two pixel rows per text row), scaled down to
/// at most `max_cols` columns. Ends with a colour reset and a newline.
std::string ansi_preview(const render::Image& image, int max_cols);

}  // namespace hfrt::tools
