#pragma once
// Bvh: a binary bounding volume hierarchy over primitive bounding boxes, built top-down with
// the binned surface area heuristic (Wald 2007). It knows nothing about triangles or patches:
// callers pass one box per primitive and get back the node array plus the order in which to
// store their primitives, so that every leaf covers a contiguous range.
//
// Large inputs are built in parallel with TBB (parallel binning near the root, parallel
// recursion below), with the two children of a node allocated as an adjacent pair from an
// atomic counter, so the result does not depend on the thread count's timing except for node
// numbering (the tree shape is deterministic).

#include <cstdint>
#include <span>
#include <vector>

#include "geom/vec.h"

namespace hfrt::geom {

/// One BVH node, 32 bytes. Leaves (count > 0) hold primitives [index, index + count) of the
/// reordered primitive array; inner nodes (count == 0) have children index and index + 1.
struct BvhNode {
  float lo[3];
  uint32_t index;
  float hi[3];
  uint32_t count;

  bool is_leaf() const { return count != 0; }
  Box bounds() const { return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}}; }
};
static_assert(sizeof(BvhNode) == 32);

struct BvhBuildOptions {
  int max_leaf_size = 4;     ///< a leaf never holds more (coincident centroids split by index)
  int bins = 16;             ///< SAH bins per axis (a node of n < bins primitives uses max(4, n))
  float traversal_cost = 1;  ///< cost of one node visit relative to one primitive test
  float primitive_cost = 1;
  size_t parallel_threshold = 4096;  ///< subtrees at least this large build in parallel
  bool parallel = true;
};

/// The hierarchy. nodes[0] is the root (a single leaf for a single primitive).
struct Bvh {
  std::vector<BvhNode> nodes;
  /// prim_order[i] = the original index of the primitive stored at position i.
  std::vector<uint32_t> prim_order;
  int depth = 0;  ///< the longest root-to-leaf path (1 for a single leaf)

  size_t memory_bytes() const {
    return nodes.capacity() * sizeof(BvhNode) + prim_order.capacity() * sizeof(uint32_t);
  }
};

/// Builds a BVH over `prim_bounds` (at least one, all non-empty). Deterministic shape.
Bvh build_bvh(std::span<const Box> prim_bounds, const BvhBuildOptions& options = {});

/// The SAH cost of a built tree (relative units): for tests and statistics.
double sah_cost(const Bvh& bvh, const BvhBuildOptions& options = {});

}  // namespace hfrt::geom
