#include "geom/mesh_surface.h"

#include <immintrin.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include "base/check.h"
#include "geom/triangle.h"

namespace hfrt::geom {
namespace {

// Deep enough for any BVH the binned builder makes from 2^31 primitives (the builder halves
// ranges it cannot split, so depth stays logarithmic in practice; 128 leaves a large margin).
constexpr int kStackSize = 128;

/// A node of a distance search (closest point, distance bounds) and its squared distance.
struct DistanceEntry {
  uint32_t node;
  float d2;
};

/// Pushes two sibling nodes so that the nearer is on top: it is searched first and tightens
/// the bound that prunes the farther one.
inline void push_nearer_on_top(DistanceEntry* stack, int& sp, uint32_t c0, float d0, uint32_t c1,
                               float d1) {
  HFRT_CHECK_LT(sp + 1, kStackSize);
  if (d0 <= d1) {
    stack[sp++] = {c1, d1};
    stack[sp++] = {c0, d0};
  } else {
    stack[sp++] = {c0, d0};
    stack[sp++] = {c1, d1};
  }
}

// The ray of the 4-lane triangle test: the watertight ray's permuted origin and shear
// broadcast to all lanes, built once per ray.
struct Lanes4Ray {
  int kx, ky, kz;
  __m128 okx, oky, okz, sx, sy, sz;
  explicit Lanes4Ray(const WatertightRay& r)
      : kx(r.kx),
        ky(r.ky),
        kz(r.kz),
        okx(_mm_set1_ps(r.org[r.kx])),
        oky(_mm_set1_ps(r.org[r.ky])),
        okz(_mm_set1_ps(r.org[r.kz])),
        sx(_mm_set1_ps(r.sx)),
        sy(_mm_set1_ps(r.sy)),
        sz(_mm_set1_ps(r.sz)) {}
};

/// Up to four triangles from slot s of `corners` (n of them), one register per corner and
/// coordinate: v0[c] holds corner 0's coordinate c of each. Rows (x0 y0 z0 x1), (x1 y1 z1 x2),
/// (x2 y2 z2 *) are loaded per triangle and transposed; lanes past n repeat triangle s (the
/// caller masks them out). `corners` must be readable one float past its last triangle
/// (MeshSurface pads it).
[[gnu::always_inline]] inline void load_triangles4(const Vec3* corners, uint32_t s, uint32_t n,
                                                   __m128 v0[4], __m128 v1[4], __m128 v2[4]) {
  const float* p0 = &corners[3 * s].x;
  const float* p1 = n > 1 ? p0 + 9 : p0;
  const float* p2 = n > 2 ? p0 + 18 : p0;
  const float* p3 = n > 3 ? p0 + 27 : p0;
  v0[0] = _mm_loadu_ps(p0), v0[1] = _mm_loadu_ps(p1), v0[2] = _mm_loadu_ps(p2),
  v0[3] = _mm_loadu_ps(p3);
  v1[0] = _mm_loadu_ps(p0 + 3), v1[1] = _mm_loadu_ps(p1 + 3), v1[2] = _mm_loadu_ps(p2 + 3),
  v1[3] = _mm_loadu_ps(p3 + 3);
  v2[0] = _mm_loadu_ps(p0 + 6), v2[1] = _mm_loadu_ps(p1 + 6), v2[2] = _mm_loadu_ps(p2 + 6),
  v2[3] = _mm_loadu_ps(p3 + 6);
  _MM_TRANSPOSE4_PS(v0[0], v0[1], v0[2], v0[3]);
  _MM_TRANSPOSE4_PS(v1[0], v1[1], v1[2], v1[3]);
  _MM_TRANSPOSE4_PS(v2[0], v2[1], v2[2], v2[3]);
}

// intersect_triangle() on the triangles in slots [s, s + n) (n <= 4) at once, one per SSE
// lane, with tmin < t < tmax; each hit goes to `accept(slot, hit)` in slot order (a nearest-hit
// caller shrinks its own limit there and rejects t >= it, as the scalar loop over a leaf would
// with tmax = the current limit). Every lane runs the same IEEE operations in the same order as
// the scalar test (no FMA: geom/ builds with -ffp-contract=off; true division), so a lane's
// edge functions, det and t are bitwise the scalar ones and shared edges stay exact negations.
// A lane with a zero edge function takes the scalar path (exact recomputation in double,
// symbolic tie-breaking).
// `corners` must be readable one float past the last triangle (MeshSurface pads it).
template <typename Accept>
[[gnu::always_inline]] inline void intersect_triangles4(const WatertightRay& r, const Lanes4Ray& pr,
                                                        const Vec3* corners, uint32_t s, uint32_t n,
                                                        float tmin, float tmax, Accept&& accept) {
  __m128 v0[4], v1[4], v2[4];
  load_triangles4(corners, s, n, v0, v1, v2);
  // a = v0 - org in the permuted frame, then the shear, as in intersect_triangle().
  const __m128 akx = _mm_sub_ps(v0[pr.kx], pr.okx), aky = _mm_sub_ps(v0[pr.ky], pr.oky),
               akz = _mm_sub_ps(v0[pr.kz], pr.okz);
  const __m128 bkx = _mm_sub_ps(v1[pr.kx], pr.okx), bky = _mm_sub_ps(v1[pr.ky], pr.oky),
               bkz = _mm_sub_ps(v1[pr.kz], pr.okz);
  const __m128 ckx = _mm_sub_ps(v2[pr.kx], pr.okx), cky = _mm_sub_ps(v2[pr.ky], pr.oky),
               ckz = _mm_sub_ps(v2[pr.kz], pr.okz);
  const __m128 ax = _mm_sub_ps(akx, _mm_mul_ps(pr.sx, akz)),
               ay = _mm_sub_ps(aky, _mm_mul_ps(pr.sy, akz));
  const __m128 bx = _mm_sub_ps(bkx, _mm_mul_ps(pr.sx, bkz)),
               by = _mm_sub_ps(bky, _mm_mul_ps(pr.sy, bkz));
  const __m128 cx = _mm_sub_ps(ckx, _mm_mul_ps(pr.sx, ckz)),
               cy = _mm_sub_ps(cky, _mm_mul_ps(pr.sy, ckz));
  const __m128 u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
  const __m128 v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
  const __m128 w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
  const __m128 zero = _mm_setzero_ps();
  const int active = (1 << n) - 1;
  const int zero_mask =
      _mm_movemask_ps(_mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
                                _mm_cmpeq_ps(w, zero))) &
      active;
  const __m128 neg =
      _mm_or_ps(_mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)), _mm_cmplt_ps(w, zero));
  const __m128 pos =
      _mm_or_ps(_mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)), _mm_cmpgt_ps(w, zero));
  const __m128 det = _mm_add_ps(_mm_add_ps(u, v), w);
  const __m128 az = _mm_mul_ps(pr.sz, akz), bz = _mm_mul_ps(pr.sz, bkz),
               cz = _mm_mul_ps(pr.sz, ckz);
  const __m128 tt = _mm_add_ps(_mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)), _mm_mul_ps(w, cz));
  const __m128 inv = _mm_div_ps(_mm_set1_ps(1.0f), det);
  const __m128 t = _mm_mul_ps(tt, inv);
  const __m128 ok =
      _mm_and_ps(_mm_and_ps(_mm_andnot_ps(_mm_and_ps(neg, pos), _mm_cmpneq_ps(det, zero)),
                            _mm_cmpgt_ps(t, _mm_set1_ps(tmin))),
                 _mm_cmplt_ps(t, _mm_set1_ps(tmax)));
  const int hit_mask = _mm_movemask_ps(ok) & active & ~zero_mask;
  if (!(hit_mask | zero_mask)) return;
  alignas(16) float ts[4], vs[4], ws[4], dets[4];
  _mm_store_ps(ts, t);
  _mm_store_ps(vs, v);
  _mm_store_ps(ws, w);
  _mm_store_ps(dets, det);
  for (uint32_t i = 0; i < n; ++i) {
    if (hit_mask >> i & 1) {
      const float inv_i = 1.0f / dets[i];
      accept(s + i, TriangleHitInfo{ts[i], vs[i] * inv_i, ws[i] * inv_i, dets[i] > 0 ? 1 : -1});
    } else if (zero_mask >> i & 1) {
      const uint32_t q = s + i;
      TriangleHitInfo h;
      if (intersect_triangle(r, corners[3 * q], corners[3 * q + 1], corners[3 * q + 2], tmin, tmax,
                             &h))
        accept(q, h);
    }
  }
}

}  // namespace

std::unique_ptr<MeshSurface> MeshSurface::build(const TriangleMesh& mesh, const Options& options) {
  return build(mesh, options, {});
}

std::unique_ptr<MeshSurface> MeshSurface::build_grouped(const TriangleMesh& mesh,
                                                        std::span<const uint64_t> keys,
                                                        const Options& options) {
  HFRT_CHECK_EQ(keys.size(), mesh.triangles.size());
  return build(mesh, options, keys);
}

std::unique_ptr<MeshSurface> MeshSurface::build(const TriangleMesh& mesh, const Options& options,
                                                std::span<const uint64_t> keys) {
  HFRT_CHECK(!mesh.triangles.empty());
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<MeshSurface> s(new MeshSurface());
  const size_t n = mesh.triangles.size();
  std::vector<Box> boxes(n);
  for (size_t i = 0; i < n; ++i) {
    Box b;
    for (int k = 0; k < 3; ++k) b.extend(mesh.corner(i, k));
    boxes[i] = b;
  }
  Bvh bvh =
      keys.empty() ? build_bvh(boxes, options.bvh) : build_bvh_grouped(boxes, keys, options.bvh);
  boxes = {};
  s->nodes_ = std::move(bvh.nodes);
  s->prim_order_ = std::move(bvh.prim_order);
  // One Vec3 of padding: the 4-lane triangle test reads one float past a triangle's corners.
  s->corners_.resize(3 * n + 1);
  for (size_t slot = 0; slot < n; ++slot)
    for (int k = 0; k < 3; ++k) s->corners_[3 * slot + k] = mesh.corner(s->prim_order_[slot], k);
  s->beta_ = options.winding_beta;
  s->build_dipoles();
  const auto end = std::chrono::steady_clock::now();

  s->stats_.source = mesh.source;
  s->stats_.triangles = n;
  s->stats_.degenerate_skipped = mesh.degenerate_skipped;
  s->stats_.bvh_nodes = s->nodes_.size();
  s->stats_.bvh_depth = bvh.depth;
  s->stats_.build_seconds = std::chrono::duration<double>(end - start).count();
  s->stats_.memory_bytes = s->memory_bytes();
  return s;
}

void MeshSurface::build_dipoles() {
  // Per binary node: the area-weighted centroid and the summed area normal (children are
  // always allocated after their parent, so a reverse sweep is bottom-up) ...
  struct DVec {
    double x, y, z;
    DVec(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
    explicit DVec(Vec3 v) : x(v.x), y(v.y), z(v.z) {}
    DVec() : x(0), y(0), z(0) {}
  };
  struct Dipole {
    DVec center, area_normal;  // double: areas of large meshes overflow float
  };
  std::vector<Dipole> dipoles(nodes_.size());
  std::vector<double> area(nodes_.size(), 0.0);
  for (size_t i = nodes_.size(); i-- > 0;) {
    const BvhNode& node = nodes_[i];
    double a_sum = 0, cx = 0, cy = 0, cz = 0, nx = 0, ny = 0, nz = 0;
    if (node.is_leaf()) {
      for (uint32_t s = node.index; s < node.index + node.count; ++s) {
        // In double: a float cross product overflows for coordinates past ~1e19.
        const Vec3 a = corners_[3 * s], b = corners_[3 * s + 1], c = corners_[3 * s + 2];
        const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
        const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
        const double crx = uy * vz - uz * vy, cry = uz * vx - ux * vz, crz = ux * vy - uy * vx;
        const double ar = 0.5 * std::sqrt(crx * crx + cry * cry + crz * crz);
        a_sum += ar;
        cx += ar * ((double(a.x) + b.x + c.x) / 3), cy += ar * ((double(a.y) + b.y + c.y) / 3),
            cz += ar * ((double(a.z) + b.z + c.z) / 3);
        nx += 0.5 * crx, ny += 0.5 * cry, nz += 0.5 * crz;
      }
    } else {
      for (uint32_t c = node.index; c < node.index + 2; ++c) {
        const double ar = area[c];
        a_sum += ar;
        cx += ar * dipoles[c].center.x, cy += ar * dipoles[c].center.y,
            cz += ar * dipoles[c].center.z;
        nx += dipoles[c].area_normal.x, ny += dipoles[c].area_normal.y,
            nz += dipoles[c].area_normal.z;
      }
    }
    area[i] = a_sum;
    dipoles[i].center =
        a_sum > 0 ? DVec(cx / a_sum, cy / a_sum, cz / a_sum) : DVec(node.bounds().center());
    dipoles[i].area_normal = DVec(nx, ny, nz);
  }
  // ... then laid out per 4-wide node, four children side by side.
  // (The box's largest side, not its diagonal: a length squares the sides, which overflows
  // float for exactly the meshes this is for.)
  const float size = nodes_[0].bounds().max_extent();
  winding_scale_ = size > 0 && std::isfinite(size) ? std::ldexp(1.0f, -std::ilogb(size)) : 1.0f;
  const double s1 = winding_scale_, s2 = s1 * s1;
  std::vector<uint32_t> kids;
  wide_ = WideBvh::collapse(nodes_, &kids);
  dipoles_.assign(wide_.nodes.size(), WideDipole{});
  const double beta2 = beta_ * beta_;
  for (size_t w = 0; w < wide_.nodes.size(); ++w) {
    WideDipole& d = dipoles_[w];
    for (int k = 0; k < 4; ++k) {
      const uint32_t b = kids[4 * w + k];
      if (b == WideBvh::kEmpty) {
        d.r2[k] = std::numeric_limits<float>::infinity();
        continue;
      }
      const Dipole& s = dipoles[b];
      d.cx[k] = float(s.center.x * s1), d.cy[k] = float(s.center.y * s1),
      d.cz[k] = float(s.center.z * s1);
      d.nx[k] = float(s.area_normal.x * s2), d.ny[k] = float(s.area_normal.y * s2),
      d.nz[k] = float(s.area_normal.z * s2);
      const Box box = nodes_[b].bounds();
      // Box::max_distance2 in double and scaled: its float squares overflow for the very
      // large meshes that winding_scale_ is for.
      double radius2 = 0;
      for (int a = 0; a < 3; ++a) {
        const double c = a == 0 ? s.center.x : a == 1 ? s.center.y : s.center.z;
        const double r = std::max(c - box.lo[a], double(box.hi[a]) - c) * s1;
        radius2 += r * r;
      }
      d.r2[k] = float(beta2 * radius2);
    }
  }
}

bool MeshSurface::intersect(const Ray& ray, float tmin, float tmax, SurfaceHit* hit) const {
  if (wide_.empty()) return intersect_binary(ray, tmin, tmax, hit);
  const WatertightRay r(ray);
  uint32_t best_slot = ~0u;
  TriangleHitInfo best{};
  float closest = tmax;
  const Lanes4Ray pr(r);
  const Vec3* corners = corners_.data();
  wide_.traverse(nodes_, r, tmin, &closest, [&](const BvhNode& n, float* limit) {
    for (uint32_t s = n.index, end = n.index + n.count; s < end; s += 4)
      intersect_triangles4(r, pr, corners, s, std::min<uint32_t>(4, end - s), tmin, *limit,
                           [&](uint32_t slot, const TriangleHitInfo& h) {
                             if (h.t < *limit) {
                               *limit = h.t;
                               best = h;
                               best_slot = slot;
                             }
                           });
  });
  if (best_slot == ~0u) return false;
  hit->t = best.t;
  hit->prim = prim_order_[best_slot];
  hit->u = best.b1;
  hit->v = best.b2;
  const Vec3 a = corners_[3 * best_slot], b = corners_[3 * best_slot + 1],
             c = corners_[3 * best_slot + 2];
  hit->normal = normalize(cross(b - a, c - a));
  return true;
}

bool MeshSurface::intersect_binary(const Ray& ray, float tmin, float tmax, SurfaceHit* hit) const {
  const WatertightRay r(ray);
  float tnear;
  if (!slab_hit(r, nodes_[0].lo, nodes_[0].hi, tmin, tmax, &tnear)) return false;
  // Front-to-back: the nearer child first, the farther one on the stack with its entry
  // distance so that it is dropped when a closer hit has been found meanwhile.
  struct Entry {
    uint32_t node;
    float tnear;
  };
  Entry stack[kStackSize];
  int sp = 0;
  uint32_t node = 0;
  uint32_t best_slot = ~0u;
  TriangleHitInfo best{};
  float closest = tmax;
  while (true) {
    const BvhNode& n = nodes_[node];
    if (n.is_leaf()) {
      for (uint32_t s = n.index; s < n.index + n.count; ++s) {
        TriangleHitInfo h;
        if (intersect_triangle(r, corners_[3 * s], corners_[3 * s + 1], corners_[3 * s + 2], tmin,
                               closest, &h)) {
          closest = h.t;
          best = h;
          best_slot = s;
        }
      }
    } else {
      const uint32_t c0 = n.index, c1 = n.index + 1;
      float t0, t1;
      const bool h0 = slab_hit(r, nodes_[c0].lo, nodes_[c0].hi, tmin, closest, &t0);
      const bool h1 = slab_hit(r, nodes_[c1].lo, nodes_[c1].hi, tmin, closest, &t1);
      if (h0 && h1) {
        const bool first0 = t0 <= t1;
        HFRT_CHECK_LT(sp, kStackSize);
        stack[sp++] = first0 ? Entry{c1, t1} : Entry{c0, t0};
        node = first0 ? c0 : c1;
        continue;
      }
      if (h0 || h1) {
        node = h0 ? c0 : c1;
        continue;
      }
    }
    // Pop the next node that can still hold a closer hit.
    while (sp > 0 && stack[sp - 1].tnear > closest) --sp;
    if (sp == 0) break;
    node = stack[--sp].node;
  }
  if (best_slot == ~0u) return false;
  hit->t = best.t;
  hit->prim = prim_order_[best_slot];
  hit->u = best.b1;
  hit->v = best.b2;
  const Vec3 a = corners_[3 * best_slot], b = corners_[3 * best_slot + 1],
             c = corners_[3 * best_slot + 2];
  hit->normal = normalize(cross(b - a, c - a));
  return true;
}

bool MeshSurface::occluded(const Ray& ray, float tmin, float tmax) const {
  if (wide_.empty()) return occluded_binary(ray, tmin, tmax);
  // Any hit through the 4-wide BVH: the first hit lowers the traversal's limit below tmin,
  // which empties the stack (every entry lies beyond it) and ends the walk.
  const WatertightRay r(ray);
  const Lanes4Ray pr(r);
  const Vec3* corners = corners_.data();
  bool hit = false;
  float limit = tmax;
  wide_.traverse(nodes_, r, tmin, &limit, [&](const BvhNode& n, float* lim) {
    for (uint32_t s = n.index, end = n.index + n.count; s < end && !hit; s += 4)
      intersect_triangles4(r, pr, corners, s, std::min<uint32_t>(4, end - s), tmin, *lim,
                           [&](uint32_t, const TriangleHitInfo&) { hit = true; });
    if (hit) *lim = -std::numeric_limits<float>::infinity();
  });
  return hit;
}

bool MeshSurface::occluded_binary(const Ray& ray, float tmin, float tmax) const {
  const WatertightRay r(ray);
  float tnear;
  uint32_t stack[kStackSize];
  int sp = 0;
  stack[sp++] = 0;
  while (sp > 0) {
    const BvhNode& n = nodes_[stack[--sp]];
    if (!slab_hit(r, n.lo, n.hi, tmin, tmax, &tnear)) continue;
    if (n.is_leaf()) {
      for (uint32_t s = n.index; s < n.index + n.count; ++s) {
        TriangleHitInfo h;
        if (intersect_triangle(r, corners_[3 * s], corners_[3 * s + 1], corners_[3 * s + 2], tmin,
                               tmax, &h))
          return true;
      }
    } else {
      HFRT_CHECK_LT(sp + 1, kStackSize);
      stack[sp++] = n.index + 1;
      stack[sp++] = n.index;
    }
  }
  return false;
}

void order_crossings(std::vector<Crossing>* out) {
  std::sort(out->begin(), out->end(), [](const Crossing& a, const Crossing& b) {
    return a.t < b.t || (a.t == b.t && a.prim < b.prim);
  });
  // Crossings at the same t, up to rounding (a ray touching the surface at a silhouette edge or
  // vertex counts twice, once each way) are ordered so that the sequence alternates enter / exit
  // whenever it can: entering first while outside, exiting first while inside.
  int depth = 0;
  for (size_t i = 0; i < out->size();) {
    size_t j = i + 1;
    // "The same t" up to rounding: two triangles through one vertex compute t = T / det with
    // different rounding.
    while (j < out->size() && (*out)[j].t - (*out)[j - 1].t <= 1e-6f * std::abs((*out)[j].t)) ++j;
    if (j - i > 1) {
      const int first = depth > 0 ? -1 : 1;
      std::stable_partition(out->begin() + i, out->begin() + j,
                            [first](const Crossing& c) { return c.facing == first; });
      // Interleave: first, other, first, other, ...
      std::vector<Crossing> group(out->begin() + i, out->begin() + j);
      size_t a = 0, b = 0;
      const size_t na = std::count_if(group.begin(), group.end(),
                                      [first](const Crossing& c) { return c.facing == first; });
      for (size_t k = i; k < j; ++k) {
        const bool take_first = ((k - i) % 2 == 0 && a < na) || b >= group.size() - na;
        (*out)[k] = take_first ? group[a++] : group[na + b++];
      }
    }
    for (size_t k = i; k < j; ++k) depth += (*out)[k].facing;
    i = j;
  }
}

void MeshSurface::crossings(const Ray& ray, float tmin, float tmax,
                            std::vector<Crossing>* out) const {
  out->clear();
  const WatertightRay r(ray);
  const Lanes4Ray pr(r);
  auto leaf = [&](const BvhNode& n) {
    for (uint32_t s = n.index, end = n.index + n.count; s < end; s += 4)
      intersect_triangles4(r, pr, corners_.data(), s, std::min<uint32_t>(4, end - s), tmin, tmax,
                           [&](uint32_t slot, const TriangleHitInfo& h) {
                             out->push_back({h.t, h.facing, prim_order_[slot]});
                           });
  };
  if (!wide_.empty()) {
    float limit = tmax;  // never shrinks: every crossing is wanted
    wide_.traverse(nodes_, r, tmin, &limit, [&](const BvhNode& n, float*) { leaf(n); });
  } else {
    float tnear;
    if (slab_hit(r, nodes_[0].lo, nodes_[0].hi, tmin, tmax, &tnear)) leaf(nodes_[0]);
  }
  order_crossings(out);
}

namespace {

/// q = a + b1 (b - a) + b2 (c - a) for q in the triangle's plane (least squares in double);
/// 0, 0 for a degenerate triangle.
void barycentrics(Vec3 q, Vec3 a, Vec3 b, Vec3 c, float* b1, float* b2) {
  const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
  const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
  const double w[3] = {double(q.x) - a.x, double(q.y) - a.y, double(q.z) - a.z};
  auto dot3 = [](const double* x, const double* y) {
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
  };
  const double d00 = dot3(e1, e1), d01 = dot3(e1, e2), d11 = dot3(e2, e2);
  const double d20 = dot3(w, e1), d21 = dot3(w, e2);
  const double den = d00 * d11 - d01 * d01;
  if (!(den > 0)) {
    *b1 = *b2 = 0;
    return;
  }
  *b1 = float((d11 * d20 - d01 * d21) / den);
  *b2 = float((d00 * d21 - d01 * d20) / den);
}

/// Pushes the children of wide node `w` whose squared distance d2[k] is below `bound` onto a
/// stack of WideBvh::kWideStackSize entries, farthest first, so that the nearest is searched
/// next and tightens the bound for the others (the wide distance searches).
inline void push_wide_children(const WideNode& w, const float d2[4], float bound,
                               DistanceEntry* stack, int& sp) {
  DistanceEntry kids[4];
  int nk = 0;
  for (int k = 0; k < 4; ++k) {
    if (!(d2[k] < bound)) continue;
    DistanceEntry c{w.child[k], d2[k]};
    int j = nk++;
    while (j > 0 && kids[j - 1].d2 < c.d2) {
      kids[j] = kids[j - 1];
      --j;
    }
    kids[j] = c;
  }
  HFRT_CHECK_LE(sp + nk, WideBvh::kWideStackSize);
  for (int k = 0; k < nk; ++k) stack[sp++] = kids[k];
}

/// A query box broadcast for wide_box_distance2: a point is the box lo = hi = p.
struct WideQuery {
  __m128 lo[3], hi[3];
  explicit WideQuery(const Box& b) {
    for (int a = 0; a < 3; ++a) lo[a] = _mm_set1_ps(b.lo[a]), hi[a] = _mm_set1_ps(b.hi[a]);
  }
};

/// Squared distances from the query to a wide node's four child boxes, as Box::distance2
/// computes them (for a point: the same operations as Box::distance2(Vec3)); an empty
/// slot's box gives +inf.
inline __m128 wide_box_distance2(const WideNode& w, const WideQuery& q) {
  const __m128 zero = _mm_setzero_ps();
  auto axis = [&](const float* lo, const float* hi, int a) {
    const __m128 d = _mm_max_ps(_mm_max_ps(_mm_sub_ps(_mm_load_ps(lo), q.hi[a]), zero),
                                _mm_sub_ps(q.lo[a], _mm_load_ps(hi)));
    return _mm_mul_ps(d, d);
  };
  return _mm_add_ps(_mm_add_ps(axis(w.lo_x, w.hi_x, 0), axis(w.lo_y, w.hi_y, 1)),
                    axis(w.lo_z, w.hi_z, 2));
}

}  // namespace

template <typename Leaf>
void MeshSurface::walk_by_distance(const Box& query, bool wide, const float* bound,
                                   Leaf&& leaf) const {
  // Entries are wide nodes, or kLeafBit | a binary node: the binary tree's leaves, and every
  // node of the binary walk. A point's query box is lo = hi = p, whose Box::distance2 is
  // Box::distance2(p) operation for operation.
  const WideQuery wq(query);
  DistanceEntry stack[WideBvh::kWideStackSize];
  int sp = 0;
  stack[sp++] = {wide ? 0u : WideBvh::kLeafBit, nodes_[0].bounds().distance2(query)};
  while (sp > 0) {
    const DistanceEntry e = stack[--sp];
    if (e.d2 >= *bound) continue;
    if (!(e.node & WideBvh::kLeafBit)) {
      const WideNode& w = wide_.nodes[e.node];
      alignas(16) float d2[4];
      _mm_store_ps(d2, wide_box_distance2(w, wq));
      push_wide_children(w, d2, *bound, stack, sp);
      continue;
    }
    const BvhNode& n = nodes_[e.node & ~WideBvh::kLeafBit];
    if (n.is_leaf()) {
      if (!leaf(n)) return;
      continue;
    }
    const uint32_t c0 = n.index, c1 = n.index + 1;
    const float d0 = nodes_[c0].bounds().distance2(query),
                d1 = nodes_[c1].bounds().distance2(query);
    HFRT_CHECK_LE(sp + 2, WideBvh::kWideStackSize);
    push_nearer_on_top(stack, sp, c0 | WideBvh::kLeafBit, d0, c1 | WideBvh::kLeafBit, d1);
  }
}

ClosestPoint MeshSurface::closest_point(Vec3 p, float max_distance) const {
  return closest_point_walk(p, max_distance, !wide_.empty());
}

ClosestPoint MeshSurface::closest_point_binary(Vec3 p, float max_distance) const {
  return closest_point_walk(p, max_distance, false);
}

ClosestPoint MeshSurface::closest_point_walk(Vec3 p, float max_distance, bool wide) const {
  // Nearest first. Through the 4-wide tree, four box distances per SSE step (the binary walk
  // tests two per step and pushes twice as many entries; a teapot frame's shading normals
  // 125M -> 62M instructions).
  ClosestPoint best;
  float best_d2 = max_distance < std::numeric_limits<float>::infinity()
                      ? max_distance * max_distance
                      : std::numeric_limits<float>::infinity();
  uint32_t best_slot = ~0u;
  walk_by_distance(Box(p, p), wide, &best_d2, [&](const BvhNode& n) {
    for (uint32_t s = n.index; s < n.index + n.count; ++s) {
      const Vec3 q =
          closest_point_on_triangle(p, corners_[3 * s], corners_[3 * s + 1], corners_[3 * s + 2]);
      const float d2 = length2(q - p);
      if (d2 < best_d2) {
        best_d2 = d2;
        best.point = q;
        best_slot = s;
      }
    }
    return true;
  });
  if (best_slot != ~0u) {
    best.prim = prim_order_[best_slot];
    best.distance = std::sqrt(best_d2);
    const Vec3 a = corners_[3 * best_slot], b = corners_[3 * best_slot + 1],
               c = corners_[3 * best_slot + 2];
    best.normal = normalize(cross(b - a, c - a));
    barycentrics(best.point, a, b, c, &best.b1, &best.b2);
  }
  return best;
}

SurfaceTopology MeshSurface::topology() const {
  // Asked on every ray of the analytic search: settled, one atomic load (base/once.h).
  topology_once_.call([this] {
    // Vertices are identified by their coordinates' bits (an STL file repeats them per
    // triangle); -0 and +0 are one vertex. An open-addressing table of corner indices
    // (std::unordered_map allocated a node per corner: with the sort below, 4 % of an
    // armadillo render's CPU, on the first sign query's critical path).
    const size_t n = prim_order_.size();
    auto bits = [](float f) { return uint64_t(std::bit_cast<uint32_t>(f == 0 ? 0.0f : f)); };
    auto same = [&](const Vec3& v, const Vec3& w) {
      return bits(v.x) == bits(w.x) && bits(v.y) == bits(w.y) && bits(v.z) == bits(w.z);
    };
    size_t capacity = 16;
    while (capacity < 6 * n) capacity *= 2;
    constexpr uint32_t kEmpty = ~0u;
    std::vector<uint32_t> table(capacity, kEmpty);
    std::vector<uint32_t> ids(3 * n);
    for (size_t i = 0; i < 3 * n; ++i) {
      const Vec3 v = corners_[i];
      const uint64_t h = (bits(v.x) * 0x9E3779B97F4A7C15ull) ^ (bits(v.y) * 0xC2B2AE3D27D4EB4Full) ^
                         (bits(v.z) * 0x165667B19E3779F9ull);
      size_t slot = (h ^ (h >> 29)) & (capacity - 1);
      while (table[slot] != kEmpty && !same(corners_[table[slot]], v))
        slot = (slot + 1) & (capacity - 1);
      if (table[slot] == kEmpty) table[slot] = uint32_t(i);
      ids[i] = table[slot];
    }
    table = {};
    // Undirected edges (low, high) with the direction in bit 0: a closed, consistently
    // oriented mesh has each exactly twice, once each way.
    std::vector<uint64_t> edges(3 * n);
    uint64_t all = 0;
    for (size_t t = 0; t < n; ++t)
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = ids[3 * t + k], b = ids[3 * t + (k + 1) % 3];
        edges[3 * t + k] =
            (uint64_t(std::min(a, b)) << 33) | (uint64_t(std::max(a, b)) << 1) | uint64_t(a > b);
        all |= edges[3 * t + k];
      }
    // Sorted by an LSD radix sort over the bytes that are not zero in every key (about three
    // times std::sort's speed on the 156000 edges of the armadillo).
    std::vector<uint64_t> scratch(edges.size());
    for (int shift = 0; shift < 64; shift += 8) {
      if (((all >> shift) & 0xff) == 0) continue;
      size_t count[257] = {};
      for (uint64_t e : edges) ++count[((e >> shift) & 0xff) + 1];
      for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
      for (uint64_t e : edges) scratch[count[(e >> shift) & 0xff]++] = e;
      edges.swap(scratch);
    }
    size_t boundary = 0;
    for (size_t i = 0; i < edges.size();) {
      size_t j = i;
      while (j < edges.size() && edges[j] >> 1 == edges[i] >> 1) ++j;
      const bool paired = j - i == 2 && (edges[i] & 1) == 0 && (edges[i + 1] & 1) == 1;
      if (!paired) boundary += j - i;
      i = j;
    }
    topology_.closed = boundary == 0;
    topology_.boundary_edges = boundary;
  });
  return topology_;
}

namespace {

/// atan2(y, x) in four float lanes, within ~2e-7 rad of the exact value: |y| / |x| or its
/// inverse folded into [0, 1], Abramowitz and Stegun 4.4.49 there (|error| <= 1e-8), then the
/// octant restored. atan2(0, 0) is 0; the lanes' signs of zero are not kept.
inline __m128 atan2_ps(__m128 y, __m128 x) {
  const __m128 sign_bit = _mm_set1_ps(-0.0f);
  const __m128 ax = _mm_andnot_ps(sign_bit, x), ay = _mm_andnot_ps(sign_bit, y);
  const __m128 lo = _mm_min_ps(ax, ay), hi = _mm_max_ps(ax, ay);
  // hi = 0 only when both are 0: a = 0 there (the division would be 0/0).
  const __m128 nonzero = _mm_cmpgt_ps(hi, _mm_setzero_ps());
  const __m128 a =
      _mm_and_ps(nonzero, _mm_div_ps(lo, _mm_or_ps(hi, _mm_andnot_ps(nonzero, _mm_set1_ps(1)))));
  const __m128 s = _mm_mul_ps(a, a);
  __m128 r = _mm_set1_ps(0.0028662257f);
  for (const float c : {-0.0161657367f, 0.0429096138f, -0.0752896400f, 0.1065626393f,
                        -0.1420889944f, 0.1999355085f, -0.3333314528f, 1.0f})
    r = _mm_add_ps(_mm_mul_ps(r, s), _mm_set1_ps(c));
  r = _mm_mul_ps(r, a);
  // |y| > |x|: pi/2 - r; x < 0: pi - r; y < 0: -r.
  const __m128 steep = _mm_cmpgt_ps(ay, ax);
  r = _mm_or_ps(_mm_and_ps(steep, _mm_sub_ps(_mm_set1_ps(float(std::numbers::pi / 2)), r)),
                _mm_andnot_ps(steep, r));
  const __m128 back = _mm_cmplt_ps(x, _mm_setzero_ps());
  r = _mm_or_ps(_mm_and_ps(back, _mm_sub_ps(_mm_set1_ps(float(std::numbers::pi)), r)),
                _mm_andnot_ps(back, r));
  return _mm_xor_ps(r, _mm_and_ps(sign_bit, y));
}

}  // namespace

double MeshSurface::leaf_solid_angle(const BvhNode& n, Vec3 p) const {
  // Four triangles per step in float SSE (Van Oosterom and Strackee, as solid_angle() in
  // double; lanes past the leaf's end repeat its first triangle and are masked out). Near
  // leaves are the other half of a winding number's cost; float keeps the angle within ~1e-6
  // of the double one except within ~1e-6 of the triangle's size from it, where the winding
  // number jumps by 1 anyway.
  const __m128 px = _mm_set1_ps(p.x), py = _mm_set1_ps(p.y), pz = _mm_set1_ps(p.z);
  const __m128 scale = _mm_set1_ps(winding_scale_);
  __m128 sum = _mm_setzero_ps();
  for (uint32_t s = n.index, end = n.index + n.count; s < end; s += 4) {
    const uint32_t k = std::min<uint32_t>(4, end - s);
    __m128 v0[4], v1[4], v2[4];
    load_triangles4(corners_.data(), s, k, v0, v1, v2);
    for (int c = 0; c < 3; ++c) {
      v0[c] = _mm_mul_ps(v0[c], scale), v1[c] = _mm_mul_ps(v1[c], scale);
      v2[c] = _mm_mul_ps(v2[c], scale);
    }
    const __m128 ax = _mm_sub_ps(v0[0], px), ay = _mm_sub_ps(v0[1], py), az = _mm_sub_ps(v0[2], pz);
    const __m128 bx = _mm_sub_ps(v1[0], px), by = _mm_sub_ps(v1[1], py), bz = _mm_sub_ps(v1[2], pz);
    const __m128 cx = _mm_sub_ps(v2[0], px), cy = _mm_sub_ps(v2[1], py), cz = _mm_sub_ps(v2[2], pz);
    auto dot = [](__m128 x0, __m128 y0, __m128 z0, __m128 x1, __m128 y1, __m128 z1) {
      return _mm_add_ps(_mm_add_ps(_mm_mul_ps(x0, x1), _mm_mul_ps(y0, y1)), _mm_mul_ps(z0, z1));
    };
    const __m128 la = _mm_sqrt_ps(dot(ax, ay, az, ax, ay, az)),
                 lb = _mm_sqrt_ps(dot(bx, by, bz, bx, by, bz)),
                 lc = _mm_sqrt_ps(dot(cx, cy, cz, cx, cy, cz));
    const __m128 det = dot(ax, ay, az, _mm_sub_ps(_mm_mul_ps(by, cz), _mm_mul_ps(bz, cy)),
                           _mm_sub_ps(_mm_mul_ps(bz, cx), _mm_mul_ps(bx, cz)),
                           _mm_sub_ps(_mm_mul_ps(bx, cy), _mm_mul_ps(by, cx)));
    const __m128 ab = dot(ax, ay, az, bx, by, bz), ac = dot(ax, ay, az, cx, cy, cz),
                 bc = dot(bx, by, bz, cx, cy, cz);
    const __m128 den =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(_mm_mul_ps(la, lb), lc), _mm_mul_ps(ab, lc)),
                   _mm_add_ps(_mm_mul_ps(ac, lb), _mm_mul_ps(bc, la)));
    static const int32_t kLanes[5][4] = {
        {0, 0, 0, 0}, {-1, 0, 0, 0}, {-1, -1, 0, 0}, {-1, -1, -1, 0}, {-1, -1, -1, -1}};
    const __m128 active =
        _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(kLanes[k])));
    sum = _mm_add_ps(sum, _mm_and_ps(active, atan2_ps(det, den)));
  }
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, sum);
  return 2 * ((double(lanes[0]) + double(lanes[1])) + (double(lanes[2]) + double(lanes[3])));
}

double MeshSurface::winding_number(Vec3 p) const {
  // In units of winding_scale_ (exact: a power of two).
  const Vec3 ps = p * winding_scale_;
  // A mesh of one leaf: every triangle exactly.
  if (wide_.empty()) return leaf_solid_angle(nodes_[0], ps) / (4 * std::numbers::pi);
  // Through the 4-wide tree, four children per step in SSE (float): a child farther than
  // beta times its radius counts as one dipole (first order of Barill et al. 2018), a near
  // leaf adds its triangles' solid angles (float SSE, leaf_solid_angle), a near inner node is
  // opened. The far field is accumulated per lane and summed once; its rounding (~1e-6) is
  // far below the dipoles' own error (~0.08 at beta = 2 on the armadillo).
  const __m128 px = _mm_set1_ps(ps.x), py = _mm_set1_ps(ps.y), pz = _mm_set1_ps(ps.z);

  __m128 far = _mm_setzero_ps();
  double near = 0;
  uint32_t stack[WideBvh::kWideStackSize];
  int sp = 0;
  uint32_t ref = 0;
  while (true) {
    const WideDipole& d = dipoles_[ref];
    const __m128 cx = _mm_load_ps(d.cx), cy = _mm_load_ps(d.cy), cz = _mm_load_ps(d.cz);
    const __m128 rx = _mm_sub_ps(cx, px), ry = _mm_sub_ps(cy, py), rz = _mm_sub_ps(cz, pz);
    const __m128 dist2 =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(rx, rx), _mm_mul_ps(ry, ry)), _mm_mul_ps(rz, rz));
    const __m128 accept = _mm_cmpgt_ps(dist2, _mm_load_ps(d.r2));
    const int accepted = _mm_movemask_ps(accept);
    if (accepted) {
      const __m128 dot = _mm_add_ps(
          _mm_add_ps(_mm_mul_ps(_mm_load_ps(d.nx), rx), _mm_mul_ps(_mm_load_ps(d.ny), ry)),
          _mm_mul_ps(_mm_load_ps(d.nz), rz));
      const __m128 term = _mm_div_ps(dot, _mm_mul_ps(dist2, _mm_sqrt_ps(dist2)));
      far = _mm_add_ps(far, _mm_and_ps(accept, term));
    }
    const uint32_t* child = wide_.nodes[ref].child;
    for (int rest = ~accepted & 0xf; rest != 0; rest &= rest - 1) {
      const uint32_t c = child[std::countr_zero(unsigned(rest))];
      if (c == WideBvh::kEmpty) continue;
      if (c & WideBvh::kLeafBit) {
        near += leaf_solid_angle(nodes_[c & ~WideBvh::kLeafBit], ps);
      } else {
        HFRT_CHECK_LT(sp, WideBvh::kWideStackSize);
        stack[sp++] = c;
      }
    }
    if (sp == 0) break;
    ref = stack[--sp];
  }
  alignas(16) float lanes[4];
  _mm_store_ps(lanes, far);
  const double omega =
      near + (double(lanes[0]) + double(lanes[1])) + (double(lanes[2]) + double(lanes[3]));
  return omega / (4 * std::numbers::pi);
}

MeshSurface::~MeshSurface() = default;

bool MeshSurface::inside(Vec3 p) const {
  return side_grid_.get(bounds()).inside(
      p,
      [this](Vec3 c, float r) {
        const ClosestPoint near = closest_point(c, r);
        return near.prim == ~0u ? std::numeric_limits<float>::infinity() : near.distance;
      },
      [this](Vec3 q) { return winding_number(q); });
}

double MeshSurface::winding_number_exact(Vec3 p) const {
  double omega = 0;
  for (size_t s = 0; s < prim_order_.size(); ++s)
    omega += solid_angle(p, corners_[3 * s], corners_[3 * s + 1], corners_[3 * s + 2]);
  return omega / (4 * std::numbers::pi);
}

float MeshSurface::signed_distance(Vec3 p, Vec3* gradient) const {
  const ClosestPoint c = closest_point(p);
  return signed_distance_from(c, p, inside(p), gradient);
}

float MeshSurface::distance_lower_bound(const Box& box, Vec3* near_vertex) const {
  float best = std::numeric_limits<float>::infinity();
  uint32_t best_slot = 0;
  // Through the 4-wide tree when there is one (four box distances per step in SSE, nearest
  // first), else the binary one.
  walk_by_distance(box, !wide_.empty(), &best, [&](const BvhNode& n) {
    for (uint32_t s = n.index; s < n.index + n.count; ++s) {
      Box tb;
      for (int k = 0; k < 3; ++k) tb.extend(corners_[3 * s + k]);
      const float d2 = tb.distance2(box);
      if (d2 < best) {
        best = d2;
        best_slot = s;
      }
    }
    return best != 0;  // a triangle's box meets the box: the bound is 0, stop
  });
  if (best == 0) {
    if (near_vertex) {
      // A corner of that triangle inside the box, if one is: a point of the mesh there.
      *near_vertex = corners_[3 * best_slot];
      for (int k = 0; k < 3; ++k) {
        if (box.contains(corners_[3 * best_slot + k])) {
          *near_vertex = corners_[3 * best_slot + k];
          break;
        }
      }
    }
    return 0;
  }
  if (near_vertex) *near_vertex = corners_[3 * best_slot];
  // Rounding in the squared distance: shrink slightly so the bound stays a lower bound.
  return std::sqrt(best) * (1.0f - 1e-6f);
}

DistanceBounds MeshSurface::signed_distance_bounds(const Box& box) const {
  const Vec3 c = box.center();
  Vec3 vertex;
  const float apart = distance_lower_bound(box, &vertex);
  // No point of the box is farther from the mesh than from that vertex of it.
  const float reach = std::sqrt(box.max_distance2(vertex)) * (1.0f + 1e-6f);
  if (apart > 0) {
    // No triangle's box meets the box. The distance from its centre would tighten the bounds
    // (by up to half the box), but far from the mesh that search visits a hundred nodes and
    // triangles, a cache miss each (7-9 us per box: 80 % of the armadillo's culling); the
    // reach of the vertex caps it instead. The sign is the sign at the centre (exact for
    // closed meshes, whose winding number is constant off the surface).
    if (inside(c)) return {apart, reach};
    return {-reach, -apart};
  }
  // A point of the mesh in the box: F takes 0 there. (Most boxes of a culling near the
  // surface; the search at the centre below cost them 7-9 us each.)
  if (box.contains(vertex)) return {-reach, reach};
  const float half_diag = 0.5f * length(box.diagonal()) * (1.0f + 1e-6f);
  // A search within half the diagonal prunes far more and finds the same closest point when
  // the box may hold the surface; only when it finds none is the whole mesh searched.
  ClosestPoint near = closest_point(c, half_diag);
  const float dc = near.prim != ~0u ? near.distance : closest_point(c).distance;
  const float upper = dc + half_diag;
  const float lower = dc - half_diag;
  if (lower <= 0) return {-upper, upper};
  // The box meets a triangle's box but not the mesh: signed as above.
  if (inside(c)) return {lower, upper};
  return {-upper, -lower};
}

SurfaceStats MeshSurface::stats() const {
  return stats_;
}

size_t MeshSurface::memory_bytes() const {
  const size_t grid = side_grid_.memory_bytes();  // inside()'s cells, once made
  return sizeof(*this) + nodes_.capacity() * sizeof(BvhNode) + corners_.capacity() * sizeof(Vec3) +
         prim_order_.capacity() * sizeof(uint32_t) + dipoles_.capacity() * sizeof(WideDipole) +
         wide_.memory_bytes() + grid;
}

}  // namespace hfrt::geom
