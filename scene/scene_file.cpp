// Scene files: TOML (toml++) to a validated SceneDesc. Every check stops at the first problem
// and locates it at the key or value toml++ recorded (docs/scenes.md lists the keys).
#include "scene/scene_file.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <string_view>

#include "base/check.h"
#include "base/file.h"

namespace hfrt::scene {
namespace {

namespace fs = std::filesystem;

// Lines longer than this are shown as a window around the caret (as compile errors do).
constexpr size_t kMaxShownLine = 160;
constexpr size_t kWindowBefore = 80;

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

/// Edit distance (insertions, deletions, substitutions) for "did you mean".
size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

/// The nearest of `choices` to `word` when it is a plausible misspelling, else "".
std::string nearest(std::string_view word, const std::vector<std::string>& choices) {
  std::string best;
  size_t best_d = std::max<size_t>(1, std::min<size_t>(2, word.size() / 3)) + 1;
  for (const std::string& c : choices) {
    size_t d = edit_distance(word, c);
    // A key with a suffix added or dropped ("reflection" for "reflect") is a near miss too.
    const size_t shorter = std::min(word.size(), c.size());
    if (shorter >= 3 && (c.rfind(word, 0) == 0 || word.rfind(c, 0) == 0))
      d = std::min<size_t>(d, 1);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

std::string join(const std::vector<std::string>& words, const char* sep = ", ") {
  std::string out;
  for (size_t i = 0; i < words.size(); ++i) out += (i ? sep : "") + words[i];
  return out;
}

std::string quoted_list(const std::vector<std::string>& words) {
  std::vector<std::string> q;
  for (const std::string& w : words) q.push_back("\"" + w + "\"");
  if (q.size() <= 1) return join(q);
  std::string last = q.back();
  q.pop_back();
  return join(q) + " or " + last;
}

const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string:
      return "a string";
    case toml::node_type::integer:
      return "an integer";
    case toml::node_type::floating_point:
      return "a float";
    case toml::node_type::boolean:
      return "a boolean";
    case toml::node_type::date:
      return "a date";
    case toml::node_type::time:
      return "a time";
    case toml::node_type::date_time:
      return "a date-time";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::table:
      return "a table";
    default:
      return "nothing";
  }
}

bool before(const toml::source_region& a, const toml::source_region& b) {
  return a.begin.line != b.begin.line ? a.begin.line < b.begin.line
                                      : a.begin.column < b.begin.column;
}

/// Reads one document. Every method returns false after recording the (first) error.
class Reader {
 public:
  Reader(const std::string& text, const std::string& path, SceneDesc* out, SceneError* err)
      : text_(text), path_(path), out_(out), err_(err) {
    const fs::path parent = fs::path(path).parent_path();
    folder_ = parent.string();
  }

  bool read() {
    *out_ = SceneDesc{};
    out_->path = path_;
    toml::table root;
    try {
      root = toml::parse(std::string_view(text_), std::string_view(path_));
    } catch (const toml::parse_error& e) {
      return fail(e.source(), "invalid TOML: " + std::string(e.description()));
    }
    if (!check_keys(root, "the scene file", "at the top level",
                    {"camera", "render", "light", "material", "object", "animation"}))
      return false;
    if (const toml::node* n = root.get("camera")) {
      const toml::table* t = table_of(*n, "camera", "[camera]");
      if (!t || !read_camera(*t)) return false;
    }
    if (const toml::node* n = root.get("render")) {
      const toml::table* t = table_of(*n, "render", "[render]");
      if (!t || !read_render(*t)) return false;
    }
    if (const toml::node* n = root.get("animation")) {
      const toml::table* t = table_of(*n, "animation", "[animation]");
      if (!t || !read_animation(*t)) return false;
    }
    // Materials before objects: objects name them.
    if (const toml::node* n = root.get("material")) {
      if (!read_materials(*n)) return false;
    }
    if (const toml::node* n = root.get("light")) {
      const toml::array* a = array_of_tables(*n, "light");
      if (!a) return false;
      for (const toml::node& e : *a) {
        if (!read_light(*e.as_table())) return false;
      }
    }
    if (const toml::node* n = root.get("object")) {
      const toml::array* a = array_of_tables(*n, "object");
      if (!a) return false;
      for (const toml::node& e : *a) {
        if (!read_object(*e.as_table())) return false;
      }
    }
    if (out_->objects.empty()) {
      SceneError& e = *err_;
      e = SceneError{};
      e.pos.file = path_;
      e.message = "the scene has no objects";
      e.hint = "add an [[object]] table with file = \"model.hf\" (or source = \"...\")";
      return false;
    }
    out_->keyed_params.resize(out_->objects.size(), false);
    return true;
  }

 private:
  bool fail(const toml::source_region& where, std::string message, std::string hint = {}) {
    SceneError& e = *err_;
    e = SceneError{};
    e.pos.file = path_;
    e.pos.line = static_cast<int>(where.begin.line);
    e.pos.column = static_cast<int>(where.begin.column);
    e.message = std::move(message);
    e.hint = std::move(hint);
    e.line_text = line_text(e.pos.line);
    if (where.end.line == where.begin.line && where.end.column > where.begin.column)
      e.length = static_cast<int>(where.end.column - where.begin.column);
    return false;
  }

  /// Where the text of the string value starting at `where` begins: after its opening quote
  /// (or three), and on the next line when a newline follows triple quotes (TOML drops it).
  SourcePos text_start(const toml::source_region& where) const {
    SourcePos p;
    p.file = path_;
    p.line = static_cast<int>(where.begin.line);
    p.column = static_cast<int>(where.begin.column);
    const std::string line = line_text(p.line);
    size_t byte = 0;  // byte offset of the value's column (columns count code points)
    for (int c = 1; c < p.column && byte < line.size(); ++c) {
      ++byte;
      while (byte < line.size() && (static_cast<unsigned char>(line[byte]) & 0xC0) == 0x80) ++byte;
    }
    const bool triple = line.compare(byte, 3, "\"\"\"") == 0 || line.compare(byte, 3, "'''") == 0;
    if (triple && line.size() == byte + 3) {
      p.line += 1;
      p.column = 1;
    } else {
      p.column += triple ? 3 : 1;
    }
    return p;
  }

  std::string line_text(int line) const {
    if (line <= 0) return {};
    size_t start = 0;
    for (int l = 1; l < line; ++l) {
      start = text_.find('\n', start);
      if (start == std::string::npos) return {};
      ++start;
    }
    size_t end = text_.find('\n', start);
    std::string s = text_.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!s.empty() && s.back() == '\r') s.pop_back();
    return s;
  }

  /// Every key of `t` must be one of `allowed`; `what` names the table in messages ("[camera]"),
  /// `where` says where the keys sit ("in [camera]").
  bool check_keys(const toml::table& t, const std::string& what, const std::string& where,
                  std::initializer_list<const char*> allowed) {
    std::vector<std::string> names(allowed.begin(), allowed.end());
    const toml::key* first = nullptr;
    for (auto&& [k, v] : t) {
      (void)v;
      if (std::find(names.begin(), names.end(), k.str()) != names.end()) continue;
      if (!first || before(k.source(), first->source())) first = &k;
    }
    if (!first) return true;
    std::string hint;
    const std::string near = nearest(first->str(), names);
    if (!near.empty()) hint = "did you mean '" + near + "'? ";
    hint += what + " has: " + join(names);
    return fail(first->source(), "unknown key '" + std::string(first->str()) + "' " + where, hint);
  }

  const toml::table* table_of(const toml::node& n, const std::string& key,
                              const std::string& shown) {
    if (const toml::table* t = n.as_table()) return t;
    fail(n.source(), "'" + key + "' must be a table (" + shown + "), not " + type_name(n));
    return nullptr;
  }

  const toml::array* array_of_tables(const toml::node& n, const std::string& key) {
    const toml::array* a = n.as_array();
    if (!a || !a->is_array_of_tables()) {
      fail(n.source(),
           "'" + key + "' must be an array of tables ([[" + key + "]]), not " +
               (n.is_table() ? "a single table ([" + key + "])" : std::string(type_name(n))));
      return nullptr;
    }
    return a;
  }

  // --- typed values ------------------------------------------------------------------------

  /// Writes a number's value at a time into a SceneDesc (for keyed numbers).
  using Setter = std::function<void(SceneDesc&, double)>;
  /// The same for component i of a vector (or element i of params).
  using IndexSetter = std::function<void(SceneDesc&, size_t, double)>;

  /// A number; where `set` is given, also keys (`{ keys = [[t, v], ...] }`): then *out is the
  /// value at time 0 and the keys are recorded with `set` (SceneDesc::keyed). Either way
  /// values_ lists every value read with its node, for the callers' range checks.
  bool number(const toml::node& n, const std::string& what, double* out, const Setter& set = {}) {
    values_.clear();
    if (const toml::table* t = n.as_table()) {
      if (!set) {
        return fail(n.source(), what + " cannot be keyed: it must be a number",
                    std::string("keys are for ") + keyable_numbers());
      }
      return keys(*t, what, out, set);
    }
    if (!plain_number(n, what, out)) return false;
    values_.push_back({*out, &n});
    return true;
  }

  bool plain_number(const toml::node& n, const std::string& what, double* out) {
    if (const auto* i = n.as_integer()) {
      *out = static_cast<double>(i->get());
    } else if (const auto* f = n.as_floating_point()) {
      *out = f->get();
      if (!std::isfinite(*out)) return fail(n.source(), what + " must be a finite number");
    } else {
      return fail(n.source(), what + " must be a number, not " + type_name(n));
    }
    return true;
  }

  /// `{ keys = [[t0, v0], [t1, v1], ...] }`.
  bool keys(const toml::table& t, const std::string& what, double* out, const Setter& set) {
    const std::string kwhat = what + " keys";
    if (!check_keys(t, "a keyed number", "in the keys of " + what, {"keys"})) return false;
    const toml::node* k = t.get("keys");
    static const char* kShape =
        "keys = [[time, value], ...]: times increasing; linear between keys, constant outside";
    if (!k) return fail(t.source(), what + " is a table without keys", kShape);
    const toml::array* a = k->as_array();
    if (!a || a->empty()) {
      return fail(k->source(),
                  kwhat + " must be a non-empty array of [time, value] pairs, not " +
                      (a ? std::string("an empty array") : std::string(type_name(*k))),
                  kShape);
    }
    KeyedNumber kn;
    kn.what = what;
    kn.pos = SourcePos{path_, static_cast<int>(t.source().begin.line),
                       static_cast<int>(t.source().begin.column)};
    kn.set = set;
    std::vector<std::pair<double, const toml::node*>> values;
    for (size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      const toml::array* pair = e.as_array();
      const std::string item = kwhat + "[" + std::to_string(i) + "]";
      if (!pair || pair->size() != 2) {
        return fail(
            e.source(),
            item + " must be a [time, value] pair, not " +
                (pair ? "an array of " + std::to_string(pair->size()) : std::string(type_name(e))),
            kShape);
      }
      double time = 0, value = 0;
      if (!plain_number(*pair->get(0), item + " time", &time)) return false;
      if (!plain_number(*pair->get(1), item + " value", &value)) return false;
      if (!kn.keys.keys.empty() && !(time > kn.keys.keys.back()[0])) {
        return fail(pair->get(0)->source(),
                    item + " time must be after the previous key's (" +
                        fmt(kn.keys.keys.back()[0]) + "), not " + fmt(time),
                    kShape);
      }
      kn.keys.keys.push_back({time, value});
      values.push_back({value, pair->get(1)});
    }
    *out = kn.keys.at(0.0);
    out_->keyed.push_back(std::move(kn));
    values_ = std::move(values);
    return true;
  }

  bool integer(const toml::node& n, const std::string& what, long long* out) {
    const auto* i = n.as_integer();
    if (!i) return fail(n.source(), what + " must be an integer, not " + type_name(n));
    *out = i->get();
    return true;
  }

  bool string(const toml::node& n, const std::string& what, std::string* out) {
    const auto* s = n.as_string();
    if (!s) return fail(n.source(), what + " must be a string, not " + type_name(n));
    *out = s->get();
    return true;
  }

  bool boolean(const toml::node& n, const std::string& what, bool* out) {
    const auto* b = n.as_boolean();
    if (!b) return fail(n.source(), what + " must be true or false, not " + type_name(n));
    *out = b->get();
    return true;
  }

  /// An array of exactly `count` numbers (count 0: any length); with `set`, each may be keys.
  /// all_values_ gets every value read (for range checks).
  bool numbers(const toml::node& n, const std::string& what, size_t count, std::vector<double>* out,
               const IndexSetter& set = {}) {
    const toml::array* a = n.as_array();
    const std::string shape =
        count ? "an array of " + std::to_string(count) + " numbers" : "an array of numbers";
    if (!a) return fail(n.source(), what + " must be " + shape + ", not " + type_name(n));
    if (count && a->size() != count) {
      return fail(n.source(), what + " must be " + shape + ", not " + std::to_string(a->size()));
    }
    out->clear();
    all_values_.clear();
    for (size_t i = 0; i < a->size(); ++i) {
      double v = 0;
      Setter one;
      if (set) one = [set, i](SceneDesc& s, double value) { set(s, i, value); };
      if (!number(*a->get(i), what + "[" + std::to_string(i) + "]", &v, one)) return false;
      out->push_back(v);
      for (const auto& [value, node] : values_) all_values_.push_back({value, node, i});
    }
    return true;
  }

  /// A Vec3 component by index (for setters).
  static float& component(render::Vec3& v, size_t i) { return i == 0 ? v.x : i == 1 ? v.y : v.z; }

  /// `place` finds the vector in a SceneDesc (for keyed components); null: not keyable.
  using VecPlace = std::function<render::Vec3&(SceneDesc&)>;

  bool vec3(const toml::node& n, const std::string& what, render::Vec3* out,
            const VecPlace& place = {}) {
    std::vector<double> v;
    IndexSetter set;
    if (place)
      set = [place](SceneDesc& s, size_t i, double x) { component(place(s), i) = float(x); };
    if (!numbers(n, what, 3, &v, set)) return false;
    *out = render::Vec3{float(v[0]), float(v[1]), float(v[2])};
    return true;
  }

  /// A vector whose components are >= 0 (colours, absorption); every key value too.
  bool colour(const toml::node& n, const std::string& what, render::Vec3* out,
              const VecPlace& place = {}) {
    if (!vec3(n, what, out, place)) return false;
    for (const ValueAt& va : all_values_) {
      if (va.value < 0) {
        return fail(va.node->source(),
                    what + "[" + std::to_string(va.index) + "] must be >= 0, not " + fmt(va.value));
      }
    }
    return true;
  }

  /// A number in a range: lo/hi with open (>) or closed (>=) ends; NaN bounds are absent.
  /// With `set`, the number may be keyed: every key's value must be in range.
  bool ranged(const toml::node& n, const std::string& what, double lo, bool lo_open, double hi,
              bool hi_open, float* out, const std::string& unit = "", const Setter& set = {}) {
    double first = 0;
    if (!number(n, what, &first, set)) return false;
    *out = static_cast<float>(first);
    for (const auto& [v, node] : values_) {
      if (!in_range(*node, what, v, lo, lo_open, hi, hi_open, unit)) return false;
    }
    return true;
  }

  bool in_range(const toml::node& n, const std::string& what, double v, double lo, bool lo_open,
                double hi, bool hi_open, const std::string& unit) {
    const bool lo_ok = std::isnan(lo) || (lo_open ? v > lo : v >= lo);
    const bool hi_ok = std::isnan(hi) || (hi_open ? v < hi : v <= hi);
    if (!lo_ok || !hi_ok) {
      std::string range;
      if (std::isnan(hi)) {
        range = std::string(lo_open ? "> " : ">= ") + fmt(lo);
      } else {
        range = std::string("in ") + (lo_open ? "(" : "[") + fmt(lo) + ", " + fmt(hi) +
                (hi_open ? ")" : "]");
      }
      return fail(n.source(), what + " must be " + range + unit + ", not " + fmt(v));
    }
    return true;
  }

  bool at_least(const toml::node& n, const std::string& what, long long lo, int* out) {
    long long v = 0;
    if (!integer(n, what, &v)) return false;
    if (v < lo || v > 1000000000) {
      return fail(n.source(), what + " must be " +
                                  (v < lo ? "at least " + std::to_string(lo)
                                          : std::string("at most 1000000000")) +
                                  ", not " + std::to_string(v));
    }
    *out = static_cast<int>(v);
    return true;
  }

  bool choice(const toml::node& n, const std::string& what, const std::vector<std::string>& ok,
              std::string* out) {
    if (!string(n, what, out)) return false;
    if (std::find(ok.begin(), ok.end(), *out) != ok.end()) return true;
    std::string hint;
    const std::string near = nearest(*out, ok);
    if (!near.empty()) hint = "did you mean \"" + near + "\"? ";
    hint += what + " is one of " + quoted_list(ok);
    return fail(n.source(), "unknown " + what + " \"" + *out + "\"", hint);
  }

  /// A file named by a value: relative names are taken from the scene file's folder; the file
  /// must exist.
  bool existing_file(const toml::node& n, const std::string& what, const std::string& kind,
                     std::string* out) {
    std::string name;
    if (!string(n, what, &name)) return false;
    if (name.empty()) return fail(n.source(), what + " must not be empty");
    fs::path p(name);
    if (p.is_relative() && !folder_.empty()) p = fs::path(folder_) / p;
    p = p.lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(p, ec)) {
      const bool exists = fs::exists(p, ec);
      return fail(n.source(),
                  kind + " '" + name + "' " + (exists ? "is not a file" : "does not exist"),
                  p.string() != name ? "looked for " + p.string() + " (relative names are " +
                                           "taken from the scene file's folder)"
                                     : std::string());
    }
    *out = p.string();
    return true;
  }

  // --- tables --------------------------------------------------------------------------------

  bool read_camera(const toml::table& t) {
    if (!check_keys(t, "[camera]", "in [camera]",
                    {"eye", "look_at", "up", "fov", "ortho", "aperture", "focus_distance"}))
      return false;
    CameraDesc& c = out_->camera;
    out_->has_camera = true;
    render::Vec3 v;
    if (const toml::node* n = t.get("eye")) {
      if (!vec3(*n, "[camera] eye", &v,
                [](SceneDesc& s) -> render::Vec3& { return *s.camera.request.eye; }))
        return false;
      c.request.eye = v;
    }
    if (const toml::node* n = t.get("look_at")) {
      if (!vec3(*n, "[camera] look_at", &v,
                [](SceneDesc& s) -> render::Vec3& { return *s.camera.request.look_at; }))
        return false;
      c.request.look_at = v;
    }
    if (const toml::node* n = t.get("up")) {
      if (!vec3(*n, "[camera] up", &v)) return false;
      if (length(v) <= 0) return fail(n->source(), "[camera] up must not be zero");
      c.request.up = v;
    }
    const toml::node* fov = t.get("fov");
    const toml::node* ortho = t.get("ortho");
    if (fov && ortho) {
      const toml::node* second = before(fov->source(), ortho->source()) ? ortho : fov;
      return fail(second->source(), "[camera] has both fov and ortho",
                  "fov (vertical degrees) makes a perspective camera, ortho (view width) an "
                  "orthographic one: give one of them");
    }
    float f = 0;
    if (fov) {
      if (!ranged(*fov, "[camera] fov", 0, true, 180, true, &f, " degrees",
                  [](SceneDesc& s, double x) { s.camera.request.fov_deg = float(x); }))
        return false;
      c.request.fov_deg = f;
    }
    if (ortho) {
      if (!ranged(*ortho, "[camera] ortho", 0, true, NAN, false, &f)) return false;
      c.request.ortho_width = f;
    }
    if (const toml::node* n = t.get("aperture")) {
      if (!ranged(*n, "[camera] aperture", 0, false, NAN, false, &c.aperture)) return false;
    }
    if (const toml::node* n = t.get("focus_distance")) {
      if (!ranged(*n, "[camera] focus_distance", 0, true, NAN, false, &f)) return false;
      c.focus_distance = f;
    }
    if (c.request.eye && c.request.look_at && length(*c.request.look_at - *c.request.eye) <= 0) {
      return fail(t.get("look_at")->source(), "[camera] look_at is the eye position",
                  "the camera looks from eye towards look_at: they must differ");
    }
    return true;
  }

  bool read_render(const toml::table& t) {
    if (!check_keys(t, "[render]", "in [render]",
                    {"size", "spp", "adaptive", "max_depth", "background", "root"}))
      return false;
    RenderDesc& r = out_->render;
    if (const toml::node* n = t.get("size")) {
      const toml::array* a = n->as_array();
      if (!a || a->size() != 2) {
        return fail(n->source(),
                    "[render] size must be an array of 2 integers (width, height), "
                    "not " +
                        (a ? std::to_string(a->size()) : std::string(type_name(*n))));
      }
      std::array<int, 2> wh{};
      for (size_t i = 0; i < 2; ++i) {
        if (!at_least(*a->get(i), "[render] size[" + std::to_string(i) + "]", 1, &wh[i]))
          return false;
      }
      r.size = wh;
    }
    int i = 0;
    if (const toml::node* n = t.get("spp")) {
      if (!at_least(*n, "[render] spp", 1, &i)) return false;
      r.spp = i;
    }
    if (const toml::node* n = t.get("adaptive")) {
      bool b = false;
      if (!boolean(*n, "[render] adaptive", &b)) return false;
      r.adaptive = b;
    }
    if (const toml::node* n = t.get("max_depth")) {
      if (!at_least(*n, "[render] max_depth", 0, &i)) return false;
      r.max_depth = i;
    }
    if (const toml::node* n = t.get("background")) {
      render::Vec3 v;
      if (!colour(*n, "[render] background", &v)) return false;
      r.background = v;
    }
    if (const toml::node* n = t.get("root")) {
      std::string s;
      if (!choice(*n, "[render] root", {"auto", "sign", "interval", "analytic"}, &s)) return false;
      r.root = s;
    }
    return true;
  }

  bool read_animation(const toml::table& t) {
    if (!check_keys(t, "[animation]", "in [animation]", {"frames", "start", "end", "shutter"}))
      return false;
    AnimationDesc& a = out_->animation;
    a.given = true;
    if (const toml::node* n = t.get("frames")) {
      if (!at_least(*n, "[animation] frames", 1, &a.frames)) return false;
    }
    if (const toml::node* n = t.get("start")) {
      if (!number(*n, "[animation] start", &a.start)) return false;
    }
    a.end = a.start;
    if (const toml::node* n = t.get("end")) {
      if (!number(*n, "[animation] end", &a.end)) return false;
      if (a.frames > 1 && !(a.end > a.start)) {
        return fail(n->source(),
                    "[animation] end must be after start (" + fmt(a.start) + "), not " + fmt(a.end),
                    "frame i has time start + (end - start) * i / (frames - 1)");
      }
    } else if (a.frames > 1) {
      return fail(t.source(), "[animation] has " + std::to_string(a.frames) + " frames but no end",
                  "end = 1.0: frame i has time start + (end - start) * i / (frames - 1)");
    }
    if (const toml::node* n = t.get("shutter")) {
      float s = 0;
      if (!ranged(*n, "[animation] shutter", 0, false, NAN, false, &s)) return false;
      a.shutter = s;
    }
    return true;
  }

  bool read_light(const toml::table& t) {
    if (!check_keys(t, "[[light]]", "in [[light]]",
                    {"kind", "position", "direction", "radius", "color", "intensity", "samples"}))
      return false;
    render::Light l;
    const size_t li = out_->lights.size();
    const VecPlace light_v = [li](SceneDesc& s) -> render::Vec3& { return s.lights[li].v; };
    std::string kind = "point";
    if (const toml::node* n = t.get("kind")) {
      if (!choice(*n, "[[light]] kind", {"point", "directional", "sphere"}, &kind)) return false;
    }
    l.kind = kind == "point"         ? render::Light::Kind::kPoint
             : kind == "directional" ? render::Light::Kind::kDirectional
                                     : render::Light::Kind::kSphere;
    const bool directional = l.kind == render::Light::Kind::kDirectional;
    const bool sphere = l.kind == render::Light::Kind::kSphere;
    // Keys that belong to other kinds of light.
    auto only_for = [&](const char* key, const std::string& kinds) -> bool {
      const toml::node* n = t.get(key);
      if (!n) return true;
      for (auto&& [k, v] : t) {
        if (k.str() == key)
          return fail(k.source(), std::string("[[light]] ") + key + " is for " + kinds +
                                      " only (this light is \"" + kind + "\")");
      }
      return true;
    };
    if (directional && !only_for("position", "point and sphere lights")) return false;
    if (!directional && !only_for("direction", "directional lights")) return false;
    // radius and samples matter to sphere lights only; others accept and keep them (the
    // issue's example gives them to a point light), so that switching kind is a one-line edit.
    const toml::source_region& header = t.source();
    if (directional) {
      const toml::node* n = t.get("direction");
      if (!n)
        return fail(header, "a directional light needs a direction",
                    "direction = [x, y, z] points from the scene towards the light");
      if (!vec3(*n, "[[light]] direction", &l.v, light_v)) return false;
      if (length(l.v) <= 0) return fail(n->source(), "[[light]] direction must not be zero");
    } else {
      const toml::node* n = t.get("position");
      if (!n)
        return fail(header, std::string("a ") + kind + " light needs a position",
                    "position = [x, y, z]");
      if (!vec3(*n, "[[light]] position", &l.v, light_v)) return false;
    }
    if (sphere) {
      const toml::node* n = t.get("radius");
      if (!n)
        return fail(header, "a sphere light needs a radius",
                    "radius = 0.5 (the size of the lamp sets how soft the shadows are)");
      if (!ranged(*n, "[[light]] radius", 0, true, NAN, false, &l.radius, " for a sphere light"))
        return false;
    } else if (const toml::node* n = t.get("radius")) {
      if (!ranged(*n, "[[light]] radius", 0, false, NAN, false, &l.radius)) return false;
    }
    if (const toml::node* s = t.get("samples")) {
      if (!at_least(*s, "[[light]] samples", 1, &l.samples)) return false;
    }
    if (const toml::node* n = t.get("color")) {
      if (!colour(*n, "[[light]] color", &l.color,
                  [li](SceneDesc& s) -> render::Vec3& { return s.lights[li].color; }))
        return false;
    }
    if (const toml::node* n = t.get("intensity")) {
      if (!ranged(*n, "[[light]] intensity", 0, false, NAN, false, &l.intensity, "",
                  [li](SceneDesc& s, double x) { s.lights[li].intensity = float(x); }))
        return false;
    }
    out_->lights.push_back(l);
    return true;
  }

  bool read_materials(const toml::node& node) {
    const toml::table* all = node.as_table();
    if (!all) {
      return fail(node.source(), std::string("'material' must be a table of materials "
                                             "([material.NAME]), not ") +
                                     type_name(node));
    }
    // Document order, so that the first error in the file is the one reported.
    std::vector<std::pair<const toml::key*, const toml::node*>> items;
    for (auto&& [k, v] : *all) items.emplace_back(&k, &v);
    std::sort(items.begin(), items.end(), [](const auto& a, const auto& b) {
      return before(a.first->source(), b.first->source());
    });
    for (const auto& [k, v] : items) {
      const std::string name(k->str());
      const toml::table* t = v->as_table();
      if (!t) {
        return fail(k->source(),
                    "'" + name + "' in [material] must be a material table ([material." + name +
                        "]), not " + type_name(*v),
                    "each material is a table of its own: [material.NAME] with color, "
                    "diffuse, ...");
      }
      if (!read_material(name, *t)) return false;
    }
    return true;
  }

  bool read_material(const std::string& name, const toml::table& t) {
    const std::string what = "[material." + name + "]";
    if (!check_keys(t, what, "in " + what,
                    {"color", "ambient", "diffuse", "specular", "shininess", "reflect", "transmit",
                     "ior", "fresnel", "absorb", "roughness", "texture", "mapping"}))
      return false;
    render::Material m;
    const std::string p = what + " ";
    auto place = [name](render::Vec3 render::Material::*field) -> VecPlace {
      return [name, field](SceneDesc& s) -> render::Vec3& { return s.materials[name].*field; };
    };
    if (const toml::node* n = t.get("color");
        n && !colour(*n, p + "color", &m.color, place(&render::Material::color)))
      return false;
    struct Scalar {
      const char* key;
      float render::Material::*field;
      double lo;
      bool lo_open;
      double hi;
    };
    const Scalar scalars[] = {
        {"ambient", &render::Material::ambient, 0, false, NAN},
        {"diffuse", &render::Material::diffuse, 0, false, NAN},
        {"specular", &render::Material::specular, 0, false, NAN},
        {"shininess", &render::Material::shininess, 0, true, NAN},
        {"reflect", &render::Material::reflect, 0, false, 1},
        {"transmit", &render::Material::transmit, 0, false, 1},
        {"ior", &render::Material::ior, 0, true, NAN},
        {"roughness", &render::Material::roughness, 0, false, 1},
    };
    for (const Scalar& s : scalars) {
      if (const toml::node* n = t.get(s.key)) {
        const auto field = s.field;
        if (!ranged(*n, p + s.key, s.lo, s.lo_open, s.hi, false, &(m.*field), "",
                    [name, field](SceneDesc& d, double x) { d.materials[name].*field = float(x); }))
          return false;
      }
    }
    if (const toml::node* n = t.get("fresnel"); n && !boolean(*n, p + "fresnel", &m.fresnel))
      return false;
    if (const toml::node* n = t.get("absorb");
        n && !colour(*n, p + "absorb", &m.absorb, place(&render::Material::absorb)))
      return false;
    if (const toml::node* n = t.get("texture")) {
      if (!existing_file(*n, p + "texture", "texture file", &m.texture)) return false;
      std::error_code ec;
      const fs::path abs = fs::absolute(m.texture, ec);
      if (!ec) m.texture = abs.lexically_normal().string();
    }
    if (const toml::node* n = t.get("mapping")) {
      std::string s;
      if (!choice(*n, p + "mapping", {"planar", "spherical", "cylindrical", "triplanar", "uv"}, &s))
        return false;
      m.mapping = s == "planar"        ? render::TextureMapping::kPlanar
                  : s == "spherical"   ? render::TextureMapping::kSpherical
                  : s == "cylindrical" ? render::TextureMapping::kCylindrical
                  : s == "triplanar"   ? render::TextureMapping::kTriplanar
                                       : render::TextureMapping::kUv;
    }
    out_->materials[name] = m;
    return true;
  }

  bool read_object(const toml::table& t) {
    if (!check_keys(t, "[[object]]", "in [[object]]",
                    {"file", "source", "name", "params", "bbox", "material", "translate", "rotate",
                     "scale"}))
      return false;
    ObjectDesc o;
    const size_t oi = out_->objects.size();
    o.pos.file = path_;
    o.pos.line = static_cast<int>(t.source().begin.line);
    o.pos.column = static_cast<int>(t.source().begin.column);
    const toml::node* file = t.get("file");
    const toml::node* source = t.get("source");
    if (file && source) {
      const toml::node* second = before(file->source(), source->source()) ? source : file;
      return fail(second->source(), "[[object]] has both file and source",
                  "an object is either a model file (file = \"blob.hf\") or inline HyperFun "
                  "text (source = \"\"\"...\"\"\"): give one");
    }
    if (!file && !source) {
      return fail(t.source(), "[[object]] needs a file or a source",
                  "file = \"blob.hf\" (a model file, relative to the scene file) or "
                  "source = \"\"\"...\"\"\" (HyperFun text)");
    }
    if (file && !existing_file(*file, "[[object]] file", "model file", &o.file)) return false;
    if (source) {
      if (!string(*source, "[[object]] source", &o.source)) return false;
      o.source_pos = text_start(source->source());
      if (o.source.find_first_not_of(" \t\r\n") == std::string::npos)
        return fail(source->source(), "[[object]] source is empty");
    }
    if (const toml::node* n = t.get("name")) {
      std::string s;
      if (!string(*n, "[[object]] name", &s)) return false;
      o.name = s;
      o.name_pos = SourcePos{path_, static_cast<int>(n->source().begin.line),
                             static_cast<int>(n->source().begin.column)};
    }
    if (const toml::node* n = t.get("params")) {
      const size_t keyed_before = out_->keyed.size();
      if (!numbers(*n, "[[object]] params", 0, &o.params,
                   [oi](SceneDesc& s, size_t i, double x) { s.objects[oi].params[i] = x; }))
        return false;
      if (out_->keyed.size() > keyed_before) {
        out_->keyed_params.resize(oi + 1, false);
        out_->keyed_params[oi] = true;
      }
    }
    if (const toml::node* n = t.get("bbox")) {
      std::vector<double> b;
      if (!numbers(*n, "[[object]] bbox", 6, &b)) return false;
      static const char* kAxes[] = {"x", "y", "z"};
      for (int i = 0; i < 3; ++i) {
        if (!(float(b[i]) < float(b[i + 3]))) {
          return fail(n->source(),
                      std::string("[[object]] bbox must have lo < hi on every axis; on ") +
                          kAxes[i] + " it is " + fmt(b[i]) + " >= " + fmt(b[i + 3]),
                      "bbox = [x0, y0, z0, x1, y1, z1]: the low corner, then the high one");
        }
      }
      o.bbox = render::Box({float(b[0]), float(b[1]), float(b[2])},
                           {float(b[3]), float(b[4]), float(b[5])});
    }
    if (const toml::node* n = t.get("material")) {
      if (!string(*n, "[[object]] material", &o.material)) return false;
      if (!out_->materials.count(o.material)) {
        std::vector<std::string> names;
        for (const auto& [k, v] : out_->materials) names.push_back(k);
        std::string hint;
        if (names.empty()) {
          hint = "the scene defines no materials: add a [material." + o.material +
                 "] table, or leave material out for the default look";
        } else {
          const std::string near = nearest(o.material, names);
          if (!near.empty()) hint = "did you mean \"" + near + "\"? ";
          hint += "the scene defines " + quoted_list(names);
        }
        return fail(n->source(), "unknown material \"" + o.material + "\"", hint);
      }
    }
    if (const toml::node* n = t.get("translate");
        n && !vec3(*n, "[[object]] translate", &o.translate,
                   [oi](SceneDesc& s) -> render::Vec3& { return s.objects[oi].translate; }))
      return false;
    if (const toml::node* n = t.get("rotate");
        n && !vec3(*n, "[[object]] rotate", &o.rotate_deg,
                   [oi](SceneDesc& s) -> render::Vec3& { return s.objects[oi].rotate_deg; }))
      return false;
    if (const toml::node* n = t.get("scale")) {
      if (!ranged(*n, "[[object]] scale", 0, true, NAN, false, &o.scale, "",
                  [oi](SceneDesc& s, double x) { s.objects[oi].scale = float(x); }))
        return false;
    }
    out_->objects.push_back(std::move(o));
    return true;
  }

  const std::string& text_;
  const std::string& path_;
  SceneDesc* out_;
  SceneError* err_;
  std::string folder_;
  /// The values the last number() read, with their nodes (one, or one per key).
  std::vector<std::pair<double, const toml::node*>> values_;
  struct ValueAt {
    double value;
    const toml::node* node;
    size_t index;  ///< element of the array
  };
  /// The values the last numbers() read.
  std::vector<ValueAt> all_values_;
};

}  // namespace

std::string SceneError::render() const {
  std::string out = pos.file;
  if (pos.line > 0) out += ':' + std::to_string(pos.line) + ':' + std::to_string(pos.column);
  out += ": error: " + message + '\n';
  if (pos.line > 0 && !line_text.empty()) {
    // toml++ counts columns in code points; the caret line counts them the same way.
    const std::string& line = line_text;
    auto continuation = [](char c) { return (static_cast<unsigned char>(c) & 0xC0) == 0x80; };
    size_t col0 = 0, cols = 0;  // byte offset of the caret's column
    while (col0 < line.size() && cols + 1 < static_cast<size_t>(pos.column)) {
      ++col0;
      while (col0 < line.size() && continuation(line[col0])) ++col0;
      ++cols;
    }
    size_t first = 0, last = line.size();
    if (line.size() > kMaxShownLine) {
      first = col0 > kWindowBefore ? col0 - kWindowBefore : 0;
      last = std::min(last, first + kMaxShownLine);
      while (first > 0 && continuation(line[first])) --first;
    }
    std::string shown, caret;
    if (first > 0) {
      shown += "...";
      caret += "   ";
    }
    for (size_t i = first; i < last; ++i) {
      const char c = line[i];
      const bool control = (static_cast<unsigned char>(c) < 0x20 && c != '\t') || c == 0x7F;
      shown += control ? ' ' : c;
      if (i < col0 && !continuation(c)) caret += c == '\t' ? '\t' : ' ';
    }
    if (last < line.size()) shown += "...";
    caret += '^';
    for (int i = 1; i < length; ++i) caret += '~';
    out += ' ' + shown + "\n " + caret + '\n';
  }
  if (!hint.empty()) out += "hint: " + hint + '\n';
  return out;
}

bool parse_scene(const std::string& text, const std::string& path, SceneDesc* out,
                 SceneError* err) {
  Reader reader(text, path, out, err);
  return reader.read();
}

bool read_scene_file(const std::string& path, SceneDesc* out, SceneError* err) {
  Result<std::string> text = read_file(path);
  if (!text) {
    *err = SceneError{};
    err->pos.file = path;
    err->message = text.error().message;
    return false;
  }
  return parse_scene(*text, path, out, err);
}

double Keys::at(double t) const {
  HFRT_CHECK(!keys.empty());
  if (t <= keys.front()[0]) return keys.front()[1];
  if (t >= keys.back()[0]) return keys.back()[1];
  const auto hi =
      std::upper_bound(keys.begin(), keys.end(), t,
                       [](double x, const std::array<double, 2>& k) { return x < k[0]; });
  const auto lo = hi - 1;
  const double u = (t - (*lo)[0]) / ((*hi)[0] - (*lo)[0]);
  return (*lo)[1] + u * ((*hi)[1] - (*lo)[1]);
}

double AnimationDesc::frame_time(int frame) const {
  if (frames <= 1) return start;
  return start + (end - start) * double(frame) / double(frames - 1);
}

SceneDesc scene_at(const SceneDesc& scene, double t) {
  SceneDesc s = scene;
  for (const KeyedNumber& k : scene.keyed) k.set(s, k.keys.at(t));
  return s;
}

const char* keyable_numbers() {
  return "an object's params, translate, rotate and scale; the camera's eye, look_at and fov; a "
         "light's position, direction, color and intensity; a material's numbers and colours";
}

render::Transform placement(const ObjectDesc& o) {
  return render::Transform::from_srt(o.scale, o.rotate_deg, o.translate);
}

bool object_source(const ObjectDesc& o, const std::string& scene_path, std::string* text,
                   std::string* name, std::string* error) {
  if (o.file.empty()) {
    *name = scene_path;
    *text = std::string(std::max(0, o.source_pos.line - 1), '\n') +
            std::string(std::max(0, o.source_pos.column - 1), ' ') + o.source;
    return true;
  }
  *name = o.file;
  Result<std::string> read = read_file(o.file);
  if (!read) {
    *error = read.error().message;
    return false;
  }
  *text = std::move(read).value();
  return true;
}

render::Vec3 object_to_world(const ObjectDesc& o, render::Vec3 p) {
  return placement(o).point_to_world(p);
}

render::Box world_box(const ObjectDesc& o, const render::Box& b) {
  return placement(o).box_to_world(b);
}

const char* mapping_name(render::TextureMapping mapping) {
  switch (mapping) {
    case render::TextureMapping::kPlanar:
      return "planar";
    case render::TextureMapping::kSpherical:
      return "spherical";
    case render::TextureMapping::kCylindrical:
      return "cylindrical";
    case render::TextureMapping::kTriplanar:
      return "triplanar";
    case render::TextureMapping::kUv:
      return "uv";
  }
  return "planar";
}

std::string summary(const SceneDesc& s) {
  auto count = [](size_t n, const char* one, const char* many) {
    return std::to_string(n) + " " + (n == 1 ? one : many);
  };
  std::string out = s.path + ": " + count(s.objects.size(), "object", "objects") + ", ";
  out += s.lights.empty() ? std::string("the default lights")
                          : count(s.lights.size(), "light", "lights");
  out += ", " + count(s.materials.size(), "material", "materials");
  if (s.has_camera) {
    const render::CameraRequest& c = s.camera.request;
    out += c.ortho_width ? "; orthographic camera" : "; perspective camera";
    if (s.camera.aperture > 0) out += " with depth of field";
  }
  std::vector<std::string> settings;
  if (s.render.size)
    settings.push_back(std::to_string((*s.render.size)[0]) + "x" +
                       std::to_string((*s.render.size)[1]));
  if (s.render.spp)
    settings.push_back(std::to_string(*s.render.spp) + " spp" +
                       (s.render.adaptive.value_or(false) ? " (adaptive)" : ""));
  if (s.render.max_depth) settings.push_back("depth " + std::to_string(*s.render.max_depth));
  if (s.render.root) settings.push_back("root " + *s.render.root);
  if (!settings.empty()) out += "; " + join(settings);
  if (s.animation.given) {
    out += "; " + count(size_t(s.animation.frames), "frame", "frames") + " (time " +
           fmt(s.animation.start) + " to " + fmt(s.animation.end) + ")";
    if (s.animation.shutter > 0) out += ", motion blur " + fmt(s.animation.shutter);
  }
  if (!s.keyed.empty()) out += ", " + count(s.keyed.size(), "keyed number", "keyed numbers");
  return out;
}

}  // namespace hfrt::scene
