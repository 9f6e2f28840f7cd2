#pragma once
// Materials and lights of a scene: what a surface does with light (render/tracer.h traces
// them). Pure data; the scene file (scene/scene_file.h) fills them from TOML and the command
// line's single-model render uses the defaults, which reproduce hfrt's first-hit look.

#include <memory>
#include <string>

#include "render/vec.h"

namespace hfrt::render {

struct TextureImage;

/// How a material's image texture is laid onto a surface point (object space).
enum class TextureMapping { kPlanar, kSpherical, kCylindrical, kTriplanar, kUv };

/// A surface's response to light. Colours are linear RGB. The default is the look of a plain
/// `hfrt render` (ambient 0.12, Lambert 1, a Blinn-Phong highlight 0.25 with exponent 48).
struct Material {
  Vec3 color{0.78f, 0.76f, 0.7f};  ///< base colour; a model's s[1..3] replaces it per point
  float ambient = 0.12f;           ///< ambient term, times color
  float diffuse = 1.0f;            ///< Lambert, times color
  float specular = 0.25f;          ///< Blinn-Phong highlight, times the light colour
  float shininess = 48.0f;
  float reflect = 0.0f;    ///< mirror reflection weight
  float transmit = 0.0f;   ///< refraction weight
  float ior = 1.5f;        ///< index of refraction of the solid's inside
  bool fresnel = false;    ///< weigh reflect/transmit by the dielectric Fresnel terms
  Vec3 absorb{0, 0, 0};    ///< Beer-Lambert coefficients per unit length inside
  float roughness = 0.0f;  ///< > 0: glossy reflection and refraction, sampled
  std::string texture;     ///< image file (absolute path), "" for none
  TextureMapping mapping = TextureMapping::kPlanar;
  /// The loaded `texture` (render/texture.h), null for none: whoever reads the scene loads it
  /// (app::run_scene_job), the tracer only looks it up.
  std::shared_ptr<const TextureImage> texture_image;
};

/// A light. Its radiance is color * intensity.
struct Light {
  enum class Kind { kPoint, kDirectional, kSphere };
  Kind kind = Kind::kDirectional;
  /// The position of a point or sphere light, or the direction *towards* a directional one.
  Vec3 v{0, 1, 0};
  Vec3 color{1, 1, 1};
  float intensity = 1.0f;
  float radius = 0.0f;  ///< sphere lights: the emitting sphere's radius (soft shadows)
  int samples = 16;     ///< sphere lights: shadow rays per shading point
};

}  // namespace hfrt::render
