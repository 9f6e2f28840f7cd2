#pragma once
// The queries the fuzz targets of geom/ run on a surface that loaded: a ray through the
// middle of its box, crossings, winding number and signed distance at the centre and at a
// corner, distance bounds of its box. None may crash on any mesh that the loaders accept.
#include <vector>

#include "geom/surface.h"

namespace hfrt::fuzz {

/// Runs every Surface query once or twice.
inline void exercise_surface(const geom::Surface& s) {
  const Box b = s.bounds();
  const Vec3 c = (b.lo + b.hi) * 0.5f;
  const geom::Ray ray{Vec3{b.lo.x - 1, c.y, c.z}, Vec3{1, 0.001f, 0.002f}};
  geom::SurfaceHit hit;
  (void)s.intersect(ray, 0, 1e30f, &hit);
  std::vector<geom::Crossing> xs;
  s.crossings(ray, 0, 1e30f, &xs);
  for (const Vec3 p : {c, b.lo, b.hi}) {
    (void)s.winding_number(p);
    Vec3 g;
    (void)s.signed_distance(p, &g);
  }
  (void)s.signed_distance_bounds(b);
  (void)s.stats();
}

}  // namespace hfrt::fuzz
