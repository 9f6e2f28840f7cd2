#pragma once
// MeshSurface: a triangle mesh ready for every query a leaf makes: nearest hit and all
// crossings along a ray (watertight, geom/triangle.h), distance and closest point, the
// generalised winding number (fast, hierarchical) and the signed distance with its bounds
// over a box. Built once per file; immutable and thread-safe afterwards.
//
// Memory (measured by memory_bytes(), ~101 bytes per triangle on the armadillo): the BVH
// nodes (32 bytes each), a 4-wide copy of their upper levels for rays (geom/wide_bvh.h, ~19
// bytes per triangle), the triangle corners copied in leaf order (36 bytes per triangle, so a
// leaf's triangles are contiguous and no index indirection happens in the inner loop), the
// original index of each (4 bytes), and the dipoles of the 4-wide nodes' children for the
// winding number (112 bytes per wide node).
// The indexed TriangleMesh it was built from is not kept.

#include <atomic>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include "base/once.h"
#include "geom/bvh.h"
#include "geom/mesh.h"
#include "geom/side_grid.h"
#include "geom/surface.h"
#include "geom/wide_bvh.h"

namespace hfrt::geom {

/// Sorts a ray's crossings by t (then primitive) and orders crossings at the same t up to
/// rounding so that entries and exits alternate where they can (MeshSurface::crossings' order;
/// shared by its packet form).
void order_crossings(std::vector<Crossing>* out);

/// The query of a packet walk (MeshSurface::intersect_packet and its kin).
enum class PacketMode { kNearest, kAny, kAll };

class MeshSurface final : public Surface {
 public:
  struct Options {
    /// A node visit tests two child boxes, about the cost of two watertight triangle tests; a
    /// higher traversal cost also makes larger leaves (fewer nodes, less memory).
    BvhBuildOptions bvh{.traversal_cost = 2.0f};
    /// Far-field acceptance of the hierarchical winding number: a node whose dipole centre is
    /// farther than beta times its radius uses the dipole (Barill et al. 2018 use 2).
    double winding_beta = 2.0;
  };

  /// Builds the BVH (in parallel for large meshes) and the winding-number dipoles.
  static std::unique_ptr<MeshSurface> build(const TriangleMesh& mesh, const Options& options);
  static std::unique_ptr<MeshSurface> build(const TriangleMesh& mesh) {
    return build(mesh, Options{});
  }
  ~MeshSurface() override;
  /// The same surface over build_bvh_grouped's hierarchy instead of the SAH search (keys: one
  /// per triangle, as build_bvh_grouped takes them): for tessellations whose parametric grid
  /// already is a good hierarchy (patches' field meshes): the teapot's in 2-3 ms, not 21.
  static std::unique_ptr<MeshSurface> build_grouped(const TriangleMesh& mesh,
                                                    std::span<const uint64_t> keys,
                                                    const Options& options);

  Box bounds() const override { return nodes_[0].bounds(); }
  bool intersect(const Ray& ray, float tmin, float tmax, SurfaceHit* hit) const override;
  void crossings(const Ray& ray, float tmin, float tmax, std::vector<Crossing>* out) const override;
  /// Packets of kPacketRays consecutive rays (crossings_packet).
  void crossings_many(const Ray* rays, size_t n, const float* tmin, const float* tmax,
                      std::vector<Crossing>* out) const override;
  double winding_number(Vec3 p) const override;
  /// winding_number(p) >= 1/2 through a SideGrid over the mesh's bounds (geom/side_grid.h):
  /// one winding number per cell near which the mesh does not pass, not one per point.
  bool inside(Vec3 p) const override;
  float signed_distance(Vec3 p, Vec3* gradient = nullptr) const override;
  DistanceBounds signed_distance_bounds(const Box& box) const override;
  SurfaceStats stats() const override;

  /// intersect() through the binary BVH only (the 4-wide one is the default): for tests.
  bool intersect_binary(const Ray& ray, float tmin, float tmax, SurfaceHit* hit) const;

  /// True when any triangle is hit with tmin < t < tmax (shadow rays): stops at the first,
  /// through the 4-wide BVH with the four-triangle leaf test.
  bool occluded(const Ray& ray, float tmin, float tmax) const;
  /// occluded() through the binary BVH, one triangle at a time: for tests.
  bool occluded_binary(const Ray& ray, float tmin, float tmax) const;

  /// The packet queries below take at most this many rays per call.
  static constexpr int kPacketRays = 8;

  /// intersect() for n <= kPacketRays rays traced together through the 4-wide BVH: each node's
  /// four boxes and each leaf triangle are tested against every ray of the packet at once (AVX2
  /// where the CPU has it, eight lanes; the same code on SSE2 elsewhere), so coherent rays (a
  /// tile's camera rays, shadow rays towards one light) share their node and triangle loads.
  /// Ray i's hit, when bit i of the returned mask is set, is in hits[i]: t, barycentrics and
  /// normal are bitwise intersect()'s, and so is prim unless two triangles are hit at exactly
  /// the same t (then either may be reported; intersect() keeps the first it met).
  uint32_t intersect_packet(const Ray* rays, int n, const float* tmin, const float* tmax,
                            SurfaceHit* hits) const;
  /// occluded() for n <= kPacketRays rays traced together (as intersect_packet); bit i of the
  /// result is occluded(rays[i], tmin[i], tmax[i]). A ray leaves the packet at its first hit.
  uint32_t occluded_packet(const Ray* rays, int n, const float* tmin, const float* tmax) const;
  /// crossings() for n <= kPacketRays rays traced together (as intersect_packet): out[i]
  /// receives exactly crossings(rays[i], tmin[i], tmax[i]).
  void crossings_packet(const Ray* rays, int n, const float* tmin, const float* tmax,
                        std::vector<Crossing>* out) const;

  /// Whether the packet queries run their AVX2 copy (chosen at start-up by the CPU); false
  /// makes them run the x86-64 baseline copy from now on: for tests of that copy on AVX2
  /// machines. Not thread-safe: call it while no packet query runs.
  static bool packets_use_avx2();
  static void set_packets_use_avx2(bool avx2);

  /// closest_point() through the binary BVH (the 4-wide one is the default): for tests.
  ClosestPoint closest_point_binary(
      Vec3 p, float max_distance = std::numeric_limits<float>::infinity()) const;

  /// The closest point of the mesh to p among points closer than `max_distance`.
  ClosestPoint closest_point(
      Vec3 p, float max_distance = std::numeric_limits<float>::infinity()) const override;
  /// Edges matched by coordinates (a sort of the 3n directed edges, on first use).
  SurfaceTopology topology() const override;

  /// A lower bound on the distance from `box` to the mesh (0 when the box may touch it): the
  /// distance to the nearest triangle's bounding box. `near_vertex`, when given, is set to a
  /// corner of that triangle (a point of the mesh near the box; for a bound of 0, one inside
  /// the box when the first triangle whose box meets it has one).
  float distance_lower_bound(const Box& box, Vec3* near_vertex = nullptr) const;

  /// The winding number summed exactly over every triangle (no hierarchy): for tests.
  double winding_number_exact(Vec3 p) const;

  size_t num_triangles() const { return prim_order_.size(); }
  const std::vector<BvhNode>& nodes() const { return nodes_; }
  size_t memory_bytes() const;

 private:
  MeshSurface() = default;

  static std::unique_ptr<MeshSurface> build(const TriangleMesh& mesh, const Options& options,
                                            std::span<const uint64_t> keys);

  /// The far-field data of a wide node's four children (112 bytes, lanes as in WideNode), in
  /// units of winding_scale_.
  struct alignas(16) WideDipole {
    float cx[4], cy[4], cz[4];  ///< area-weighted centroid of the child's triangles
    float nx[4], ny[4], nz[4];  ///< sum of area * unit normal = half the sum of the crosses
    /// (beta x the farthest corner of the child's box from the centroid)^2: farther than
    /// that, the child is one dipole. +inf for an empty slot (never far).
    float r2[4];
  };

  void build_dipoles();
  /// The packet walk behind intersect_packet, occluded_packet and crossings_packet
  /// (geom/mesh_packet.cpp); `mode` picks the query.
  uint32_t packet_walk(PacketMode mode, const Ray* rays, int n, const float* tmin,
                       const float* tmax, SurfaceHit* hits, std::vector<Crossing>* out) const;
  /// closest_point through the 4-wide tree (`wide`) or the binary one (closest_point_binary).
  ClosestPoint closest_point_walk(Vec3 p, float max_distance, bool wide) const;
  /// The distance searches' walk: the binary leaves nearest first by box distance to `query`
  /// (a point is the box lo = hi = p), through the 4-wide tree when `wide`, skipping nodes at
  /// squared distance >= *bound; `leaf(const BvhNode&)` may lower *bound, and returns false
  /// to end the walk.
  template <typename Leaf>
  void walk_by_distance(const Box& query, bool wide, const float* bound, Leaf&& leaf) const;
  /// The solid angle of the triangles of binary leaf `n`, summed exactly.
  /// `p` is in units of winding_scale_ (p * winding_scale_), as the corners are scaled here.
  double leaf_solid_angle(const BvhNode& n, Vec3 p) const;

  std::vector<BvhNode> nodes_;
  std::vector<Vec3> corners_;         // 3 per triangle, in leaf order, + 1 padding Vec3
  std::vector<uint32_t> prim_order_;  // leaf order -> original index
  WideBvh wide_;                      // 4-wide upper levels, for rays and winding numbers
  std::vector<WideDipole> dipoles_;   // one per wide node
  double beta_ = 2.0;
  /// The winding number's float arithmetic works in these units: the power of two that makes
  /// the mesh's largest side about 1, so that squared and cubed distances neither underflow nor
  /// overflow float for meshes of any size (the scaling is exact: results are unchanged).
  float winding_scale_ = 1;
  SurfaceStats stats_;
  mutable SettledOnce topology_once_;  ///< sets topology_
  mutable SurfaceTopology topology_;
  LazySideGrid side_grid_;  ///< made on first inside()
};

}  // namespace hfrt::geom
