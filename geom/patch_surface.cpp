#include "geom/patch_surface.h"

#include <algorithm>
#include <chrono>
#include <limits>

#include "base/check.h"
#include "base/parallel.h"
#include "geom/packet_lanes.h"
#include "geom/triangle.h"

namespace hfrt::geom {
namespace {

constexpr int kMaxRefine = 3;  // extra on-the-fly splits of a piece where Newton fails
/// A ray steeper than kFold x delta / side against a piece's corner triangles meets it once
/// (solve_piece).
constexpr float kFold = 8;
constexpr int kMaxNewton = 10;
constexpr double kHitTolerance = 1e-7;  // residual, relative to the patch size

// How far a (sub)patch can be from the two triangles of its corner quad: the control points'
// distance from the bilinear patch through the corners (the patch lies in their hull), plus the
// bilinear patch's largest distance from the triangles (at the quad centre, where the two
// diagonals' midpoints differ), with a 1% + tiny margin for rounding.
/// `flatness`: b.flatness(), when the caller has it.
float piece_delta(const BezierPatch& b, float flatness) {
  const Vec3 p00 = b.control(0, 0), p10 = b.control(b.du, 0), p01 = b.control(0, b.dv),
             p11 = b.control(b.du, b.dv);
  const float twist = 0.5f * length((p00 + p11) * 0.5f - (p10 + p01) * 0.5f);
  const float size = length(b.control_bounds().diagonal());
  return (flatness + twist) * 1.01f + 1e-6f * size;
}
float piece_delta(const BezierPatch& b) {
  return piece_delta(b, b.flatness());
}

// De Casteljau at 1/2 of the n + 1 points p[0], p[stride], ...: the left half's points into
// left[0, stride, ...], the right half's into right[...].
void halve_curve(int n, const DVec3* p, int stride, DVec3* left, DVec3* right) {
  DVec3 w[4];
  for (int i = 0; i <= n; ++i) w[i] = p[i * stride];
  left[0] = w[0];
  right[n * stride] = w[n];
  for (int r = 1; r <= n; ++r) {
    for (int i = 0; i <= n - r; ++i)
      w[i] = {0.5 * (w[i].x + w[i + 1].x), 0.5 * (w[i].y + w[i + 1].y),
              0.5 * (w[i].z + w[i + 1].z)};
    left[r * stride] = w[0];
    right[(n - r) * stride] = w[n - r];
  }
}

// The four quarters of a patch of degree (du, dv) (control points cp[j * (du + 1) + i]):
// out[b][a] is the half a along u of the half b along v.
void halve_patch(int du, int dv, const std::array<DVec3, 16>& cp, std::array<DVec3, 16> out[2][2]) {
  std::array<DVec3, 16> half[2];  // along u
  for (int j = 0; j <= dv; ++j) {
    const int row = j * (du + 1);
    halve_curve(du, cp.data() + row, 1, half[0].data() + row, half[1].data() + row);
  }
  for (int a = 0; a < 2; ++a)
    for (int i = 0; i <= du; ++i)
      halve_curve(dv, half[a].data() + i, du + 1, out[0][a].data() + i, out[1][a].data() + i);
}

}  // namespace

std::unique_ptr<PatchSurface> PatchSurface::build(const PatchSet& set, const Options& options) {
  HFRT_CHECK(!set.patches.empty());
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<PatchSurface> s(new PatchSurface());
  s->set_ = set;
  s->bounds_ = set.bounds();
  for (const BezierPatch& patch : set.patches) {
    const bool bicubic = patch.du == 3 && patch.dv == 3;
    s->bicubic_index_.push_back(bicubic ? int32_t(s->bicubic_.size()) : -1);
    if (bicubic) s->bicubic_.emplace_back(patch);
  }
  // The two halves are independent (the pieces and their BVH for rays; the field's
  // tessellation, its BVH and dipoles): built side by side, each on its own thread of TBB.
  int bvh_depth = 0;
  // Each patch's kept border, made once (Trim::border): which trimmed patches keep anything
  // (those with a border: the square's own sides are one when all is kept), the exact field's
  // boundary, and its closest points' trim curves.
  const std::vector<CurveOnPatch> borders = kept_borders(set);
  std::vector<uint8_t> keeps(set.patches.size(), 0);
  for (const CurveOnPatch& c : borders) keeps[c.patch] = 1;
  auto build_pieces = [&] {
    std::vector<Piece> pieces;
    std::vector<BezierPatch> piece_cp;
    for (uint32_t p = 0; p < set.patches.size(); ++p) {
      const BezierPatch& patch = set.patches[p];
      const float size = std::max(length(patch.control_bounds().diagonal()), 1e-30f);
      s->patch_size_.push_back(size);
      // A trim that keeps nothing of positive area leaves no piece, not even where its loops
      // run.
      if (!keeps[p]) continue;
      // Split in parameter space until flat (quadtree, leaves in any order). Each node's
      // control points are its parent's halved (de Casteljau at 1/2, in double; rounded to
      // float for the piece), not the patch's cut to the node's range: a fifth of the cost.
      struct Todo {
        float u0, u1, v0, v1;
        int depth;
        std::array<DVec3, 16> cp;
      };
      std::vector<Todo> todo(1, Todo{0, 1, 0, 1, 0, {}});
      for (int k = 0; k < patch.num_control_points(); ++k) todo[0].cp[k] = to_d(patch.cp[k]);
      while (!todo.empty()) {
        const Todo t = std::move(todo.back());
        todo.pop_back();
        BezierPatch sub = patch;
        for (int k = 0; k < patch.num_control_points(); ++k) sub.cp[k] = to_f(t.cp[k]);
        const float flat = sub.flatness();
        if (t.depth < options.max_split_depth && flat > options.flatness * size) {
          const float um = 0.5f * (t.u0 + t.u1), vm = 0.5f * (t.v0 + t.v1);
          std::array<DVec3, 16> q[2][2];  // [v half][u half]
          halve_patch(patch.du, patch.dv, t.cp, q);
          todo.push_back({t.u0, um, t.v0, vm, t.depth + 1, q[0][0]});
          todo.push_back({um, t.u1, t.v0, vm, t.depth + 1, q[0][1]});
          todo.push_back({t.u0, um, vm, t.v1, t.depth + 1, q[1][0]});
          todo.push_back({um, t.u1, vm, t.v1, t.depth + 1, q[1][1]});
          continue;
        }
        const Trim* trim = set.trim(p);
        const Trim::Cover cover =
            trim ? trim->classify(t.u0, t.u1, t.v0, t.v1) : Trim::Cover::kKept;
        if (cover == Trim::Cover::kRemoved) continue;  // never hit: not in the BVH
        pieces.push_back(
            {p, t.u0, t.u1, t.v0, t.v1, piece_delta(sub, flat), cover == Trim::Cover::kPartial});
        piece_cp.push_back(sub);
      }
    }
    if (!pieces.empty()) {
      std::vector<Box> boxes(pieces.size());
      for (size_t i = 0; i < pieces.size(); ++i) boxes[i] = piece_cp[i].control_bounds();
      Bvh bvh = build_bvh(boxes, BvhBuildOptions{.max_leaf_size = 2});
      s->nodes_ = std::move(bvh.nodes);
      s->wide_ = WideBvh::collapse(s->nodes_);
      bvh_depth = bvh.depth;
      s->pieces_.resize(pieces.size());
      s->piece_cp_.resize(pieces.size());
      for (size_t i = 0; i < pieces.size(); ++i) {
        s->pieces_[i] = pieces[bvh.prim_order[i]];
        s->piece_cp_[i] = piece_cp[bvh.prim_order[i]];
      }
    }
  };
  float err = 0;
  size_t all_triangles = 0;
  Result<TriangleMesh> clean = Error{"not built"};
  auto build_field = [&] {
    // The field goes through a tessellation (clipped to the trims). Nothing left of it (every
    // patch trimmed away or degenerate): an empty surface.
    // Its BVH follows the patches' quad grids (build_bvh_grouped) instead of an SAH search
    // over every triangle: the teapot's 65k triangles take 2-3 ms instead of 21. Leaves of one
    // quad (2 triangles): with leaves of up to 4, as the SAH tree has, the winding numbers of
    // a teapot frame cost 30 % more instructions (their near leaves); with 2, 14 % more, and
    // the closest points 2 % fewer, for 33 % more nodes (a frame, callgrind: 1.77G -> 1.66G
    // instructions in all).
    std::vector<uint64_t> all_keys;
    std::vector<TriangleUV> all_uv;
    TriangleMesh mesh = tessellate(set, options.field_tessellation, &err, &all_keys, &all_uv);
    all_triangles = mesh.triangles.size();
    std::vector<uint64_t> kept(all_triangles);  // which triangles finish_mesh keeps
    for (size_t i = 0; i < kept.size(); ++i) kept[i] = i;
    clean = finish_mesh(std::move(mesh), &kept);
    std::vector<uint64_t> keys(kept.size());
    s->field_uv_.resize(kept.size());
    for (size_t i = 0; i < kept.size(); ++i) {
      keys[i] = all_keys[kept[i]];
      s->field_uv_[i] = all_uv[kept[i]];
    }
    MeshSurface::Options field_options;
    field_options.bvh.max_leaf_size = 2;
    if (clean.ok()) s->field_ = MeshSurface::build_grouped(*clean, keys, field_options);
  };
  bool exact = options.exact_field;
  size_t curves = 0;  // the boundary's, when the exact field was asked for
  if (exact) {
    // The exact field needs no tessellation: the pieces, the borders that do not cancel, and
    // for the closest points of trimmed patches their kept regions' borders.
    par::parallel_invoke(build_pieces, [&] {
      s->boundary_ = BoundaryCurves::build(borders);
      if (options.seal_tolerance > 0 && !s->boundary_.curves().empty()) {
        // The crack tolerance from the control points' box (the pieces' bounds are not made
        // yet).
        Box box;
        for (const BezierPatch& patch : set.patches) box.extend(patch.control_bounds());
        const double tolerance = options.seal_tolerance * double(length(box.hi - box.lo));
        SealedCracks sealed = seal_cracks(s->boundary_.curves(), tolerance, s->boundary_.patches());
        if (sealed.pairs > 0) {
          s->stats_.sealed_curves = sealed.sealed_curves;
          s->stats_.crack_gap = sealed.gap;
          s->unsealed_ = std::move(s->boundary_);
          s->boundary_ = BoundaryCurves::of(std::move(sealed.open));
          s->cracks_ = CrackSet::build(sealed.sealed, 2 * tolerance);
        }
      }
      if (s->boundary_.curves().size() <= options.max_exact_curves) {
        // The trimmed patches' borders (where a closest point may lie on a trim loop, or on a
        // side that a partly trimmed piece's own search does not reach).
        std::vector<CurveOnPatch> trimmed;
        for (const CurveOnPatch& c : borders)
          if (set.trim(c.patch)) trimmed.push_back(c);
        s->trim_borders_ = NearestOnCurves::build(std::move(trimmed));
      }
    });
    curves = s->boundary_.curves().size();
    exact = curves <= options.max_exact_curves;
    if (exact) {
      s->exact_ = !s->pieces_.empty();
      clean = TriangleMesh{};
    } else {
      s->boundary_ = BoundaryCurves{};
      s->unsealed_ = BoundaryCurves{};
      s->cracks_ = CrackSet{};
      build_field();
    }
  } else {
    par::parallel_invoke(build_pieces, build_field);
  }
  s->field_error_ = err;
  const auto end = std::chrono::steady_clock::now();

  s->stats_.source = set.source;
  s->stats_.patches = set.patches.size();
  s->stats_.pieces = s->pieces_.size();
  s->stats_.exact_field = s->exact_;
  s->stats_.boundary_curves = curves;
  s->stats_.triangles = s->field_ ? s->field_->num_triangles() : 0;
  s->stats_.degenerate_skipped = clean.ok() ? clean->degenerate_skipped : all_triangles;
  s->stats_.bvh_nodes = s->nodes_.size() + (s->field_ ? s->field_->nodes().size() : 0);
  s->stats_.bvh_depth = bvh_depth;
  s->stats_.build_seconds = std::chrono::duration<double>(end - start).count();
  s->stats_.memory_bytes =
      sizeof(*s) + s->nodes_.capacity() * sizeof(BvhNode) + s->wide_.memory_bytes() +
      s->pieces_.capacity() * sizeof(Piece) + s->piece_cp_.capacity() * sizeof(BezierPatch) +
      (s->field_ ? s->field_->memory_bytes() : 0) + s->field_uv_.capacity() * sizeof(TriangleUV);
  for (const Trim& t : s->set_.trims) s->stats_.memory_bytes += sizeof(Trim) + t.memory_bytes();
  s->stats_.memory_bytes += s->boundary_.memory_bytes() + s->unsealed_.memory_bytes() +
                            s->cracks_.memory_bytes() + s->trim_borders_.memory_bytes();
  return s;
}

bool PatchSurface::unit_normal(uint32_t prim, const DVec3& pu, const DVec3& pv, Vec3* n) const {
  const double nx = pu.y * pv.z - pu.z * pv.y, ny = pu.z * pv.x - pu.x * pv.z,
               nz = pu.x * pv.y - pu.y * pv.x;
  const double len = std::sqrt(nx * nx + ny * ny + nz * nz);
  const double size = patch_size_[prim];
  if (!(len > 1e-10 * size * size)) return false;
  *n = {float(nx / len), float(ny / len), float(nz / len)};
  return true;
}

ClosestPoint PatchSurface::closest_point(Vec3 p, float max_distance) const {
  if (exact_) return closest_point_on_patches(p, max_distance);
  if (!field_) return {};
  if (std::isfinite(max_distance)) {
    ClosestPoint c = closest_point_on_patches(p, max_distance);
    if (c.prim != ~0u) return c;
  }
  ClosestPoint c = field_->closest_point(p, max_distance);
  if (c.prim == ~0u) return c;
  const TriangleUV& t = field_uv_[c.prim];
  auto at = [&](const float* w) {
    return std::clamp(double(w[0]) + c.b1 * (double(w[1]) - w[0]) + c.b2 * (double(w[2]) - w[0]),
                      0.0, 1.0);
  };
  const Vec3 n = normal(t.patch, at(t.u), at(t.v));
  if (length2(n) > 0) c.normal = dot(n, c.normal) >= 0 ? n : -n;
  return c;
}

PatchSurface::Nearest PatchSurface::nearest_on_patches(Vec3 p, float max_distance) const {
  Nearest best;
  if (nodes_.empty()) return best;
  const DVec3 q = to_d(p);
  double best2 = double(max_distance) * max_distance;
  // The exact field of a trimmed set: the nearest point may lie on a trim loop, or on a kept
  // side of a trimmed patch that a partly trimmed piece's search does not reach (its own
  // nearest point trimmed away). Those borders are searched first (their point bounds the
  // pieces' search); a piece's point trimmed away is then simply not a candidate.
  if (exact_) {
    NearestOnCurves::Hit h;
    if (trim_borders_.nearest(q, &best2, &h)) {
      const CurveOnPatch& c = trim_borders_.curves()[h.curve];
      best.patch = c.patch, best.on_border = true;
      best.u = std::clamp(c.a.u + h.t * (c.b.u - c.a.u), 0.0, 1.0);
      best.v = std::clamp(c.a.v + h.t * (c.b.v - c.a.v), 0.0, 1.0);
      best.point = h.point;
    }
  }
  auto box_distance2 = [&](const BvhNode& n) {
    double d2 = 0;
    const double c[3] = {q.x, q.y, q.z};
    for (int a = 0; a < 3; ++a) {
      const double e = std::max({double(n.lo[a]) - c[a], c[a] - double(n.hi[a]), 0.0});
      d2 += e * e;
    }
    return d2;
  };
  double &best_u = best.u, &best_v = best.v;
  DVec3& best_point = best.point;
  Vec3& best_normal = best.normal;
  double& trimmed_away2 = best.trimmed_away2;
  auto try_piece = [&](uint32_t k, bool anywhere) {
    const Piece& pc = pieces_[k];
    // The piece lies within delta of its corner triangles: no nearer to p than they are, less
    // delta. That rejects most of the pieces a box test lets through, without Newton.
    const BezierPatch& cp = piece_cp_[k];
    const Vec3 c00 = cp.control(0, 0), c10 = cp.control(cp.du, 0), c01 = cp.control(0, cp.dv),
               c11 = cp.control(cp.du, cp.dv);
    const float tri = std::sqrt(std::min(length2(closest_point_on_triangle(p, c00, c10, c11) - p),
                                         length2(closest_point_on_triangle(p, c00, c11, c01) - p)));
    const double lower = double(tri) * (1 - 1e-6) - double(pc.delta) * (1 + 1e-6);
    if (lower > 0 && lower * lower > best2) return true;
    {
      // The piece's corners lie on the patch: its nearest (kept) one is a candidate itself,
      // evaluated exactly when its float copy may beat the best so far. Without a limit, the
      // first pieces tried (the nearest boxes first) bound the rest of the search this way.
      Corner nearest{0, 0, {}, false};
      float nearest2 = std::numeric_limits<float>::infinity();
      for (int c = 0; c < 4; ++c) {
        const Corner cn = corner(k, c);
        const float d2f = length2(cn.point - p);
        if (d2f < nearest2 && cn.kept) nearest = cn, nearest2 = d2f;
      }
      if (nearest.kept && double(nearest2) * (1 - 1e-5) < best2) {
        const double u = nearest.u, v = nearest.v;
        const DVec3 x = eval_patch(pc.patch, u, v, nullptr, nullptr);
        const double dx = x.x - q.x, dy = x.y - q.y, dz = x.z - q.z;
        const double d2 = dx * dx + dy * dy + dz * dz;
        if (d2 < best2) {
          // (The normal is normal()'s at (u, v), taken at the end if this point stays best.)
          best2 = d2, best_u = u, best_v = v, best_point = x;
          best_normal = {0, 0, 0}, best.patch = pc.patch, best.on_border = false;
        }
      }
    }
    double u, v;
    DVec3 x;
    Vec3 nrm;
    if (!project_onto_piece(pc, q, anywhere, &u, &v, &x, &nrm)) return false;
    const double dx = x.x - q.x, dy = x.y - q.y, dz = x.z - q.z;
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (!(d2 <= best2)) return true;
    if (pc.trimmed && !set_.trim(pc.patch)->contains(u, v)) {
      // Trimmed away: the piece's nearest kept point lies on its trim loop, which this search
      // does not find (see below).
      trimmed_away2 = std::min(trimmed_away2, d2);
      return true;
    }
    best2 = d2, best_u = u, best_v = v, best_point = x, best_normal = nrm;
    best.patch = pc.patch, best.on_border = false;
    return true;
  };
  // Nearest first (the nearer child is visited first), pruned by the best distance so far. A
  // piece onto whose corner quad q projects well outside is put off: a point on the surface
  // settles on its own piece and needs none of them; any other point tries them afterwards.
  constexpr int kDeferMax = 32;
  uint32_t deferred[kDeferMax];
  double deferred_d2[kDeferMax];
  int ndeferred = 0;
  walk_nearest(nodes_, box_distance2, &best2, [&](const BvhNode& n, double nd2) {
    for (uint32_t k = n.index; k < n.index + n.count; ++k) {
      if (try_piece(k, ndeferred == kDeferMax)) continue;
      deferred[ndeferred] = k, deferred_d2[ndeferred] = nd2, ++ndeferred;
    }
    return true;
  });
  // On the surface (to rounding of its size): the deferred pieces cannot be nearer.
  const double on_surface = 1e-6 * double(bounds_.max_extent());
  if (!(best2 <= on_surface * on_surface)) {
    for (int i = 0; i < ndeferred; ++i)
      if (deferred_d2[i] <= best2) try_piece(deferred[i], true);
  }
  best.d2 = best.patch == ~0u ? std::numeric_limits<double>::infinity() : best2;
  return best;
}

ClosestPoint PatchSurface::closest_point_on_patches(Vec3 p, float max_distance) const {
  const Nearest n = nearest_on_patches(p, max_distance);
  // A trimmed piece's point nearer than the best was trimmed away: the closest kept point may
  // be on that piece's trim loop. Without the exact field's trim borders, the tessellation
  // (clipped to the kept region) answers.
  if (n.patch == ~0u || (!exact_ && n.trimmed_away2 < n.d2)) return {};
  const double best_u = n.u, best_v = n.v, best2 = n.d2;
  const DVec3 best_point = n.point;
  const Vec3 best_normal = n.on_border ? Vec3{0, 0, 0} : n.normal;
  ClosestPoint best;
  const uint32_t patch = n.patch;
  // Where Pu x Pv vanishes (a collapsed edge), the limit from inside the patch (normal()); on a
  // trimmed patch's border, its normal there.
  const Vec3 nrm = length2(best_normal) > 0 ? best_normal : normal(patch, best_u, best_v);
  if (!(length2(nrm) > 0)) return best;  // no normal: the tessellation's answer instead
  best.distance = float(std::sqrt(best2));
  best.point = to_f(best_point);
  best.normal = nrm;
  best.prim = patch;
  return best;
}

bool PatchSurface::project_onto_piece(const Piece& pc, const DVec3& q, bool anywhere, double* u_out,
                                      double* v_out, DVec3* x_out, Vec3* n_out) const {
  constexpr double kOutside = 0.125;
  // Gauss-Newton on |P(u, v) - q|^2, each step clamped to the piece's rectangle (a piece is
  // flat to 2e-3 of its patch, so the function is nearly a convex quadratic on it): two or
  // three evaluations for a point on the piece.
  // The start: q projected onto the parallelogram of the corner quad's mean edges (the
  // piece's parameters are nearly linear on it).
  double u = 0.5 * (double(pc.u0) + pc.u1), v = 0.5 * (double(pc.v0) + pc.v1);
  {
    const BezierPatch& cp = piece_cp_[size_t(&pc - pieces_.data())];
    const Vec3 p00 = cp.control(0, 0), p10 = cp.control(cp.du, 0), p01 = cp.control(0, cp.dv),
               p11 = cp.control(cp.du, cp.dv);
    const Vec3 eu = 0.5f * ((p10 - p00) + (p11 - p01)), ev = 0.5f * ((p01 - p00) + (p11 - p10));
    const Vec3 r = to_f(q) - 0.25f * (p00 + p10 + p01 + p11);
    const float a = dot(eu, eu), b = dot(eu, ev), c = dot(ev, ev), ru = dot(eu, r), rv = dot(ev, r),
                det = a * c - b * b;
    if (det > 0) {
      const double s0 = 0.5 + double((c * ru - b * rv) / det);
      const double t0 = 0.5 + double((a * rv - b * ru) / det);
      // Well outside the piece: its nearest point is on its border, which a neighbour's
      // interior holds (or, at the patches' outer border, the tessellation's answer).
      if (!anywhere &&
          !(s0 > -kOutside && s0 < 1 + kOutside && t0 > -kOutside && t0 < 1 + kOutside))
        return false;
      const double s = std::clamp(s0, 0.0, 1.0), t = std::clamp(t0, 0.0, 1.0);
      u = pc.u0 + s * (double(pc.u1) - pc.u0), v = pc.v0 + t * (double(pc.v1) - pc.v0);
    }
  }
  const double tol_u = 1e-7 * (double(pc.u1) - pc.u0), tol_v = 1e-7 * (double(pc.v1) - pc.v0);
  DVec3 x;
  // A step that brings P less than a quarter as much nearer q as its first-order model
  // predicts is halved: off the surface, where |P - q| times the curvature exceeds the
  // parameters' speed (across the rim's tightly curved lip), Gauss-Newton alone overshoots
  // and oscillates.
  // (prev_u, prev_v): the last point accepted, where the last step started.
  double prev_u = u, prev_v = v, prev_r2 = std::numeric_limits<double>::infinity(), want = 0;
  for (int it = 0; it < 24; ++it) {
    DVec3 pu, pv;
    x = eval_patch(pc.patch, u, v, &pu, &pv);
    const double rx = x.x - q.x, ry = x.y - q.y, rz = x.z - q.z;
    const double r2 = rx * rx + ry * ry + rz * rz;
    if (prev_r2 - r2 < 0.25 * want) {
      u = 0.5 * (u + prev_u), v = 0.5 * (v + prev_v);
      want *= 0.5;
      continue;
    }
    prev_u = u, prev_v = v, prev_r2 = r2;
    const double a = pu.x * pu.x + pu.y * pu.y + pu.z * pu.z;
    const double b = pu.x * pv.x + pu.y * pv.y + pu.z * pv.z;
    const double c = pv.x * pv.x + pv.y * pv.y + pv.z * pv.z;
    const double gu = pu.x * rx + pu.y * ry + pu.z * rz, gv = pv.x * rx + pv.y * ry + pv.z * rz;
    const double det = a * c - b * b;
    if (!(det > 0)) break;  // a collapsed edge: keep the point reached
    const double nu = std::clamp(u - (c * gu - b * gv) / det, double(pc.u0), double(pc.u1));
    const double nv = std::clamp(v - (a * gv - b * gu) / det, double(pc.v0), double(pc.v1));
    if (std::abs(nu - u) <= tol_u && std::abs(nv - v) <= tol_v) {
      // Converged: x is P(u, v), and its derivatives give the normal.
      *u_out = u, *v_out = v, *x_out = x;
      if (!unit_normal(pc.patch, pu, pv, n_out)) *n_out = {0, 0, 0};
      return true;
    }
    want = -2 * (gu * (nu - u) + gv * (nv - v));  // the first-order decrease of r2
    u = nu, v = nv;
  }
  // Out of steps, or no step from a collapsed edge: the last point accepted.
  u = prev_u, v = prev_v;
  *u_out = u, *v_out = v;
  DVec3 pu, pv;
  *x_out = eval_patch(pc.patch, u, v, &pu, &pv);
  if (!unit_normal(pc.patch, pu, pv, n_out)) *n_out = {0, 0, 0};
  return true;
}

Vec3 PatchSurface::normal(uint32_t prim, double u, double v) const {
  for (int attempt = 0; attempt < 4; ++attempt) {
    DVec3 pu, pv;
    eval_patch(prim, u, v, &pu, &pv);
    Vec3 n;
    if (unit_normal(prim, pu, pv, &n)) return n;
    // A collapsed edge (a pole): the normal is the limit from inside the patch.
    u += (0.5 - u) * 1e-4 * (1 << (3 * attempt));
    v += (0.5 - v) * 1e-4 * (1 << (3 * attempt));
  }
  return {0, 0, 0};
}

namespace {

/// Whether the ray (direction d, planes from ray_planes) may meet the piece `sub` (corners
/// p00..p11, within delta of its corner triangles) more than once. First a cheap test: the
/// piece is a height field within delta of each corner triangle, its slope against them about
/// kFold x delta / its shortest side at most, so a ray steeper than that meets it once. Else
/// the exact one: the normal Pu x Pv is a convex combination of the cross products of the
/// derivative nets' vectors (the differences of neighbouring control points), so when every
/// such product has the same sign along d (in the plane across the ray: 2-D cross products of
/// the vectors projected onto the two planes), the piece projects one-to-one along the ray.
bool may_meet_twice(const BezierPatch& sub, const double plane[2][4], float delta, Vec3 p00,
                    Vec3 p10, Vec3 p01, Vec3 p11, Vec3 d) {
  const Vec3 e1 = p10 - p00, e2 = p11 - p00, e3 = p01 - p00;
  const Vec3 na = cross(e1, e2), nb = cross(e2, e3);
  const float side2 = std::min({length2(e1), length2(p11 - p10), length2(p11 - p01), length2(e3)});
  const float steep = kFold * delta / std::sqrt(side2);
  const float dl = length(d), da = dot(na, d), db = dot(nb, d);
  if (std::abs(da) > steep * length(na) * dl && std::abs(db) > steep * length(nb) * dl &&
      (da > 0) == (db > 0))
    return false;
  const int du = sub.du, dv = sub.dv;
  auto project = [&](Vec3 v, double* x, double* y) {
    *x = plane[0][0] * v.x + plane[0][1] * v.y + plane[0][2] * v.z;
    *y = plane[1][0] * v.x + plane[1][1] * v.y + plane[1][2] * v.z;
  };
  double ax[12], ay[12], cx[12], cy[12];
  int na_ = 0, nc = 0;
  for (int j = 0; j <= dv; ++j)
    for (int i = 0; i < du; ++i, ++na_)
      project(sub.control(i + 1, j) - sub.control(i, j), &ax[na_], &ay[na_]);
  for (int j = 0; j < dv; ++j)
    for (int i = 0; i <= du; ++i, ++nc)
      project(sub.control(i, j + 1) - sub.control(i, j), &cx[nc], &cy[nc]);
  bool pos = false, neg = false;
  for (int i = 0; i < na_; ++i)
    for (int j = 0; j < nc; ++j) {
      const double c = ax[i] * cy[j] - ay[i] * cx[j];
      pos = pos || c > 0;
      neg = neg || c < 0;
    }
  return pos == neg;  // both signs (or none: degenerate)
}

}  // namespace

template <typename Visit>
void PatchSurface::solve_piece(const Ray& ray, const double plane[2][4], uint32_t patch_id,
                               double u0, double u1, double v0, double v1, const BezierPatch& sub,
                               float delta, int depth, float tmin, float tmax, Visit&& visit,
                               bool split_folds) const {
  const DVec3 o = to_d(ray.org), d = to_d(ray.dir);
  const Vec3 p00 = sub.control(0, 0), p10 = sub.control(sub.du, 0), p01 = sub.control(0, sub.dv),
             p11 = sub.control(sub.du, sub.dv);
  // The piece lies within delta of the hull of its four corners, and the two planes are unit
  // distances whose zero set is the ray: a piece whose corners are all more than delta on one
  // side of either plane cannot meet the ray (the tests below would reject it too; this
  // rejects 3 of every 4 pieces the teapot's rays reach).
  // f[k][q]: corner q's (00, 10, 01, 11) signed distance from plane k. The planes are
  // orthonormal and meet in the ray, so (f[0][q], f[1][q]) is the corner projected along the
  // ray, with the ray at the origin: the tests below are 2-D and reuse these values.
  double f[2][4];
  for (int k = 0; k < 2; ++k) {
    auto dist = [&](Vec3 q) {
      return plane[k][0] * q.x + plane[k][1] * q.y + plane[k][2] * q.z + plane[k][3];
    };
    f[k][0] = dist(p00), f[k][1] = dist(p10), f[k][2] = dist(p01), f[k][3] = dist(p11);
    if (std::min({f[k][0], f[k][1], f[k][2], f[k][3]}) > delta ||
        std::max({f[k][0], f[k][1], f[k][2], f[k][3]}) < -delta)
      return;
  }
  // A ray nearly parallel to the piece may meet it twice (a curved piece, a grazing ray), and
  // Newton finds one root: such a piece is split, as below, until each part is met once.
  if (split_folds && depth < kMaxRefine &&
      may_meet_twice(sub, plane, delta, p00, p10, p01, p11, ray.dir)) {
    refine(ray, plane, patch_id, u0, u1, v0, v1, sub, depth, tmin, tmax, visit, true);
    return;
  }
  // Newton starts where the ray meets the corner quad's two triangles: the barycentrics of
  // the origin in the projected triangle (corners a, b, c), as a 3-D ray-triangle test would
  // find them.
  auto triangle = [&](int a, int b, int c, double* b1, double* b2) {
    const double e1x = f[0][b] - f[0][a], e1y = f[1][b] - f[1][a];
    const double e2x = f[0][c] - f[0][a], e2y = f[1][c] - f[1][a];
    const double det = e1x * e2y - e1y * e2x;
    if (!(std::abs(det) > 1e-300)) return false;
    const double px = -f[0][a], py = -f[1][a];
    *b1 = (px * e2y - py * e2x) / det;
    *b2 = (e1x * py - e1y * px) / det;
    return *b1 >= 0 && *b2 >= 0 && *b1 + *b2 <= 1;
  };
  double s = 0.5, t = 0.5, b1, b2;
  if (triangle(0, 1, 3, &b1, &b2)) {
    s = b1 + b2, t = b2;
  } else if (triangle(0, 3, 2, &b1, &b2)) {
    s = b1, t = b1 + b2;
  } else {
    // The ray misses the quad: the piece (within delta of it) can only be hit if the ray
    // passes within delta of the quad's border; start from the nearest border point (the
    // distance from the origin to the projected edges and diagonal).
    static constexpr int kEdge[5][2] = {{0, 1}, {1, 3}, {3, 2}, {2, 0}, {0, 3}};
    // (s, t) of each edge's start and end in the piece's parameter square.
    static constexpr double kEs[5][4] = {
        {0, 0, 1, 0}, {1, 0, 1, 1}, {1, 1, 0, 1}, {0, 1, 0, 0}, {0, 0, 1, 1}};
    double best2 = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 5; ++k) {
      const int a = kEdge[k][0], b = kEdge[k][1];
      const double ax = f[0][a], ay = f[1][a], ex = f[0][b] - ax, ey = f[1][b] - ay;
      const double ee = ex * ex + ey * ey;
      const double w = ee > 0 ? std::clamp(-(ax * ex + ay * ey) / ee, 0.0, 1.0) : 0.0;
      const double qx = ax + w * ex, qy = ay + w * ey;
      const double d2 = qx * qx + qy * qy;
      if (d2 < best2) {
        best2 = d2;
        s = kEs[k][0] + w * (kEs[k][2] - kEs[k][0]);
        t = kEs[k][1] + w * (kEs[k][3] - kEs[k][1]);
      }
    }
    if (best2 > double(delta) * delta) return;
  }
  double u = u0 + s * (u1 - u0), v = v0 + t * (v1 - v0);
  const double eps = kHitTolerance * patch_size_[patch_id];
  const double wu = u1 - u0, wv = v1 - v0;
  bool converged = false;
  DVec3 p, pu, pv;
  for (int it = 0; it < kMaxNewton; ++it) {
    p = eval_patch(patch_id, u, v, &pu, &pv);
    const double f1 = plane[0][0] * p.x + plane[0][1] * p.y + plane[0][2] * p.z + plane[0][3];
    const double f2 = plane[1][0] * p.x + plane[1][1] * p.y + plane[1][2] * p.z + plane[1][3];
    if (std::abs(f1) < eps && std::abs(f2) < eps) {
      converged = true;
      break;
    }
    const double j11 = plane[0][0] * pu.x + plane[0][1] * pu.y + plane[0][2] * pu.z;
    const double j12 = plane[0][0] * pv.x + plane[0][1] * pv.y + plane[0][2] * pv.z;
    const double j21 = plane[1][0] * pu.x + plane[1][1] * pu.y + plane[1][2] * pu.z;
    const double j22 = plane[1][0] * pv.x + plane[1][1] * pv.y + plane[1][2] * pv.z;
    const double det = j11 * j22 - j12 * j21;
    if (!(std::abs(det) > 0)) break;
    u -= (j22 * f1 - j12 * f2) / det;
    v -= (j11 * f2 - j21 * f1) / det;
    // Far outside the piece: the root (if any) belongs to another piece.
    if (!(u > u0 - wu && u < u1 + wu && v > v0 - wv && v < v1 + wv)) break;
  }
  const double slack = 1e-9;
  const bool inside = converged && u >= std::max(0.0, u0 - slack) &&
                      u <= std::min(1.0, u1 + slack) && v >= std::max(0.0, v0 - slack) &&
                      v <= std::min(1.0, v1 + slack);
  if (inside) {
    const double dd = d.x * d.x + d.y * d.y + d.z * d.z;
    const double th = ((p.x - o.x) * d.x + (p.y - o.y) * d.y + (p.z - o.z) * d.z) / dd;
    if (th > tmin && th < tmax) {
      RawHit h{th, std::clamp(u, 0.0, 1.0), std::clamp(v, 0.0, 1.0), patch_id, false, {}};
      // normal()'s first attempt, from the derivatives at this very (u, v).
      if (h.u == u && h.v == v) h.has_normal = unit_normal(patch_id, pu, pv, &h.n);
      visit(h);
    }
    return;
  }
  // Converged to a root outside the piece: the piece that owns it reports it (a ray passing
  // near a shared border starts Newton in both pieces). Only a failure to converge -- a grazing
  // ray, a silhouette -- is worth refining.
  if (converged || depth >= kMaxRefine) return;
  // Newton failed (grazing ray, silhouette): split and retry in the sub-pieces the ray meets.
  refine(ray, plane, patch_id, u0, u1, v0, v1, sub, depth, tmin, tmax, visit, split_folds);
}

template <typename Visit>
void PatchSurface::refine(const Ray& ray, const double plane[2][4], uint32_t patch_id, double u0,
                          double u1, double v0, double v1, const BezierPatch& sub, int depth,
                          float tmin, float tmax, Visit&& visit, bool split_folds) const {
  const WatertightRay wr(ray);
  const double um = 0.5 * (u0 + u1), vm = 0.5 * (v0 + v1);
  const double cu[3] = {u0, um, u1}, cv[3] = {v0, vm, v1};
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      const BezierPatch child = sub.sub_patch(0.5 * i, 0.5 * (i + 1), 0.5 * j, 0.5 * (j + 1));
      const Box b = child.control_bounds();
      const float lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
      float tn;
      if (!slab_hit(wr, lo, hi, tmin, tmax, &tn)) continue;
      solve_piece(ray, plane, patch_id, cu[i], cu[i + 1], cv[j], cv[j + 1], child,
                  piece_delta(child), depth + 1, tmin, tmax, visit, split_folds);
    }
}

void PatchSurface::ray_planes(const Ray& ray, double plane[2][4]) {
  const DVec3 d = to_d(normalize(ray.dir));
  DVec3 n1 = std::abs(d.x) > std::abs(d.y) && std::abs(d.x) > std::abs(d.z) ? DVec3{d.y, -d.x, 0}
                                                                            : DVec3{0, d.z, -d.y};
  const double l1 = std::sqrt(n1.x * n1.x + n1.y * n1.y + n1.z * n1.z);
  n1 = {n1.x / l1, n1.y / l1, n1.z / l1};
  const DVec3 n2{d.y * n1.z - d.z * n1.y, d.z * n1.x - d.x * n1.z, d.x * n1.y - d.y * n1.x};
  const DVec3 o = to_d(ray.org);
  const double p[2][4] = {{n1.x, n1.y, n1.z, -(n1.x * o.x + n1.y * o.y + n1.z * o.z)},
                          {n2.x, n2.y, n2.z, -(n2.x * o.x + n2.y * o.y + n2.z * o.z)}};
  std::copy(&p[0][0], &p[0][0] + 8, &plane[0][0]);
}

template <typename Visit>
void PatchSurface::solve_leaf(const BvhNode& n, const Ray& ray, const double plane[2][4],
                              float tmin, const float* closest, Visit&& visit,
                              bool split_folds) const {
  for (uint32_t k = n.index; k < n.index + n.count; ++k) {
    const Piece& pc = pieces_[k];
    if (!pc.trimmed) {
      solve_piece(ray, plane, pc.patch, pc.u0, pc.u1, pc.v0, pc.v1, piece_cp_[k], pc.delta, 0, tmin,
                  *closest, visit, split_folds);
      continue;
    }
    // A trim loop crosses the piece: a root counts only where the trim keeps it. RawHit's
    // (u, v) are the patch's own parameters (the piece's are never used), and a piece owns
    // at most one root, so a root trimmed away is not replaced by another. A separate
    // instantiation, so that the untrimmed path stays as fast as before.
    const Trim& trim = *set_.trim(pc.patch);
    solve_piece(
        ray, plane, pc.patch, pc.u0, pc.u1, pc.v0, pc.v1, piece_cp_[k], pc.delta, 0, tmin, *closest,
        [&](const RawHit& h) {
          if (trim.contains(h.u, h.v)) visit(h);
        },
        split_folds);
  }
}

template <typename Visit>
void PatchSurface::trace(const Ray& ray, float tmin, float* tmax, Visit&& visit,
                         bool split_folds) const {
  // Two planes whose intersection is the ray: set up at the first leaf only, as most rays of
  // a frame never reach one.
  double plane[2][4];
  bool have_planes = false;
  const WatertightRay r(ray);
  auto leaf = [&](const BvhNode& n, float* closest) {
    if (!have_planes) ray_planes(ray, plane), have_planes = true;
    solve_leaf(n, ray, plane, tmin, closest, visit, split_folds);
  };
  if (nodes_.empty()) return;  // every patch trimmed away
  if (!wide_.empty()) {
    wide_.traverse(nodes_, r, tmin, tmax, leaf);
    return;
  }
  float tn;
  if (slab_hit(r, nodes_[0].lo, nodes_[0].hi, tmin, *tmax, &tn)) leaf(nodes_[0], tmax);
}

bool PatchSurface::intersect(const Ray& ray, float tmin, float tmax, SurfaceHit* hit) const {
  float limit = tmax;
  bool found = false;
  RawHit best{};
  trace(ray, tmin, &limit, [&](const RawHit& h) {
    if (h.t < limit) {
      // Keep the hit in double until the end; the float limit only prunes the traversal.
      if (!found || h.t < best.t) best = h;
      found = true;
      limit = static_cast<float>(h.t);
      // The float rounding of limit must not prune this very hit's neighbours below it.
      limit = std::nextafter(limit, std::numeric_limits<float>::infinity());
    }
  });
  if (!found) return false;
  hit->t = static_cast<float>(best.t);
  hit->prim = best.patch;
  hit->u = static_cast<float>(best.u);
  hit->v = static_cast<float>(best.v);
  hit->normal = hit_normal(best);
  return true;
}

void PatchSurface::RootBuffer::push(const RawHit& h) {
  if (count < kInline) {
    inline_hits[count++] = h;
    return;
  }
  if (spill.empty()) spill.assign(inline_hits, inline_hits + kInline);
  spill.push_back(h);
  ++count;
}

void PatchSurface::finish_crossings(const Ray& ray, RootBuffer* roots,
                                    std::vector<Crossing>* out) const {
  out->clear();
  const size_t count = roots->count;
  RawHit* raw = roots->spill.empty() ? roots->inline_hits : roots->spill.data();
  // A total order, so that the roots' order does not depend on the order the pieces were
  // visited in (the packets' walk and the single ray's differ): the same crossings either way.
  std::sort(raw, raw + count, [](const RawHit& a, const RawHit& b) {
    if (a.t != b.t) return a.t < b.t;
    if (a.patch != b.patch) return a.patch < b.patch;
    return a.u != b.u ? a.u < b.u : a.v < b.v;
  });
  const double dl = length(ray.dir);
  int facings[RootBuffer::kInline];
  std::vector<int> spill_facings(count > RootBuffer::kInline ? count : 0);
  int* facing_of = count > RootBuffer::kInline ? spill_facings.data() : facings;
  size_t kept = 0;  // raw[0, kept): the roots kept, with facing_of[] their facings
  for (size_t i = 0; i < count; ++i) {
    const RawHit h = raw[i];
    const int facing = dot(hit_normal(h), ray.dir) < 0 ? 1 : -1;
    bool dup = false;
    // The same point found by two pieces (on their shared border) or by two patches sharing
    // an edge: same facing, same place.
    for (size_t k = kept; k-- > 0;) {
      const double tol = 1e-6 * patch_size_[h.patch] / std::max(dl, 1e-30);
      if (h.t - raw[k].t > tol) break;
      if (facing_of[k] == facing) dup = true;
    }
    if (dup) continue;
    raw[kept] = h;
    facing_of[kept++] = facing;
    out->push_back({static_cast<float>(h.t), facing, h.patch});
  }
}

void PatchSurface::crossings(const Ray& ray, float tmin, float tmax,
                             std::vector<Crossing>* out) const {
  // The roots in a buffer on the stack (a ray meets a few; more spill to the heap), sorted,
  // then compacted in place: no allocation per ray.
  collect_crossings(ray, tmin, tmax, /*split_folds=*/false, out);
}

void PatchSurface::crossings_all(const Ray& ray, float tmin, float tmax,
                                 std::vector<Crossing>* out) const {
  collect_crossings(ray, tmin, tmax, /*split_folds=*/true, out);
}

void PatchSurface::collect_crossings(const Ray& ray, float tmin, float tmax, bool split_folds,
                                     std::vector<Crossing>* out) const {
  RootBuffer roots;
  float limit = tmax;
  trace(
      ray, tmin, &limit, [&](const RawHit& h) { roots.push(h); }, split_folds);
  finish_crossings(ray, &roots, out);
}

void PatchSurface::crossings_many(const Ray* rays, size_t n, const float* tmin, const float* tmax,
                                  std::vector<Crossing>* out) const {
  if (wide_.empty()) {  // a root leaf, or no pieces at all: one ray at a time
    for (size_t i = 0; i < n; ++i) crossings(rays[i], tmin[i], tmax[i], &out[i]);
    return;
  }
  for (size_t i = 0; i < n; i += packet::kLanes) {
    const int m = int(std::min<size_t>(packet::kLanes, n - i));
    crossings_packet(rays + i, m, tmin + i, tmax + i, out + i);
  }
}

namespace {

// The packet walk, for AVX2 and for the x86-64 baseline (chosen at start-up, as the meshes'
// is: geom/mesh_packet.cpp). The leaves' Newton solves are the same scalar code in both,
// reached through `leaf` (one indirect call per leaf the packet reaches).
using PacketLeaf = void (*)(void* ctx, const BvhNode& leaf, int lanes);
using PacketWalk = void (*)(const WideBvh&, const std::vector<BvhNode>&, const Ray*, int,
                            const float*, const float*, PacketLeaf, void*);

[[gnu::always_inline]] inline void packet_walk_body(const WideBvh& wide,
                                                    const std::vector<BvhNode>& nodes,
                                                    const Ray* rays, int n, const float* tmin,
                                                    const float* tmax, PacketLeaf leaf, void* ctx) {
  packet::RayLanes L;
  for (int i = 0; i < packet::kLanes; ++i)
    packet::set_lane(L, i, WatertightRay(rays[i < n ? i : 0]));
  packet::set_segments(L, n, tmin, tmax);
  packet::walk<true>(wide, nodes, L, [&](const BvhNode& l, int lanes) { leaf(ctx, l, lanes); });
}

void packet_walk_generic(const WideBvh& wide, const std::vector<BvhNode>& nodes, const Ray* rays,
                         int n, const float* tmin, const float* tmax, PacketLeaf leaf, void* ctx) {
  packet_walk_body(wide, nodes, rays, n, tmin, tmax, leaf, ctx);
}

__attribute__((target("avx2"))) void packet_walk_avx2(const WideBvh& wide,
                                                      const std::vector<BvhNode>& nodes,
                                                      const Ray* rays, int n, const float* tmin,
                                                      const float* tmax, PacketLeaf leaf,
                                                      void* ctx) {
  packet_walk_body(wide, nodes, rays, n, tmin, tmax, leaf, ctx);
}

const PacketWalk g_packet_walk = packet::cpu_has_avx2() ? packet_walk_avx2 : packet_walk_generic;

}  // namespace

void PatchSurface::crossings_packet(const Ray* rays, int n, const float* tmin, const float* tmax,
                                    std::vector<Crossing>* out) const {
  // The rays walk the 4-wide BVH together (their node boxes tested in 8 lanes at once); at a
  // leaf, each lane whose ray met its box solves its pieces as its single-ray walk would.
  RootBuffer roots[packet::kLanes];
  double planes[packet::kLanes][2][4];
  int have_planes = 0;
  auto leaf = [&](const BvhNode& node, int lanes) {
    for (int m = lanes; m; m &= m - 1) {
      const int i = __builtin_ctz(m);
      if (!(have_planes >> i & 1)) ray_planes(rays[i], planes[i]), have_planes |= 1 << i;
      RootBuffer& r = roots[i];
      solve_leaf(node, rays[i], planes[i], tmin[i], &tmax[i], [&](const RawHit& h) { r.push(h); });
    }
  };
  const PacketLeaf call = [](void* ctx, const BvhNode& l, int lanes) {
    (*static_cast<decltype(leaf)*>(ctx))(l, lanes);
  };
  g_packet_walk(wide_, nodes_, rays, n, tmin, tmax, call, &leaf);
  for (int i = 0; i < n; ++i) finish_crossings(rays[i], &roots[i], &out[i]);
}

bool PatchSurface::ray_facings(const Ray& ray, float tmax, int* facings, bool check_cracks) const {
  RootBuffer roots;
  float limit = tmax;
  bool doubtful = false;
  trace(
      ray, 0.0f, &limit,
      [&](const RawHit& h) {
        // Within 1e-5 of a border: the same crossing may be found by both patches of a seam, or
        // by neither; grazing: a pair of roots may be found as one.
        constexpr double kBorder = 1e-5, kGrazing = 1e-3;
        const double u = h.u, v = h.v;
        if (u < kBorder || u > 1 - kBorder || v < kBorder || v > 1 - kBorder) doubtful = true;
        // Near a trim loop: whether the root is kept is as uncertain as the boundary term
        // (the string passes next to the loop's curve).
        if (const Trim* trim = set_.trim(h.patch); trim && trim->near_edge(u, v, kBorder))
          doubtful = true;
        if (std::abs(dot(hit_normal(h), ray.dir)) < kGrazing * length(ray.dir)) doubtful = true;
        roots.push(h);
      },
      /*split_folds=*/true);
  if (doubtful) return false;
  // Through or next to a sealed crack: whether the ray passes between the two loops (no
  // crossing of the open surface, one of the sealed one) is in doubt.
  if (!cracks_.empty() && check_cracks && cracks_.near(to_d(ray.org), to_d(ray.dir), double(tmax)))
    return false;
  thread_local std::vector<Crossing> crossings;
  finish_crossings(ray, &roots, &crossings);
  int sum = 0;
  for (const Crossing& c : crossings) sum += c.facing;
  *facings = sum;
  return true;
}

double PatchSurface::winding_number_with(const BoundaryCurves& b, bool cracks, Vec3 p,
                                         bool* settled) const {
  // Directions away from the axes and from each other, so that a point on an axis-aligned
  // grid (the renderer's and the mesher's samples) does not send its ray along a seam.
  static const std::array<DVec3, 8> kDirections = [] {
    const double raw[8][3] = {{0.5137, 0.2713, 0.8140},  {-0.6823, 0.5521, 0.4791},
                              {0.3379, -0.8861, 0.3172}, {-0.2531, -0.3797, -0.8898},
                              {0.8527, 0.4389, -0.2834}, {-0.5903, -0.7142, 0.3761},
                              {0.1473, 0.9217, -0.3589}, {-0.9011, 0.1687, -0.3993}};
    std::array<DVec3, 8> d;
    for (int i = 0; i < 8; ++i) {
      const double l =
          std::sqrt(raw[i][0] * raw[i][0] + raw[i][1] * raw[i][1] + raw[i][2] * raw[i][2]);
      d[i] = {raw[i][0] / l, raw[i][1] / l, raw[i][2] / l};
    }
    return d;
  }();
  const DVec3 q = to_d(p);
  // The directions in the order their rays leave the bounds soonest: fewer pieces on the way.
  std::array<std::pair<float, int>, 8> order;
  for (int i = 0; i < 8; ++i) {
    const DVec3& s = kDirections[size_t(i)];
    const float d[3] = {float(s.x), float(s.y), float(s.z)};
    float exit = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 3; ++a)  // no direction component is 0
      exit = std::min(exit, ((d[a] > 0 ? bounds_.hi[a] : bounds_.lo[a]) - p[a]) / d[a]);
    order[size_t(i)] = {std::max(exit, 0.0f), i};
  }
  std::sort(order.begin(), order.end());
  double w = 0;
  *settled = false;
  for (const auto& [exit, i] : order) {
    const DVec3& s = kDirections[size_t(i)];
    bool reliable = true;
    const double term = b.string_term(q, s, &reliable);
    int facings = 0;
    const bool clear =
        ray_facings({p, to_f(s)}, std::numeric_limits<float>::infinity(), &facings, cracks);
    w = term - facings;
    // Every direction in doubt (a point on a border curve, or on a seam with every ray along
    // the surface): the last answer, as good as any.
    if (reliable && clear) {
      *settled = true;
      break;
    }
  }
  return w;
}

double PatchSurface::exact_winding_number(Vec3 p) const {
  bool settled;
  const double w = winding_number_with(boundary_, true, p, &settled);
  // Next to a sealed crack in every direction: the open surface's winding number (every
  // curve, and rays through the crack counted as they are).
  if (settled || cracks_.empty()) return w;
  return winding_number_with(unsealed_, false, p, &settled);
}

double PatchSurface::winding_number(Vec3 p) const {
  if (exact_) return exact_winding_number(p);
  return field_ ? field_->winding_number(p) : 0.0;
}

bool PatchSurface::inside(Vec3 p) const {
  if (!exact_) return field_ && field_->inside(p);
  return side_grid_.get(bounds_).inside(
      p, [this](Vec3 q) { return exact_winding_number(q); },
      [this](Vec3 c, float r) {
        return float(std::min(boundary_.smooth_change(to_d(c), r), 1e30));
      },
      [this](Vec3 c, float r) {
        // Farther than r is as good as r: the search stops there. Not past a sealed crack
        // (the segment from c would not be checked against it).
        const double d = std::sqrt(piece_box_distance2(Box(c, c), nullptr, double(r) * r));
        return float(cracks_.empty() ? d : std::min(d, cracks_.distance(to_d(c), d)));
      },
      [this](Vec3 c, Vec3 q, int* sum) {
        return ray_facings({c, q - c}, 1.0f, sum);
      });
}

float PatchSurface::signed_distance(Vec3 p, Vec3* gradient) const {
  if (exact_) {
    const ClosestPoint c = closest_point_on_patches(p, std::numeric_limits<float>::infinity());
    return signed_distance_from(c, p, inside(p), gradient);
  }
  if (!field_) {
    if (gradient) *gradient = {0, 0, 0};
    return -std::numeric_limits<float>::max();
  }
  return field_->signed_distance(p, gradient);
}

DistanceBounds PatchSurface::signed_distance_bounds(const Box& box) const {
  if (exact_) return exact_distance_bounds(box);
  if (!field_) return {-std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()};
  DistanceBounds b = field_->signed_distance_bounds(box);
  // The field is the tessellation's: widen by its distance to the true patches.
  return {b.lo - field_error_, b.hi + field_error_};
}

double PatchSurface::piece_box_distance2(const Box& box, uint32_t* piece, double cap2) const {
  double apart2 = cap2;
  uint32_t near_piece = 0;
  auto box_distance2 = [&](const BvhNode& n) { return double(n.bounds().distance2(box)); };
  walk_nearest(nodes_, box_distance2, &apart2, [&](const BvhNode& n, double) {
    for (uint32_t k = n.index; k < n.index + n.count; ++k) {
      const double d2 = piece_cp_[k].control_bounds().distance2(box);
      if (d2 < apart2) apart2 = d2, near_piece = k;
    }
    return apart2 != 0;  // a piece's box meets the box: the bound is 0, stop
  });
  if (piece) *piece = near_piece;
  return apart2;
}

DistanceBounds PatchSurface::exact_distance_bounds(const Box& box) const {
  // The nearest piece box (the pieces lie in their control-point boxes) and a point of the
  // patches near the box: one of that piece's corners (on the patch), inside the box if one
  // is.
  uint32_t near_piece = 0;
  const double apart2 = piece_box_distance2(box, &near_piece);
  // A corner of the piece on the surface (kept, when the piece is partly trimmed), inside
  // the box if one is.
  Vec3 vertex;
  bool have_vertex = false, vertex_in_box = false;
  for (int c = 0; c < 4 && !vertex_in_box; ++c) {
    const Corner cn = corner(near_piece, c);
    if (!cn.kept) continue;
    vertex = cn.point, have_vertex = true;
    vertex_in_box = box.contains(vertex);
  }
  if (!have_vertex) {
    // Every corner trimmed away: a point of the patches from the closest point at the box's
    // centre.
    const Nearest at = nearest_on_patches(box.center(), std::numeric_limits<float>::infinity());
    vertex = to_f(at.point);
  }
  const float size = bounds_.max_extent();
  // No point of the box is farther from the patches than from that point of them (rounded
  // onto the patch to ~1e-7 of its size: the margin).
  const float reach = std::sqrt(box.max_distance2(vertex)) * (1.0f + 1e-6f) + 1e-6f * size;
  if (apart2 > 0) {
    // No piece's box meets the box: the sign at its centre (exact for closed patch sets,
    // whose winding number is constant off the surface), as MeshSurface's bounds do.
    const float apart = float(std::sqrt(apart2)) * (1.0f - 1e-6f);
    if (inside(box.center())) return {apart, reach};
    return {-reach, -apart};
  }
  // A point of the patches in the box: F takes 0 there.
  if (vertex_in_box) return {-reach, reach};
  const Vec3 c = box.center();
  const float half_diag = 0.5f * length(box.diagonal()) * (1.0f + 1e-6f);
  // A search within half the diagonal finds the closest point when the box may hold the
  // surface; only when it finds none are all the pieces searched.
  Nearest near = nearest_on_patches(c, half_diag);
  if (near.patch == ~0u) near = nearest_on_patches(c, std::numeric_limits<float>::infinity());
  // Newton's closest point is exact to ~1e-7 of the size: a margin on both sides.
  const float margin = 1e-5f * size;
  const float dc = near.patch == ~0u ? 0.0f : float(std::sqrt(near.d2));
  const float upper = std::min(dc + half_diag + margin, reach);
  const float lower = dc - half_diag - margin;
  if (lower <= 0) return {-upper, upper};
  if (inside(c)) return {lower, upper};
  return {-upper, -lower};
}

}  // namespace hfrt::geom
