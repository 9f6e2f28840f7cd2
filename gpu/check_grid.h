#pragma once
// Compact forms of the device check's case data (docs/gpu.md, "Device check cases"), shared by
// the producer (app/gpu_cases.cpp) and the runner (tools/gpu_runner), so that both make the
// same bits: a grid of points given by its parameters instead of a file, and 8-bit images.
// They keep the prepared check small enough to carry to the GPU machine.

#include <cmath>
#include <cstdint>
#include <vector>

#include "base/color.h"

namespace hfrt::gpu {

/// The points of `grid=W,H,X0,X1,Y0,Y1,Z`, structure of arrays with `num_inputs` coordinates:
/// point j*W + i is x = x0 + (i + 0.5) dx, y = y1 - (j + 0.5) dy with dx = (x1 - x0) / W and
/// dy = (y1 - y0) / H (row 0 at the top), z, then `x4` (x[4], a model's time), then 0;
/// computed in float, in this order: render::render_slice's pixel centres (render/slice.cpp).
inline std::vector<float> grid_points(int w, int h, float x0, float x1, float y0, float y1, float z,
                                      int num_inputs, float x4 = 0.0f) {
  const size_t n = size_t(w) * size_t(h);
  std::vector<float> xs(n * size_t(num_inputs > 0 ? num_inputs : 1), 0.0f);
  const float dx = (x1 - x0) / float(w), dy = (y1 - y0) / float(h);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const size_t k = size_t(j) * size_t(w) + size_t(i);
      xs[k] = x0 + (float(i) + 0.5f) * dx;
      if (num_inputs > 1) xs[n + k] = y1 - (float(j) + 0.5f) * dy;
      if (num_inputs > 2) xs[2 * n + k] = z;
      if (num_inputs > 3) xs[3 * n + k] = x4;
    }
  }
  return xs;
}

/// One pixel of render kernel output (linear r, g, b, coverage, ...) as `format=rgba8` stores
/// it: sRGB-encoded r, g, b and the coverage, each rounded to 8 bits.
inline void quantize_rgba8(const float* px, uint8_t out[4]) {
  for (int c = 0; c < 3; ++c) out[c] = uint8_t(std::lround(linear_to_srgb(px[c]) * 255.0f));
  const float a = px[3] > 0 ? (px[3] < 1 ? px[3] : 1.0f) : 0.0f;
  out[3] = uint8_t(std::lround(a * 255.0f));
}

}  // namespace hfrt::gpu
