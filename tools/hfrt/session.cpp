#include "tools/hfrt/session.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <thread>

#include "app/mesh_job.h"
#include "app/model_field.h"
#include "base/check.h"
#include "base/memory.h"
#include "base/timer.h"
#include "lang/diagnostics.h"
#include "lang/objects.h"
#include "mesher/mesh_io.h"

namespace hfrt::tools {
namespace {

/// The session's ModelOptions::background_interval_min_insts and
/// background_gradient_min_insts (see Session::model_for).
constexpr int kBackgroundIntervalInsts = 200;
constexpr int kBackgroundGradientInsts = 200;

/// Whether a compile of `model`'s code still runs on a thread of its own.
bool compile_running(const Model& model) {
  const ModelStats st = model.stats();
  auto running = [](bool background, bool compiled) { return background && !compiled; };
  return running(st.jit_f32.background, st.jit_f32.compiled) ||
         running(st.interval.background, st.interval.compiled) ||
         running(st.gradient_f32.background, st.gradient_f32.compiled);
}

/// Gives a cached model the parameters and time of one render or mesh (-a, --time) and its own
/// back when the scope ends.
class ScopedModelSettings {
 public:
  ScopedModelSettings(Model& model, const std::vector<double>& params, double time)
      : model_(model), params_(model.params()), time_(model.time()) {
    model_.set_params(params);
    model_.set_time(time);
  }
  ~ScopedModelSettings() {
    model_.set_params(params_);
    model_.set_time(time_);
  }
  ScopedModelSettings(const ScopedModelSettings&) = delete;
  ScopedModelSettings& operator=(const ScopedModelSettings&) = delete;

 private:
  Model& model_;
  std::vector<double> params_;
  double time_;
};

std::string trim(std::string_view s) {
  size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return std::string(s.substr(b, e - b));
}

std::vector<std::string> split_words(std::string_view s) {
  std::vector<std::string> words;
  std::istringstream in{std::string(s)};
  std::string w;
  while (in >> w) words.push_back(w);
  return words;
}

void append_number(std::string& out, double v) {
  if (std::isnan(v)) {
    out += "nan";  // as `hfrt eval`: never "-nan"
    return;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  out += buf;
}

bool parse_double(const std::string& s, double* v) {
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return !s.empty() && *end == '\0';
}

int count_lines(std::string_view s) {
  return int(std::count(s.begin(), s.end(), '\n'));
}

/// Diagnostics of a compile, with lines moved by `line_offset` and named `file`; those outside
/// the typed text (line <= 0 after the shift) keep the session-source location.
std::string format_diagnostics(const CompileResult& r, int line_offset, std::string_view file) {
  if (!r.error.empty()) return "hfrt: " + r.error + "\n";
  std::string out;
  for (const SourceDiagnostic& d : r.diagnostics) {
    int line = d.line - line_offset;
    std::string where =
        line > 0 ? std::string(file) + ":" + std::to_string(line) + ":" + std::to_string(d.col)
                 : "<session>:" + std::to_string(d.line) + ":" + std::to_string(d.col);
    const lang::Severity sev =
        d.severity == SourceDiagnostic::Severity::kError     ? lang::Severity::kError
        : d.severity == SourceDiagnostic::Severity::kWarning ? lang::Severity::kWarning
                                                             : lang::Severity::kNote;
    out += lang::render_brief(where, sev, d.message, d.hint);
  }
  if (out.empty()) out = r.rendered;
  return out;
}

SessionResult failure(std::string err) {
  SessionResult r;
  r.ok = false;
  r.err = std::move(err);
  if (!r.err.empty() && r.err.back() != '\n') r.err += '\n';
  return r;
}

SessionResult success(std::string out) {
  SessionResult r;
  r.out = std::move(out);
  if (!r.out.empty() && r.out.back() != '\n') r.out += '\n';
  return r;
}

const char* kHelp =
    "Type a HyperFun object definition to add or replace it (it becomes current), or a command:\n"
    "  :load FILE                 load all objects of FILE (my_model, else the last, is current)\n"
    "  :eval X Y Z [A1 ...]       value of the current model at a point (then s[])\n"
    "  :render OUT [options]      render to OUT; options (as hfrt render) are remembered;\n"
    "                             edits of the same object keep its camera (:set frames anew)\n"
    "  :set OPTION VALUE...       set any option of hfrt render (size, bbox, eye, look-at, up,\n"
    "                             fov, ortho, root, spp, threads, a, object, light, step, "
    "epsilon,\n"
    "                             aov, background, no-shadows, no-prune, backend, stats; flags\n"
    "                             take on|off;\n"
    "                             VALUE 'default' restores the default; light takes several)\n"
    "  :scene FILE.toml [OUT]     load a scene file (docs/scenes.md); with OUT, render it\n"
    "  :scene -o OUT              render the loaded scene (with its edits) to OUT\n"
    "  :set material.NAME.KEY V   edit the loaded scene (also camera.KEY, render.KEY,\n"
    "                             light.N.KEY, object.N.KEY); re-renders a rendered scene\n"
    "  :mesh OUT [RESOLUTION]     mesh the current object to OUT (.stl .obj .ply .glb; as hfrt\n"
    "                             mesh, with the remembered bbox, a, object and threads)\n"
    "  :show  :objects  :stats    session state\n"
    "  :watch FILE                reload and re-render whenever FILE changes (Ctrl-C stops)\n"
    "  :preview off|ansi|sixel|kitty|auto   inline preview in a terminal (auto: detected)\n"
    "  :help  :quit\n";

}  // namespace

Session::Session() {
  // Every render and image write allocates and frees the same large buffers: keep them on
  // malloc's heap rather than fault in fresh pages each time (base/memory.h).
  keep_large_blocks_on_heap();
  std::string err;
  HFRT_CHECK(translate_render_options(cli_, &setup_, &err));
  settings_.options = setup_.options;
  settings_.camera = setup_.camera;
}

const std::vector<std::string>& Session::command_names() {
  static const std::vector<std::string> names = {":load",    ":eval",  ":render", ":set",   ":show",
                                                 ":objects", ":stats", ":watch",  ":scene", ":mesh",
                                                 ":preview", ":help",  ":quit"};
  return names;
}

std::vector<std::string> Session::option_names() {
  std::vector<std::string> names = render_option_names();
  names.push_back("shadows");
  return names;
}

std::string Session::source() const {
  std::string s;
  for (const auto& [name, text] : objects_) {
    s += text;
    if (!s.empty() && s.back() != '\n') s += '\n';
  }
  return s;
}

std::optional<SessionResult> Session::feed_line(std::string_view line) {
  if (pending_.empty()) {
    std::string t = trim(line);
    if (t.empty()) return SessionResult{};
    if (t[0] == ':') return run(t);
    if (t.compare(0, 2, "--") == 0) return SessionResult{};  // a comment line
  }
  pending_ += line;
  pending_ += '\n';
  pending_depth_ += lang::brace_delta(line);
  bool opened = pending_.find('{') != std::string::npos;
  if (!opened || pending_depth_ > 0) return std::nullopt;
  std::string text = std::move(pending_);
  pending_.clear();
  pending_depth_ = 0;
  return run(text);
}

SessionResult Session::run(std::string_view input) {
  SessionResult r = dispatch(input);
  cancel_.store(false);  // a cancel ends with the command that saw it
  return r;
}

SessionResult Session::dispatch(std::string_view input) {
  std::string t = trim(input);
  if (t.empty()) return SessionResult{};
  if (t[0] != ':') return define(input);
  std::vector<std::string> words = split_words(t);
  std::string cmd = words[0];
  std::vector<std::string> args(words.begin() + 1, words.end());
  if (cmd == ":load") return cmd_load(args);
  if (cmd == ":eval") return cmd_eval(args);
  if (cmd == ":render") return cmd_render(args);
  if (cmd == ":set") {
    // Dotted keys (material.glass.ior) edit the loaded scene (session_scene.cpp).
    if (!args.empty() && args[0].find('.') != std::string::npos) return cmd_scene_set(args);
    return cmd_set(args);
  }
  if (cmd == ":scene") return cmd_scene(args);
  if (cmd == ":show") return cmd_show();
  if (cmd == ":objects") return cmd_objects();
  if (cmd == ":stats") return cmd_stats();
  if (cmd == ":mesh") return cmd_mesh(args);
  if (cmd == ":help") return success(kHelp);
  if (cmd == ":quit" || cmd == ":q") {
    SessionResult r;
    r.quit = true;
    return r;
  }
  if (cmd == ":watch") {
    if (args.size() != 1) return failure("hfrt: :watch expects one FILE");
    SessionResult r = watch_step(args[0]);
    if (r.ok) r.watch_file = args[0];
    return r;
  }
  if (cmd == ":preview") return failure("hfrt: :preview is handled by the terminal front end");
  return failure("hfrt: unknown command '" + cmd + "' (:help lists them)");
}

const Model* Session::model_for(const std::string& source, const std::string& object,
                                std::string* err, int line_offset, std::string_view file) {
  // The backend is part of the key: `:set backend interp` compiles anew.
  const bool interp = cli_.model.backend == "interp";
  auto key = std::make_pair(source, interp ? object + "\n@interp" : object);
  auto it = cache_.find(key);
  if (it != cache_.end()) return &it->second;
  ModelOptions mo;
  mo.object = object;
  mo.backend = interp ? Backend::kInterp : Backend::kJit;
  // No JIT inside compile(): a definition only needs its diagnostics; a render compiles the
  // evaluators it needs in parallel (prepare_for_render), :eval its f64 code on first use.
  mo.eager_f64 = false;
  mo.eager_f32 = false;
  // Numbers as hidden parameters: an edit that changes only numbers (a radius, a blend
  // factor) gets the code of the model it was edited from, compiled or not, and costs no JIT.
  mo.hoist_constants = true;
  // A lower bar than the command line's for compiling the interval code in the background
  // (the tape VM answering meanwhile, with the same bits): the terminal shows a coarse picture
  // first, and a structural edit of c1_gear (255 instructions, ~0.3 s of interval compile)
  // showed it after 123-140 ms instead of 347-365 ms, the full image after 529-557 ms instead
  // of 686-696 ms (`HFRT_NO_CACHE=1 hfrt_bench_repl --only c1_gear`, bench/README.md). Small
  // models compile in a few tens of ms: the JIT from the first box serves them better.
  mo.background_interval_min_insts = kBackgroundIntervalInsts;
  // The same for the gradient code of a model of exact arithmetic (the tape VM's gradient
  // pass answering meanwhile, with the same bits).
  mo.background_gradient_min_insts = kBackgroundGradientInsts;
  // (Not the point code below the library's 500: a structural edit of c1_gear, 255
  // instructions, showed its coarse picture after 29-33 ms instead of 46-56 ms but its full
  // image after 350-379 ms instead of 295-298 ms, the tape VM's points costing more than the
  // JIT's while four compiles shared the two cores.)
  auto t0 = std::chrono::steady_clock::now();
  CompileResult r = Model::compile(source, mo, "<session>");
  ++compiles_;
  if (!r.ok()) {
    *err = format_diagnostics(r, line_offset, file);
    return nullptr;
  }
  for (const auto& [k, cached] : cache_) {
    if (share_code && r.model->share_code(cached)) {
      ++code_shares_;
      break;
    }
  }
  last_compile_ms_ = ms_since(t0);
  timings_.compile = last_compile_ms_;
  // A small cache: the session's models change rarely, but keep memory bounded. The newest
  // model stays (an edit shares its code), the oldest goes first.
  if (cache_.size() >= 16) cache_.erase(cache_order_.front()), cache_order_.pop_front();
  cache_order_.push_back(key);
  return &cache_.emplace(std::move(key), std::move(*r.model)).first->second;
}

SessionResult Session::define(std::string_view text) {
  std::string name = lang::defined_object_name(text);
  if (name.empty())
    return failure("<input>:1:1: error: expected an object definition `name(x[3], a[1]) { ... }`");
  // The candidate source: the object replaced in place, or appended.
  auto objects = objects_;
  auto it =
      std::find_if(objects.begin(), objects.end(), [&](const auto& o) { return o.first == name; });
  int line_offset = 0;
  std::string def(text);
  if (!def.empty() && def.back() != '\n') def += '\n';
  if (it != objects.end()) {
    for (auto j = objects.begin(); j != it; ++j) line_offset += count_lines(j->second);
    it->second = def;
  } else {
    for (const auto& o : objects) line_offset += count_lines(o.second);
    objects.emplace_back(name, def);
  }
  std::string src;
  for (const auto& o : objects) src += o.second;
  std::string err;
  if (!model_for(src, name, &err, line_offset, "<input>")) return failure(err);
  objects_ = std::move(objects);
  current_ = name;
  return success("defined " + name);
}

SessionResult Session::cmd_load(const std::vector<std::string>& args) {
  if (args.size() != 1) return failure("hfrt: :load expects one FILE");
  std::ifstream in(args[0], std::ios::binary);
  if (!in) return failure("hfrt: cannot read '" + args[0] + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  // The file alone first, so its diagnostics name its own lines.
  ModelOptions mo;
  // No JIT inside compile(): a definition only needs its diagnostics; a render compiles the
  // evaluators it needs in parallel (prepare_for_render), :eval its f64 code on first use.
  mo.eager_f64 = false;
  mo.eager_f32 = false;
  auto t0 = std::chrono::steady_clock::now();
  CompileResult alone = Model::compile(text, mo, args[0]);
  ++compiles_;
  last_compile_ms_ = ms_since(t0);
  if (!alone.ok()) return failure(alone.error.empty() ? alone.rendered : "hfrt: " + alone.error);
  std::vector<std::string> defs = lang::split_objects(text);
  auto objects = objects_;
  std::string current;
  for (const std::string& d : defs) {
    std::string name = lang::defined_object_name(d);
    if (name.empty()) continue;
    auto it = std::find_if(objects.begin(), objects.end(),
                           [&](const auto& o) { return o.first == name; });
    if (it != objects.end()) {
      it->second = d;
    } else {
      objects.emplace_back(name, d);
    }
    if (current != "my_model") current = name;
  }
  if (current.empty()) return failure("hfrt: '" + args[0] + "' defines no object");
  std::string src;
  for (const auto& o : objects) {
    src += o.second;
    if (src.back() != '\n') src += '\n';
  }
  // Into an empty session the file is the whole source: its model serves (no second compile).
  if (src == text && alone.model->object_name() == current && cli_.model.backend != "interp") {
    if (cache_.size() >= 16) cache_.clear();
    cache_.emplace(std::make_pair(src, current), std::move(*alone.model));
  }
  std::string err;
  if (!model_for(src, current, &err, 0, "<session>")) return failure(err);
  objects_ = std::move(objects);
  current_ = current;
  return success("loaded " + std::to_string(defs.size()) + " object(s) from " + args[0] +
                 "; current: " + current);
}

SessionResult Session::cmd_eval(const std::vector<std::string>& args) {
  if (current_.empty()) return failure("hfrt: no current object (define one or :load a file)");
  std::string err;
  const Model* m = model_for(source(), current_, &err, 0, "<session>");
  if (!m) return failure(err);
  std::vector<double> x, a;
  for (size_t i = 0; i < args.size(); ++i) {
    double v;
    if (!parse_double(args[i], &v))
      return failure("hfrt: :eval cannot read '" + args[i] + "' as a number");
    (int(i) < m->num_inputs() ? x : a).push_back(v);
  }
  if (int(x.size()) < m->num_inputs()) {
    return failure("hfrt: :eval expects " + std::to_string(m->num_inputs()) + " coordinates");
  }
  // Parameters: a copy of the model gets them (the cached model keeps its own).
  PointValue pv;
  if (!a.empty()) {
    Model& mm = const_cast<Model&>(*m);
    std::vector<double> saved = mm.params();
    mm.set_params(a);
    pv = mm.eval(x);
    mm.set_params(saved);
  } else {
    pv = m->eval(x);
  }
  ++evals_;
  std::string line;
  append_number(line, pv.f);
  // s[] as `hfrt eval` prints it: num_attributes() values (none for an object without s).
  for (int k = 0; k < m->num_attributes() && k < int(pv.s.size()); ++k) {
    line += ' ';
    append_number(line, pv.s[size_t(k)]);
  }
  SessionResult r = success(line);
  if (!pv.ok()) {
    r.err = "<session>:" + std::to_string(pv.error_line) + ":" + std::to_string(pv.error_col) +
            ": run-time error: " + pv.error + "\n";
  }
  return r;
}

namespace {

/// What `:set NAME default` restores: the option's value in a fresh RenderCli.
bool reset_option(const std::string& name, RenderCli* cli) {
  const RenderCli d;
  if (name == "size")
    cli->size = d.size;
  else if (name == "bbox")
    cli->bbox = d.bbox;
  else if (name == "eye")
    cli->eye = d.eye;
  else if (name == "look-at")
    cli->look_at = d.look_at;
  else if (name == "up")
    cli->up = d.up;
  else if (name == "fov")
    cli->fov = d.fov;
  else if (name == "ortho")
    cli->ortho = d.ortho;
  else if (name == "root")
    cli->root = d.root;
  else if (name == "spp")
    cli->spp = d.spp;
  else if (name == "threads")
    cli->threads = d.threads;
  else if (name == "a")
    cli->model.params = d.model.params;
  else if (name == "time")
    cli->model.time = d.model.time;
  else if (name == "object")
    cli->model.object = d.model.object;
  else if (name == "light")
    cli->lights = d.lights;
  else if (name == "step")
    cli->step = d.step;
  else if (name == "epsilon")
    cli->epsilon = d.epsilon;
  else if (name == "aov")
    cli->aov = d.aov;
  else if (name == "max-depth")
    cli->max_depth = d.max_depth;
  else if (name == "background")
    cli->background = d.background;
  else if (name == "no-shadows")
    cli->no_shadows = d.no_shadows;
  else if (name == "shadows")
    cli->no_shadows = d.no_shadows;
  else if (name == "no-prune")
    cli->no_prune = d.no_prune;
  else if (name == "backend")
    cli->model.backend = d.model.backend;
  else if (name == "stats")
    cli->stats = d.stats;
  else
    return false;
  return true;
}

/// on/off (true/false, yes/no, 1/0) for the flags; false when it is none of them.
bool parse_switch(const std::string& value, bool* on) {
  if (value == "on" || value == "true" || value == "yes" || value == "1") {
    *on = true;
  } else if (value == "off" || value == "false" || value == "no" || value == "0") {
    *on = false;
  } else {
    return false;
  }
  return true;
}

}  // namespace

bool Session::apply_options(const std::vector<std::string>& words, std::string* err) {
  RenderCli cli = cli_;
  CLI::App app{"render options", ":render"};
  app.set_help_flag();  // no --help here: :help is the session's
  app.allow_extras(false);
  add_render_options(app, &cli);
  try {
    std::vector<std::string> args(words.rbegin(), words.rend());  // CLI11 parses from the back
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    *err = std::string("hfrt: ") + e.what();
    return false;
  }
  app::RenderSetup setup;
  if (!translate_render_options(cli, &setup, err)) {
    *err = "hfrt: " + *err;
    return false;
  }
  cli_ = std::move(cli);
  setup_ = std::move(setup);
  view_key_.clear();  // a changed option frames anew
  settings_.options = setup_.options;
  settings_.camera = setup_.camera;
  return true;
}

SessionResult Session::cmd_set(const std::vector<std::string>& args) {
  if (args.size() < 2) return failure("hfrt: :set expects OPTION VALUE (:help lists the options)");
  std::string name = args[0];
  while (!name.empty() && name[0] == '-') name.erase(0, 1);
  const std::vector<std::string>& known = render_option_names();
  if (name != "shadows" && std::find(known.begin(), known.end(), name) == known.end()) {
    return failure("hfrt: unknown render option '" + args[0] + "' (:help lists them)");
  }
  std::string err;
  RenderCli saved = cli_;
  if (args.size() == 2 && args[1] == "default") {
    reset_option(name, &cli_);
    app::RenderSetup setup;
    if (!translate_render_options(cli_, &setup, &err)) {  // cannot fail: defaults are valid
      cli_ = saved;
      return failure("hfrt: " + err);
    }
    setup_ = std::move(setup);
    settings_.options = setup_.options;
    settings_.camera = setup_.camera;
    view_key_.clear();
    return success("");
  }
  // The spellings of the first REPL: "auto" for a framed camera, "off" for perspective.
  std::vector<std::string> values(args.begin() + 1, args.end());
  if (values.size() == 1 &&
      ((values[0] == "auto" && (name == "eye" || name == "look-at" || name == "up")) ||
       (values[0] == "off" && name == "ortho"))) {
    values[0] = name == "ortho" ? "0" : "";
  }
  std::vector<std::string> words;
  if (render_option_is_flag(name) || name == "shadows") {
    bool on = false;
    if (values.size() != 1 || !parse_switch(values[0], &on)) {
      return failure("hfrt: " + name + " expects on or off (got '" + values[0] + "')");
    }
    if (name == "shadows") {
      name = "no-shadows";
      on = !on;
    }
    // A flag can only be raised by the parser: lower it first.
    reset_option(name, &cli_);
    if (on) words.push_back("--" + name);
  } else {
    words.push_back(name == "a" ? "-a" : "--" + name);
    if (name == "light") reset_option(name, &cli_);  // :set replaces the lights
    for (const std::string& v : values) words.push_back(v);
  }
  if (!apply_options(words, &err)) {
    cli_ = saved;
    return failure(err);
  }
  return success("");
}

SessionResult Session::cmd_render(const std::vector<std::string>& args) {
  if (args.empty() && last_output_.empty()) return failure("hfrt: :render expects OUT [options]");
  if (current_.empty()) return failure("hfrt: no current object (define one or :load a file)");
  // Options first (all or nothing), then the render; a failed render keeps the old options.
  RenderCli saved_cli = cli_;
  app::RenderSetup saved_setup = setup_;
  std::string out = args.empty() ? last_output_ : args[0];
  if (!out.empty() && out[0] == '-')
    return failure("hfrt: :render expects OUT first, then options");
  std::string err;
  if (args.size() > 1) {
    // A repeated option given here replaces the remembered list (as on the command line).
    std::vector<std::string> words(args.begin() + 1, args.end());
    if (std::find(words.begin(), words.end(), "--light") != words.end()) cli_.lights.clear();
    if (!apply_options(words, &err)) {
      cli_ = saved_cli;
      return failure(err);
    }
  }
  SessionResult r = render_to(out);
  if (!r.ok) {
    cli_ = saved_cli;
    setup_ = saved_setup;
    settings_.options = setup_.options;
    settings_.camera = setup_.camera;
  }
  return r;
}

SessionResult Session::render_to(const std::string& out) {
  const std::string object = cli_.model.object.empty() ? current_ : cli_.model.object;
  std::string err;
  const Model* m = model_for(source(), object, &err, 0, "<session>");
  if (!m) return failure(err);
  auto t0 = std::chrono::steady_clock::now();
  // -a and --time: the cached model gets them for this render and its own back afterwards.
  Model& model = const_cast<Model&>(*m);
  ScopedModelSettings scoped(model, setup_.params, setup_.time);

  app::RenderJob job;
  job.model = &model;
  job.file = "<session>";
  job.setup = setup_;
  job.setup.options.cancel = &cancel_;
  // The view of the last render of this object with these options (see ViewCache).
  std::string key = object + '\x1f' + cli_.size + '\x1f' + cli_.bbox + '\x1f' + cli_.eye + '\x1f' +
                    cli_.look_at + '\x1f' + cli_.up + '\x1f' + std::to_string(cli_.fov) + '\x1f' +
                    std::to_string(cli_.ortho) + '\x1f' + cli_.root + '\x1f' + cli_.model.params +
                    '\x1f' + cli_.model.time + '\x1f' + cli_.model.backend + '\x1f' +
                    std::to_string(cli_.threads);
  if (view_key_ == key) job.view = &view_;
  job.on_coarse = on_coarse;
  // The full picture comes quickly (see on_coarse) when the last render of this view was quick
  // and ran the same code: this model's, or the code it shares (a numbers-only edit).
  const bool same_code = model.code_key() == view_code_key_ &&
                         (&model == view_model_ || model.shares_code()) && !compile_running(model);
  if (view_key_ == key && view_render_ms_ < kQuickRenderMs && same_code) job.on_coarse = nullptr;
  // Into the image buffer of the render before last (the last one is still shown): its pages
  // are already mapped.
  render::RenderResult result;
  result.image = std::move(spare_image_);
  app::RenderJobResult done = app::run_render_job(job, &result);
  std::string warnings;
  for (const std::string& w : done.warnings) warnings += w + "\n";
  if (!warnings.empty()) std::fputs(warnings.c_str(), stderr);
  if (done.status == app::RenderJobStatus::kSourceError) return failure(done.error);
  if (done.status == app::RenderJobStatus::kUsageError) return failure("hfrt: " + done.error);
  view_key_ = key;
  view_ = done.view;
  view_render_ms_ = done.status == app::RenderJobStatus::kCancelled
                        ? std::numeric_limits<double>::infinity()
                        : done.render_ms;
  view_model_ = &model;
  view_code_key_ = model.code_key();
  timings_.prepare = done.report.prepare_ms;
  timings_.frame = done.report.framing.ms;
  timings_.probe = done.report.root.probe_ms;
  timings_.render = done.render_ms;
  if (done.status == app::RenderJobStatus::kCancelled) {
    spare_image_ = std::move(result.image);
    return failure("hfrt: render cancelled");
  }
  const render::RenderOptions& opt = done.options;
  auto t_write = std::chrono::steady_clock::now();
  // The REPL writes for the next look, not for keeping: the fast PNG settings.
  auto written = render::write_image(result.image, out, setup_.aovs, render::PngCompression::kFast);
  timings_.write = ms_since(t_write);
  if (!written.ok()) return failure("hfrt: " + written.error().message);
  last_render_ms_ = ms_since(t0);
  last_output_ = out;
  if (last_image_) spare_image_ = std::move(*last_image_);
  last_image_ = std::move(result.image);
  ++renders_;
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s %dx%d %.1f ms", out.c_str(), opt.width, opt.height,
                last_render_ms_);
  std::string text = buf;
  for (size_t i = 1; i < written.value().size(); ++i) text += "\n" + written.value()[i];
  if (cli_.stats) {
    app::RenderReport report = done.report;
    report.compile_ms = last_compile_ms_;
    text += "\n" + app::format_render_stats(report);
  }
  SessionResult r = success(text);
  if (result.stats.evals.nan_samples > 0) {
    r.err = "hfrt: warning: F has no value at " + std::to_string(result.stats.evals.nan_samples) +
            " samples (counted as outside)\n";
  }
  r.rendered = true;
  return r;
}

SessionResult Session::watch_step(const std::string& file) {
  SessionResult r = cmd_load({file});
  if (!r.ok || last_output_.empty()) {
    cancel_.store(false);
    return r;
  }
  SessionResult rr = cmd_render({});
  rr.out = r.out + rr.out;
  rr.err = r.err + rr.err;
  cancel_.store(false);
  return rr;
}

SessionResult Session::cmd_show() const {
  std::ostringstream s;
  s << "current: " << (current_.empty() ? "(none)" : current_) << "\n";
  s << "objects:";
  for (const auto& o : objects_) s << ' ' << o.first;
  s << "\n";
  const auto& o = settings_.options;
  const auto& c = settings_.camera;
  auto vec = [](const std::optional<render::Vec3>& v) {
    if (!v) return std::string("auto");
    char b[96];
    std::snprintf(b, sizeof b, "%g,%g,%g", v->x, v->y, v->z);
    return std::string(b);
  };
  s << "size " << o.width << "x" << o.height << "\n";
  s << "bbox " << o.bbox.lo.x << "," << o.bbox.lo.y << "," << o.bbox.lo.z << "," << o.bbox.hi.x
    << "," << o.bbox.hi.y << "," << o.bbox.hi.z << "\n";
  s << "eye " << vec(c.eye) << "\nlook-at " << vec(c.look_at) << "\nup " << vec(c.up) << "\n";
  s << "fov " << (c.fov_deg ? std::to_string(*c.fov_deg) : "35") << "\n";
  s << "ortho " << (c.ortho_width ? std::to_string(*c.ortho_width) : "off") << "\n";
  s << "root " << render::root_mode_name(o.root) << "\nspp " << o.spp << "\nthreads " << o.threads
    << "\n";
  s << "shadows " << (o.shadows ? "on" : "off") << "\n";
  if (!o.pruned_tapes) s << "no-prune on\n";
  auto typed = [&s](const char* name, const std::string& v) {
    s << name << ' ' << (v.empty() ? "default" : v) << "\n";
  };
  std::string lights;
  for (const std::string& l : cli_.lights) lights += (lights.empty() ? "" : " ") + l;
  typed("light", lights);
  typed("a", cli_.model.params);
  typed("time", cli_.model.time);
  typed("object", cli_.model.object.empty() ? "" : cli_.model.object);
  typed("aov", cli_.aov);
  typed("background", cli_.background);
  s << "step " << o.step << "\nepsilon " << o.epsilon << "\n";
  s << "backend " << cli_.model.backend << "\nstats " << (cli_.stats ? "on" : "off") << "\n";
  if (!last_output_.empty()) s << "output " << last_output_ << "\n";
  return success(s.str());
}

SessionResult Session::cmd_objects() const {
  std::string s;
  for (const auto& o : objects_) s += o.first + (o.first == current_ ? " *\n" : "\n");
  return success(s);
}

SessionResult Session::cmd_stats() const {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "objects %zu, compiles %d, cached models %zu, last compile %.1f ms, renders %d "
                "(last %.1f ms), evals %d",
                objects_.size(), compiles_, cache_.size(), last_compile_ms_, renders_,
                last_render_ms_, evals_);
  return success(buf);
}

}  // namespace hfrt::tools

namespace hfrt::tools {

SessionResult Session::cmd_mesh(const std::vector<std::string>& args) {
  if (args.empty() || args.size() > 2) return failure("hfrt: :mesh expects OUT [RESOLUTION]");
  if (current_.empty()) return failure("hfrt: no current object (define one or :load a file)");
  int resolution = 128;
  if (args.size() == 2) {
    char* end = nullptr;
    const long v = std::strtol(args[1].c_str(), &end, 10);
    if (*end || v < 1 || v > 8192) {
      return failure("hfrt: :mesh: RESOLUTION expects a cell count from 1 to 8192 (got '" +
                     args[1] + "')");
    }
    resolution = int(v);
  }
  if (!mesher::mesh_format_for(args[0])) {
    return failure("hfrt: " + args[0] + ": unknown mesh format (expected " +
                   mesher::mesh_formats_list() + ")");
  }
  const std::string object = cli_.model.object.empty() ? current_ : cli_.model.object;
  std::string err;
  const Model* m = model_for(source(), object, &err, 0, "<session>");
  if (!m) return failure(err);
  // -a and --time: as in render_to, for this mesh only.
  Model& model = const_cast<Model&>(*m);
  ScopedModelSettings scoped(model, setup_.params, setup_.time);
  app::MeshJob job;
  job.model = &model;
  job.file = "<session>";
  job.bbox_given = !cli_.bbox.empty();
  if (job.bbox_given) job.bbox = setup_.options.bbox;
  job.resolution = resolution;
  job.threads = setup_.options.threads;
  app::MeshJobResult r = app::run_mesh_job(job);
  for (const std::string& w : r.warnings) std::fprintf(stderr, "%s\n", w.c_str());
  if (r.status != app::MeshJobStatus::kOk) return failure(r.error);
  auto written = mesher::write_mesh(args[0], r.mesh);
  if (!written.ok()) return failure("hfrt: " + written.error().message);
  char buf[200];
  std::snprintf(buf, sizeof buf, "%s %zu vertices, %zu triangles, %.1f ms", args[0].c_str(),
                r.mesh.vertices.size(), r.mesh.triangles.size(), r.stats.seconds_total * 1e3);
  return success(buf);
}

}  // namespace hfrt::tools
