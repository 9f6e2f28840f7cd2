#pragma once
// Colour helpers shared by the image writers (render/image.cpp) and the device check's 8-bit
// images (gpu/check_grid.h), which must encode alike.

#include <cmath>

namespace hfrt {

/// Linear -> sRGB transfer function, clamped to [0, 1] (NaN: 0).
inline float linear_to_srgb(float v) {
  if (!(v > 0)) return 0;
  if (v >= 1) return 1;
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

}  // namespace hfrt
