#pragma once
// Editing one value of a scene, as the REPL's `:set material.glass.ior 1.3` does. The edit is
// made on the scene's TOML text (toml++ tables), which is then read again by parse_scene():
// every check of the reader applies to an edited value exactly as to a written one.

#include <string>

#include "scene/scene_file.h"

namespace hfrt::scene {

/// Sets `key` to `value` in the scene text `*text` (named `path` in messages) and reads it
/// again into `*out`. `key` is a dotted path: `camera.KEY`, `render.KEY`,
/// `material.NAME.KEY` (a new NAME defines a material), `light.N.KEY` and `object.N.KEY` (N
/// from 1, an existing light or object). `value` is a TOML value: `1.3`, `[1, 0.5, 0]`, `true`,
/// `"glass"`. On any problem returns false with `*err` (a malformed key or value, or what the
/// reader says of the edited scene) and leaves `*text` and `*out` unchanged.
bool set_scene_value(std::string* text, const std::string& path, const std::string& key,
                     const std::string& value, SceneDesc* out, SceneError* err);

}  // namespace hfrt::scene
