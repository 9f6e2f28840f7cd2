#include "scene/scene_edit.h"

#include <toml++/toml.h>

#include <sstream>
#include <vector>

namespace hfrt::scene {
namespace {

std::vector<std::string> split_dots(const std::string& key) {
  std::vector<std::string> parts;
  size_t pos = 0;
  while (true) {
    size_t dot = key.find('.', pos);
    parts.push_back(key.substr(pos, dot == std::string::npos ? std::string::npos : dot - pos));
    if (dot == std::string::npos) break;
    pos = dot + 1;
  }
  return parts;
}

bool fail(const std::string& path, std::string message, std::string hint, SceneError* err) {
  *err = SceneError{};
  err->pos.file = path;
  err->message = std::move(message);
  err->hint = std::move(hint);
  return false;
}

}  // namespace

bool set_scene_value(std::string* text, const std::string& path, const std::string& key,
                     const std::string& value, SceneDesc* out, SceneError* err) {
  const char* kHint =
      "keys are camera.KEY, render.KEY, material.NAME.KEY, light.N.KEY or object.N.KEY";
  toml::table root;
  try {
    root = toml::parse(std::string_view(*text), std::string_view(path));
  } catch (const toml::parse_error&) {
    // The scene was read before; its text parses. Re-read it for the located message.
    SceneDesc unused;
    return parse_scene(*text, path, &unused, err) ||
           fail(path, "the scene text does not parse", "", err);
  }
  // The value, parsed as the right-hand side of a TOML key.
  toml::table holder;
  try {
    holder = toml::parse("v = " + value);
  } catch (const toml::parse_error& e) {
    return fail(path, "'" + value + "' is not a TOML value (" + std::string(e.description()) + ")",
                "write numbers as 1.5, colours and points as [1, 0.5, 0], words as \"glass\"", err);
  }
  std::vector<std::string> parts = split_dots(key);
  for (const std::string& p : parts) {
    if (p.empty()) return fail(path, "'" + key + "' is not a scene key", kHint, err);
  }
  toml::table* table = nullptr;
  std::string leaf;
  auto index_of = [&](const std::string& word, size_t count, size_t* i) {
    char* end = nullptr;
    long n = std::strtol(word.c_str(), &end, 10);
    if (word.empty() || *end || n < 1 || size_t(n) > count) return false;
    *i = size_t(n - 1);
    return true;
  };
  if ((parts[0] == "camera" || parts[0] == "render") && parts.size() == 2) {
    if (!root.contains(parts[0])) root.insert(parts[0], toml::table{});
    table = root[parts[0]].as_table();
    leaf = parts[1];
  } else if (parts[0] == "material" && parts.size() == 3) {
    if (!root.contains("material")) root.insert("material", toml::table{});
    toml::table* mats = root["material"].as_table();
    if (mats && !mats->contains(parts[1])) mats->insert(parts[1], toml::table{});
    table = mats ? (*mats)[parts[1]].as_table() : nullptr;
    leaf = parts[2];
  } else if ((parts[0] == "light" || parts[0] == "object") && parts.size() == 3) {
    toml::array* arr = root[parts[0]].as_array();
    size_t i = 0;
    if (!arr || !index_of(parts[1], arr->size(), &i)) {
      return fail(path,
                  "there is no " + parts[0] + " " + parts[1] + " (the scene has " +
                      std::to_string(arr ? arr->size() : 0) + ")",
                  parts[0] + "s are numbered from 1 in the order of the file", err);
    }
    table = (*arr)[i].as_table();
    leaf = parts[2];
  }
  if (!table) return fail(path, "'" + key + "' is not a scene key", kHint, err);
  table->insert_or_assign(leaf, *holder.get("v"));
  std::ostringstream os;
  os << root;
  std::string edited = os.str();
  SceneDesc desc;
  if (!parse_scene(edited, path, &desc, err)) return false;
  *text = std::move(edited);
  *out = std::move(desc);
  return true;
}

}  // namespace hfrt::scene
