#include "tools/hfrt/session.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "tools/hfrt/model_field.h"

namespace hfrt::tools {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

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

bool parse_float_list(const std::string& s, size_t count, std::vector<float>* out) {
  return parse_floats(s, out, count);
}

bool parse_vec3(const std::string& s, render::Vec3* v) {
  std::vector<float> f;
  if (!parse_float_list(s, 3, &f)) return false;
  *v = render::Vec3{f[0], f[1], f[2]};
  return true;
}

/// The name of the object a definition defines: its first identifier (comments skipped).
std::string object_name(std::string_view text) {
  size_t i = 0;
  while (i < text.size()) {
    if (std::isspace(static_cast<unsigned char>(text[i]))) {
      ++i;
    } else if (text.compare(i, 2, "--") == 0) {
      while (i < text.size() && text[i] != '\n') ++i;
    } else {
      break;
    }
  }
  size_t b = i;
  while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '_')) ++i;
  return std::string(text.substr(b, i - b));
}

/// Splits a file into object definitions: each ends where its braces balance.
std::vector<std::string> split_objects(std::string_view text) {
  std::vector<std::string> out;
  std::string cur;
  int depth = 0;
  bool opened = false;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t nl = text.find('\n', pos);
    std::string_view line = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos + 1);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    cur += line;
    int d = brace_delta(line);
    if (line.find('{') != std::string_view::npos) opened = true;
    depth += d;
    if (opened && depth <= 0) {
      out.push_back(cur);
      cur.clear();
      depth = 0;
      opened = false;
    }
  }
  if (!trim(cur).empty() && opened) out.push_back(cur);
  return out;
}

int count_lines(std::string_view s) { return int(std::count(s.begin(), s.end(), '\n')); }

/// Diagnostics of a compile, with lines moved by `line_offset` and named `file`; those outside
/// the typed text (line <= 0 after the shift) keep the session-source location.
std::string format_diagnostics(const CompileResult& r, int line_offset, std::string_view file) {
  if (!r.error.empty()) return "hfrt: " + r.error + "\n";
  std::string out;
  for (const SourceDiagnostic& d : r.diagnostics) {
    int line = d.line - line_offset;
    std::string where = line > 0 ? std::string(file) + ":" + std::to_string(line) + ":" + std::to_string(d.col)
                                 : "<session>:" + std::to_string(d.line) + ":" + std::to_string(d.col);
    const char* sev = d.severity == SourceDiagnostic::Severity::kError     ? "error"
                      : d.severity == SourceDiagnostic::Severity::kWarning ? "warning"
                                                                           : "note";
    out += where + ": " + sev + ": " + d.message + "\n";
    if (!d.hint.empty()) out += "  hint: " + d.hint + "\n";
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
    "  :render OUT [options]      render to OUT; options (as hfrt render) are remembered\n"
    "  :set OPTION VALUE          set a render option (size, bbox, eye, look-at, up, fov, ortho,\n"
    "                             root, spp, threads, step, epsilon, background, shadows)\n"
    "  :show  :objects  :stats    session state\n"
    "  :watch FILE                reload and re-render whenever FILE changes (Ctrl-C stops)\n"
    "  :preview off|ansi          inline preview in a terminal\n"
    "  :help  :quit\n";

}  // namespace

int brace_delta(std::string_view line) {
  int d = 0;
  for (size_t i = 0; i < line.size(); ++i) {
    if (line.compare(i, 2, "--") == 0) break;
    if (line[i] == '{') ++d;
    if (line[i] == '}') --d;
  }
  return d;
}

std::string ansi_preview(const render::Image& image, int max_cols) {
  if (image.width <= 0 || image.height <= 0 || image.rgb.empty()) return "";
  const int cols = std::max(1, std::min(max_cols, image.width));
  const double scale = double(image.width) / cols;
  const int rows = std::max(1, int(image.height / scale));  // pixel rows after scaling
  auto pixel = [&](int col, int row, int c) {
    int x = std::min(image.width - 1, int(col * scale));
    int y = std::min(image.height - 1, int(row * scale));
    float v = image.rgb[(size_t(y) * image.width + x) * 3 + c];
    v = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(std::max(v, 0.0f), 1 / 2.4f) - 0.055f;
    return std::clamp(int(std::lround(v * 255)), 0, 255);
  };
  std::string out;
  char buf[64];
  for (int r = 0; r < rows; r += 2) {
    for (int c = 0; c < cols; ++c) {
      int lower = std::min(r + 1, rows - 1);
      std::snprintf(buf, sizeof buf, "\x1b[38;2;%d;%d;%dm\x1b[48;2;%d;%d;%dm", pixel(c, r, 0),
                    pixel(c, r, 1), pixel(c, r, 2), pixel(c, lower, 0), pixel(c, lower, 1),
                    pixel(c, lower, 2));
      out += buf;
      out += "\xe2\x96\x80";  // U+2580 upper half block: fg = upper pixel, bg = lower pixel
    }
    out += "\x1b[0m\n";
  }
  return out;
}

Session::Session() = default;

const std::vector<std::string>& Session::command_names() {
  static const std::vector<std::string> names = {":load",    ":eval",  ":render", ":set",
                                                 ":show",    ":objects", ":stats", ":watch",
                                                 ":preview", ":help",  ":quit"};
  return names;
}

std::vector<std::string> Session::option_names() {
  return {"size", "bbox", "eye", "look-at", "up", "fov", "ortho", "root", "spp", "threads",
          "step", "epsilon", "background", "shadows", "no-shadows"};
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
  pending_depth_ += brace_delta(line);
  bool opened = pending_.find('{') != std::string::npos;
  if (!opened || pending_depth_ > 0) return std::nullopt;
  std::string text = std::move(pending_);
  pending_.clear();
  pending_depth_ = 0;
  return run(text);
}

SessionResult Session::run(std::string_view input) {
  std::string t = trim(input);
  if (t.empty()) return SessionResult{};
  if (t[0] != ':') return define(input);
  std::vector<std::string> words = split_words(t);
  std::string cmd = words[0];
  std::vector<std::string> args(words.begin() + 1, words.end());
  if (cmd == ":load") return cmd_load(args);
  if (cmd == ":eval") return cmd_eval(args);
  if (cmd == ":render") return cmd_render(args);
  if (cmd == ":set") return cmd_set(args);
  if (cmd == ":show") return cmd_show();
  if (cmd == ":objects") return cmd_objects();
  if (cmd == ":stats") return cmd_stats();
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
  auto key = std::make_pair(source, object);
  auto it = cache_.find(key);
  if (it != cache_.end()) return &it->second;
  ModelOptions mo;
  mo.object = object;
  mo.eager_f32 = true;
  auto t0 = std::chrono::steady_clock::now();
  CompileResult r = Model::compile(source, mo, "<session>");
  ++compiles_;
  if (!r.ok()) {
    *err = format_diagnostics(r, line_offset, file);
    return nullptr;
  }
  last_compile_ms_ = ms_since(t0);
  // A small cache: the session's models change rarely, but keep memory bounded.
  if (cache_.size() >= 16) cache_.clear();
  return &cache_.emplace(std::move(key), std::move(*r.model)).first->second;
}

SessionResult Session::define(std::string_view text) {
  std::string name = object_name(text);
  if (name.empty()) return failure("<input>:1:1: error: expected an object definition `name(x[3], a[1]) { ... }`");
  // The candidate source: the object replaced in place, or appended.
  auto objects = objects_;
  auto it = std::find_if(objects.begin(), objects.end(), [&](const auto& o) { return o.first == name; });
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
  mo.eager_f32 = true;
  auto t0 = std::chrono::steady_clock::now();
  CompileResult alone = Model::compile(text, mo, args[0]);
  ++compiles_;
  last_compile_ms_ = ms_since(t0);
  if (!alone.ok()) return failure(alone.error.empty() ? alone.rendered : "hfrt: " + alone.error);
  std::vector<std::string> defs = split_objects(text);
  auto objects = objects_;
  std::string current;
  for (const std::string& d : defs) {
    std::string name = object_name(d);
    if (name.empty()) continue;
    auto it = std::find_if(objects.begin(), objects.end(), [&](const auto& o) { return o.first == name; });
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
  if (src == text && alone.model->object_name() == current) {
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
    if (!parse_double(args[i], &v)) return failure("hfrt: :eval cannot read '" + args[i] + "' as a number");
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

bool Session::apply_option(const std::string& name_in, const std::string& value, std::string* err) {
  std::string name = name_in;
  while (!name.empty() && name[0] == '-') name.erase(0, 1);
  render::RenderOptions& o = settings_.options;
  render::CameraRequest& c = settings_.camera;
  render::Vec3 v;
  std::vector<float> f;
  double d = 0;
  auto bad = [&](const char* what) {
    *err = "hfrt: " + name + " expects " + what + " (got '" + value + "')";
    return false;
  };
  if (name == "size") {
    int w = 0, h = 0;
    char x = 0, extra = 0;
    if (std::sscanf(value.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || x != 'x' || w < 1 || h < 1 ||
        w > 16384 || h > 16384) {
      return bad("WxH");
    }
    o.width = w;
    o.height = h;
  } else if (name == "bbox") {
    if (!parse_float_list(value, 6, &f) || !(f[0] < f[3] && f[1] < f[4] && f[2] < f[5])) {
      return bad("xmin,ymin,zmin,xmax,ymax,zmax with min < max");
    }
    o.bbox = render::Box{{f[0], f[1], f[2]}, {f[3], f[4], f[5]}};
  } else if (name == "eye" || name == "look-at" || name == "up" || name == "background") {
    if (value == "auto" && name != "background") {
      (name == "eye" ? c.eye : name == "up" ? c.up : c.look_at).reset();
      return true;
    }
    if (!parse_vec3(value, &v)) return bad("x,y,z");
    if (name == "eye") c.eye = v;
    if (name == "look-at") c.look_at = v;
    if (name == "up") c.up = v;
    if (name == "background") o.background = v;
  } else if (name == "fov") {
    if (!parse_double(value, &d) || !(d > 0 && d < 180)) return bad("degrees in (0, 180)");
    c.fov_deg = float(d);
  } else if (name == "ortho") {
    if (value == "off") {
      c.ortho_width.reset();
      return true;
    }
    if (!parse_double(value, &d) || !(d > 0)) return bad("a positive view width, or off");
    c.ortho_width = float(d);
  } else if (name == "root") {
    if (value == "sign") {
      o.root = render::RootMode::kSign;
    } else if (value == "interval") {
      o.root = render::RootMode::kInterval;
    } else if (value == "auto") {
      o.root = render::RootMode::kAuto;
    } else {
      return bad("sign, interval or auto");
    }
  } else if (name == "spp") {
    if (!parse_double(value, &d) || d != std::floor(d) || d < 1 || d > 4096) return bad("1..4096");
    o.spp = int(d);
  } else if (name == "threads") {
    if (!parse_double(value, &d) || d != std::floor(d) || d < 0) return bad("a count (0: all cores)");
    o.threads = int(d);
  } else if (name == "step" || name == "epsilon") {
    if (!parse_double(value, &d) || d < 0) return bad("a non-negative length (0: default)");
    (name == "step" ? o.step : o.epsilon) = float(d);
  } else if (name == "shadows") {
    if (value != "on" && value != "off") return bad("on or off");
    o.shadows = value == "on";
  } else {
    *err = "hfrt: unknown render option '" + name_in + "'";
    return false;
  }
  return true;
}

SessionResult Session::cmd_set(const std::vector<std::string>& args) {
  if (args.size() != 2) return failure("hfrt: :set expects OPTION VALUE");
  std::string err;
  SessionRenderSettings saved = settings_;
  if (!apply_option(args[0], args[1], &err)) {
    settings_ = saved;
    return failure(err);
  }
  return success("");
}

SessionResult Session::cmd_render(const std::vector<std::string>& args) {
  if (args.empty() && last_output_.empty()) return failure("hfrt: :render expects OUT [options]");
  if (current_.empty()) return failure("hfrt: no current object (define one or :load a file)");
  // Options first (all or nothing), then the render.
  SessionRenderSettings saved = settings_;
  std::string out = args.empty() ? last_output_ : args[0];
  std::string err;
  for (size_t i = 1; i < args.size(); ++i) {
    std::string name = args[i];
    if (name == "--no-shadows") {
      settings_.options.shadows = false;
      continue;
    }
    std::string value;
    size_t eq = name.find('=');
    if (eq != std::string::npos) {
      value = name.substr(eq + 1);
      name = name.substr(0, eq);
    } else if (i + 1 < args.size()) {
      value = args[++i];
    } else {
      settings_ = saved;
      return failure("hfrt: " + name + " needs a value");
    }
    if (!apply_option(name, value, &err)) {
      settings_ = saved;
      return failure(err);
    }
  }
  const Model* m = model_for(source(), current_, &err, 0, "<session>");
  if (!m) {
    settings_ = saved;
    return failure(err);
  }
  auto t0 = std::chrono::steady_clock::now();
  ModelField field(*m, "<session>");
  prepare_render_code(*m, field.has_interval(), /*gradient=*/true);
  render::RenderOptions opt = settings_.options;
  render::Box extent = opt.bbox;
  if (!settings_.camera.eye || !settings_.camera.look_at) extent = render::find_extent(field, opt.bbox, 6);
  opt.camera = render::resolve_camera(settings_.camera, extent, float(opt.width) / float(opt.height));
  render::Vec3 view = opt.camera.look_at - opt.camera.eye;
  if (length(view) == 0 || length(cross(normalize(view), normalize(opt.camera.up))) < 1e-6f) {
    settings_ = saved;
    return failure("hfrt: the camera is degenerate (eye = look-at, or up parallel to the view)");
  }
  render::RenderResult result = render::render(field, opt);
  auto written = render::write_image(result.image, out);
  if (!written.ok()) {
    settings_ = saved;
    return failure("hfrt: " + written.error().message);
  }
  last_render_ms_ = ms_since(t0);
  last_output_ = out;
  last_image_ = std::move(result.image);
  ++renders_;
  char buf[128];
  std::snprintf(buf, sizeof buf, "%s %dx%d %.1f ms", out.c_str(), opt.width, opt.height, last_render_ms_);
  SessionResult r = success(buf);
  r.rendered = true;
  return r;
}

SessionResult Session::watch_step(const std::string& file) {
  SessionResult r = cmd_load({file});
  if (!r.ok || last_output_.empty()) return r;
  SessionResult rr = cmd_render({});
  rr.out = r.out + rr.out;
  rr.err = r.err + rr.err;
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
  s << "bbox " << o.bbox.lo.x << "," << o.bbox.lo.y << "," << o.bbox.lo.z << "," << o.bbox.hi.x << ","
    << o.bbox.hi.y << "," << o.bbox.hi.z << "\n";
  s << "eye " << vec(c.eye) << "\nlook-at " << vec(c.look_at) << "\nup " << vec(c.up) << "\n";
  s << "fov " << (c.fov_deg ? std::to_string(*c.fov_deg) : "35") << "\n";
  s << "ortho " << (c.ortho_width ? std::to_string(*c.ortho_width) : "off") << "\n";
  s << "root " << render::root_mode_name(o.root) << "\nspp " << o.spp << "\nthreads " << o.threads << "\n";
  s << "shadows " << (o.shadows ? "on" : "off") << "\n";
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
                objects_.size(), compiles_, cache_.size(), last_compile_ms_, renders_, last_render_ms_,
                evals_);
  return success(buf);
}

}  // namespace hfrt::tools
