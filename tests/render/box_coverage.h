#pragma once
// Test helper: compares an image's coverage with the box it was rendered in, for solids that
// fill the box's faces (every camera ray that meets the box must hit its cap).

#include <cstddef>

#include "render/camera.h"
#include "render/image.h"

namespace hfrt::testing {

struct BoxCoverage {
  size_t meets = 0;  ///< pixels whose centre ray meets the box
  size_t wrong = 0;  ///< pixels whose coverage differs from "the ray meets the box"
};

/// Pixel by pixel: does the centre ray of `camera` meet `box`, and is the pixel covered?
inline BoxCoverage box_coverage(const render::Camera& camera, const Box& box,
                                const render::Image& image) {
  const render::CameraFrame frame(camera, image.width, image.height);
  BoxCoverage c;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      float te, tx;
      int axis;
      const bool meets = render::intersect_box(frame.ray(x + 0.5f, y + 0.5f), box, &te, &tx, &axis);
      c.meets += meets;
      c.wrong += meets != (image.alpha[size_t(y) * image.width + x] > 0);
    }
  return c;
}

}  // namespace hfrt::testing
