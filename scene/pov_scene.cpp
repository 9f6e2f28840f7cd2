// A scene as POV-Ray SDL (see scene/pov_scene.h and docs/emit.md for the mapping).
#include "scene/pov_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace hfrt::scene {
namespace {

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.7g", v);
  return buf;
}

std::string vec(render::Vec3 v) {
  return "<" + num(v.x) + ", " + num(v.y) + ", " + num(v.z) + ">";
}

std::string camera_text(const PovSceneSettings& s) {
  const render::Camera& cam = s.camera;
  render::CameraFrame frame(cam, s.width, s.height);
  const float aspect = float(s.width) / float(s.height);
  float half_w, half_h;
  if (frame.orthographic()) {
    half_w = cam.ortho_width * 0.5f;
    half_h = half_w / aspect;
  } else {
    half_h = std::tan(cam.fov_deg * 0.5f * float(M_PI) / 180.0f);
    half_w = half_h * aspect;
  }
  // As `hfrt emit --pov MODEL.hf` writes it: POV-Ray's ray through the pixel centre (px, py) is
  // direction + (px/W - 0.5) right + (0.5 - py/H) up, which with these vectors is hfrt's ray
  // (render/camera.cpp); explicit vectors keep x, y, z meaning the same in both programs.
  std::string t = "camera {\n  ";
  t += frame.orthographic() ? "orthographic" : "perspective";
  t += "\n  location " + vec(frame.eye()) + "\n  direction " + vec(frame.forward()) + "\n  right " +
       vec(frame.right() * (2 * half_w)) + "\n  up " + vec(frame.up() * (2 * half_h)) + "\n";
  if (s.aperture > 0) {
    // Thin lens: POV-Ray's focal blur. Its lens disc has radius aperture / 4; the focal point
    // lies focus_distance along the view direction; every one of blur_samples rays is traced
    // (variance 0 turns the early stop off, as hfrt traces every sample).
    t += "  aperture " + num(pov_aperture(s.aperture)) + "\n  focal_point " +
         vec(frame.eye() + frame.forward() * s.focus_distance) + "\n  blur_samples " +
         std::to_string(std::max(1, s.spp)) + "\n  variance 0\n";
  }
  t += "}\n";
  return t;
}

std::string light_text(const render::Light& l, const PovSceneSettings& s) {
  const render::Vec3 centre = s.extent.empty() ? render::Vec3{0, 0, 0} : s.extent.center();
  const float size = s.extent.empty() ? 1.0f : s.extent.max_extent();
  const float far = 1e4f * std::max(1.0f, size);
  const render::Vec3 colour = l.color * l.intensity;
  std::string t = "light_source {\n";
  switch (l.kind) {
    case render::Light::Kind::kDirectional:
      // Parallel rays from far away in the direction towards the light (l.v).
      t += "  " + vec(centre + normalize(l.v) * far) + " color rgb " + vec(colour) +
           "\n  parallel point_at " + vec(centre) + "\n";
      break;
    case render::Light::Kind::kPoint:
      t += "  " + vec(l.v) + " color rgb " + vec(colour) + "\n";
      break;
    case render::Light::Kind::kSphere: {
      // A disc of the sphere's radius facing each lit point (circular orient), sampled by an
      // n x n grid with n*n about `samples`.
      const int n = pov_area_light_side(l.samples);
      const float d = 2 * l.radius;
      t += "  " + vec(l.v) + " color rgb " + vec(colour) + "\n  area_light " + vec({d, 0, 0}) +
           ", " + vec({0, d, 0}) + ", " + std::to_string(n) + ", " + std::to_string(n) +
           "\n  circular orient\n";
      break;
    }
  }
  if (!s.shadows) t += "  shadowless\n";
  t += "}\n";
  return t;
}

}  // namespace

PovFade pov_fade(render::Vec3 absorb) {
  PovFade f;
  const float top = std::max({absorb.x, absorb.y, absorb.z});
  if (!(top > 0)) return f;
  f.on = true;
  f.distance = 1.0f / top;
  f.color = render::Vec3{1 - absorb.x / top, 1 - absorb.y / top, 1 - absorb.z / top};
  return f;
}

float pov_aperture(float lens_radius) {
  return 4 * lens_radius;
}

int pov_area_light_side(int samples) {
  // POV-Ray refuses circular area lights of fewer than 2 x 2 (parse error).
  return std::max(2, static_cast<int>(std::lround(std::sqrt(double(std::max(1, samples))))));
}

std::string pov_material(const render::Material& m, const std::string& in) {
  std::string t;
  // POV-Ray weighs the pigment's own light (ambient, diffuse) by 1 - transmit, while hfrt's
  // ambient and diffuse are weights of their own: divide them back (nothing to divide at
  // transmit 1, where POV-Ray shows no diffuse light at all).
  const float keep = 1 - m.transmit;
  const float scale = keep > 1e-6f ? 1 / keep : 1;
  t += in + "texture {\n";
  t += in + "  pigment { rgbt <" + num(m.color.x) + ", " + num(m.color.y) + ", " + num(m.color.z) +
       ", " + num(m.transmit) + "> }\n";
  if (!m.texture.empty()) {
    t += in + "  // hfrt texture " + m.texture + " (" +
         (m.mapping == render::TextureMapping::kUv ? "uv" : "mapped") +
         ") is not written: the base colour stands in for it\n";
  }
  t += in + "  finish {\n";
  t += in + "    ambient " + num(m.ambient * scale) + " diffuse " + num(m.diffuse * scale) + "\n";
  if (m.specular > 0) {
    // Blinn-Phong (n.h)^shininess: POV-Ray's specular highlight with roughness 1 / shininess.
    t += in + "    specular " + num(m.specular) + " roughness " + num(1.0 / m.shininess) + "\n";
  }
  if (m.fresnel && (m.reflect > 0 || m.transmit > 0)) {
    // Reflection follows the dielectric Fresnel term of the interior's ior, up to
    // reflect + transmit; conserve_energy takes what is reflected from the transmitted part.
    t += in + "    reflection { 0, " + num(std::min(1.0f, m.reflect + m.transmit)) +
         " fresnel on }\n";
    if (m.transmit > 0) t += in + "    conserve_energy\n";
  } else if (m.reflect > 0) {
    t += in + "    reflection { " + num(m.reflect) + " }\n";
  }
  if (m.roughness > 0) {
    t += in + "    // hfrt roughness " + num(m.roughness) +
         " (sampled glossy reflection and refraction) has no POV-Ray finish: not written\n";
  }
  t += in + "  }\n";
  t += in + "}\n";
  const PovFade fade = pov_fade(m.absorb);
  if (m.transmit > 0 || m.fresnel || fade.on) {
    t += in + "interior {\n";
    t += in + "  ior " + num(m.ior) + "\n";
    if (fade.on) {
      // exp(-(1 - fade_color) d / fade_distance) = exp(-absorb d) per channel.
      t += in + "  fade_power 1001\n";
      t += in + "  fade_distance " + num(fade.distance) + "\n";
      t += in + "  fade_color rgb " + vec(fade.color) + "\n";
    }
    t += in + "}\n";
  }
  return t;
}

std::string pov_scene_text(const PovSceneSettings& s, const std::vector<PovObject>& objects) {
  std::string t;
  // max_trace_level counts the camera ray as level 1: max_depth bounces need max_depth + 1.
  t += "global_settings {\n  assumed_gamma 1.0\n  max_trace_level " +
       std::to_string(s.max_depth + 1) + "\n}\n";
  t += camera_text(s);
  for (const render::Light& l : s.lights) t += light_text(l, s);
  const render::Vec3 bg = s.background;
  t += s.transparent_background
           ? "background { rgbt <" + num(bg.x) + ", " + num(bg.y) + ", " + num(bg.z) + ", 1> }\n"
           : "background { rgb " + vec(bg) + " }\n";
  for (const PovObject& o : objects) {
    t += "\n";
    if (!o.comment.empty()) t += "// " + o.comment + "\n";
    t += "isosurface {\n  function { -" + o.function + "(x, y, z) }\n";
    t += "  contained_by { box { " + vec(o.bbox.lo) + ", " + vec(o.bbox.hi) + " } }\n";
    t += "  threshold 0\n  max_gradient " + num(o.max_gradient) + "\n  accuracy " +
         num(o.accuracy) + "\n";
    t += pov_material(o.material, "  ");
    // The scene file's order: scale, then rotate about x, y and z, then translate.
    if (o.scale != 1) t += "  scale " + num(o.scale) + "\n";
    if (o.rotate_deg.x != 0) t += "  rotate <" + num(o.rotate_deg.x) + ", 0, 0>\n";
    if (o.rotate_deg.y != 0) t += "  rotate <0, " + num(o.rotate_deg.y) + ", 0>\n";
    if (o.rotate_deg.z != 0) t += "  rotate <0, 0, " + num(o.rotate_deg.z) + ">\n";
    if (o.translate.x != 0 || o.translate.y != 0 || o.translate.z != 0)
      t += "  translate " + vec(o.translate) + "\n";
    t += "}\n";
  }
  return t;
}

}  // namespace hfrt::scene
