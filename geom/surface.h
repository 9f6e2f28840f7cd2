#pragma once
// Surface: what a mesh or patch leaf of a HyperFun model needs from geom/, whatever the
// primitive. One Surface is built per loaded file and shared, immutable, by every leaf and
// thread that uses it (instancing: a transformed leaf maps its points or rays into the
// surface's own space before calling it). All methods are const and thread-safe.
//
// Field convention (as HyperFun): positive inside. Inside is decided by the generalised
// winding number w >= 1/2 (Jacobson et al. 2013), so meshes with small holes and patch sets
// that are not closed (the Utah teapot) still have a sensible inside.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "geom/vec.h"

namespace hfrt::geom {

/// The nearest surface point along a ray.
struct SurfaceHit {
  float t = 0;
  Vec3 normal;         ///< unit geometric normal, facing outward for an outward-oriented surface
  uint32_t prim = 0;   ///< triangle or patch index, in the order of the input
  float u = 0, v = 0;  ///< barycentrics (triangles: of corners 1, 2) or patch parameters
};

/// One crossing of a ray with the surface. facing = +1 when the ray enters (against the
/// outward normal), -1 when it exits. For an outward-oriented closed surface and a ray starting
/// outside, crossings alternate +1, -1 and their count is even.
struct Crossing {
  float t = 0;
  int facing = 0;
  uint32_t prim = 0;
};

/// Counts for `hfrt render --stats`.
struct SurfaceStats {
  std::string source;
  size_t triangles = 0;  ///< triangles (for patches: of the field tessellation, if any)
  size_t patches = 0;
  size_t pieces = 0;  ///< patches: the flat pieces rays are solved in
  size_t boundary_curves =
      0;  ///< patches: the open borders (boundary_winding.h) when the exact field was asked for
  bool exact_field = false;  ///< patches: the field from the patches, no tessellation
  size_t degenerate_skipped = 0;
  size_t bvh_nodes = 0;
  int bvh_depth = 0;
  double build_seconds = 0;
  size_t memory_bytes = 0;
  /// Patches: the border curves in cracks sealed (PatchSurface::Options::seal_tolerance),
  /// and the widest sealed crack measured.
  size_t sealed_curves = 0;
  double crack_gap = 0;
};

/// The closest surface point to a query point.
struct ClosestPoint {
  float distance = std::numeric_limits<float>::infinity();
  Vec3 point;
  /// Unit normal of the closest primitive (a triangle's geometric normal, (b - a) x (c - a)):
  /// the generalised winding number drops by 1 across the primitive along it, so -normal is
  /// the direction into the solid (the field's gradient on the surface).
  Vec3 normal;
  uint32_t prim = ~0u;  ///< original triangle index; ~0u when nothing within the limit
  /// `point` = corner 0 + b1 (corner 1 - corner 0) + b2 (corner 2 - corner 0) of the
  /// triangle (meshes; 0 for others).
  float b1 = 0, b2 = 0;
};

/// The signed distance (positive inside) from the closest point c of a surface to p and p's
/// side, and its gradient when asked: away from c, signed by the side; on the surface, the
/// inward normal (c.normal is outward). What MeshSurface and PatchSurface's signed_distance
/// share.
inline float signed_distance_from(const ClosestPoint& c, Vec3 p, bool inside, Vec3* gradient) {
  if (gradient) {
    if (c.distance > 0) {
      const Vec3 away = (p - c.point) / c.distance;  // grows the distance
      *gradient = inside ? away : -away;
    } else {
      *gradient = -c.normal;
    }
  }
  return inside ? c.distance : -c.distance;
}

/// How the inside of a surface can be decided along a ray (Surface::topology()).
struct SurfaceTopology {
  /// Every edge is shared by exactly two primitives that use it in opposite directions
  /// (vertices identified by their coordinates): the winding number is an integer off the
  /// surface, 0 outside its bounds, and changes by exactly the crossing's facing at each
  /// crossing of a ray, so a ray's crossings decide inside and outside without a winding
  /// number (closed and self-intersecting meshes alike).
  bool closed = false;
  size_t boundary_edges = 0;  ///< directed edges without their one opposite partner
};

/// A closed interval of signed-distance values.
struct DistanceBounds {
  float lo = 0, hi = 0;
};

class Surface {
 public:
  virtual ~Surface() = default;

  virtual Box bounds() const = 0;

  /// The nearest hit with tmin < t < tmax; false when none.
  virtual bool intersect(const Ray& ray, float tmin, float tmax, SurfaceHit* hit) const = 0;

  /// Every crossing with tmin < t < tmax, sorted by t, appended to `out` (cleared first). A
  /// ray through a shared edge or vertex counts once (see geom/triangle.h).
  virtual void crossings(const Ray& ray, float tmin, float tmax,
                         std::vector<Crossing>* out) const = 0;

  /// crossings() of n rays at once: out[i] receives exactly crossings(rays[i], tmin[i],
  /// tmax[i]). Meshes trace them in packets (MeshSurface::crossings_packet), so coherent rays
  /// (a tile's camera rays) share their node and triangle loads; the default asks one ray at a
  /// time.
  virtual void crossings_many(const Ray* rays, size_t n, const float* tmin, const float* tmax,
                              std::vector<Crossing>* out) const {
    for (size_t i = 0; i < n; ++i) crossings(rays[i], tmin[i], tmax[i], &out[i]);
  }

  /// Generalised winding number at p (about 1 inside a closed outward surface, 0 outside).
  virtual double winding_number(Vec3 p) const = 0;

  /// The side of p: winding_number(p) >= 1/2, except that a surface may answer a point in a
  /// region that touches no primitive by the side of another point of that region (exact for
  /// closed surfaces, whose winding number is constant there; for open ones the assumption
  /// signed_distance_bounds already makes). signed_distance's sign and the renderer's sign
  /// samples use this test.
  virtual bool inside(Vec3 p) const { return winding_number(p) >= 0.5; }

  /// Signed distance: +distance to the closest surface point when inside(p), -distance
  /// otherwise. When `gradient` is not null it receives the gradient of that field:
  /// the unit vector from the closest point (pointing into the solid, as HyperFun's).
  virtual float signed_distance(Vec3 p, Vec3* gradient = nullptr) const = 0;

  /// Sound bounds of signed_distance over `box` (for closed surfaces; for open ones the sign
  /// part assumes w does not cross 1/2 inside a box that touches no primitive).
  virtual DistanceBounds signed_distance_bounds(const Box& box) const = 0;

  /// The closest surface point to p among points closer than max_distance, with the
  /// primitive's normal: the gradient on the surface needs no winding number.
  virtual ClosestPoint closest_point(
      Vec3 p, float max_distance = std::numeric_limits<float>::infinity()) const = 0;

  /// How far the field's surface (what closest_point and the winding number see) may be from
  /// the surface that rays hit: 0 for meshes; for patches, their tessellation's measured
  /// distance (PatchSurface::field_error). A ray hit lies within it of the field's surface.
  virtual float field_tolerance() const { return 0; }

  /// Whether the surface is closed (computed once, on first use; thread-safe).
  virtual SurfaceTopology topology() const = 0;

  virtual SurfaceStats stats() const = 0;
};

}  // namespace hfrt::geom
