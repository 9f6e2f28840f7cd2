#pragma once
// Scene files: a TOML description of a camera, render settings, lights, materials and one or
// more placed HyperFun objects (docs/scenes.md documents every key). This layer only reads and
// validates the file into a SceneDesc (pure data, no models compiled): app/ compiles the
// objects and render/ traces them. Errors are user-input diagnostics located at the file, line
// and column of the offending key or value (toml++ keeps source positions).

#include <array>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "render/camera.h"
#include "render/framing.h"
#include "render/material.h"
#include "render/tracer.h"

namespace hfrt::scene {

/// A position in a scene file (1-based line and column; 0 when unknown).
struct SourcePos {
  std::string file;
  int line = 0, column = 0;
};

/// `[camera]`. Unset optionals are filled the way `hfrt render` fills them (framing the
/// solids when eye or look_at is missing).
struct CameraDesc {
  render::CameraRequest request;        ///< eye, look_at, up, fov (vertical degrees), ortho (width)
  float aperture = 0;                   ///< thin-lens radius; 0: pinhole
  std::optional<float> focus_distance;  ///< along the view direction; default |look_at - eye|
};

/// `[render]`. Unset optionals keep the command line's (or its defaults') value.
struct RenderDesc {
  std::optional<std::array<int, 2>> size;  ///< width, height
  std::optional<int> spp;
  std::optional<bool> adaptive;
  std::optional<int> max_depth;
  std::optional<render::Vec3> background;
  std::optional<std::string> root;  ///< "sign" | "interval" | "analytic" | "auto"
};

/// One `[[object]]`: a model (from a file, or inline source) placed in the scene.
struct ObjectDesc {
  std::string file;    ///< absolute or relative to the current directory (resolved against the
                       ///< scene file's folder by the reader); "" when `source` is given
  std::string source;  ///< inline HyperFun text (`source = """..."""`), "" when `file` is given
  std::optional<std::string> name;  ///< which object of the file
  std::vector<double> params;       ///< a[1], a[2], ...
  std::optional<render::Box> bbox;  ///< [x0, y0, z0, x1, y1, z1]
  std::string material;             ///< "" : the default material
  render::Vec3 translate{0, 0, 0};
  render::Vec3 rotate_deg{0, 0, 0};  ///< about x, then y, then z
  float scale = 1;
  SourcePos pos;  ///< where the [[object]] table starts (for messages)
  /// Where the text of `source` starts in the scene file (the line after `source = """`
  /// when a newline follows the quotes), so that the model's diagnostics can be located in
  /// the scene file: compile the source preceded by line - 1 newlines and column - 1 spaces
  /// (exact for literal strings and for basic strings without escapes).
  SourcePos source_pos;
  SourcePos name_pos;  ///< where the `name` value is (line 0 when there is none)
};

/// The HyperFun text of an object as the compiler should see it, and the file name its
/// diagnostics should carry: the model file's contents (`*name` = the file), or the inline
/// `source` preceded by source_pos.line - 1 newlines and source_pos.column - 1 spaces
/// (`*name` = the scene file), so that diagnostics point into the scene file. False with
/// `*error` when the model file cannot be read.
bool object_source(const ObjectDesc& object, const std::string& scene_path, std::string* text,
                   std::string* name, std::string* error);

/// A point of the object's model space in the world: scaled, rotated about x, then y, then z
/// (degrees, right-handed: rotating y towards z, z towards x, x towards y), then translated.
render::Vec3 object_to_world(const ObjectDesc& object, render::Vec3 p);
/// The object's placement as the tracer takes it (render::Transform, the one implementation).
render::Transform placement(const ObjectDesc& object);
/// A box enclosing `box` (model space) placed in the world by object_to_world.
render::Box world_box(const ObjectDesc& object, const render::Box& box);

/// A number that changes with time: `{ keys = [[t0, v0], [t1, v1], ...] }` in the file, times
/// strictly increasing; linear between keys, the first / last value before / after them.
struct Keys {
  std::vector<std::array<double, 2>> keys;  ///< (time, value), at least one
  double at(double t) const;
};

/// `[animation]`: frame i (0-based) has time start + (end - start) * i / (frames - 1).
struct AnimationDesc {
  bool given = false;  ///< the file has an [animation] table
  int frames = 1;
  double start = 0, end = 0;
  /// > 0: motion blur; each sample of frame time t takes a time in [t, t + shutter].
  double shutter = 0;
  double frame_time(int frame) const;
};

struct SceneDesc;

/// One keyed number of a scene file: what it is, where it was written, its keys, and how its
/// value at a time reaches a SceneDesc (scene_at).
struct KeyedNumber {
  std::string what;  ///< "[[object]] translate[0]", as in messages
  SourcePos pos;
  Keys keys;
  std::function<void(SceneDesc&, double)> set;
};

/// A whole scene file.
struct SceneDesc {
  std::string path;  ///< the scene file as given
  CameraDesc camera;
  bool has_camera = false;
  RenderDesc render;
  std::vector<render::Light> lights;  ///< empty: the default lights
  /// `[material.NAME]`, by name. Texture paths are resolved against the scene file's folder.
  std::map<std::string, render::Material> materials;
  std::vector<ObjectDesc> objects;
  AnimationDesc animation;
  /// Every keyed number. The values above are the ones at time 0; scene_at() gives others.
  std::vector<KeyedNumber> keyed;
  /// Objects whose params are keyed (object index -> true): their models take new parameter
  /// values per frame (Model::set_params), never a recompile.
  std::vector<bool> keyed_params;
};

/// The scene at time `t`: every keyed number set to its value at t. (`keyed` is kept, so the
/// result can be moved to another time again.)
SceneDesc scene_at(const SceneDesc& scene, double t);

/// One located error: `file:line:col: error: message` (+ an optional hint line).
struct SceneError {
  SourcePos pos;
  std::string message;
  std::string hint;
  /// The text of line `pos.line` (without its newline), shown under the message with a caret;
  /// "" when unknown.
  std::string line_text;
  /// How many columns the caret line underlines (at least 1).
  int length = 1;
  /// The message in the format of hfrt's compile errors (file:line:col: error: ..., then the
  /// source line with a caret and the hint when there is one).
  std::string render() const;
};

/// Reads and validates a scene file into `*out`. Every problem the file can have (TOML syntax,
/// an unknown key, a wrong type, a value out of range, a material that is not defined, an
/// object with neither or both of file and source, a model or texture file that does not
/// exist, a file that cannot be read) is a SceneError located at the key or value: false with
/// `*err` set (the first error). The reader does not compile models.
bool read_scene_file(const std::string& path, SceneDesc* out, SceneError* err);
/// The same from text in memory (`path` names it in messages; relative file names are resolved
/// against its folder).
bool parse_scene(const std::string& text, const std::string& path, SceneDesc* out, SceneError* err);

/// Numbers that may be keyed instead of constant: an object's params, translate, rotate and
/// scale; the camera's eye, look_at and fov; a light's position, direction, color and
/// intensity; a material's numbers and colours. For messages.
const char* keyable_numbers();

/// A one-line description of a scene that read without errors, for `hfrt check`, e.g.
/// `scene.toml: 3 objects, 2 lights, 2 materials; perspective camera; 512x512, 4 spp, depth 5`
/// (settings the file leaves to the command line are not mentioned).
std::string summary(const SceneDesc& scene);

/// The name of a texture mapping as the scene file spells it ("planar", ..., "uv").
const char* mapping_name(render::TextureMapping mapping);

}  // namespace hfrt::scene
