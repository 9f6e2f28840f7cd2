// Program-level queries on the AST.
#include "lang/ast.h"

#include "lang/names.h"

namespace hfrt::lang {

int Program::default_object() const {
  if (objects.empty()) return -1;
  int model = find_object("my_model");
  return model >= 0 ? model : 0;
}

int Program::find_object(std::string_view name) const {
  for (size_t i = 0; i < objects.size(); ++i) {
    if (same_name(objects[i].name, name)) return static_cast<int>(i);
  }
  return -1;
}

int Program::select_object(std::string_view name, std::string* message, std::string* hint) const {
  const int index = name.empty() ? default_object() : find_object(name);
  if (index >= 0) return index;
  *message = name.empty() ? "the file defines no object"
                          : "no object named '" + std::string(name) + "' in the file";
  std::string names;
  for (const Object& o : objects) names += (names.empty() ? "" : ", ") + o.name;
  *hint = names.empty() ? "" : "the objects are: " + names;
  return -1;
}

}  // namespace hfrt::lang
