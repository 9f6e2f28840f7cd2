#include "render/texture.h"

#include <cmath>

#include "base/check.h"
#include "render/image.h"

namespace hfrt::render {
namespace {

float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float wrap01(float t) {
  float f = t - std::floor(t);
  return f >= 1 ? 0 : f;
}

}  // namespace

Vec3 TextureImage::lookup(float u, float v) const {
  // Texel centres at (i + 0.5) / width; rows from the top, v from the bottom.
  float x = wrap01(u) * float(width) - 0.5f;
  float y = (1 - wrap01(v)) * float(height) - 0.5f;
  int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  float fx = x - float(x0), fy = y - float(y0);
  auto texel = [&](int i, int j) {
    i = ((i % width) + width) % width;
    j = ((j % height) + height) % height;
    const float* p = &rgb[(size_t(j) * width + i) * 3];
    return Vec3{p[0], p[1], p[2]};
  };
  Vec3 a = texel(x0, y0) * (1 - fx) + texel(x0 + 1, y0) * fx;
  Vec3 b = texel(x0, y0 + 1) * (1 - fx) + texel(x0 + 1, y0 + 1) * fx;
  return a * (1 - fy) + b * fy;
}

Result<std::shared_ptr<const TextureImage>> load_texture(const std::string& path) {
  int w = 0, h = 0, c = 0;
  auto pixels = read_image(path, &w, &h, &c);
  if (!pixels.ok()) return pixels.error();
  auto dot = path.rfind('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  const bool linear = ext == ".exr" || ext == ".hdr";
  auto img = std::make_shared<TextureImage>();
  img->width = w;
  img->height = h;
  img->rgb.resize(size_t(w) * h * 3);
  for (size_t i = 0; i < size_t(w) * h; ++i) {
    for (int k = 0; k < 3; ++k) {
      float v = pixels.value()[i * c + (c >= 3 ? k : 0)];
      img->rgb[i * 3 + k] = linear ? v : srgb_to_linear(v);
    }
  }
  return std::shared_ptr<const TextureImage>(std::move(img));
}

Vec3 texture_colour(const TextureImage& image, TextureMapping mapping, Vec3 p, Vec3 n) {
  constexpr float kInvTwoPi = 0.15915494309189535f;
  switch (mapping) {
    case TextureMapping::kPlanar:
      return image.lookup(p.x, p.y);
    case TextureMapping::kSpherical: {
      float r = length(p);
      float u = std::atan2(p.x, p.z) * kInvTwoPi + 0.5f;
      float v = r > 0 ? std::asin(std::clamp(p.y / r, -1.0f, 1.0f)) / float(M_PI) + 0.5f : 0.5f;
      return image.lookup(u, v);
    }
    case TextureMapping::kCylindrical:
      return image.lookup(std::atan2(p.x, p.z) * kInvTwoPi + 0.5f, p.y);
    case TextureMapping::kTriplanar: {
      Vec3 w{n.x * n.x, n.y * n.y, n.z * n.z};
      float s = w.x + w.y + w.z;
      if (!(s > 0)) return image.lookup(p.x, p.y);
      return (image.lookup(p.z, p.y) * w.x + image.lookup(p.x, p.z) * w.y +
              image.lookup(p.x, p.y) * w.z) /
             s;
    }
    case TextureMapping::kUv:
      break;
  }
  HFRT_CHECK_MSG(false, "uv texture mapping reached the tracer");
  return {};
}

}  // namespace hfrt::render
