#pragma once
// A scene as POV-Ray 3.7 SDL: camera (with focal blur), lights (point, parallel, circular area
// lights), background, trace depth, and every object as an `isosurface` of a function declared
// elsewhere (jit/pov_emit.h writes those), placed and given its material. `hfrt emit --pov
// scene.toml` is the front end; docs/emit.md documents how each hfrt setting maps to POV-Ray's.
// Pure text: no model is compiled here.

#include <string>
#include <vector>

#include "render/camera.h"
#include "render/material.h"
#include "render/vec.h"

namespace hfrt::scene {

/// One object as POV-Ray gets it.
struct PovObject {
  std::string function;  ///< the declared POV function of F (object space; solid is F >= 0)
  render::Box bbox;      ///< the isosurface's contained_by box (object space)
  float max_gradient = 1;
  float accuracy = 1e-4f;
  render::Material material;
  /// Placement as in the scene file: scale, then rotate about x, y, z (degrees), then translate.
  render::Vec3 translate{0, 0, 0};
  render::Vec3 rotate_deg{0, 0, 0};
  float scale = 1;
  std::string comment;  ///< one line naming the object in the output ("" for none)
};

/// Everything of the scene but its objects, already resolved (camera framed, lights filled).
struct PovSceneSettings {
  render::Camera camera;
  int width = 512, height = 512;
  float aperture = 0;                 ///< hfrt's thin-lens radius; 0: pinhole
  float focus_distance = 0;           ///< along the view direction (used when aperture > 0)
  int spp = 1;                        ///< samples per pixel (focal blur samples with an aperture)
  int max_depth = 5;                  ///< reflection/refraction bounces
  std::vector<render::Light> lights;  ///< as given (the caller fills in default lights)
  bool shadows = true;
  render::Vec3 background{0.18f, 0.2f, 0.24f};
  bool transparent_background = false;  ///< background with transmit 1 (alpha with +UA)
  render::Box extent;  ///< encloses the objects: parallel lights are placed far outside it
};

/// POV-Ray's exponential interior fade (fade_power >= 1000 multiplies light that travelled d
/// inside by exp(-(1 - fade_color) * d / fade_distance) per channel) chosen to equal hfrt's
/// Beer-Lambert exp(-absorb * d): fade_distance = 1 / max(absorb), fade_color = 1 - absorb *
/// fade_distance (every component in [0, 1)). `on` is false when absorb is zero.
struct PovFade {
  bool on = false;
  float distance = 0;
  render::Vec3 color{1, 1, 1};
};
PovFade pov_fade(render::Vec3 absorb);

/// POV-Ray's `aperture` for hfrt's thin-lens radius: POV-Ray samples the lens on a disc of
/// radius aperture / 4 (core/render/tracepixel.cpp: offsets of at most 0.5 times
/// aperture / 2), so aperture = 4 * radius.
float pov_aperture(float lens_radius);

/// The side n of POV-Ray's n x n area light for `samples` shadow rays per point: n*n is the
/// square nearest to `samples`, but at least 2 x 2 (POV-Ray rejects smaller circular lights).
int pov_area_light_side(int samples);

/// The material as a POV-Ray `texture { pigment finish }` and `interior { }` (both blocks,
/// each line indented by `indent`).
std::string pov_material(const render::Material& material, const std::string& indent = "  ");

/// The whole scene after the function declarations: global settings, camera, lights,
/// background and one isosurface per object.
std::string pov_scene_text(const PovSceneSettings& settings, const std::vector<PovObject>& objects);

}  // namespace hfrt::scene
