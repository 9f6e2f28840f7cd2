// Ray packets through MeshSurface's 4-wide BVH (issue 17): up to eight rays traced together.
//
// Coherent rays (a tile's camera rays, shadow rays towards one light) visit nearly the same
// nodes and triangles. A packet walk loads each node and each triangle once for all of them:
// a node's four child boxes are each tested against the eight rays in one 8-lane slab test,
// and a leaf's triangles each against the eight rays in one 8-lane watertight test (Wald et
// al. 2001's packets on Woop et al. 2013's test; Embree's rtcIntersect8 does the same). The
// stack holds a node with the smallest entry distance of the rays that meet it; a node is
// skipped when that exceeds every live ray's current limit. (That walk is geom/packet_lanes.h,
// shared with PatchSurface's packets; this file has the triangles' part.)
//
// Results equal the single-ray queries': each lane runs the scalar watertight test's IEEE
// operations in the same order (geom/ builds with -ffp-contract=off; a true division), with the
// ray's own axis permutation and shear chosen per lane, so a lane's edge functions, det and t
// are bitwise intersect_triangle()'s; a lane with an exactly zero edge function takes the
// scalar test (exact recomputation in double, symbolic tie-breaking). The box tests only prune
// (the same conservative slab test as slab_hit()), so the hits found do not depend on them.
//
// The lanes are GCC vector extensions of eight floats: one copy of the walk compiled for AVX2
// (chosen at start-up where the CPU has it, as eval_bicubic is: geom/bezier.cpp), one for the
// x86-64 baseline, where each operation is two SSE2 instructions.

#include <algorithm>

#include "base/check.h"
#include "geom/mesh_surface.h"
#include "geom/packet_lanes.h"
#include "geom/triangle.h"

namespace hfrt::geom {
namespace {

using namespace packet;
static_assert(kLanes == MeshSurface::kPacketRays);

/// The coordinate `k` (0, 1, 2 per lane, as is0/is1 say) of (x, y, z).
[[gnu::always_inline]] inline F8 pick(const I8& is0, const I8& is1, const F8& x, const F8& y,
                                      const F8& z) {
  return is0 ? x : (is1 ? y : z);
}

/// What the walk keeps per lane: the rays (packet::RayLanes) and their triangle tests' setup.
struct Lanes : RayLanes {
  I8 kx0, kx1, ky0, ky1, kz0, kz1;  // the watertight permutation: kx == 0, kx == 1, ...
  F8 sx, sy, sz;                    // the shear
  WatertightRay wr[kLanes];         // the scalar form, for lanes with a zero edge function
};

template <PacketMode kMode>
[[gnu::always_inline]] inline uint32_t walk(const WideBvh& wide, const std::vector<BvhNode>& binary,
                                            const Vec3* corners, const uint32_t* prim_order,
                                            const Ray* rays, int n, const float* tmin,
                                            const float* tmax, SurfaceHit* hits,
                                            std::vector<Crossing>* out) {
  using Mode = PacketMode;
  Lanes L;
  for (int i = 0; i < kLanes; ++i) {
    // Lanes past n repeat ray 0 and never go live.
    L.wr[i] = WatertightRay(rays[i < n ? i : 0]);
    const WatertightRay& r = L.wr[i];
    set_lane(L, i, r);
    L.kx0[i] = r.kx == 0 ? -1 : 0, L.kx1[i] = r.kx == 1 ? -1 : 0;
    L.ky0[i] = r.ky == 0 ? -1 : 0, L.ky1[i] = r.ky == 1 ? -1 : 0;
    L.kz0[i] = r.kz == 0 ? -1 : 0, L.kz1[i] = r.kz == 1 ? -1 : 0;
    L.sx[i] = r.sx, L.sy[i] = r.sy, L.sz[i] = r.sz;
  }
  set_segments(L, n, tmin, tmax);
  if constexpr (kMode == Mode::kAll)
    for (int i = 0; i < n; ++i) out[i].clear();
  // Nearest hits per lane: slot, t (= tfar) and barycentrics.
  I8 best_slot = ~I8{};
  F8 best_b1{}, best_b2{};
  uint32_t found = 0;

  // One triangle against every live lane.
  auto triangle = [&](uint32_t q) __attribute__((always_inline)) {
    const Vec3 A = corners[3 * q], B = corners[3 * q + 1], C = corners[3 * q + 2];
    // a = v0 - org, then the lane's permutation (the same values as a[r.kx], ...).
    const F8 adx = splat(A.x) - L.ox, ady = splat(A.y) - L.oy, adz = splat(A.z) - L.oz;
    const F8 bdx = splat(B.x) - L.ox, bdy = splat(B.y) - L.oy, bdz = splat(B.z) - L.oz;
    const F8 cdx = splat(C.x) - L.ox, cdy = splat(C.y) - L.oy, cdz = splat(C.z) - L.oz;
    const F8 akx = pick(L.kx0, L.kx1, adx, ady, adz), aky = pick(L.ky0, L.ky1, adx, ady, adz),
             akz = pick(L.kz0, L.kz1, adx, ady, adz);
    const F8 bkx = pick(L.kx0, L.kx1, bdx, bdy, bdz), bky = pick(L.ky0, L.ky1, bdx, bdy, bdz),
             bkz = pick(L.kz0, L.kz1, bdx, bdy, bdz);
    const F8 ckx = pick(L.kx0, L.kx1, cdx, cdy, cdz), cky = pick(L.ky0, L.ky1, cdx, cdy, cdz),
             ckz = pick(L.kz0, L.kz1, cdx, cdy, cdz);
    const F8 ax = akx - L.sx * akz, ay = aky - L.sy * akz;
    const F8 bx = bkx - L.sx * bkz, by = bky - L.sy * bkz;
    const F8 cx = ckx - L.sx * ckz, cy = cky - L.sy * ckz;
    const F8 u = cx * by - cy * bx;
    const F8 v = ax * cy - ay * cx;
    const F8 w = bx * ay - by * ax;
    const I8 zero = (u == 0) | (v == 0) | (w == 0);
    const I8 neg = (u < 0) | (v < 0) | (w < 0);
    const I8 pos = (u > 0) | (v > 0) | (w > 0);
    const F8 det = u + v + w;
    const F8 az = L.sz * akz, bz = L.sz * bkz, cz = L.sz * ckz;
    const F8 tt = u * az + v * bz + w * cz;
    const F8 inv = 1.0f / det;
    const F8 t = tt * inv;
    const I8 ok = ~(neg & pos) & (det != 0) & (t > L.tmin) & (t < L.tfar) & ~zero;
    const int live = L.live;
    int hit_mask = movemask(ok) & live;
    const int zero_mask = movemask(zero) & live;
    if (!(hit_mask | zero_mask)) return;
    F8 b1 = v * inv, b2 = w * inv, th = t;
    F8 facing = det;  // its sign
    // Lanes with a zero edge function: the scalar test decides, and its hit joins the lanes'.
    for (int m = zero_mask; m; m &= m - 1) {
      const int i = __builtin_ctz(m);
      TriangleHitInfo h;
      if (intersect_triangle(L.wr[i], A, B, C, L.tmin[i], L.tfar[i], &h)) {
        hit_mask |= 1 << i;
        th[i] = h.t, b1[i] = h.b1, b2[i] = h.b2, facing[i] = float(h.facing);
      }
    }
    if (!hit_mask) return;
    if constexpr (kMode == Mode::kNearest) {
      // Every hit is nearer than its lane's limit: it becomes the lane's best.
      const I8 take = lanes_of(hit_mask);
      L.tfar = take ? th : L.tfar;
      best_b1 = take ? b1 : best_b1;
      best_b2 = take ? b2 : best_b2;
      best_slot = take ? (I8{} + int32_t(q)) : best_slot;
      found |= uint32_t(hit_mask);
    } else if constexpr (kMode == Mode::kAny) {
      found |= uint32_t(hit_mask);
      L.live &= ~hit_mask;
      L.tfar = lanes_of(hit_mask) ? splat(-kInf) : L.tfar;
    } else {
      for (int m = hit_mask; m; m &= m - 1) {
        const int i = __builtin_ctz(m);
        out[i].push_back({th[i], facing[i] > 0 ? 1 : -1, prim_order[q]});
      }
    }
  };

  // Every triangle of a leaf against all live lanes (not only those that met the leaf's box:
  // one 8-lane test costs about what one lane's would).
  packet::walk<false>(
      wide, binary, L, [&](const BvhNode& leaf, int) __attribute__((always_inline)) {
        for (uint32_t q = leaf.index, end = leaf.index + leaf.count; q < end && L.live; ++q)
          triangle(q);
      });

  if constexpr (kMode == Mode::kNearest) {
    for (uint32_t m = found; m; m &= m - 1) {
      const int i = __builtin_ctz(m);
      const uint32_t slot = uint32_t(best_slot[i]);
      SurfaceHit& h = hits[i];
      h.t = L.tfar[i];
      h.prim = prim_order[slot];
      h.u = best_b1[i];
      h.v = best_b2[i];
      const Vec3 a = corners[3 * slot], b = corners[3 * slot + 1], c = corners[3 * slot + 2];
      h.normal = normalize(cross(b - a, c - a));
    }
  } else if constexpr (kMode == Mode::kAll) {
    for (int i = 0; i < n; ++i) order_crossings(&out[i]);
  }
  return found;
}

using WalkFn = uint32_t (*)(PacketMode, const WideBvh&, const std::vector<BvhNode>&, const Vec3*,
                            const uint32_t*, const Ray*, int, const float*, const float*,
                            SurfaceHit*, std::vector<Crossing>*);

// The walk of each query, for the x86-64 baseline and for AVX2.
#define HFRT_PACKET_WALKS(ATTR, NAME)                                                             \
  ATTR uint32_t NAME(PacketMode mode, const WideBvh& wide, const std::vector<BvhNode>& binary,    \
                     const Vec3* corners, const uint32_t* prim_order, const Ray* rays, int n,     \
                     const float* tmin, const float* tmax, SurfaceHit* hits,                      \
                     std::vector<Crossing>* out) {                                                \
    switch (mode) {                                                                               \
      case PacketMode::kNearest:                                                                  \
        return walk<PacketMode::kNearest>(wide, binary, corners, prim_order, rays, n, tmin, tmax, \
                                          hits, out);                                             \
      case PacketMode::kAny:                                                                      \
        return walk<PacketMode::kAny>(wide, binary, corners, prim_order, rays, n, tmin, tmax,     \
                                      hits, out);                                                 \
      case PacketMode::kAll:                                                                      \
        return walk<PacketMode::kAll>(wide, binary, corners, prim_order, rays, n, tmin, tmax,     \
                                      hits, out);                                                 \
    }                                                                                             \
    return 0;                                                                                     \
  }
HFRT_PACKET_WALKS(, walk_generic)
HFRT_PACKET_WALKS(__attribute__((target("avx2"))), walk_avx2)
#undef HFRT_PACKET_WALKS

// Chosen once at start-up, not by a target_clones ifunc (whose resolver runs before
// sanitizer runtimes are up: geom/bezier.cpp).
const bool kCpuHasAvx2 = packet::cpu_has_avx2();
WalkFn g_walk = kCpuHasAvx2 ? walk_avx2 : walk_generic;

}  // namespace

uint32_t MeshSurface::packet_walk(PacketMode mode, const Ray* rays, int n, const float* tmin,
                                  const float* tmax, SurfaceHit* hits,
                                  std::vector<Crossing>* out) const {
  HFRT_CHECK(n >= 0 && n <= kPacketRays);
  if (n == 0) return 0;
  if (wide_.empty()) {
    // A mesh whose root is a leaf: the single-ray queries.
    uint32_t found = 0;
    for (int i = 0; i < n; ++i) {
      switch (mode) {
        case PacketMode::kNearest:
          if (intersect(rays[i], tmin[i], tmax[i], &hits[i])) found |= 1u << i;
          break;
        case PacketMode::kAny:
          if (occluded(rays[i], tmin[i], tmax[i])) found |= 1u << i;
          break;
        case PacketMode::kAll:
          crossings(rays[i], tmin[i], tmax[i], &out[i]);
          break;
      }
    }
    return found;
  }
  return g_walk(mode, wide_, nodes_, corners_.data(), prim_order_.data(), rays, n, tmin, tmax, hits,
                out);
}

bool MeshSurface::packets_use_avx2() {
  return g_walk == walk_avx2;
}

void MeshSurface::set_packets_use_avx2(bool avx2) {
  g_walk = avx2 && kCpuHasAvx2 ? walk_avx2 : walk_generic;
}

uint32_t MeshSurface::intersect_packet(const Ray* rays, int n, const float* tmin, const float* tmax,
                                       SurfaceHit* hits) const {
  return packet_walk(PacketMode::kNearest, rays, n, tmin, tmax, hits, nullptr);
}

uint32_t MeshSurface::occluded_packet(const Ray* rays, int n, const float* tmin,
                                      const float* tmax) const {
  return packet_walk(PacketMode::kAny, rays, n, tmin, tmax, nullptr, nullptr);
}

void MeshSurface::crossings_packet(const Ray* rays, int n, const float* tmin, const float* tmax,
                                   std::vector<Crossing>* out) const {
  packet_walk(PacketMode::kAll, rays, n, tmin, tmax, nullptr, out);
}

void MeshSurface::crossings_many(const Ray* rays, size_t n, const float* tmin, const float* tmax,
                                 std::vector<Crossing>* out) const {
  for (size_t i = 0; i < n; i += kPacketRays) {
    const int m = int(std::min<size_t>(kPacketRays, n - i));
    crossings_packet(rays + i, m, tmin + i, tmax + i, out + i);
  }
}

}  // namespace hfrt::geom
