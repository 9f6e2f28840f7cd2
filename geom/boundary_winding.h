#pragma once
// The generalised winding number of a surface from its boundary curves and the crossings of
// one ray, with no discretisation of the surface (PatchSurface's exact field).
//
// Why it works (Stokes): the solid angle of a surface S seen from p is the flux through S of
// the field r / |r|^3 (r = x - p). Away from a half-line ("Dirac string") from p in direction
// s, that field is the curl of the monopole's vector potential
//     A(r) = (r x s) / (|r| (|r| - s . r)),
// so the flux through S is the line integral of A around the boundary of S, corrected by 4 pi
// for every point where the string pierces S (the flux the string carries back). With
// `facing` +1 where a ray enters S against its outward normal and -1 where it leaves:
//     w(p) = (1 / 4 pi) * integral of A . dl over the boundary of S  -  sum of the facings of
//            the crossings of the ray from p along s.
// A closed surface has no boundary: w is minus the sum of the facings, an integer. An open
// one (the Utah teapot) has a fractional w near its openings, which the boundary term gives
// exactly, without the solid angle of any triangle.
//
// The curves: every patch's four borders, in the order (u, v) runs around [0,1]^2
// counter-clockwise (right-handed about Pu x Pv, the outward normal), except a border whose
// control points all coincide (a collapsed edge: no length) and the pairs of borders that
// cancel (one the other's control points reversed: a seam of two patches, or of a patch with
// itself). The teapot keeps 16 of its 128. A trimmed patch's border is its kept region's
// (Trim::border: loop edges and the kept parts of its sides, kept region on the left), each
// segment mapped through the patch: a line in (u, v) is a Bézier curve of degree du + dv on
// it. The crossings of the ray then count only where the trim keeps them, and the formula
// holds as it is: a trimmed patch is a surface with that boundary. Where a trim loop follows
// the next patch's rim, the two almost cancel: PatchSurface seals such cracks (seal_cracks,
// below) before it counts the curves.
//
// The integral: each curve is split in de Casteljau halves until every piece is small and far
// enough, seen from p, both from p and from the string (its control points' bounding sphere's
// radius below half its distance, and its angle from s above twice its angular radius), then
// summed by six-point Gauss-Legendre on each piece (error ~1e-4 of w at worst). The first four
// levels of halves are made once, with their points (BoundaryCurves::tree_); deeper ones on
// the fly. Near the string (a curve passing within ~1e-11 of the ray, 40 halvings) the split
// would not end: the answer is then flagged unreliable and the caller picks another
// direction.

#include <array>
#include <vector>

#include "geom/bezier.h"
#include "geom/bvh.h"
#include "geom/trim.h"

namespace hfrt::geom {

/// A Bézier curve in 3-D of degree 1..6 (a patch border: the patch's degree along it; a trim
/// loop's edge: up to du + dv, a line in (u, v) mapped through the patch).
struct BezierCurve {
  int degree = 3;
  std::array<DVec3, 7> cp{};
};

/// The image on `patch` of the parameter segment from a to b, parametrised as
/// t -> P(a + t (b - a)): of degree du where v is constant, dv where u is, else du + dv (the
/// diagonal of the sub-patch over the segment's rectangle: B_i^du B_j^dv =
/// C(du,i) C(dv,j) / C(du+dv,i+j) B_{i+j}^{du+dv}). A whole side of the square gives the
/// patch's border control points themselves (bit for bit: seams still cancel).
BezierCurve curve_on_patch(const BezierPatch& patch, UV a, UV b);

/// A curve on patch `patch`: the image of the parameter segment (a, b) (curve_on_patch).
struct CurveOnPatch {
  BezierCurve curve;
  uint32_t patch = 0;
  UV a, b;
};

/// The border of each patch's kept region on the patch, oriented with it on the left
/// (right-handed about Pu x Pv): an untrimmed patch's four sides, a trimmed one's
/// Trim::border() (none when it keeps nothing of positive area).
std::vector<CurveOnPatch> kept_borders(const PatchSet& set);

/// The boundary of a set of Bézier patches (trimmed or not), and the string term of its
/// winding number (see the file comment).
class BoundaryCurves {
 public:
  /// The oriented borders of `set`'s patches' kept regions (kept_borders) that do not cancel
  /// (see the file comment).
  static BoundaryCurves build(const PatchSet& set) { return build(kept_borders(set)); }
  /// The same from the kept borders already made.
  static BoundaryCurves build(const std::vector<CurveOnPatch>& borders);
  /// A boundary of these curves as they are (no cancellation): what is left of one after
  /// seal_cracks; `patches`: each curve's patch, or none.
  static BoundaryCurves of(std::vector<BezierCurve> curves, std::vector<uint32_t> patches = {});

  /// (1 / 4 pi) x the line integral of A (string along the unit vector s from p) around the
  /// curves: w(p) plus the sum of the facings of the ray from p along s. *reliable is set
  /// false when a curve passes so close to the string (or to p) that the quadrature could not
  /// resolve it; the value is then not to be trusted.
  double string_term(const DVec3& p, const DVec3& s, bool* reliable) const;

  /// A bound on how much the winding number's smooth part (w less its jumps across the
  /// surface) changes within r of c. First order: r x its gradient's bound, the Biot-Savart
  /// field of the boundary, |grad w| <= (1 / 4 pi) x the sum over the curves of length /
  /// distance^2 (each curve's control polygon's length, its distance from the ball bounded
  /// through its control points' sphere, halved where that is loose). Where that exceeds 0.05,
  /// also second order: r |grad w(c)| (field(), with its quadrature's error) + r^2 / 2 x the
  /// Hessian's bound (1 / 4 pi) x the sum of 2 length / distance^3; the smaller of the two.
  /// +inf when a piece's sphere still meets the ball after 8 halvings (a ball on a curve); 0
  /// without curves (a closed set: w is constant off the surface).
  double smooth_change(const DVec3& c, double r) const;

  /// grad w at p off the curves: the Biot-Savart field of the boundary over 4 pi (the sign
  /// aside: its magnitude is what smooth_change needs), by halves as string_term (no string).
  /// *magnitude: the sum of its quadrature terms' magnitudes (the scale of its error);
  /// *ok false when a curve passes too near p to resolve.
  DVec3 field(const DVec3& p, double* magnitude, bool* ok) const;

  const std::vector<BezierCurve>& curves() const { return curves_; }
  /// Each curve's patch (empty for a boundary made by of() without them).
  const std::vector<uint32_t>& patches() const { return patches_; }
  size_t memory_bytes() const {
    return (curves_.capacity() + pieces_.capacity()) * sizeof(BezierCurve) +
           tree_.capacity() * sizeof(TreeNode) + samples_.capacity() * sizeof(Samples);
  }

  /// Gauss-Legendre points per curve (see kFar in the .cpp).
  static constexpr int kGauss = 6;
  /// A piece's Gauss-Legendre points and their derivatives times the weights, in single
  /// precision (w needs ~1e-5; the potential's float rounding is ~1e-6 of it), padded to
  /// eight lanes with zero weights: the sum over a piece is two SSE steps.
  struct Samples {
    float x[8], y[8], z[8], wx[8], wy[8], wz[8];
  };

 private:
  std::vector<BezierCurve> curves_;
  std::vector<uint32_t> patches_;
  /// Each curve's halves, quarters, ... down to kTreeDepth levels, made once: a piece's
  /// bounding sphere and its Gauss-Legendre points, which do not depend on p, so a piece
  /// summed directly costs only the vector potential at its points. Curve i's whole is
  /// tree_[i]; a piece's halves are tree_[children] and tree_[children + 1] (0: the deepest
  /// level, whose pieces are halved on the fly when they need to be).
  struct TreeNode {
    DVec3 centre;
    double radius2;
    double length;  ///< its control polygon's (smooth_change's bounds)
    uint32_t children;
    uint32_t curve;  ///< the piece's control points in pieces_ (the deepest level's only)
  };
  std::vector<TreeNode> tree_;
  std::vector<BezierCurve> pieces_;
  /// smooth_change's sum of length / distance^power over tree_[k]'s pieces seen from the
  /// ball (c, r), from the stored spheres and lengths (gradient_bound below the tree).
  double tree_bound(uint32_t k, const DVec3& c, double r, int power, int depth) const;
  /// Every curve's pieces whose bounding spheres accept(centre, radius2) takes: a tree node's
  /// stored samples to node(samples), a piece halved on the fly below the tree to
  /// piece(control points). False when some piece was still not taken after kMaxDepth
  /// halvings (every other piece is visited all the same). What string_term and field share.
  template <typename Accept, typename Node, typename Piece>
  bool for_each_piece(const Accept& accept, const Node& node, const Piece& piece) const;
  /// The samples of tree_[k].
  std::vector<Samples> samples_;
};

/// Cracks: loops of a boundary that another loop retraces in the opposite direction within a
/// tolerance. A trimmed patch whose trim loop follows the rim of the next patch (the cup's base
/// disk, cut by a polygon, against its wall's cubic rim, ~5e-4 apart) leaves two such loops:
/// the surfaces meet up to a crack, and its boundary's curves almost cancel. Sealing the
/// crack (dropping both loops) leaves a closed surface whose winding number is an integer,
/// with no boundary integral and no smooth part: exact for the surface with the crack filled,
/// and the same as the open surface's away from the crack save for the crack's own solid
/// angle (a strip of width <= tolerance: ~ tolerance x length / distance^2 / 4 pi). Rays that
/// pass near a sealed crack are put in doubt (CrackSet), so that no crossing through the
/// crack is miscounted.
struct SealedCracks {
  std::vector<BezierCurve> open;    ///< the curves in no sealed pair of loops
  std::vector<BezierCurve> sealed;  ///< the curves of the first loop of each sealed pair
  size_t pairs = 0;                 ///< pairs of loops sealed
  size_t sealed_curves = 0;         ///< the curves of both loops of every pair
  double gap = 0;                   ///< the largest distance measured between partners
};

/// The loops of `curves` (chains whose ends meet, each curve's end the start of exactly one
/// other, within 1e-9 of the coordinates' scale) that pair up: every sample of each loop
/// (spaced at most `tolerance` apart along it) within `tolerance` of the other loop, where the
/// other runs the opposite way (tangents with a negative dot product, away from curve ends),
/// and the two loops' lengths within 1 % + 4 tolerance of each other (one loop, not two, along
/// the other). Every point of one loop is then within 1.5 tolerance of the other.
/// `patches` (empty, or each curve's patch): two chains with a patch in common do not pair (a
/// thin sliver kept, or a slit cut, by one patch's trim is part of that patch, not a crack
/// between surfaces).
SealedCracks seal_cracks(const std::vector<BezierCurve>& curves, double tolerance,
                         const std::vector<uint32_t>& patches = {});

/// The sealed cracks' neighbourhood: the first loops' curves halved until their control
/// points lie within radius / 4 of their chords, as capsules of `radius` about the chords (a
/// BVH over their boxes). With radius = 2 tolerance they hold every point within 1.5
/// tolerance of a loop, so the crack between the two.
class CrackSet {
 public:
  static CrackSet build(const std::vector<BezierCurve>& loops, double radius);
  bool empty() const { return segments_.empty(); }
  double radius() const { return radius_; }
  size_t memory_bytes() const {
    return segments_.capacity() * sizeof(Segment) + nodes_.capacity() * sizeof(BvhNode);
  }
  /// Whether the segment o + t d (0 <= t <= tmax, tmax may be +inf) passes within radius of a
  /// capsule's axis.
  bool near(const DVec3& o, const DVec3& d, double tmax) const;
  /// A lower bound of the distance from p to the capsules (0 inside one), capped at cap.
  double distance(const DVec3& p, double cap) const;

 private:
  struct Segment {
    DVec3 a, b;
  };
  std::vector<Segment> segments_;  // in leaf order
  std::vector<BvhNode> nodes_;
  double radius_ = 0;
};

/// The closest point of a set of curves on patches (a trimmed set's kept_borders): each curve
/// halved (de Casteljau) until its pieces are straight to 1e-3 of their chord, once, at build;
/// a BVH over the pieces' control-point boxes, nearest first; in each piece Newton on the
/// distance from the chord's nearest point, clamped to the piece (exact to rounding: a
/// straight piece has one minimum).
class NearestOnCurves {
 public:
  static NearestOnCurves build(std::vector<CurveOnPatch> curves);
  bool empty() const { return curves_.empty(); }
  const std::vector<CurveOnPatch>& curves() const { return curves_; }
  size_t memory_bytes() const {
    return curves_.capacity() * sizeof(CurveOnPatch) + pieces_.capacity() * sizeof(Piece) +
           nodes_.capacity() * sizeof(BvhNode);
  }

  struct Hit {
    uint32_t curve = ~0u;
    double t = 0;  ///< the curve's parameter: (u, v) = a + t (b - a) on its patch
    DVec3 point;
  };
  /// The nearest point of the curves to p if nearer than sqrt(*best2): then *best2 and *hit
  /// are set to it and true is returned.
  bool nearest(const DVec3& p, double* best2, Hit* hit) const;

 private:
  /// A straight piece: curve `curve`'s part [t0, t1], its control points.
  struct Piece {
    BezierCurve cp;
    double t0, t1;
    uint32_t curve;
  };
  std::vector<CurveOnPatch> curves_;
  std::vector<Piece> pieces_;  // in leaf order
  std::vector<BvhNode> nodes_;
};

}  // namespace hfrt::geom
