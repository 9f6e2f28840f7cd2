#pragma once
// Bézier patches: the BPT text format (hfBezierSurface(x, "file.bpt")), inline bicubic
// patches (hfBezierPatches(x, P), 48 numbers each), evaluation with derivatives, sub-patch
// extraction (de Casteljau) and uniform tessellation.
//
// BPT: the number of patches; then per patch its two degrees du dv (1 to 3 each) and
// (du+1)(dv+1) control points of 3 coordinates, row by row: dv+1 rows of du+1 points, so
// point (i, j) -- i along u, j along v -- is the (j*(du+1) + i)-th of the patch. Whitespace and
// line breaks are free; '#' starts a comment. The Utah teapot (32 bicubic patches) is
// /work/shared/corpus/bezier/teapot.bpt.
//
// Trimmed patches (an extension; files without it read as before): after the last patch, any
// number of records `trim P L`, P a 1-based patch index and L >= 1 loops, each loop `n` (>= 3)
// then n points `u v` of a closed polyline in patch P's parameter square (geom/trim.h: the
// kept region is what lies inside an odd number of the patch's loops). Several records for
// one patch add their loops together; a patch with none is untrimmed.

#include <array>
#include <span>
#include <string>
#include <vector>

#include "base/limits.h"
#include "base/result.h"
#include "geom/mesh.h"
#include "geom/trim.h"
#include "geom/vec.h"

namespace hfrt::geom {

/// A 3-vector in double, for Newton iteration on patches (hits exact to 1e-7 of the patch).
struct DVec3 {
  double x = 0, y = 0, z = 0;
};
inline DVec3 to_d(Vec3 v) {
  return {v.x, v.y, v.z};
}
inline Vec3 to_f(DVec3 v) {
  return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
}

/// A tensor-product Bézier patch of degrees du, dv in 1..3 over [0,1]^2.
struct BezierPatch {
  int du = 3, dv = 3;
  std::array<Vec3, 16> cp{};  ///< cp[j*(du+1) + i]: i along u, j along v

  Vec3 control(int i, int j) const { return cp[j * (du + 1) + i]; }
  Vec3& control(int i, int j) { return cp[j * (du + 1) + i]; }
  int num_control_points() const { return (du + 1) * (dv + 1); }

  /// The point at (u, v) and, when not null, the partial derivatives.
  DVec3 eval(double u, double v, DVec3* pu = nullptr, DVec3* pv = nullptr) const;

  /// The bounding box of the control points (contains the patch: convex hull property).
  Box control_bounds() const;

  /// The same surface restricted to [u0,u1] x [v0,v1], reparametrised over [0,1]^2.
  BezierPatch sub_patch(double u0, double u1, double v0, double v1) const;

  /// The largest distance of a control point from the bilinear interpolation of the four
  /// corners: 0 for a bilinear patch; how far the patch is from "flat enough".
  float flatness() const;
};

/// A bicubic patch's control points in double, four lanes each (x, y, z, 0): what Newton's
/// method on every ray evaluates (eval_bicubic).
struct alignas(32) BicubicD {
  // Aligned to 32 explicitly: without AVX enabled the compiler aligns a 32-byte vector type
  // to 16 only, while eval_bicubic's AVX2 clone loads it aligned.
  using V4d = double __attribute__((vector_size(32), aligned(32)));
  V4d cp[16];
  explicit BicubicD(const BezierPatch& p);
};

/// BezierPatch::eval of a bicubic patch (du = dv = 3) from its double control points: the
/// same operations in the same order on the x, y and z lanes, so the same bits, in vector
/// instructions.
DVec3 eval_bicubic(const BicubicD& patch, double u, double v, DVec3* pu, DVec3* pv);
/// eval_bicubic's copy for CPUs without AVX2 (eval_bicubic picks it there): for tests.
DVec3 eval_bicubic_generic(const BicubicD& patch, double u, double v, DVec3* pu, DVec3* pv);

/// A set of patches, their trimming regions and where they came from.
struct PatchSet {
  std::vector<BezierPatch> patches;
  /// Empty (no patch is trimmed) or one per patch (an empty Trim: that patch is untrimmed).
  std::vector<Trim> trims;
  std::string source;

  /// The trim of patch p, or null when it is untrimmed.
  const Trim* trim(size_t p) const {
    return p < trims.size() && !trims[p].empty() ? &trims[p] : nullptr;
  }

  Box bounds() const;
};

/// Parses BPT text; `name` is used in messages ("teapot.bpt:17: ..."). Errors: malformed
/// numbers, degrees outside 1..3, non-finite coordinates, a truncated file, trailing data
/// (anything after the patches that is not a trim record), zero patches; in trim records, a
/// patch index out of range, no loops, a loop of fewer than 3 points, a point outside [0,1]^2
/// by more than 1e-6 (points within it are clamped).
Result<PatchSet> parse_bpt(const std::string& text, const std::string& name);

/// Reads a BPT file (missing or unreadable files are errors naming the path). Like load_mesh,
/// refuses what is not a regular file and a file of more than limits.max_mesh_bytes bytes
/// before reading it.
Result<PatchSet> load_bpt(const std::string& path, const Limits& limits = {});

/// Inline bicubic patches as hfBezierPatches(x, P) passes them: 48 numbers (16 control points,
/// row by row) per patch.
Result<PatchSet> patches_from_array(std::span<const double> p,
                                    const std::string& what = "inline patches");

/// An n x n grid of quads (2 triangles each) per patch, vertices shared within a patch.
/// Degenerate triangles (at collapsed patch edges such as the teapot lid's pole) are dropped
/// and counted by finish_mesh(). A trimmed patch keeps the quads inside its region, drops those
/// outside, and replaces those its loops cross by the exact kept part (Trim::clip, mapped
/// through the patch). `max_error`, when not null, receives an estimate of the largest
/// distance between the (trimmed) patches and the triangles (sampled at quad centres and edge
/// midpoints; for clipped triangles, at their edge midpoints and centroids).
/// The quads of a patch come in Morton order of their (i, j); `keys`, when not null, receives
/// per triangle (patch << 32) | Morton code of its quad: the keys of build_bvh_grouped.
/// `uvs`, when not null, receives per triangle its patch and its corners' (u, v).
struct TriangleUV {
  uint32_t patch = 0;
  float u[3] = {0, 0, 0}, v[3] = {0, 0, 0};
};
TriangleMesh tessellate(const PatchSet& set, int n, float* max_error = nullptr,
                        std::vector<uint64_t>* keys = nullptr,
                        std::vector<TriangleUV>* uvs = nullptr);

}  // namespace hfrt::geom
