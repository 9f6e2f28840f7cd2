#pragma once
// Ray packets through a WideBvh (issue 17): eight rays as the lanes of GCC vectors, walked
// together. Each node's four child boxes are tested against the eight rays in one 8-lane slab
// test per box; the stack holds a node with the smallest entry distance of the rays that meet
// it and the lanes that do; a node is skipped when that distance exceeds every live ray's
// current limit. What happens at a leaf is the caller's: MeshSurface tests each triangle
// against all live lanes at once (geom/mesh_packet.cpp), PatchSurface runs Newton for each lane
// that meets the leaf's box (geom/patch_surface.cpp).
//
// The slab test is slab_hit()'s, lane by lane (the same IEEE operations, the far distance
// widened, a NaN slab never narrowing): a lane visits at least the leaves its single-ray walk
// would. Included only by the packet walks' sources, each of which compiles them twice (for
// AVX2 and for the x86-64 baseline, where each 8-lane operation is two SSE2 instructions).

#include <immintrin.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <vector>

#include "base/check.h"
#include "geom/triangle.h"
#include "geom/wide_bvh.h"

// Every helper taking or returning lanes is always_inline, so no vector crosses a call: GCC's
// note that a 32-byte vector argument's ABI differs without AVX does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace hfrt::geom::packet {

constexpr int kLanes = 8;

/// Whether the CPU runs AVX2: the walks' AVX2 copies are chosen once at start-up by it (not by
/// a target_clones ifunc, whose resolver runs before sanitizer runtimes are up).
inline bool cpu_has_avx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
}
using F8 = float __attribute__((vector_size(32)));
using I8 = int32_t __attribute__((vector_size(32)));
constexpr float kInf = std::numeric_limits<float>::infinity();

/// The lanes' sign bits. Two SSE movemasks, in the AVX2 copy too: an AVX intrinsic cannot be
/// inlined through the lambdas of the walk, which do not inherit its target; GCC makes this
/// one extract and two vmovmskps there.
[[gnu::always_inline]] inline int movemask(const I8& m) {
  __m128 lo, hi;
  std::memcpy(&lo, &m, 16);
  std::memcpy(&hi, reinterpret_cast<const char*>(&m) + 16, 16);
  return _mm_movemask_ps(lo) | _mm_movemask_ps(hi) << 4;
}

/// Lanes where bit i of `mask` is set: all ones.
[[gnu::always_inline]] inline I8 lanes_of(int mask) {
  I8 m;
  for (int i = 0; i < kLanes; ++i) m[i] = (mask >> i & 1) ? -1 : 0;
  return m;
}

/// x in every lane.
[[gnu::always_inline]] inline F8 splat(float x) {
  return F8{x, x, x, x, x, x, x, x};
}

/// What the walk keeps per lane.
struct RayLanes {
  F8 ox, oy, oz;  // origin
  F8 ix, iy, iz;  // 1 / direction
  I8 nx, ny, nz;  // the slab's near plane is hi (direction negative)
  F8 tmin, tfar;  // tfar: the query's tmax, lowered by nearest hits; -inf for a finished lane
  int live;       // lanes still searching
};

/// Lane i's origin, inverse direction and slab planes from `r`.
[[gnu::always_inline]] inline void set_lane(RayLanes& L, int i, const WatertightRay& r) {
  L.ox[i] = r.org.x, L.oy[i] = r.org.y, L.oz[i] = r.org.z;
  L.ix[i] = r.inv_dir.x, L.iy[i] = r.inv_dir.y, L.iz[i] = r.inv_dir.z;
  L.nx[i] = r.near_is_hi[0] ? -1 : 0, L.ny[i] = r.near_is_hi[1] ? -1 : 0;
  L.nz[i] = r.near_is_hi[2] ? -1 : 0;
}

/// Lanes [0, n) get [tmin[i], tmax[i]] and are live unless that is empty (the single-ray
/// queries find nothing there); lanes past n never go live.
[[gnu::always_inline]] inline void set_segments(RayLanes& L, int n, const float* tmin,
                                                const float* tmax) {
  alignas(32) float tmin_a[kLanes], tmax_a[kLanes];
  L.live = 0;
  for (int i = 0; i < kLanes; ++i) {
    tmin_a[i] = i < n ? tmin[i] : kInf;
    tmax_a[i] = i < n && tmin[i] < tmax[i] ? tmax[i] : -kInf;
    if (i < n && tmin[i] < tmax[i]) L.live |= 1 << i;
  }
  std::memcpy(&L.tmin, tmin_a, sizeof tmin_a);
  std::memcpy(&L.tfar, tmax_a, sizeof tmax_a);
}

/// The walk: `leaf(const BvhNode& binary_leaf, int lanes)` for every leaf that a live lane's
/// ray meets within its [tmin, tfar] (a leaf may clear bits of L.live and lower L.tfar).
/// Nearest entries first. With kLeafLanes, `lanes` is the live lanes that met the leaf's box;
/// without, all live lanes (the stack then carries no lane masks: for a leaf test that costs
/// the same for one lane as for eight, such as the triangles').
template <bool kLeafLanes, typename Leaf>
[[gnu::always_inline]] inline void walk(const WideBvh& wide, const std::vector<BvhNode>& binary,
                                        RayLanes& L, Leaf&& leaf) {
  if (!L.live) return;
  struct Entry {
    uint32_t ref;  // wide node, or kLeafBit | binary leaf
    float tnear;   // the smallest entry distance of the lanes that meet it
  };
  const F8 widen = splat(kSlabWiden);
  Entry stack[WideBvh::kWideStackSize];
  int stack_lanes[kLeafLanes ? WideBvh::kWideStackSize : 1];  // the lanes that meet each
  int sp = 0;
  if constexpr (kLeafLanes) stack_lanes[sp] = L.live;
  stack[sp++] = {0, -kInf};
  const WideNode* const nodes = wide.nodes.data();
  while (sp > 0 && L.live) {
    const Entry e = stack[--sp];
    const int e_lanes = kLeafLanes ? stack_lanes[sp] : L.live;
    // The farthest limit of the live lanes: an entry beyond it holds nothing for any of them.
    float reach = -kInf;
    for (int m = L.live; m; m &= m - 1) reach = std::max(reach, L.tfar[__builtin_ctz(m)]);
    if (e.tnear > reach) continue;
    if (e.ref & WideBvh::kLeafBit) {
      const int lanes = e_lanes & L.live;
      if (lanes) leaf(binary[e.ref & ~WideBvh::kLeafBit], lanes);
      continue;
    }
    const WideNode& w = nodes[e.ref];
    Entry hit[4];
    int hit_lanes[4];
    int nh = 0;
    for (int k = 0; k < 4; ++k) {
      if (w.child[k] == WideBvh::kEmpty) continue;
      // slab_hit() per lane: near and far planes by the direction's sign, the far distance
      // widened; a NaN slab (zero direction, face through the origin) never narrows.
      const F8 lox = splat(w.lo_x[k]), hix = splat(w.hi_x[k]);
      const F8 nxp = L.nx ? hix : lox, fxp = L.nx ? lox : hix;
      const F8 loy = splat(w.lo_y[k]), hiy = splat(w.hi_y[k]);
      const F8 nyp = L.ny ? hiy : loy, fyp = L.ny ? loy : hiy;
      const F8 loz = splat(w.lo_z[k]), hiz = splat(w.hi_z[k]);
      const F8 nzp = L.nz ? hiz : loz, fzp = L.nz ? loz : hiz;
      F8 tn = L.tmin, tf = L.tfar;
      const F8 t0x = (nxp - L.ox) * L.ix, t1x = (fxp - L.ox) * L.ix * widen;
      const F8 t0y = (nyp - L.oy) * L.iy, t1y = (fyp - L.oy) * L.iy * widen;
      const F8 t0z = (nzp - L.oz) * L.iz, t1z = (fzp - L.oz) * L.iz * widen;
      tn = t0x > tn ? t0x : tn;
      tn = t0y > tn ? t0y : tn;
      tn = t0z > tn ? t0z : tn;
      tf = t1x < tf ? t1x : tf;
      tf = t1y < tf ? t1y : tf;
      tf = t1z < tf ? t1z : tf;
      const int m = movemask(tn <= tf) & L.live;
      if (!m) continue;
      float near = kInf;
      for (int b = m; b; b &= b - 1) near = std::min(near, tn[__builtin_ctz(b)]);
      // Sorted by entry distance, farthest first.
      int j = nh++;
      while (j > 0 && hit[j - 1].tnear < near) {
        hit[j] = hit[j - 1];
        if constexpr (kLeafLanes) hit_lanes[j] = hit_lanes[j - 1];
        --j;
      }
      hit[j] = {w.child[k], near};
      if constexpr (kLeafLanes) hit_lanes[j] = m;
    }
    HFRT_CHECK_LE(sp + nh, WideBvh::kWideStackSize);
    for (int k = 0; k < nh; ++k) {
      if constexpr (kLeafLanes) stack_lanes[sp] = hit_lanes[k];
      stack[sp++] = hit[k];
    }
  }
}

}  // namespace hfrt::geom::packet
