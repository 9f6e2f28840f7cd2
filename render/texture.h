#pragma once
// Image textures of materials (`texture = "wood.png"`, `mapping = ...` in a scene file), as
// POV-Ray's `image_map`: the image replaces the material's colour at every surface point,
// looked up by a projection of the point (object space) onto the image's unit square, which
// repeats. The image is linear RGB (8- and 16-bit files are decoded from sRGB on loading).

#include <memory>
#include <string>
#include <vector>

#include "base/result.h"
#include "render/material.h"
#include "render/vec.h"

namespace hfrt::render {

/// A loaded image, linear RGB, row-major from the top-left pixel.
struct TextureImage {
  int width = 0, height = 0;
  std::vector<float> rgb;

  /// Bilinear lookup at (u, v); the image covers [0, 1)^2 with v = 0 at the *bottom* (as
  /// POV-Ray's image_map) and repeats in both directions.
  Vec3 lookup(float u, float v) const;
};

/// Reads an image file through OpenImageIO; integer formats are converted from sRGB.
Result<std::shared_ptr<const TextureImage>> load_texture(const std::string& path);

/// The texture's colour at object-space point p with object-space unit normal n:
///  - planar: (u, v) = (x, y) (the image spans the unit square of the x-y plane, repeated
///    along z and across the plane);
///  - spherical: u = longitude about the y axis / 360 degrees, v = latitude / 180 + 1/2, about
///    the origin;
///  - cylindrical: u = the angle about the y axis / 360 degrees, v = y;
///  - triplanar: the planar lookups on the y-z, z-x and x-y planes blended by |n| squared;
///  - uv: needs texture coordinates, which a model's points do not have: the caller refuses
///    it before tracing (kUv reaching here is a bug).
Vec3 texture_colour(const TextureImage& image, TextureMapping mapping, Vec3 p, Vec3 n);

}  // namespace hfrt::render
