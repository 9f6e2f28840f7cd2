#pragma once
// Per-triangle kernels: the watertight ray–triangle test, the closest point on a triangle and
// the signed solid angle of a triangle. Header-only so the traversal loops inline them.
//
// Watertight test (Woop, Benthin, Wald 2013, "Watertight Ray/Triangle Intersection"): the
// ray is made the +z axis by a permutation and a shear that depend only on the ray, so every
// vertex is transformed exactly the same way in every triangle that uses it; the three 2-D
// edge functions of a shared edge are then exact negations of each other, and a zero edge
// function is recomputed in double (a product of two floats is exact there). That alone
// guarantees no ray slips between two triangles sharing an edge or a vertex.
//
// hfrt goes one step further for crossing counts (all-hits queries, parity, candidate roots):
// a ray that passes exactly through an edge or a vertex would otherwise hit every triangle
// touching it, counting one crossing two or more times. We break such ties by symbolic
// perturbation: the ray is displaced by (eps, eps^2) in the sheared plane, with eps -> 0, so it
// lies on no edge; an edge function that is exactly zero takes the sign of its derivative along
// that displacement. Every point of the plane is then inside exactly the triangles a generic
// nearby ray would hit: one triangle of a fan at a vertex, one of the two at a shared edge,
// none or two at a silhouette edge. Crossing counts of closed meshes are therefore always even.
//
// This file must be compiled without floating-point contraction (geom/ uses -ffp-contract=off):
// a fused multiply-add would round the two halves of an edge function differently and break
// the exact negation on shared edges.

#include <cmath>
#include <cstdint>

#include "geom/vec.h"

namespace hfrt::geom {

/// A ray prepared for the watertight test: axis permutation, shear and robust box slabs.
struct WatertightRay {
  Vec3 org, dir, inv_dir;
  int kx, ky, kz;
  float sx, sy, sz;
  int near_is_hi[3];  ///< per axis: the slab's near plane is hi (direction negative)

  WatertightRay() = default;  ///< uninitialised: for arrays filled later
  explicit WatertightRay(const Ray& r) : org(r.org), dir(r.dir) {
    const float ax = std::abs(r.dir.x), ay = std::abs(r.dir.y), az = std::abs(r.dir.z);
    kz = (ax >= ay && ax >= az) ? 0 : (ay >= az ? 1 : 2);
    kx = (kz + 1) % 3;
    ky = (kx + 1) % 3;
    if (r.dir[kz] < 0) std::swap(kx, ky);  // keeps the winding of the projected triangle
    sx = r.dir[kx] / r.dir[kz];
    sy = r.dir[ky] / r.dir[kz];
    sz = 1.0f / r.dir[kz];
    for (int a = 0; a < 3; ++a) {
      inv_dir[a] = 1.0f / r.dir[a];  // +-inf for a zero component: handled by slab_hit
      near_is_hi[a] = std::signbit(inv_dir[a]) ? 1 : 0;
    }
  }
};

/// 1 + 2 gamma(3): widens the far slab distance so rounding never rejects a box that the
/// ray touches (pbrt-v4, "Robust spawned rays"; Ize 2013).
inline constexpr float kSlabWiden =
    1.0f + 2.0f * (3 * 5.960464477539063e-08f) / (1 - 3 * 5.960464477539063e-08f);

/// Robust ray–box test against [lo, hi]; on a hit returns true and the entry distance. A zero
/// direction component gives NaN slabs for a box face through the origin; the comparisons are
/// written so a NaN never narrows the interval (conservative).
inline bool slab_hit(const WatertightRay& r, const float lo[3], const float hi[3], float tmin,
                     float tmax, float* tnear_out) {
  float tn = tmin, tf = tmax;
  for (int a = 0; a < 3; ++a) {
    const float o = r.org[a], inv = r.inv_dir[a];
    const float near_plane = r.near_is_hi[a] ? hi[a] : lo[a];
    const float far_plane = r.near_is_hi[a] ? lo[a] : hi[a];
    const float t0 = (near_plane - o) * inv;
    const float t1 = (far_plane - o) * inv * kSlabWiden;
    tn = t0 > tn ? t0 : tn;
    tf = t1 < tf ? t1 : tf;
  }
  *tnear_out = tn;
  return tn <= tf;
}

/// A ray–triangle hit: distance, barycentrics of corners 1 and 2, and the facing of the
/// triangle: +1 when the ray enters (meets the counter-clockwise, outward face's front),
/// -1 when it exits.
struct TriangleHitInfo {
  float t, b1, b2;
  int facing;
};

namespace detail {
// The sign (+1, -1, 0) of an edge function X1*Y2 - Y1*X2 that is exactly zero, under the
// symbolic displacement (eps, eps^2) of the ray: d/dpx = Y1 - Y2 first, then d/dpy = X2 - X1.
inline float perturbed_sign(float x1, float y1, float x2, float y2) {
  if (y1 != y2) return y1 > y2 ? 1.0f : -1.0f;
  if (x1 != x2) return x2 > x1 ? 1.0f : -1.0f;
  return 0.0f;
}
// The edge function in double, where the products of floats are exact.
inline float exact_edge(float x1, float y1, float x2, float y2) {
  return static_cast<float>(double(x1) * double(y2) - double(y1) * double(x2));
}
}  // namespace detail

/// Watertight ray–triangle test with symbolic tie-breaking (see the file comment). Hits with
/// tmin < t < tmax count; both faces are hit.
[[gnu::always_inline]] inline bool intersect_triangle(const WatertightRay& r, Vec3 v0, Vec3 v1,
                                                      Vec3 v2, float tmin, float tmax,
                                                      TriangleHitInfo* hit) {
  const Vec3 a = v0 - r.org, b = v1 - r.org, c = v2 - r.org;
  const float ax = a[r.kx] - r.sx * a[r.kz], ay = a[r.ky] - r.sy * a[r.kz];
  const float bx = b[r.kx] - r.sx * b[r.kz], by = b[r.ky] - r.sy * b[r.kz];
  const float cx = c[r.kx] - r.sx * c[r.kz], cy = c[r.ky] - r.sy * c[r.kz];
  float u = cx * by - cy * bx;
  float v = ax * cy - ay * cx;
  float w = bx * ay - by * ax;
  if (u == 0 || v == 0 || w == 0) [[unlikely]] {
    u = detail::exact_edge(cx, cy, bx, by);
    v = detail::exact_edge(ax, ay, cx, cy);
    w = detail::exact_edge(bx, by, ax, ay);
    // Ties: the inside test uses the perturbed signs; the hit point keeps the true (zero)
    // weights.
    const float su = u != 0 ? u : detail::perturbed_sign(cx, cy, bx, by);
    const float sv = v != 0 ? v : detail::perturbed_sign(ax, ay, cx, cy);
    const float sw = w != 0 ? w : detail::perturbed_sign(bx, by, ax, ay);
    if ((su < 0 || sv < 0 || sw < 0) && (su > 0 || sv > 0 || sw > 0)) return false;
    if (su == 0 || sv == 0 || sw == 0) return false;
  } else if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) {
    return false;
  }
  const float det = u + v + w;
  if (det == 0) return false;  // the triangle projects to a segment: the ray grazes it
  const float az = r.sz * a[r.kz], bz = r.sz * b[r.kz], cz = r.sz * c[r.kz];
  const float tt = u * az + v * bz + w * cz;
  const float inv = 1.0f / det;
  const float t = tt * inv;
  if (!(t > tmin && t < tmax)) return false;
  hit->t = t;
  hit->b1 = v * inv;
  hit->b2 = w * inv;
  // det > 0: the ray travels against the triangle's (counter-clockwise) normal, so it enters an
  // outward-oriented mesh here.
  hit->facing = det > 0 ? 1 : -1;
  return true;
}

/// The closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5).
inline Vec3 closest_point_on_triangle(Vec3 p, Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec3 bp = p - b;
  const float d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - c;
  const float d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const float denom = 1.0f / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// The signed solid angle of triangle (a, b, c) seen from p, in steradians (Van Oosterom and
/// Strackee 1983), in double: positive when p is behind the counter-clockwise face, so an
/// outward-oriented closed mesh sums to 4 pi inside and 0 outside.
inline double solid_angle(Vec3 p, Vec3 a, Vec3 b, Vec3 c) {
  const double ax = double(a.x) - p.x, ay = double(a.y) - p.y, az = double(a.z) - p.z;
  const double bx = double(b.x) - p.x, by = double(b.y) - p.y, bz = double(b.z) - p.z;
  const double cx = double(c.x) - p.x, cy = double(c.y) - p.y, cz = double(c.z) - p.z;
  const double la = std::sqrt(ax * ax + ay * ay + az * az);
  const double lb = std::sqrt(bx * bx + by * by + bz * bz);
  const double lc = std::sqrt(cx * cx + cy * cy + cz * cz);
  const double det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
  const double ab = ax * bx + ay * by + az * bz, ac = ax * cx + ay * cy + az * cz,
               bc = bx * cx + by * cy + bz * cz;
  const double den = la * lb * lc + ab * lc + ac * lb + bc * la;
  return 2.0 * std::atan2(det, den);
}

}  // namespace hfrt::geom
