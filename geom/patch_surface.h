#pragma once
// PatchSurface: Bézier patches ray-traced directly, not through a tessellation.
//
// Build: every patch is split (de Casteljau, in parameter space) until each piece is nearly
// flat -- its control points within `flatness` x the patch's size of the bilinear patch through
// its corners -- and a binned-SAH BVH is built over the pieces' control-point boxes (which
// contain the piece: convex hull property).
// Ray: for every piece whose box the ray meets, Newton's method in double solves
// P(u, v) on the ray -- two equations, the distances from P to two planes through the ray
// (Martin et al. 2000, "Practical ray tracing of trimmed NURBS") -- started where the ray meets
// the two triangles of the piece's corner quad, or at the point of the quad's border nearest to
// the ray when the ray passes within the piece's flatness bound of it (otherwise the piece is
// skipped: it lies within that bound of its quad, and a line's distance to a triangle is
// attained on its border unless they intersect). A root is accepted when it
// lies in the piece's parameter rectangle, so each hit is found by the piece that owns it; it is
// exact to 1e-7 of the patch size. A piece where Newton does not converge (grazing rays at
// silhouettes, where the Jacobian is nearly singular) is split in four again, on the fly, down
// to kMaxRefine more levels. Normals come from the patch derivatives Pu x Pv.
// Field (distance, winding number, bounds): from the patches themselves, with no
// tessellation, trimmed or not. The winding number is the boundary's string term plus the
// crossings of one ray (geom/boundary_winding.h: exact, whether the patches close up or not;
// a trimmed patch's boundary is its kept region's, trim loops included), the side of a point
// goes through a WindingGrid of those (geom/side_grid.h), the distance is
// closest_point_on_patches' (Newton in the pieces near p, and for trimmed patches the nearest
// point of their kept regions' borders: NearestOnCurves), and the bounds over a box come from
// the pieces' control-point boxes.
// Cracks narrower than Options::seal_tolerance (a trim loop retracing the next patch's rim the
// other way) are sealed first (geom/boundary_winding.h, seal_cracks): their curves leave the
// boundary, and rays that pass near them are in doubt.
// A set whose boundary then has more than Options::max_exact_curves curves (or
// Options::exact_field false) goes through a fine tessellation instead (`field_tessellation`
// quads per patch side, MeshSurface, clipped to the trims), whose error is stats'd as
// field_error(); the ray queries never use it.
// Trimmed patches (PatchSet::trims): each piece is classified against its patch's trim once,
// at build time; pieces wholly outside the kept region are left out of the BVH, pieces wholly
// inside it behave as untrimmed, and only the pieces that a trim loop crosses test a root's
// (u, v) -- in the original patch's parameters -- with Trim::contains. The field tessellation
// is clipped to the kept region. When nothing is left (every patch trimmed away, or only
// degenerate triangles), the surface is empty: no hits, winding number 0, and a field of
// -FLT_MAX (outside, infinitely far).

#include <memory>

#include "geom/bezier.h"
#include "geom/boundary_winding.h"
#include "geom/mesh_surface.h"
#include "geom/side_grid.h"
#include "geom/surface.h"
#include "geom/wide_bvh.h"

namespace hfrt::geom {

class PatchSurface final : public Surface {
 public:
  struct Options {
    float flatness = 2e-3f;       ///< relative to each patch's bounding-box diagonal
    int max_split_depth = 6;      ///< per patch side: at most 2^6 x 2^6 pieces
    int field_tessellation = 32;  ///< quads per patch side of a tessellated field
    /// The field from the patches (no tessellation), trimmed or not; false: through the
    /// tessellation (for tests that compare the two).
    bool exact_field = true;
    /// A set whose boundary (after the seams cancel) has more curves than this keeps the
    /// tessellated field all the same: the exact winding number visits every curve
    /// (BoundaryCurves::string_term, no hierarchy over curves yet), ~1 us a point for the
    /// teapot's 16 and ~13 us for the trimmed cup's 528 (its trim polygons and the walls'
    /// rims), where the tessellation's hierarchical one takes ~0.7 us.
    size_t max_exact_curves = 64;
    /// Cracks narrower than this (relative to the control points' bounding-box diagonal) are
    /// sealed before the curves are counted (seal_cracks): pairs of boundary loops, or of
    /// chains between the same two junctions, that retrace each other the opposite way -- a
    /// trim loop along the next patch's rim. 0: none. The trimmed cup's are ~5e-4 wide
    /// (1.7e-4 of its diagonal): sealed, its 528 border curves leave none open.
    double seal_tolerance = 1e-3;
  };

  static std::unique_ptr<PatchSurface> build(const PatchSet& set, const Options& options);
  static std::unique_ptr<PatchSurface> build(const PatchSet& set) { return build(set, Options{}); }

  Box bounds() const override { return bounds_; }
  bool intersect(const Ray& ray, float tmin, float tmax, SurfaceHit* hit) const override;
  void crossings(const Ray& ray, float tmin, float tmax, std::vector<Crossing>* out) const override;
  /// crossings() with both roots of a ray that grazes a curved piece, which Newton finds one
  /// of: the pieces the ray may meet twice are split first (may_meet_twice). What the exact
  /// winding number's rays use; slower (the teapot's camera rays: 37 against 63 frames/s).
  void crossings_all(const Ray& ray, float tmin, float tmax, std::vector<Crossing>* out) const;
  /// Packets of eight consecutive rays (crossings_packet): out[i] is crossings(rays[i], ...)
  /// exactly.
  void crossings_many(const Ray* rays, size_t n, const float* tmin, const float* tmax,
                      std::vector<Crossing>* out) const override;
  /// crossings() for n <= 8 rays walked through the 4-wide BVH together (geom/packet_lanes.h):
  /// each node's boxes are tested against the rays in one 8-lane test, and each lane that meets
  /// a leaf's box runs its Newton solves there as its own walk would.
  void crossings_packet(const Ray* rays, int n, const float* tmin, const float* tmax,
                        std::vector<Crossing>* out) const;
  /// Exact (exact_winding_number) for the exact field, else the field tessellation's.
  double winding_number(Vec3 p) const override;
  /// winding_number(p) >= 1/2 through a grid of cells (geom/side_grid.h): the exact field's
  /// WindingGrid (a cell's centre and the crossings of a short segment decide most points),
  /// the tessellation's SideGrid otherwise.
  bool inside(Vec3 p) const override;
  float signed_distance(Vec3 p, Vec3* gradient = nullptr) const override;
  DistanceBounds signed_distance_bounds(const Box& box) const override;
  /// The closest point of the patches themselves (closest_point_on_patches: Newton in the
  /// pieces near p, no tessellation), with the patch's normal Pu x Pv there and prim = the
  /// patch: always for the exact field; for a tessellated one within a finite max_distance (the
  /// gradient's query at a ray hit: jit/surface_ops.cpp) when it finds one. Otherwise the field
  /// tessellation's closest point (within field_error() of the patches'; what a tessellated
  /// signed_distance measures), with the normal of the patch at the (u, v) of that point,
  /// oriented as the triangle's. None (prim ~0u) when nothing is left of the patches.
  ClosestPoint closest_point(
      Vec3 p, float max_distance = std::numeric_limits<float>::infinity()) const override;
  /// Never closed: Newton's roots on two patches that share a seam are not watertight (a ray
  /// through the seam may be found on both or neither), so crossings cannot replace the
  /// winding number even when the patches close up (boundary_edges is not counted).
  SurfaceTopology topology() const override { return {}; }
  float field_tolerance() const override { return field_error_; }
  SurfaceStats stats() const override { return stats_; }

  const PatchSet& patches() const { return set_; }
  size_t num_pieces() const { return pieces_.size(); }
  /// Largest measured distance between the field tessellation and the patches (0 for the
  /// exact field).
  float field_error() const { return field_error_; }
  /// False when nothing of the patches is left (all trimmed away or degenerate).
  bool has_field() const { return exact_ || field_ != nullptr; }
  /// Whether the field goes through a tessellation (too many boundary curves, or exact_field
  /// off).
  bool has_tessellation() const { return field_ != nullptr; }
  /// The field tessellation (only when has_tessellation()).
  const MeshSurface& field_mesh() const { return *field_; }
  /// The open borders of an exact field's patches (geom/boundary_winding.h).
  const BoundaryCurves& boundary() const { return boundary_; }
  /// The generalised winding number of the patches at p with no tessellation: the boundary's
  /// string term minus the facings of the crossings of a ray from p (geom/boundary_winding.h),
  /// along the first of a fixed list of directions for which neither is in doubt (no root
  /// within 1e-5 of a patch's border in (u, v) or grazing the patch, the string not too close
  /// to a border curve, no root within 1e-5 of a trim loop in (u, v), no ray within reach of
  /// a sealed crack). Cracks sealed (Options::seal_tolerance): the winding number of the
  /// surface with them filled; at a point so near a crack that every direction passes by it,
  /// the open surface's, from every curve.
  double exact_winding_number(Vec3 p) const;

  /// The unit normal of patch `prim` at (u, v) (from Pu x Pv; near a collapsed edge, from a
  /// point nudged towards the patch centre).
  Vec3 normal(uint32_t prim, double u, double v) const;

 private:
  PatchSurface() = default;

  struct Piece {
    uint32_t patch;
    float u0, u1, v0, v1;
    /// How far the piece may be from the two triangles of its corner quad: its control points'
    /// distance from the bilinear patch plus the bilinear patch's distance from the triangles.
    float delta;
    /// A trim loop crosses the piece: its roots are tested with Trim::contains.
    bool trimmed;
  };
  /// Corner c of piece k (bit 0: at u1 rather than u0; bit 1: at v1 rather than v0): its
  /// (u, v) in the patch, its control point (on the patch, rounded to float), and whether the
  /// patch's trim keeps it (always for an untrimmed piece).
  struct Corner {
    float u, v;
    Vec3 point;
    bool kept;
  };
  Corner corner(uint32_t k, int c) const {
    const Piece& pc = pieces_[k];
    const BezierPatch& cp = piece_cp_[k];
    const float u = c & 1 ? pc.u1 : pc.u0, v = c & 2 ? pc.v1 : pc.v0;
    return {u, v, cp.control(c & 1 ? cp.du : 0, c & 2 ? cp.dv : 0),
            !pc.trimmed || set_.trim(pc.patch)->contains(u, v)};
  }
  struct RawHit {
    double t, u, v;
    uint32_t patch;
    /// normal(patch, u, v), when Newton's last derivatives gave it (has_normal): the same
    /// operations at the same (u, v), without evaluating the patch again.
    bool has_normal = false;
    Vec3 n;
  };
  /// Pu x Pv of patch `prim` normalised into *n; false where it is too short to trust (a
  /// collapsed edge): normal()'s test, and the one of a hit's Newton derivatives.
  bool unit_normal(uint32_t prim, const DVec3& pu, const DVec3& pv, Vec3* n) const;
  /// The closest point of the patches to p within max_distance: the pieces whose boxes lie
  /// that close, nearest first, each by project_onto_piece; a trimmed piece's point counts
  /// only where the trim keeps it. prim ~0u when none, when a point trimmed away was nearer
  /// than the one found (the closest kept point may then lie on a trim loop), or when there is
  /// no normal there: closest_point then asks the tessellation.
  ClosestPoint closest_point_on_patches(Vec3 p, float max_distance) const;
  /// What closest_point_on_patches' search found: the nearest kept point (piece ~0u when none
  /// within the limit) and the nearest point trimmed away (squared distance; +inf when none).
  struct Nearest {
    double d2 = std::numeric_limits<double>::infinity();
    uint32_t patch = ~0u;    ///< the nearest kept point's patch (~0u: none)
    bool on_border = false;  ///< it lies on a trimmed patch's border (trim_borders_)
    double u = 0, v = 0;
    DVec3 point;
    Vec3 normal;
    double trimmed_away2 = std::numeric_limits<double>::infinity();
  };
  Nearest nearest_on_patches(Vec3 p, float max_distance) const;
  /// The sum of the facings of the crossings of `ray` for t in [0, tmax]; false (in doubt)
  /// when a root lies within 1e-5 of its patch's border in (u, v) or the ray grazes the patch
  /// there.
  bool ray_facings(const Ray& ray, float tmax, int* facings, bool check_cracks = true) const;
  /// signed_distance_bounds of the exact field: from the pieces' control-point boxes and the
  /// closest point at the box's centre.
  DistanceBounds exact_distance_bounds(const Box& box) const;
  /// The squared distance from `box` to the nearest piece's control-point box (0 when one
  /// meets it: the search stops there), that piece in *piece when not null; at most cap2
  /// (nothing nearer: cap2, *piece untouched).
  double piece_box_distance2(const Box& box, uint32_t* piece,
                             double cap2 = std::numeric_limits<double>::infinity()) const;
  /// The point *x of piece pc nearest q (Gauss-Newton clamped to its rectangle) and its
  /// (u, v), with the unit normal there (0 where Pu x Pv is too short); unless `anywhere`,
  /// false, without them, when q projects well outside the piece's corner quad.
  bool project_onto_piece(const Piece& pc, const DVec3& q, bool anywhere, double* u, double* v,
                          DVec3* x, Vec3* n) const;
  /// normal(h.patch, h.u, h.v), from the hit when it carries it.
  Vec3 hit_normal(const RawHit& h) const { return h.has_normal ? h.n : normal(h.patch, h.u, h.v); }
  /// A ray's roots: a few on the stack, more spilled to the heap. The inline slots are left
  /// uninitialised until used (a packet's eight buffers would otherwise cost more to set up
  /// than most of its rays' roots).
  struct RootBuffer {
    static constexpr size_t kInline = 32;
    RootBuffer() {}
    union {
      RawHit inline_hits[kInline];
    };
    std::vector<RawHit> spill;
    size_t count = 0;
    void push(const RawHit& h);
  };
  /// crossings() (split_folds false) and crossings_all() (true): the roots in a buffer on the
  /// stack, then finish_crossings.
  void collect_crossings(const Ray& ray, float tmin, float tmax, bool split_folds,
                         std::vector<Crossing>* out) const;
  /// The crossings of `ray` from its roots: sorted (a total order), each facing from the
  /// patch normal, duplicates (one point found by two pieces or patches) dropped.
  void finish_crossings(const Ray& ray, RootBuffer* roots, std::vector<Crossing>* out) const;
  /// Two orthonormal planes whose intersection is the ray (Newton's two equations).
  static void ray_planes(const Ray& ray, double plane[2][4]);
  /// The roots on `ray` (planes from ray_planes) in the pieces of BVH leaf n, t in
  /// [tmin, *closest] (read at each piece: a nearest-hit visitor lowers it); a trimmed
  /// piece's only where its trim keeps them.
  template <typename Visit>
  void solve_leaf(const BvhNode& n, const Ray& ray, const double plane[2][4], float tmin,
                  const float* closest, Visit&& visit, bool split_folds = false) const;
  template <typename Visit>
  // Visits every root in the pieces whose boxes the ray meets up to *tmax; a visitor that
  // lowers *tmax (nearest hit) prunes the rest of the traversal. split_folds: see solve_piece.
  void trace(const Ray& ray, float tmin, float* tmax, Visit&& visit,
             bool split_folds = false) const;
  // Newton on `patch` restricted to [u0,u1]x[v0,v1]; refines by splitting when it fails. With
  // split_folds, also where the ray may meet the piece twice (may_meet_twice: a grazing ray,
  // of which Newton finds one root): the winding number's rays, whose every crossing counts.
  // The renderer's rays do without: it costs the teapot's camera rays 40 % of their frame
  // rate (63 -> 37 frames/s), for a second root that only grazing rays have.
  template <typename Visit>
  void solve_piece(const Ray& ray, const double plane[2][4], uint32_t patch, double u0, double u1,
                   double v0, double v1, const BezierPatch& sub, float delta, int depth, float tmin,
                   float tmax, Visit&& visit, bool split_folds = false) const;
  // solve_piece in the four quarters of the piece that the ray's slab test meets.
  template <typename Visit>
  void refine(const Ray& ray, const double plane[2][4], uint32_t patch, double u0, double u1,
              double v0, double v1, const BezierPatch& sub, int depth, float tmin, float tmax,
              Visit&& visit, bool split_folds) const;

  PatchSet set_;
  std::vector<float> patch_size_;
  /// Per patch: its index in bicubic_ (the double control points Newton evaluates), or -1
  /// for a patch of other degrees.
  std::vector<int32_t> bicubic_index_;
  std::vector<BicubicD> bicubic_;
  /// patch.eval(u, v, pu, pv) of patch `id`, through bicubic_ when it has an entry.
  DVec3 eval_patch(uint32_t id, double u, double v, DVec3* pu, DVec3* pv) const {
    const int32_t b = bicubic_index_[id];
    return b >= 0 ? eval_bicubic(bicubic_[size_t(b)], u, v, pu, pv)
                  : set_.patches[id].eval(u, v, pu, pv);
  }
  std::vector<BvhNode> nodes_;
  WideBvh wide_;                       // 4-wide upper levels of nodes_, for rays
  std::vector<Piece> pieces_;          // in leaf order
  std::vector<BezierPatch> piece_cp_;  // control points of each piece (for on-the-fly refinement)
  bool exact_ = false;                 // the exact field (a set with pieces)
  BoundaryCurves boundary_;            // its open borders (cracks sealed)
  BoundaryCurves unsealed_;            // with the sealed cracks' loops (empty when none)
  CrackSet cracks_;                    // the sealed cracks: rays near them are in doubt
  /// exact_winding_number with the boundary b; `cracks`: rays near a sealed crack are in
  /// doubt. *settled: some direction was in no doubt.
  double winding_number_with(const BoundaryCurves& b, bool cracks, Vec3 p, bool* settled) const;
  NearestOnCurves trim_borders_;  // its trimmed patches' kept borders, for closest points
  LazyWindingGrid side_grid_;     // its inside()'s cells
  std::unique_ptr<MeshSurface> field_;
  std::vector<TriangleUV> field_uv_;  // per field triangle: its patch and corners' (u, v)
  float field_error_ = 0;
  Box bounds_;
  SurfaceStats stats_;
};

}  // namespace hfrt::geom
