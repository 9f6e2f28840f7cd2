#include "geom/bvh.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "base/check.h"
#include "base/parallel.h"

namespace hfrt::geom {
namespace {

constexpr int kMaxBins = 32;

struct Bin {
  Box bounds;
  uint32_t count = 0;
};

struct BinSet {
  Bin bins[3][kMaxBins];
};

class Builder {
 public:
  Builder(std::span<const Box> boxes, const BvhBuildOptions& opt, Bvh* out)
      : boxes_(boxes), opt_(opt), out_(out) {
    const size_t n = boxes.size();
    centroids_.resize(n);
    for (size_t i = 0; i < n; ++i) centroids_[i] = boxes[i].center();
    out->prim_order.resize(n);
    for (size_t i = 0; i < n; ++i) out->prim_order[i] = static_cast<uint32_t>(i);
    out->nodes.resize(std::max<size_t>(1, 2 * n - 1));
    next_node_.store(1);
  }

  void build() {
    int depth = build_node(0, 0, static_cast<uint32_t>(boxes_.size()));
    out_->nodes.resize(next_node_.load());
    out_->nodes.shrink_to_fit();
    out_->depth = depth;
  }

 private:
  struct RangeInfo {
    Box bounds, centroid_bounds;
  };

  RangeInfo range_info(uint32_t begin, uint32_t end) const {
    auto body = [&](size_t lo, size_t hi, RangeInfo acc) {
      for (size_t i = lo; i != hi; ++i) {
        uint32_t p = out_->prim_order[i];
        acc.bounds.extend(boxes_[p]);
        acc.centroid_bounds.extend(centroids_[p]);
      }
      return acc;
    };
    auto join = [](RangeInfo a, const RangeInfo& b) {
      a.bounds.extend(b.bounds);
      a.centroid_bounds.extend(b.centroid_bounds);
      return a;
    };
    if (opt_.parallel && end - begin >= 65536)
      return par::parallel_reduce(begin, end, 8192, RangeInfo{}, body, join);
    return body(begin, end, RangeInfo{});
  }

  // Clamped in float before the conversion: converting a NaN or an out-of-range float to int is
  // undefined behaviour.
  int bin_of(float c, float lo, float scale, int nbins) const {
    const float t = (c - lo) * scale;
    if (!(t > 0)) return 0;
    if (t >= static_cast<float>(nbins - 1)) return nbins - 1;
    return static_cast<int>(t);
  }

  void fill_bins(uint32_t begin, uint32_t end, const Box& cb, int nbins, BinSet* set) const {
    float scale[3];
    for (int a = 0; a < 3; ++a) {
      // A denormal extent makes nbins / ext infinite, and (c - lo) * inf is NaN at c = lo
      // (found by fuzz/mesh_fuzz.cpp): such an axis cannot be binned, like a zero extent.
      const float ext = cb.hi[a] - cb.lo[a];
      const float s = ext > 0 ? nbins / ext : 0;
      scale[a] = std::isfinite(s) ? s : 0;
    }
    auto body = [&](size_t lo, size_t hi, BinSet acc) {
      for (size_t i = lo; i != hi; ++i) {
        uint32_t p = out_->prim_order[i];
        for (int a = 0; a < 3; ++a) {
          Bin& bin = acc.bins[a][bin_of(centroids_[p][a], cb.lo[a], scale[a], nbins)];
          bin.bounds.extend(boxes_[p]);
          ++bin.count;
        }
      }
      return acc;
    };
    auto join = [&](BinSet a, const BinSet& b) {
      for (int ax = 0; ax < 3; ++ax)
        for (int k = 0; k < nbins; ++k) {
          a.bins[ax][k].bounds.extend(b.bins[ax][k].bounds);
          a.bins[ax][k].count += b.bins[ax][k].count;
        }
      return a;
    };
    if (opt_.parallel && end - begin >= 65536)
      *set = par::parallel_reduce(begin, end, 8192, BinSet{}, body, join);
    else
      *set = body(begin, end, BinSet{});
  }

  void make_leaf(BvhNode& node, uint32_t begin, uint32_t end) {
    node.index = begin;
    node.count = end - begin;
  }

  // Builds node `id` over prim_order[begin, end); returns the subtree depth.
  int build_node(uint32_t id, uint32_t begin, uint32_t end) {
    const uint32_t n = end - begin;
    RangeInfo info = range_info(begin, end);
    BvhNode& node = out_->nodes[id];
    for (int a = 0; a < 3; ++a) {
      node.lo[a] = info.bounds.lo[a];
      node.hi[a] = info.bounds.hi[a];
    }
    if (n <= 1) {
      make_leaf(node, begin, end);
      return 1;
    }
    // Choose the split: SAH over binned centroids on all three axes.
    const Box& cb = info.centroid_bounds;
    const int nbins = std::clamp(opt_.bins, 2, kMaxBins);
    int best_axis = -1, best_split = 0;
    float best_cost = std::numeric_limits<float>::infinity();
    if (cb.diagonal()[cb.max_axis()] > 0) {
      BinSet set;
      fill_bins(begin, end, cb, nbins, &set);
      for (int a = 0; a < 3; ++a) {
        if (!(cb.hi[a] > cb.lo[a])) continue;
        // Sweep from the right, then from the left.
        float right_area[kMaxBins];
        uint32_t right_count[kMaxBins];
        Box acc;
        uint32_t cnt = 0;
        for (int k = nbins - 1; k > 0; --k) {
          acc.extend(set.bins[a][k].bounds);
          cnt += set.bins[a][k].count;
          right_area[k] = acc.half_area();
          right_count[k] = cnt;
        }
        acc = Box{};
        cnt = 0;
        for (int k = 1; k < nbins; ++k) {
          acc.extend(set.bins[a][k - 1].bounds);
          cnt += set.bins[a][k - 1].count;
          if (cnt == 0 || right_count[k] == 0) continue;
          float cost = acc.half_area() * cnt + right_area[k] * right_count[k];
          if (cost < best_cost) {
            best_cost = cost;
            best_axis = a;
            best_split = k;
          }
        }
      }
    }
    const float parent_area = info.bounds.half_area();
    const float leaf_cost = opt_.primitive_cost * n;
    const float split_cost =
        best_axis < 0
            ? std::numeric_limits<float>::infinity()
            : opt_.traversal_cost + opt_.primitive_cost * best_cost / std::max(parent_area, 1e-30f);
    if (n <= static_cast<uint32_t>(opt_.max_leaf_size) && leaf_cost <= split_cost) {
      make_leaf(node, begin, end);
      return 1;
    }
    uint32_t mid;
    if (best_axis >= 0) {
      float ext = cb.hi[best_axis] - cb.lo[best_axis];
      float scale = nbins / ext;
      float lo = cb.lo[best_axis];
      auto* first = out_->prim_order.data() + begin;
      auto* split = std::partition(first, out_->prim_order.data() + end, [&](uint32_t p) {
        return bin_of(centroids_[p][best_axis], lo, scale, nbins) < best_split;
      });
      mid = static_cast<uint32_t>(split - out_->prim_order.data());
    } else {
      mid = begin + n / 2;  // all centroids coincide: any split is as good; halve by index
    }
    if (mid == begin || mid == end) mid = begin + n / 2;
    const uint32_t child = next_node_.fetch_add(2);
    HFRT_CHECK_LE(child + 1, out_->nodes.size() - 0);
    node.index = child;
    node.count = 0;
    int dl = 0, dr = 0;
    if (opt_.parallel && n >= opt_.parallel_threshold) {
      par::parallel_invoke([&] { dl = build_node(child, begin, mid); },
                           [&] { dr = build_node(child + 1, mid, end); });
    } else {
      dl = build_node(child, begin, mid);
      dr = build_node(child + 1, mid, end);
    }
    return 1 + std::max(dl, dr);
  }

  std::span<const Box> boxes_;
  const BvhBuildOptions& opt_;
  Bvh* out_;
  std::vector<Vec3> centroids_;
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
