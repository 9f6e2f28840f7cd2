#include "geom/bvh.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>

#include "base/check.h"
#include "base/memory.h"
#include "base/parallel.h"

namespace hfrt::geom {
namespace {

constexpr int kMaxBins = 32;

// The builder works on 4-lane vectors (GCC/Clang vector extensions, SSE on x86): a box is two
// of them, and binning a primitive on all three axes is a handful of vector ops instead of
// eighteen scalar min/max. Lane 3 of a primitive's upper corner carries its original index
// (bits, never computed with); lane 3 of every other vector is ignored.
using V4 = float __attribute__((vector_size(16)));
using V4i = int32_t __attribute__((vector_size(16)));

constexpr float kInf = std::numeric_limits<float>::infinity();

// As std::min / std::max (Box::extend), so that bounds are bit for bit those of the scalar
// definition (the choice between -0 and +0 included).
inline V4 vmin4(V4 a, V4 b) {
  return b < a ? b : a;
}
inline V4 vmax4(V4 a, V4 b) {
  return a < b ? b : a;
}

/// A primitive as the builder moves it: its box with its original index, 32 bytes, partitioned
/// in place. (An index into the caller's boxes made every binning pass a random read, one
/// cache miss per primitive and level on large meshes.)
struct PrimRef {
  V4 lo, hi;  // hi[3]: the original index, as bits
  uint32_t id() const { return std::bit_cast<V4i>(hi)[3]; }
  /// The centroid, computed as Box::center (lane 3 zeroed first: the index bits may read as
  /// a denormal, slow to add).
  V4 center() const {
    const V4i keep = {-1, -1, -1, 0};
    return (lo + std::bit_cast<V4>(std::bit_cast<V4i>(hi) & keep)) * 0.5f;
  }
};

/// A box as two vectors (lane 3 ignored). No default member values: the builder keeps arrays
/// of them per node and sets up only the entries it uses (VBox::empty()).
struct VBox {
  V4 lo, hi;
  static VBox empty() {
    VBox b;
    b.lo = V4{kInf, kInf, kInf, kInf};
    b.hi = V4{-kInf, -kInf, -kInf, -kInf};
    return b;
  }
  void extend(V4 l, V4 h) {
    lo = vmin4(lo, l);
    hi = vmax4(hi, h);
  }
  void extend(const VBox& b) { extend(b.lo, b.hi); }
  Box box() const { return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}}; }
  /// Box::half_area, the same operations in the same order.
  float half_area() const {
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return 0;
    const V4 d = hi - lo;
    return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
  }
};

/// The bins of one axis: bounds and counts, only the first `nbins` used (they are set up per
/// node, so a small node does not pay for kMaxBins).
struct AxisBins {
  VBox bounds[kMaxBins];
  uint32_t count[kMaxBins];
};

struct BinSet {
  AxisBins axis[3];
  int nbins = 0;

  explicit BinSet(int n = 0) : nbins(n) {
    for (AxisBins& a : axis) {
      for (int k = 0; k < n; ++k) {
        a.bounds[k] = VBox::empty();
        a.count[k] = 0;
      }
    }
  }
  void join(const BinSet& b) {
    for (int ax = 0; ax < 3; ++ax) {
      for (int k = 0; k < nbins; ++k) {
        axis[ax].bounds[k].extend(b.axis[ax].bounds[k]);
        axis[ax].count[k] += b.axis[ax].count[k];
      }
    }
  }
};

/// The binning of one node's primitives by their centroids on three axes: the one rule that
/// both fill_bins and the partition after the split use, since the children's bounds are
/// taken from the bins and must be those of the primitives each side gets.
struct Binning {
  V4 lo, scale, last;

  Binning(const Box& cb, int nbins) {
    lo = V4{cb.lo.x, cb.lo.y, cb.lo.z, 0};
    scale = V4{0, 0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      // A denormal extent makes nbins / ext infinite, and (c - lo) * inf is NaN at c = lo
      // (found by fuzz/mesh_fuzz.cpp): such an axis cannot be binned, like a zero extent.
      const float ext = cb.hi[a] - cb.lo[a];
      const float s = ext > 0 ? nbins / ext : 0;
      scale[a] = std::isfinite(s) ? s : 0;
    }
    const float top = static_cast<float>(nbins - 1);
    last = V4{top, top, top, top};
  }

  /// The bin of `r` on each axis: t <= 0 and NaN give bin 0 (t > 0 ? t : 0), the top is
  /// clamped in float (converting a NaN or an out-of-range float to int is undefined), the
  /// rest truncated.
  V4i bins(const PrimRef& r) const {
    const V4 zero = {0, 0, 0, 0};
    V4 t = (r.center() - lo) * scale;
    t = t > zero ? t : zero;
    t = t < last ? t : last;
    return __builtin_convertvector(t, V4i);
  }
};

/// Bounds of a range of primitives and of their centroids.
struct RangeInfo {
  VBox bounds = VBox::empty(), centroids = VBox::empty();
};

class Builder {
 public:
  Builder(std::span<const Box> boxes, const BvhBuildOptions& opt, Bvh* out) : opt_(opt), out_(out) {
    const size_t n = boxes.size();
    reserve_huge(refs_, n);  // 32 MB for 1M triangles: see base/memory.h
    refs_.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const Box& b = boxes[i];
      refs_[i].lo = V4{b.lo.x, b.lo.y, b.lo.z, 0};
      refs_[i].hi = V4{b.hi.x, b.hi.y, b.hi.z, std::bit_cast<float>(static_cast<uint32_t>(i))};
    }
    // Room for the most nodes a tree of n leaves can have, left uninitialised: only the
    // nodes made are touched (a zero-filled vector of 2n - 1 nodes wrote 64 MB for 1M
    // triangles, most of it never used), then copied out.
    node_capacity_ = std::max<size_t>(1, 2 * n - 1);
    nodes_.reset(new BvhNode[node_capacity_]);
    advise_huge_pages(nodes_.get(), node_capacity_ * sizeof(BvhNode));
    next_node_.store(1);
  }

  void build() {
    const uint32_t n = static_cast<uint32_t>(refs_.size());
    int depth = build_node(0, 0, n, range_info(0, n));
    out_->nodes.clear();
    reserve_huge(out_->nodes, next_node_.load());
    out_->nodes.assign(nodes_.get(), nodes_.get() + next_node_.load());
    nodes_.reset();
    out_->prim_order.resize(refs_.size());
    for (size_t i = 0; i < refs_.size(); ++i) out_->prim_order[i] = refs_[i].id();
    out_->depth = depth;
  }

 private:
  RangeInfo range_info(uint32_t begin, uint32_t end) const {
    auto body = [&](size_t lo, size_t hi, RangeInfo acc) {
      for (size_t i = lo; i != hi; ++i) {
        acc.bounds.extend(refs_[i].lo, refs_[i].hi);
        const V4 c = refs_[i].center();
        acc.centroids.extend(c, c);
      }
      return acc;
    };
    auto join = [](RangeInfo a, const RangeInfo& b) {
      a.bounds.extend(b.bounds);
      a.centroids.extend(b.centroids);
      return a;
    };
    if (opt_.parallel && end - begin >= 65536)
      return par::parallel_reduce(begin, end, 8192, RangeInfo{}, body, join);
    return body(begin, end, RangeInfo{});
  }

  /// std::partition of refs_[begin, end) by `left` (the same swaps as libstdc++'s, so the
  /// same order), returning the split; the centroid bounds of both sides are gathered on the
  /// way: no third pass over the primitives per node (1.04M triangles: 0.56-0.60 s -> 0.51-0.56
  /// s on 2 threads, bench/README.md).
  template <typename Pred>
  uint32_t partition(uint32_t begin, uint32_t end, Pred&& left, VBox* left_centroids,
                     VBox* right_centroids) {
    PrimRef* first = refs_.data() + begin;
    PrimRef* last = refs_.data() + end;
    VBox lc = VBox::empty(), rc = VBox::empty();
    auto add = [](VBox& b, const PrimRef& r) {
      const V4 c = r.center();
      b.extend(c, c);
    };
    while (true) {
      while (true) {
        if (first == last) {
          *left_centroids = lc;
          *right_centroids = rc;
          return static_cast<uint32_t>(first - refs_.data());
        }
        if (!left(*first)) break;
        add(lc, *first);
        ++first;
      }
      --last;
      while (true) {
        if (first == last) {
          add(rc, *first);  // *first failed `left`: the right side's first element
          *left_centroids = lc;
          *right_centroids = rc;
          return static_cast<uint32_t>(first - refs_.data());
        }
        if (left(*last)) break;
        add(rc, *last);
        --last;
      }
      std::iter_swap(first, last);
      add(lc, *first);
      add(rc, *last);
      ++first;
    }
  }

  void fill_bins(uint32_t begin, uint32_t end, const Binning& binning, int nbins,
                 BinSet* set) const {
    auto bin = [&](const PrimRef& r, BinSet* acc) {
      const V4i k = binning.bins(r);
      for (int a = 0; a < 3; ++a) {
        acc->axis[a].bounds[k[a]].extend(r.lo, r.hi);
        ++acc->axis[a].count[k[a]];
      }
    };
    auto body = [&](size_t first, size_t stop, BinSet* acc) {
      if (stop - first < 256) {
        for (size_t i = first; i != stop; ++i) bin(refs_[i], acc);
        return;
      }
      // Neighbours in the array are neighbours in space and mostly fall into the same bins:
      // one set of bins would make each primitive wait for the previous one's update of the
      // same bin (a load-min-store chain). Two sets, for even and odd positions, halve it.
      BinSet odd(nbins);
      size_t i = first;
      for (; i + 1 < stop; i += 2) {
        bin(refs_[i], acc);
        bin(refs_[i + 1], &odd);
      }
      if (i != stop) bin(refs_[i], acc);
      acc->join(odd);
    };
    if (opt_.parallel && end - begin >= 65536) {
      // Near the root only: a BinSet is a few KiB, copied per task.
      *set = par::parallel_reduce(
          begin, end, 8192, BinSet(nbins),
          [&](size_t first, size_t stop, BinSet acc) {
            body(first, stop, &acc);
            return acc;
          },
          [](BinSet a, const BinSet& b) {
            a.join(b);
            return a;
          });
    } else {
      body(begin, end, set);
    }
  }

  void make_leaf(BvhNode& node, uint32_t begin, uint32_t end) {
    node.index = begin;
    node.count = end - begin;
  }

  // Builds node `id` over refs_[begin, end) whose bounds are `info`; returns the subtree depth.
  int build_node(uint32_t id, uint32_t begin, uint32_t end, const RangeInfo& info) {
    const uint32_t n = end - begin;
    BvhNode& node = nodes_[id];
    const Box bounds = info.bounds.box();
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = bounds.lo[a];
      node.hi[a] = bounds.hi[a];
    }
    if (n <= 1) {
      make_leaf(node, begin, end);
      return 1;
    }
    // Choose the split: SAH over binned centroids on all three axes. The bounds of both sides
    // of the best split are kept from the sweep: they are the children's bounds.
    const Box cb = info.centroids.box();
    const int nbins = std::min(std::clamp(opt_.bins, 2, kMaxBins), std::max<int>(4, int(n)));
    int best_axis = -1, best_split = 0;
    float best_cost = std::numeric_limits<float>::infinity();
    VBox best_left, best_right;
    const Binning binning(cb, nbins);
    if (cb.diagonal()[cb.max_axis()] > 0) {
      BinSet set(nbins);
      fill_bins(begin, end, binning, nbins, &set);
      for (int a = 0; a < 3; ++a) {
        if (!(cb.hi[a] > cb.lo[a])) continue;
        const AxisBins& bins = set.axis[a];
        // Sweep from the right, then from the left.
        // (Areas only where both sides hold primitives: the splits with an empty side, which
        // most bins of a small node give, are never costed.)
        VBox right_box[kMaxBins];
        uint32_t right_count[kMaxBins];
        VBox acc = VBox::empty();
        uint32_t cnt = 0;
        for (int k = nbins - 1; k > 0; --k) {
          acc.extend(bins.bounds[k]);
          cnt += bins.count[k];
          right_box[k] = acc;
          right_count[k] = cnt;
        }
        acc = VBox::empty();
        cnt = 0;
        for (int k = 1; k < nbins; ++k) {
          acc.extend(bins.bounds[k - 1]);
          cnt += bins.count[k - 1];
          if (cnt == 0 || right_count[k] == 0) continue;
          float cost = acc.half_area() * cnt + right_box[k].half_area() * right_count[k];
          if (cost < best_cost) {
            best_cost = cost;
            best_axis = a;
            best_split = k;
            best_left = acc;
            best_right = right_box[k];
          }
        }
      }
    }
    const float parent_area = bounds.half_area();
    const float leaf_cost = opt_.primitive_cost * n;
    const float split_cost =
        best_axis < 0
            ? std::numeric_limits<float>::infinity()
            : opt_.traversal_cost + opt_.primitive_cost * best_cost / std::max(parent_area, 1e-30f);
    if (n <= static_cast<uint32_t>(opt_.max_leaf_size) && leaf_cost <= split_cost) {
      make_leaf(node, begin, end);
      return 1;
    }
    uint32_t mid = begin;
    VBox left_centroids = VBox::empty(), right_centroids = VBox::empty();
    if (best_axis >= 0) {
      mid = partition(
          begin, end, [&](const PrimRef& r) { return binning.bins(r)[best_axis] < best_split; },
          &left_centroids, &right_centroids);
    }
    RangeInfo left, right;
    if (best_axis < 0 || mid == begin || mid == end) {
      // All centroids coincide (or the split left a side empty): any split is as good; halve
      // by index, with bounds computed anew.
      mid = begin + n / 2;
      left = range_info(begin, mid);
      right = range_info(mid, end);
    } else {
      left = {best_left, left_centroids};
      right = {best_right, right_centroids};
    }
    const uint32_t child = next_node_.fetch_add(2);
    HFRT_CHECK_LE(child + 1, node_capacity_ - 1);
    node.index = child;
    node.count = 0;
    int dl = 0, dr = 0;
    if (opt_.parallel && n >= opt_.parallel_threshold) {
      par::parallel_invoke([&] { dl = build_node(child, begin, mid, left); },
                           [&] { dr = build_node(child + 1, mid, end, right); });
    } else {
      dl = build_node(child, begin, mid, left);
      dr = build_node(child + 1, mid, end, right);
    }
    return 1 + std::max(dl, dr);
  }

  const BvhBuildOptions& opt_;
  Bvh* out_;
  std::vector<PrimRef> refs_;
  std::unique_ptr<BvhNode[]> nodes_;  // the nodes being built (node_capacity_ of them)
  size_t node_capacity_ = 0;
  std::atomic<uint32_t> next_node_{1};
};

}  // namespace

Bvh build_bvh(std::span<const Box> prim_bounds, const BvhBuildOptions& options) {
  HFRT_CHECK(!prim_bounds.empty());
  HFRT_CHECK_LT(prim_bounds.size(), size_t{1} << 31);
  Bvh bvh;
  Builder builder(prim_bounds, options, &bvh);
  builder.build();
  return bvh;
}

uint32_t morton2(uint32_t i, uint32_t j) {
  HFRT_CHECK(i < (1u << 16) && j < (1u << 16));
  auto spread = [](uint32_t x) {
    x = (x | (x << 8)) & 0x00ff00ffu;
    x = (x | (x << 4)) & 0x0f0f0f0fu;
    x = (x | (x << 2)) & 0x33333333u;
    x = (x | (x << 1)) & 0x55555555u;
    return x;
  };
  return spread(i) | (spread(j) << 1);
}

namespace {

/// build_bvh_grouped's emitter: nodes are appended top-down, children as adjacent pairs.
class GroupedBuilder {
 public:
  GroupedBuilder(std::span<const Box> bounds, std::span<const uint64_t> keys, int max_leaf,
                 Bvh* out)
      : bounds_(bounds), keys_(keys), max_leaf_(uint32_t(std::max(1, max_leaf))), out_(out) {}

  /// Node `slot` over the sorted primitives [first, last) of one group: a quadtree split at the
  /// highest differing bit of the cell codes; primitives go to prim_order as leaves are made.
  Box cells(uint32_t slot, uint32_t first, uint32_t last, int depth) {
    out_->depth = std::max(out_->depth, depth);
    const uint32_t n = last - first;
    if (n <= max_leaf_) {
      Box b;
      const uint32_t at = uint32_t(out_->prim_order.size());
      for (uint32_t i = first; i < last; ++i) {
        b.extend(bounds_[i]);
        out_->prim_order.push_back(i);
      }
      set(slot, b, at, n);
      return b;
    }
    const uint32_t a = uint32_t(keys_[first]), z = uint32_t(keys_[last - 1]);
    uint32_t mid = first + n / 2;  // one cell holding many primitives: halved by count
    if (a != z) {
      // The first primitive with the highest differing bit set (keys are sorted).
      const uint32_t bit = uint32_t(1) << (31 - std::countl_zero(a ^ z));
      const uint32_t prefix = z & ~(bit - 1);
      mid = uint32_t(std::partition_point(keys_.begin() + first, keys_.begin() + last,
                                          [&](uint64_t k) { return uint32_t(k) < prefix; }) -
                     keys_.begin());
    }
    const uint32_t kids = alloc_pair();
    Box b = cells(kids, first, mid, depth + 1);
    b.extend(cells(kids + 1, mid, last, depth + 1));
    set(slot, b, kids, 0);
    return b;
  }

  /// Node `slot` as node `top` of the groups' SAH tree, whose primitives are groups.
  Box groups(const Bvh& top, const std::vector<uint32_t>& group_start, uint32_t slot, uint32_t node,
             int depth) {
    const BvhNode& t = top.nodes[node];
    if (t.is_leaf()) {
      HFRT_CHECK_EQ(t.count, 1u);  // max_leaf_size 1
      const uint32_t g = top.prim_order[t.index];
      return cells(slot, group_start[g], group_start[g + 1], depth);
    }
    const uint32_t kids = alloc_pair();
    Box b = groups(top, group_start, kids, t.index, depth + 1);
    b.extend(groups(top, group_start, kids + 1, t.index + 1, depth + 1));
    set(slot, b, kids, 0);
    return b;
  }

  uint32_t alloc_pair() {
    const uint32_t at = uint32_t(out_->nodes.size());
    out_->nodes.resize(out_->nodes.size() + 2);
    return at;
  }

 private:
  void set(uint32_t slot, const Box& b, uint32_t index, uint32_t count) {
    BvhNode& nd = out_->nodes[slot];
    for (int k = 0; k < 3; ++k) nd.lo[k] = b.lo[k], nd.hi[k] = b.hi[k];
    nd.index = index;
    nd.count = count;
  }

  std::span<const Box> bounds_;
  std::span<const uint64_t> keys_;
  uint32_t max_leaf_;
  Bvh* out_;
};

}  // namespace

Bvh build_bvh_grouped(std::span<const Box> prim_bounds, std::span<const uint64_t> keys,
                      const BvhBuildOptions& options) {
  HFRT_CHECK(!prim_bounds.empty());
  HFRT_CHECK_EQ(prim_bounds.size(), keys.size());
  HFRT_CHECK_LT(prim_bounds.size(), size_t{1} << 31);
  // The groups: contiguous runs of one key >> 32, with their boxes.
  std::vector<uint32_t> group_start;
  std::vector<Box> group_box;
  for (uint32_t i = 0; i < keys.size(); ++i) {
    HFRT_CHECK(i == 0 || keys[i - 1] <= keys[i]);
    if (i == 0 || (keys[i - 1] >> 32) != (keys[i] >> 32)) {
      group_start.push_back(i);
      group_box.push_back(Box{});
    }
    group_box.back().extend(prim_bounds[i]);
  }
  group_start.push_back(uint32_t(keys.size()));
  BvhBuildOptions top_options = options;
  top_options.max_leaf_size = 1;
  top_options.parallel = false;
  const Bvh top = build_bvh(group_box, top_options);
  Bvh bvh;
  // About two nodes per primitive over max_leaf_size / 2 (leaves are half full on average).
  bvh.nodes.reserve(4 * prim_bounds.size() / size_t(std::max(1, options.max_leaf_size)) + 4);
  bvh.prim_order.reserve(prim_bounds.size());
  bvh.nodes.resize(1);
  GroupedBuilder builder(prim_bounds, keys, options.max_leaf_size, &bvh);
  builder.groups(top, group_start, 0, 0, 1);
  return bvh;
}

double sah_cost(const Bvh& bvh, const BvhBuildOptions& options) {
  const double root = bvh.nodes[0].bounds().half_area();
  double cost = 0;
  for (const BvhNode& n : bvh.nodes) {
    double p = root > 0 ? n.bounds().half_area() / root : 1;
    cost += n.is_leaf() ? p * n.count * options.primitive_cost : p * options.traversal_cost;
  }
  return cost;
}

}  // namespace hfrt::geom
