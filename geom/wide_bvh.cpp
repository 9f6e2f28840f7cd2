#include "geom/wide_bvh.h"

#include <limits>

namespace hfrt::geom {

WideBvh WideBvh::collapse(const std::vector<BvhNode>& binary,
                          std::vector<uint32_t>* binary_children) {
  WideBvh out;
  std::vector<WideNode>& wide = out.nodes;
  wide.clear();
  if (binary_children) binary_children->clear();
  if (binary[0].is_leaf()) return out;
  // Collapse: each wide node takes a binary inner node's children, then repeatedly opens the
  // inner child with the largest surface area until it has four.
  struct Todo {
    uint32_t bin;   // binary inner node
    uint32_t wide;  // wide node to fill
  };
  std::vector<Todo> todo{{0, 0}};
  wide.push_back({});
  while (!todo.empty()) {
    const Todo t = todo.back();
    todo.pop_back();
    uint32_t kids[4] = {binary[t.bin].index, binary[t.bin].index + 1, 0, 0};
    int n = 2;
    while (n < 4) {
      int best = -1;
      float best_area = -1;
      for (int k = 0; k < n; ++k) {
        const BvhNode& c = binary[kids[k]];
        if (!c.is_leaf() && c.bounds().half_area() > best_area) {
          best_area = c.bounds().half_area();
          best = k;
        }
      }
      if (best < 0) break;
      const uint32_t open = kids[best];
      kids[best] = binary[open].index;
      kids[n++] = binary[open].index + 1;
    }
    if (binary_children) {
      if (binary_children->size() < 4 * wide.size()) binary_children->resize(4 * wide.size());
      for (int k = 0; k < 4; ++k) (*binary_children)[4 * t.wide + k] = k < n ? kids[k] : kEmpty;
    }
    for (int k = 0; k < 4; ++k) {
      WideNode& w = wide[t.wide];
      if (k >= n) {
        w.lo_x[k] = w.lo_y[k] = w.lo_z[k] = std::numeric_limits<float>::infinity();
        w.hi_x[k] = w.hi_y[k] = w.hi_z[k] = -std::numeric_limits<float>::infinity();
        w.child[k] = kEmpty;
        continue;
      }
      const BvhNode& c = binary[kids[k]];
      w.lo_x[k] = c.lo[0], w.lo_y[k] = c.lo[1], w.lo_z[k] = c.lo[2];
      w.hi_x[k] = c.hi[0], w.hi_y[k] = c.hi[1], w.hi_z[k] = c.hi[2];
      if (c.is_leaf()) {
        w.child[k] = kLeafBit | kids[k];
      } else {
        const uint32_t id = static_cast<uint32_t>(wide.size());
        wide[t.wide].child[k] = id;
        wide.push_back({});  // may reallocate: `w` is not used after this
        todo.push_back({kids[k], id});
      }
    }
  }
  wide.shrink_to_fit();
  if (binary_children) binary_children->resize(4 * wide.size(), kEmpty);
  return out;
}

}  // namespace hfrt::geom
