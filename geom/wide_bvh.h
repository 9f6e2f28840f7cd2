#pragma once
// WideBvh: the upper levels of a binary BVH (geom/bvh.h) collapsed into 4-wide nodes, traversed
// front to back with SSE (four robust slab tests per step). Its leaves are the binary tree's
// leaves, so the primitives stay where the binary BVH put them and queries that prefer the
// binary tree (distance, winding number) keep using it. Used for rays by MeshSurface and
// PatchSurface.

#include <immintrin.h>

#include <cstdint>
#include <utility>
#include <vector>

#include "base/check.h"
#include "geom/bvh.h"
#include "geom/triangle.h"

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
  /// `binary_children`, when given, receives four entries per wide node: the binary node
  /// index of each child slot (kEmpty for an empty slot), for per-child data kept beside the
  /// wide nodes (MeshSurface's winding-number dipoles).
  static WideBvh collapse(const std::vector<BvhNode>& binary,
                          std::vector<uint32_t>* binary_children = nullptr);

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
  const WideNode* const wide = nodes.data();
  const BvhNode* const bin = binary.data();
  // Per axis, the near and far planes' arrays, chosen once per ray by the direction's sign, as
  // in slab_hit().
  using Planes = float(WideNode::*)[4];
  const bool hx = r.near_is_hi[0], hy = r.near_is_hi[1], hz = r.near_is_hi[2];
  const Planes near_x = hx ? &WideNode::hi_x : &WideNode::lo_x,
               far_x = hx ? &WideNode::lo_x : &WideNode::hi_x;
  const Planes near_y = hy ? &WideNode::hi_y : &WideNode::lo_y,
               far_y = hy ? &WideNode::lo_y : &WideNode::hi_y;
  const Planes near_z = hz ? &WideNode::hi_z : &WideNode::lo_z,
               far_z = hz ? &WideNode::lo_z : &WideNode::hi_z;
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
  // `ref` is the node being visited; the nearest hit child is visited next without a round
  // trip through the stack, the others are pushed farthest first.
  uint32_t ref = 0;
  while (true) {
    if (ref & kLeafBit) {
      leaf(bin[ref & ~kLeafBit], closest);
    } else {
      const WideNode& w = wide[ref];
      // The same robust slab test as slab_hit(), four boxes at once; _mm_max_ps / _mm_min_ps
      // return their second operand when the first is NaN, so a NaN slab never narrows.
      __m128 tn = tmin4, tf = _mm_set1_ps(*closest);
      tn = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(w.*near_x), ox), ix), tn);
      tn = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(w.*near_y), oy), iy), tn);
      tn = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(w.*near_z), oz), iz), tn);
      tf = _mm_min_ps(_mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(w.*far_x), ox), ix), widen), tf);
      tf = _mm_min_ps(_mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(w.*far_y), oy), iy), widen), tf);
      tf = _mm_min_ps(_mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(w.*far_z), oz), iz), widen), tf);
      int mask = _mm_movemask_ps(_mm_cmple_ps(tn, tf));
      if (mask) {
        const uint32_t* child = w.child;
        const int k0 = __builtin_ctz(mask);
        mask &= mask - 1;
        if (!mask) {  // one child: no ordering needed
          ref = child[k0];
          continue;
        }
        alignas(16) float tns[4];
        _mm_store_ps(tns, tn);
        const int k1 = __builtin_ctz(mask);
        mask &= mask - 1;
        if (!mask) {  // two children (the common case)
          HFRT_CHECK_LT(sp, kWideStackSize);
          if (tns[k0] <= tns[k1]) {
            stack[sp++] = {child[k1], tns[k1]};
            ref = child[k0];
          } else {
            stack[sp++] = {child[k0], tns[k0]};
            ref = child[k1];
          }
          continue;
        }
        // Three or four: sorted farthest first, the nearest is visited next.
        Entry hits[4] = {{child[k0], tns[k0]}, {child[k1], tns[k1]}};
        int nh = 2;
        if (hits[0].tnear < hits[1].tnear) std::swap(hits[0], hits[1]);
        while (mask) {
          const int k = __builtin_ctz(mask);
          mask &= mask - 1;
          const Entry c{child[k], tns[k]};
          int j = nh++;
          while (j > 0 && hits[j - 1].tnear < c.tnear) {
            hits[j] = hits[j - 1];
            --j;
          }
          hits[j] = c;
        }
        HFRT_CHECK_LE(sp + nh - 1, kWideStackSize);
        for (int k = 0; k < nh - 1; ++k) stack[sp++] = hits[k];
        ref = hits[nh - 1].ref;
        continue;
      }
    }
    // Pop the next node that can still hold a closer hit.
    while (sp > 0 && stack[sp - 1].tnear > *closest) --sp;
    if (sp == 0) break;
    ref = stack[--sp].ref;
  }
}

}  // namespace hfrt::geom
