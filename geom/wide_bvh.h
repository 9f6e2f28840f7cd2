#pragma once
// WideBvh: the upper levels of a binary BVH (geom/bvh.h) collapsed into 4-wide nodes, traversed
// front to back with SSE (four robust slab tests per step). Its leaves are the binary tree's
// leaves, so the primitives stay where the binary BVH put them and queries that prefer the
// binary tree (distance, winding number) keep using it. Used for rays by MeshSurface and
// PatchSurface.

#include <immintrin.h>

#include <cstdint>
#include <vector>

#include "geom/bvh.h"
#include "geom/triangle.h"
#include "lang/check.h"

namespace hfrt::geom {

/// One 4-wide node, 112 bytes. child[k]: a wide node index, or kLeafBit | the index of a
/// binary leaf node, or kEmpty (its box is empty, so never hit).
struct alignas(16) WideNode {
  float lo_x[4], hi_x[4], lo_y[4], hi_y[4], lo_z[4], hi_z[4];
  uint32_t child[4];
};

class WideBvh {
 public:
  static constexpr uint32_t kLeafBit = 0x80000000u;
  static constexpr uint32_t kEmpty = 0xffffffffu;
  static constexpr int kWideStackSize = 256;

  /// Collapses `binary` (each wide node takes an inner node's children, then opens the inner
  /// child of largest area until it has four). Empty when the binary root is a leaf.
  static WideBvh collapse(const std::vector<BvhNode>& binary);

  bool empty() const { return nodes.empty(); }
  size_t memory_bytes() const { return nodes.capacity() * sizeof(WideNode); }

  /// Front-to-back traversal of the boxes the ray meets with tmin <= t <= *closest:
  /// `leaf(const BvhNode& binary_leaf, float* closest)` tests a leaf's primitives and may
  /// shrink *closest (nearest hit) or leave it (all crossings). Subtrees entered beyond
  /// *closest are skipped.
  template <typename Leaf>
  void traverse(const std::vector<BvhNode>& binary, const WatertightRay& r, float tmin,
                float* closest, Leaf&& leaf) const;

  std::vector<WideNode> nodes;
};

template <typename Leaf>
void WideBvh::traverse(const std::vector<BvhNode>& binary, const WatertightRay& r, float tmin,
                       float* closest, Leaf&& leaf) const {
  const std::vector<WideNode>& wide = nodes;
  // Per axis, the near and far planes' arrays (by the direction's sign), as in slab_hit().
  const int nx = r.near_is_hi[0], ny = r.near_is_hi[1], nz = r.near_is_hi[2];
  const __m128 ox = _mm_set1_ps(r.org.x), oy = _mm_set1_ps(r.org.y), oz = _mm_set1_ps(r.org.z);
  const __m128 ix = _mm_set1_ps(r.inv_dir.x), iy = _mm_set1_ps(r.inv_dir.y),
               iz = _mm_set1_ps(r.inv_dir.z);
  const __m128 widen = _mm_set1_ps(kSlabWiden);
  const __m128 tmin4 = _mm_set1_ps(tmin);
  struct Entry {
    uint32_t ref;  // wide node, or kLeafBit | binary leaf
    float tnear;
  };
  Entry stack[kWideStackSize];
  int sp = 0;
  stack[sp++] = {0, tmin};
  while (sp > 0) {
    const Entry e = stack[--sp];
    if (e.tnear > *closest) continue;
    if (e.ref & kLeafBit) {
      leaf(binary[e.ref & ~kLeafBit], closest);
      continue;
    }
    const WideNode& w = wide[e.ref];
    // The same robust slab test as slab_hit(), four boxes at once; _mm_max_ps / _mm_min_ps
    // return their second operand when the first is NaN, so a NaN slab never narrows.
    const __m128 lox = _mm_load_ps(nx ? w.hi_x : w.lo_x), hix = _mm_load_ps(nx ? w.lo_x : w.hi_x);
    const __m128 loy = _mm_load_ps(ny ? w.hi_y : w.lo_y), hiy = _mm_load_ps(ny ? w.lo_y : w.hi_y);
    const __m128 loz = _mm_load_ps(nz ? w.hi_z : w.lo_z), hiz = _mm_load_ps(nz ? w.lo_z : w.hi_z);
    __m128 tn = tmin4, tf = _mm_set1_ps(*closest);
    tn = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(lox, ox), ix), tn);
    tn = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(loy, oy), iy), tn);
    tn = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(loz, oz), iz), tn);
    tf = _mm_min_ps(_mm_mul_ps(_mm_mul_ps(_mm_sub_ps(hix, ox), ix), widen), tf);
    tf = _mm_min_ps(_mm_mul_ps(_mm_mul_ps(_mm_sub_ps(hiy, oy), iy), widen), tf);
    tf = _mm_min_ps(_mm_mul_ps(_mm_mul_ps(_mm_sub_ps(hiz, oz), iz), widen), tf);
    int mask = _mm_movemask_ps(_mm_cmple_ps(tn, tf));
    if (!mask) continue;
    alignas(16) float tns[4];
    _mm_store_ps(tns, tn);
    // Push the hit children farthest first, so the nearest is popped next.
    Entry hits[4];
    int nh = 0;
    while (mask) {
      const int k = __builtin_ctz(mask);
      mask &= mask - 1;
      Entry c{w.child[k], tns[k]};
      int j = nh++;
      while (j > 0 && hits[j - 1].tnear < c.tnear) {
        hits[j] = hits[j - 1];
        --j;
      }
      hits[j] = c;
    }
    HFRT_CHECK_LE(sp + nh, kWideStackSize);
    for (int k = 0; k < nh; ++k) stack[sp++] = hits[k];
  }
}

}  // namespace hfrt::geom
