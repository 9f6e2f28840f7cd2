// The winding number of patch sets from their boundary and one ray (geom/boundary_winding.h):
// against the exact solid angle of flat patches (two triangles each), against the teapot's
// dense tessellation away from the surface, integers for closed sets, and the same answer
// along every direction.

#include "geom/boundary_winding.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>

#include "geom/mesh_surface.h"
#include "geom/patch_surface.h"
#include "test_meshes.h"

namespace hfrt::geom {
namespace {

/// A bilinear patch over the quad a, b, c, d (counter-clockwise seen from Pu x Pv's side).
BezierPatch quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  BezierPatch p;
  p.du = p.dv = 1;
  p.control(0, 0) = a, p.control(1, 0) = b, p.control(1, 1) = c, p.control(0, 1) = d;
  return p;
}

/// The six faces of the box [lo, hi], each as a bilinear patch with Pu x Pv outward.
PatchSet box_patches(Vec3 lo, Vec3 hi) {
  PatchSet set;
  set.source = "box";
  auto v = [&](int i) {
    return Vec3{i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z};
  };
  // Each face's corners counter-clockwise seen from outside.
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) set.patches.push_back(quad(v(f[0]), v(f[1]), v(f[2]), v(f[3])));
  return set;
}

/// The same patches as triangles (two per quad, the same orientation), for the exact solid
/// angle.
std::unique_ptr<MeshSurface> as_triangles(const PatchSet& set) {
  TriangleMesh m;
  for (const BezierPatch& p : set.patches) {
    const uint32_t base = uint32_t(m.vertices.size());
    m.vertices.insert(m.vertices.end(),
                      {p.control(0, 0), p.control(1, 0), p.control(1, 1), p.control(0, 1)});
    m.triangles.push_back({base, base + 1, base + 2});
    m.triangles.push_back({base, base + 2, base + 3});
  }
  return MeshSurface::build(m);
}

const PatchSet& teapot() {
  static const PatchSet set = [] {
    Result<PatchSet> r = load_bpt(std::string(HFRT_CORPUS_DIR) + "/bezier/teapot.bpt");
    HFRT_CHECK_MSG(r.ok(), r.error().message);
    return std::move(r).value();
  }();
  return set;
}

TEST(BoundaryWinding, OpenFlatPatchesGiveTheSolidAngleOfTheirTriangles) {
  // An open box (five faces) and a single tilted quad (planar, so that it is its two
  // triangles): fractional winding numbers everywhere.
  PatchSet open = box_patches({-1, -1, -1}, {1, 1, 1});
  open.patches.pop_back();
  PatchSet tilted;
  auto plane = [](float x, float y) { return Vec3{x, y, 0.25f * x - 0.5f * y + 0.125f}; };
  tilted.patches.push_back(
      quad(plane(-1, -1), plane(1, -0.5f), plane(0.75f, 1), plane(-1.25f, 0.875f)));
  for (const PatchSet* set : {&open, &tilted}) {
    const auto s = PatchSurface::build(*set);
    ASSERT_FALSE(s->has_tessellation());
    const auto tri = as_triangles(*set);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> coord(-2.5f, 2.5f);
    double worst = 0;
    for (int k = 0; k < 2000; ++k) {
      const Vec3 p{coord(rng), coord(rng), coord(rng)};
      if (tri->closest_point(p).distance < 1e-3f) continue;
      worst = std::max(worst, std::abs(s->winding_number(p) - tri->winding_number_exact(p)));
    }
    EXPECT_LT(worst, 1e-6) << set->patches.size() << " patches";
  }
  // The open box keeps the four borders of its missing face (each face's other borders are
  // seams); the quad its own four.
  EXPECT_EQ(BoundaryCurves::build(open).curves().size(), 4u);
  EXPECT_EQ(BoundaryCurves::build(tilted).curves().size(), 4u);
}

TEST(BoundaryWinding, ClosedPatchSetsHaveNoBoundaryAndIntegerWindingNumbers) {
  const PatchSet set = box_patches({-1, -2, -0.5f}, {1, 2, 0.5f});
  EXPECT_TRUE(BoundaryCurves::build(set).curves().empty());
  const auto s = PatchSurface::build(set);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> coord(-3, 3);
  int inside = 0;
  for (int k = 0; k < 1000; ++k) {
    const Vec3 p{coord(rng), coord(rng), coord(rng)};
    const bool in = std::abs(p.x) < 1 && std::abs(p.y) < 2 && std::abs(p.z) < 0.5f;
    EXPECT_EQ(s->winding_number(p), in ? 1.0 : 0.0) << p.x << " " << p.y << " " << p.z;
    EXPECT_EQ(s->inside(p), in);
    inside += in;
  }
  EXPECT_GT(inside, 10);
}

TEST(BoundaryWinding, TeapotAgreesWithItsDenseTessellationAwayFromTheSurface) {
  const auto exact = PatchSurface::build(teapot());
  PatchSurface::Options options;
  options.exact_field = false;
  const auto dense = PatchSurface::build(teapot(), options);
  ASSERT_FALSE(exact->has_tessellation());
  ASSERT_TRUE(dense->has_tessellation());
  // The open borders: the lid's rim, the body's, and the spout's and handle's ends.
  EXPECT_GT(exact->boundary().curves().size(), 0u);
  EXPECT_LT(exact->boundary().curves().size(), 128u);
  const MeshSurface& field = dense->field_mesh();
  std::mt19937 rng(11);
  const Box box = testing::grown(exact->bounds(), 0.3f);
  std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y),
      uz(box.lo.z, box.hi.z);
  double worst = 0;
  int in = 0, fractional = 0, tested = 0;
  for (int k = 0; k < 800; ++k) {
    const Vec3 p{ux(rng), uy(rng), uz(rng)};
    // Away from the surface by more than the tessellation's error (both ways).
    if (field.closest_point(p).distance < 20 * dense->field_error()) continue;
    // The tessellation's exact sum (its hierarchical winding number is off by up to 0.05).
    const double w = exact->winding_number(p), ref = field.winding_number_exact(p);
    worst = std::max(worst, std::abs(w - ref));
    ++tested;
    in += w >= 0.5;
    fractional += std::abs(w - std::round(w)) > 0.01;
    EXPECT_EQ(exact->inside(p), ref >= 0.5) << p.x << " " << p.y << " " << p.z << " w " << w;
  }
  EXPECT_LT(worst, 2e-3);
  EXPECT_GT(tested, 500);
  EXPECT_GT(in, 30);
  EXPECT_GT(fractional, 5);
  std::printf("teapot: %d points, worst |w - w_tessellation| %.3g, %d inside, %d fractional\n",
              tested, worst, in, fractional);  // the openings make w fractional around them
}

TEST(BoundaryWinding, EveryDirectionGivesTheSameAnswer) {
  const auto s = PatchSurface::build(teapot());
  const BoundaryCurves& b = s->boundary();
  std::mt19937 rng(5);
  const Box box = testing::grown(s->bounds(), 0.3f);
  std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y),
      uz(box.lo.z, box.hi.z);
  std::normal_distribution<double> g;
  for (int k = 0; k < 300; ++k) {
    const Vec3 p{ux(rng), uy(rng), uz(rng)};
    const double w = s->winding_number(p);
    // The string term along random directions, with the crossings of the same rays.
    for (int d = 0; d < 4; ++d) {
      DVec3 dir{g(rng), g(rng), g(rng)};
      const double l = std::sqrt(dir.x * dir.x + dir.y * dir.y + dir.z * dir.z);
      dir = {dir.x / l, dir.y / l, dir.z / l};
      bool reliable = true;
      const double term = b.string_term(to_d(p), dir, &reliable);
      std::vector<Crossing> out;
      s->crossings({p, to_f(dir)}, 0, std::numeric_limits<float>::infinity(), &out);
      int facings = 0;
      for (const Crossing& c : out) facings += c.facing;
      if (reliable) {
        // The quadrature's error (six points a piece within half its distance) is ~1e-4.
        EXPECT_NEAR(term - facings, w, 3e-4) << k << " " << d;
      }
    }
  }
}

// Regression (stop 55): rays that graze a curved piece meet it twice, and Newton in the piece
// found one root, so these rays' crossings were one short (a winding number off by 1 at
// points well outside the teapot). crossings_all splits such pieces; the dense tessellation
// agrees.
TEST(BoundaryWinding, GrazingRaysFindBothRootsOfAPiece) {
  const auto s = PatchSurface::build(teapot());
  PatchSurface::Options options;
  options.exact_field = false;
  options.field_tessellation = 128;
  const auto dense = PatchSurface::build(teapot(), options);
  const DVec3 d{0.5137, 0.2713, 0.8140};
  const double l = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  const Vec3 dir = to_f(DVec3{d.x / l, d.y / l, d.z / l});
  const Vec3 origins[] = {{-4.06031f, -1.3f, -0.84f}, {0.915f, -1.2f, -0.42f}};
  const size_t want[] = {4, 5};
  for (int i = 0; i < 2; ++i) {
    std::vector<Crossing> all, once, ref;
    s->crossings_all({origins[i], dir}, 0, std::numeric_limits<float>::infinity(), &all);
    s->crossings({origins[i], dir}, 0, std::numeric_limits<float>::infinity(), &once);
    dense->field_mesh().crossings({origins[i], dir}, 0, std::numeric_limits<float>::infinity(),
                                  &ref);
    EXPECT_EQ(ref.size(), want[i]) << i;
    ASSERT_EQ(all.size(), ref.size()) << i;
    for (size_t k = 0; k < all.size(); ++k) {
      EXPECT_EQ(all[k].facing, ref[k].facing) << i << " " << k;
      EXPECT_NEAR(all[k].t, ref[k].t, 1e-3f) << i << " " << k;  // the tessellation's error
    }
    // The renderer's crossings (one Newton per piece) still miss one: why the winding number
    // has its own.
    EXPECT_EQ(once.size() + 1, ref.size()) << i;
  }
}

// The winding grid's answers (a cell's centre plus the facings of a segment, within its
// bound) are the points' own winding numbers', over a sweep of 270k points around the teapot
// asked twice (the second time every cell is settled).
TEST(BoundaryWinding, TheGridsSidesAreTheWindingNumbers) {
  const auto s = PatchSurface::build(teapot());
  const Box b = s->bounds();
  const Box g(b.lo - (b.hi - b.lo) * 0.3f, b.hi + (b.hi - b.lo) * 0.3f);
  int differ = 0, inside = 0, asked = 0;
  for (int round = 0; round < 2; ++round)
    for (int k = 0; k < 129; k += 16)
      for (int j = 0; j < 129; j += 2)
        for (int i = 0; i < 129; i += 2) {
          const Vec3 q{g.lo.x + (g.hi.x - g.lo.x) * float(i) / 128,
                       g.lo.y + (g.hi.y - g.lo.y) * float(j) / 128,
                       g.lo.z + (g.hi.z - g.lo.z) * float(k) / 128};
          const bool in = s->inside(q);
          differ += in != (s->exact_winding_number(q) >= 0.5);
          inside += in;
          ++asked;
        }
  EXPECT_EQ(differ, 0) << "of " << asked;
  EXPECT_GT(inside, asked / 50);
}

// ---- Trimmed patches -----------------------------------------------------------------------

/// The solid angle of triangle (a, b, c) seen from p, signed by its orientation (Van Oosterom
/// and Strackee), over 4 pi: its winding number.
double triangle_winding(DVec3 p, DVec3 a, DVec3 b, DVec3 c) {
  const DVec3 x{a.x - p.x, a.y - p.y, a.z - p.z}, y{b.x - p.x, b.y - p.y, b.z - p.z},
      z{c.x - p.x, c.y - p.y, c.z - p.z};
  auto dot = [](DVec3 u, DVec3 v) { return u.x * v.x + u.y * v.y + u.z * v.z; };
  const double lx = std::sqrt(dot(x, x)), ly = std::sqrt(dot(y, y)), lz = std::sqrt(dot(z, z));
  const double det =
      x.x * (y.y * z.z - y.z * z.y) - x.y * (y.x * z.z - y.z * z.x) + x.z * (y.x * z.y - y.y * z.x);
  const double den = lx * ly * lz + dot(x, y) * lz + dot(y, z) * lx + dot(z, x) * ly;
  return 2 * std::atan2(det, den) / (4 * std::numbers::pi);
}

/// The distance from p to the segment [a, b].
double segment_distance(DVec3 p, DVec3 a, DVec3 b) {
  const DVec3 d{b.x - a.x, b.y - a.y, b.z - a.z}, w{p.x - a.x, p.y - a.y, p.z - a.z};
  const double len2 = d.x * d.x + d.y * d.y + d.z * d.z;
  const double t = std::clamp((w.x * d.x + w.y * d.y + w.z * d.z) / len2, 0.0, 1.0);
  const DVec3 r{w.x - t * d.x, w.y - t * d.y, w.z - t * d.z};
  return std::sqrt(r.x * r.x + r.y * r.y + r.z * r.z);
}

/// A regular n-gon in (u, v) about (cu, cv) of radius r, counter-clockwise.
std::vector<UV> ngon(int n, double cu, double cv, double r, double phase = 0.3) {
  std::vector<UV> loop;
  for (int k = 0; k < n; ++k) {
    const double a = phase + 2 * std::numbers::pi * k / n;
    loop.push_back({cu + r * std::cos(a), cv + r * std::sin(a)});
  }
  return loop;
}

// A flat patch (an affine map of the parameter square onto a tilted plane, so the kept region
// is a polygon in space) trimmed four ways. Its winding number is the solid angle of the kept
// polygons (fans of triangles, the hole's subtracted), and its distance the plane's where p
// projects into the kept region, else the nearest polygon edge's: closed forms.
TEST(BoundaryWinding, TrimmedFlatPatchesGiveTheSolidAngleAndDistanceOfTheirRegion) {
  auto plane = [](double u, double v) {
    const double x = -1 + 2 * u + 0.25 * v, y = -1 + 2 * v;
    return DVec3{x, y, 0.25 * x - 0.5 * y + 0.125};
  };
  BezierPatch flat =
      quad(to_f(plane(0, 0)), to_f(plane(1, 0)), to_f(plane(1, 1)), to_f(plane(0, 1)));
  const std::vector<UV> square{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  const std::vector<UV> octagon = ngon(8, 0.45, 0.55, 0.3);
  const std::vector<UV> half{{0, 0}, {1, 0}, {1, 0.5}, {0, 0.5}};  // three sides on the border
  std::vector<UV> reversed_octagon(octagon.rbegin(), octagon.rend());
  struct Case {
    const char* name;
    std::vector<std::vector<UV>> loops;
    std::vector<std::vector<UV>> kept;     // counter-clockwise polygons, added
    std::vector<std::vector<UV>> removed;  // polygons inside them, subtracted
    size_t curves;                         // the border's segments
  };
  const Case cases[] = {
      {"disk", {octagon}, {octagon}, {}, 8},
      {"disk, clockwise loop", {reversed_octagon}, {octagon}, {}, 8},
      {"ring", {square, octagon}, {square}, {octagon}, 12},
      {"half", {half}, {half}, {}, 4},
  };
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> coord(-2, 2);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    PatchSet set;
    set.patches.push_back(flat);
    set.trims.push_back(Trim(c.loops));
    const auto s = PatchSurface::build(set);
    ASSERT_FALSE(s->has_tessellation());
    EXPECT_EQ(s->boundary().curves().size(), c.curves);
    // The polygons' edges in space, for the distance off the region.
    std::vector<std::pair<DVec3, DVec3>> edges;
    for (const auto* polys : {&c.kept, &c.removed})
      for (const std::vector<UV>& poly : *polys)
        for (size_t i = 0; i < poly.size(); ++i) {
          const UV a = poly[i], b = poly[(i + 1) % poly.size()];
          edges.push_back({plane(a.u, a.v), plane(b.u, b.v)});
        }
    // The plane's unit normal (Pu x Pv) and the parameters of a point's projection.
    const DVec3 pu{2, 0, 0.5}, pv{0.25, 2, 0.0625 - 1};
    DVec3 n{pu.y * pv.z - pu.z * pv.y, pu.z * pv.x - pu.x * pv.z, pu.x * pv.y - pu.y * pv.x};
    const double nl = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    n = {n.x / nl, n.y / nl, n.z / nl};
    double worst_w = 0, worst_d = 0;
    int on_plane = 0, off_region = 0;
    for (int k = 0; k < 1500; ++k) {
      DVec3 p{coord(rng), coord(rng), coord(rng)};
      if (k % 3 == 0) {
        // Just above or below the plane, where the border matters most.
        const DVec3 q = plane(1.2 * coord(rng) / 2 + 0.5, 1.2 * coord(rng) / 2 + 0.5);
        const double h = 0.05 * coord(rng);
        p = {q.x + h * n.x, q.y + h * n.y, q.z + h * n.z};
      }
      double want = 0;
      for (const auto* polys : {&c.kept, &c.removed})
        for (const std::vector<UV>& poly : *polys)
          for (size_t i = 1; i + 1 < poly.size(); ++i)
            want += (polys == &c.kept ? 1 : -1) *
                    triangle_winding(p, plane(poly[0].u, poly[0].v), plane(poly[i].u, poly[i].v),
                                     plane(poly[i + 1].u, poly[i + 1].v));
      // The projection's (u, v): the plane map is affine, solve for it.
      const DVec3 r{p.x - plane(0, 0).x, p.y - plane(0, 0).y, p.z - plane(0, 0).z};
      const double h = r.x * n.x + r.y * n.y + r.z * n.z;
      const DVec3 in{r.x - h * n.x, r.y - h * n.y, r.z - h * n.z};
      const double a = pu.x * pu.x + pu.y * pu.y + pu.z * pu.z,
                   b = pu.x * pv.x + pu.y * pv.y + pu.z * pv.z,
                   cc = pv.x * pv.x + pv.y * pv.y + pv.z * pv.z,
                   ru = in.x * pu.x + in.y * pu.y + in.z * pu.z,
                   rv = in.x * pv.x + in.y * pv.y + in.z * pv.z;
      const double u = (cc * ru - b * rv) / (a * cc - b * b),
                   v = (a * rv - b * ru) / (a * cc - b * b);
      // Kept: inside a kept polygon and no removed one (point in convex polygon).
      auto in_poly = [&](const std::vector<UV>& poly) {
        for (size_t i = 0; i < poly.size(); ++i) {
          const UV e0 = poly[i], e1 = poly[(i + 1) % poly.size()];
          if ((e1.u - e0.u) * (v - e0.v) - (e1.v - e0.v) * (u - e0.u) < 0) return false;
        }
        return true;
      };
      bool kept = false;
      for (const auto& poly : c.kept) kept = kept || in_poly(poly);
      for (const auto& poly : c.removed) kept = kept && !in_poly(poly);
      double dist = std::abs(h);
      if (!kept) {
        dist = std::numeric_limits<double>::infinity();
        for (const auto& [e0, e1] : edges) dist = std::min(dist, segment_distance(p, e0, e1));
        ++off_region;
      } else {
        ++on_plane;
      }
      if (dist < 1e-3) continue;  // on the surface: w jumps
      worst_w = std::max(worst_w, std::abs(s->winding_number(to_f(p)) - want));
      worst_d = std::max(worst_d, std::abs(double(std::abs(s->signed_distance(to_f(p)))) - dist));
    }
    // The quadrature's 1e-4 at worst near the border; float points (p rounded) for distances.
    EXPECT_LT(worst_w, 2e-4);
    EXPECT_LT(worst_d, 2e-6);
    EXPECT_GT(on_plane, 50);
    EXPECT_GT(off_region, 50);
    std::printf("%s: worst |w - w_exact| %.3g, |d - d_exact| %.3g\n", c.name, worst_w, worst_d);
  }
}

/// The teapot with a hole in every patch (a 24-gon of radius 0.3 about the centre of the
/// parameter square).
PatchSet holed_teapot() {
  PatchSet set = teapot();
  std::vector<UV> square{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (size_t p = 0; p < set.patches.size(); ++p)
    set.trims.push_back(Trim({square, ngon(24, 0.5, 0.5, 0.3)}));
  return set;
}

// Curved patches with holes (trim curves of degree 6 on the bicubic patches): the winding
// number and the distance against the dense clipped tessellation of the same trimmed set, away
// from the surface; inside() agrees with the tessellation's exact winding number.
TEST(BoundaryWinding, TrimmedTeapotAgreesWithItsDenseTessellation) {
  const PatchSet set = holed_teapot();
  PatchSurface::Options all_curves;
  all_curves.max_exact_curves = 1000;
  const auto exact = PatchSurface::build(set, all_curves);
  // By default, too many curves for the exact field: the tessellation.
  EXPECT_TRUE(PatchSurface::build(set)->has_tessellation());
  PatchSurface::Options options;
  options.exact_field = false;
  options.field_tessellation = 64;
  const auto dense = PatchSurface::build(set, options);
  ASSERT_FALSE(exact->has_tessellation());
  ASSERT_TRUE(dense->has_tessellation());
  // The teapot's 16 open curves plus 24 hole edges per patch.
  EXPECT_EQ(exact->boundary().curves().size(), 16u + 24u * 32u);
  const MeshSurface& field = dense->field_mesh();
  const float err = dense->field_error();
  std::mt19937 rng(23);
  const Box box = testing::grown(exact->bounds(), 0.3f);
  std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y),
      uz(box.lo.z, box.hi.z);
  double worst_w = 0, worst_d = 0;
  int tested = 0;
  for (int k = 0; k < 600; ++k) {
    const Vec3 p{ux(rng), uy(rng), uz(rng)};
    const float d_ref = field.closest_point(p).distance;
    const float d = std::abs(exact->signed_distance(p));
    worst_d = std::max(worst_d, double(std::abs(d - d_ref)));
    EXPECT_NEAR(d, d_ref, err + 1e-5f) << p.x << " " << p.y << " " << p.z;
    if (d_ref < 20 * err) continue;
    const double w = exact->winding_number(p), ref = field.winding_number_exact(p);
    worst_w = std::max(worst_w, std::abs(w - ref));
    EXPECT_EQ(exact->inside(p), ref >= 0.5) << p.x << " " << p.y << " " << p.z << " w " << w;
    ++tested;
  }
  // The tessellation's chords bend the holes' rims by up to its error: w differs by about
  // that much next to them.
  EXPECT_LT(worst_w, 1e-3);
  EXPECT_GT(tested, 300);
  std::printf(
      "holed teapot: %d points, worst |w - w_tessellation| %.3g, |d - d_tess| %.3g "
      "(tessellation error %.3g)\n",
      tested, worst_w, worst_d, err);
}

// curve_on_patch is the patch along the segment: at random t, for random segments of random
// teapot patches (diagonals in all four directions, and segments along u and along v, whose
// curves have the lower degree), and a whole side gives the border's control points exactly.
TEST(BoundaryWinding, CurvesOnPatchesFollowThePatch) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> unit(0, 1);
  double worst = 0;
  for (int k = 0; k < 600; ++k) {
    const BezierPatch& patch = teapot().patches[rng() % teapot().patches.size()];
    UV a{unit(rng), unit(rng)}, b{unit(rng), unit(rng)};
    if (k % 3 == 1) b.v = a.v;  // along u
    if (k % 3 == 2) b.u = a.u;  // along v
    const BezierCurve c = curve_on_patch(patch, a, b);
    EXPECT_EQ(c.degree, k % 3 == 1 ? patch.du : k % 3 == 2 ? patch.dv : patch.du + patch.dv);
    for (int j = 0; j <= 8; ++j) {
      const double t = j / 8.0;
      // The curve by de Casteljau.
      std::array<DVec3, 7> q = c.cp;
      for (int level = 1; level <= c.degree; ++level)
        for (int i = 0; i + level <= c.degree; ++i)
          q[i] = {q[i].x + (q[i + 1].x - q[i].x) * t, q[i].y + (q[i + 1].y - q[i].y) * t,
                  q[i].z + (q[i + 1].z - q[i].z) * t};
      const DVec3 want = patch.eval(a.u + t * (b.u - a.u), a.v + t * (b.v - a.v));
      worst = std::max(
          {worst, std::abs(q[0].x - want.x), std::abs(q[0].y - want.y), std::abs(q[0].z - want.z)});
    }
  }
  EXPECT_LT(worst, 1e-12);
  const BezierPatch& p = teapot().patches[3];
  const BezierCurve side = curve_on_patch(p, {1, 1}, {0, 1});  // v = 1, u from 1 to 0
  ASSERT_EQ(side.degree, p.du);
  for (int i = 0; i <= p.du; ++i) {
    EXPECT_EQ(side.cp[size_t(i)].x, double(p.control(p.du - i, p.dv).x));
    EXPECT_EQ(side.cp[size_t(i)].z, double(p.control(p.du - i, p.dv).z));
  }
}

// The second-order bound of smooth_change (|grad w(c)| from field(), plus the Hessian's
// bound) holds: around the teapot and the holed teapot (where trim loops and rims lie close),
// w at points within r of a ball's centre, less the facings of the segment from the centre,
// differs from w at the centre by at most the bound (plus w's own quadrature error). And
// field() is w's gradient (central differences).
TEST(BoundaryWinding, SmoothChangeBoundsTheChangeOfTheSmoothPart) {
  PatchSurface::Options all_curves;
  all_curves.max_exact_curves = 1000;
  const auto teapot_surface = PatchSurface::build(teapot());
  const auto holed = PatchSurface::build(holed_teapot(), all_curves);
  for (const PatchSurface* s : {teapot_surface.get(), holed.get()}) {
    const BoundaryCurves& b = s->boundary();
    const Box box = s->bounds();
    const float r = box.max_extent() / 48;
    std::mt19937 rng(31);
    std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y),
        uz(box.lo.z, box.hi.z), unit(-1, 1);
    int balls = 0;
    double worst_ratio = 0, worst_gradient = 0;
    for (int k = 0; k < 4000 && balls < 150; ++k) {
      const Vec3 c{ux(rng), uy(rng), uz(rng)};
      const float d = s->closest_point(c).distance;
      if (d > 3 * r) continue;  // near the surface, where the bound matters
      const double bound = b.smooth_change(to_d(c), r);
      if (!std::isfinite(bound) || bound > 0.45) continue;
      ++balls;
      const double wc = s->exact_winding_number(c);
      for (int j = 0; j < 6; ++j) {
        Vec3 q{unit(rng), unit(rng), unit(rng)};
        q = c + q * (r / std::max(1.0f, length(q)));
        std::vector<Crossing> cr;
        s->crossings_all({c, q - c}, 0, 1, &cr);
        int facings = 0;
        for (const Crossing& x : cr) facings += x.facing;
        const double change = std::abs(s->exact_winding_number(q) - wc - double(facings));
        EXPECT_LE(change, bound + 5e-4) << c.x << " " << c.y << " " << c.z;
        worst_ratio = std::max(worst_ratio, change / (bound + 5e-4));
      }
      if (d > r) {
        // field() against central differences of w (no surface within h).
        double magnitude;
        bool ok;
        const DVec3 g = b.field(to_d(c), &magnitude, &ok);
        ASSERT_TRUE(ok);
        const float h = 0.05f * r;
        double fd[3];
        for (int a = 0; a < 3; ++a) {
          Vec3 p1 = c, p0 = c;
          p1[a] += h, p0[a] -= h;
          fd[a] = (s->exact_winding_number(p1) - s->exact_winding_number(p0)) / (2 * h);
        }
        const double gn = std::sqrt(g.x * g.x + g.y * g.y + g.z * g.z);
        const double fn = std::sqrt(fd[0] * fd[0] + fd[1] * fd[1] + fd[2] * fd[2]);
        // w's quadrature error (~1e-4) over 2h limits the differences' accuracy.
        EXPECT_NEAR(gn, fn, 0.02 * fn + 2e-4 / h) << c.x << " " << c.y << " " << c.z;
        worst_gradient = std::max(worst_gradient, std::abs(gn - fn) / (fn + 1e-9));
      }
    }
    EXPECT_GE(balls, 100);
    std::printf("%s: %d balls, worst change / bound %.3f, worst relative |grad| error %.3g\n",
                s == holed.get() ? "holed teapot" : "teapot", balls, worst_ratio, worst_gradient);
  }
}

// Random trims (one to three loops of 3 to 7 random points: crossing, overlapping, touching
// the square's sides) on a tilted flat patch, where the clipped tessellation is exact (the
// patch is an affine map of the parameter square, and Trim::clip covers the kept region
// exactly): the exact field's w and distance against the tessellation's exact sums.
TEST(BoundaryWinding, RandomTrimsOnAFlatPatchAgreeWithTheExactClippedTessellation) {
  auto plane = [](float u, float v) {
    const float x = -1 + 2 * u + 0.3f * v, y = -1 + 2 * v;
    return Vec3{x, y, 0.2f * x + 0.4f * y - 0.1f};
  };
  const BezierPatch flat = quad(plane(0, 0), plane(1, 0), plane(1, 1), plane(0, 1));
  std::mt19937 rng(37);
  std::uniform_real_distribution<double> unit(0, 1);
  std::uniform_real_distribution<float> coord(-1.6f, 1.6f);
  int sets = 0, points = 0;
  double worst_w = 0, worst_d = 0;
  for (int trial = 0; trial < 60; ++trial) {
    std::vector<std::vector<UV>> loops(1 + rng() % 3);
    for (auto& loop : loops) {
      const int n = 3 + int(rng() % 5);
      for (int k = 0; k < n; ++k) {
        // Now and then on a side of the square or its corner.
        double u = unit(rng), v = unit(rng);
        if (rng() % 6 == 0) u = double(rng() % 2);
        if (rng() % 6 == 0) v = double(rng() % 2);
        loop.push_back({u, v});
      }
    }
    PatchSet set;
    set.patches.push_back(flat);
    set.trims.push_back(Trim(loops));
    PatchSurface::Options all_curves;  // crossing loops split into many pieces
    all_curves.max_exact_curves = 1000;
    const auto exact = PatchSurface::build(set, all_curves);
    PatchSurface::Options options;
    options.exact_field = false;
    options.field_tessellation = 4;
    const auto tess = PatchSurface::build(set, options);
    if (!exact->has_field() || !tess->has_tessellation()) {
      // Nothing kept of positive area: neither has a field.
      EXPECT_EQ(exact->has_field(), tess->has_field()) << trial;
      continue;
    }
    ASSERT_FALSE(exact->has_tessellation()) << trial;
    ++sets;
    const MeshSurface& field = tess->field_mesh();
    for (int k = 0; k < 60; ++k) {
      const Vec3 p{coord(rng), coord(rng), 0.5f * coord(rng)};
      const float d_ref = field.closest_point(p).distance;
      const float d = std::abs(exact->signed_distance(p));
      EXPECT_NEAR(d, d_ref, 2e-5f) << trial << " at " << p.x << " " << p.y << " " << p.z;
      worst_d = std::max(worst_d, double(std::abs(d - d_ref)));
      if (d_ref < 1e-3f) continue;
      const double w = exact->winding_number(p), ref = field.winding_number_exact(p);
      // (~1e-7 measured: 1e-5 also catches a thin sliver of one patch's trim sealed as a
      // crack, which moved w by up to 5.6e-5.)
      EXPECT_NEAR(w, ref, 1e-5) << trial << " at " << p.x << " " << p.y << " " << p.z;
      worst_w = std::max(worst_w, std::abs(w - ref));
      ++points;
    }
  }
  EXPECT_GT(sets, 30);
  std::printf("%d random trims, %d points: worst |w - w_tessellation| %.3g, |d - d_tess| %.3g\n",
              sets, points, worst_w, worst_d);
}

// ---- Sealed cracks (seal_cracks, CrackSet, PatchSurface::Options::seal_tolerance) -----------

namespace sealing {

/// A circle of radius r at height z as four cubic arcs (the standard quarter-circle cubic,
/// within 2.7e-4 r of the circle), counter-clockwise about +z unless `clockwise`.
std::vector<BezierCurve> circle_arcs(double r, double z, bool clockwise) {
  const double k = 0.5522847498 * r;
  std::vector<BezierCurve> arcs;
  for (int q = 0; q < 4; ++q) {
    const double a = q * std::numbers::pi / 2;
    const double c = std::cos(a), s = std::sin(a);
    BezierCurve arc;
    arc.degree = 3;
    // From angle a to a + pi / 2 (rotated from (r, 0) -> (0, r)).
    const double px[4] = {r, r, k, 0}, py[4] = {0, k, r, r};
    for (int i = 0; i < 4; ++i)
      arc.cp[size_t(i)] = {c * px[i] - s * py[i], s * px[i] + c * py[i], z};
    arcs.push_back(arc);
  }
  if (clockwise) {
    std::reverse(arcs.begin(), arcs.end());
    for (BezierCurve& arc : arcs) std::reverse(arc.cp.begin(), arc.cp.begin() + 4);
  }
  return arcs;
}

/// A regular n-gon inscribed in that circle (starting at angle 0: its vertices at the arcs'
/// ends where n is a multiple of 4), as lines, `turns` times around.
std::vector<BezierCurve> polygon(int n, double r, double z, bool clockwise, int turns = 1) {
  std::vector<BezierCurve> edges;
  for (int t = 0; t < turns; ++t)
    for (int i = 0; i < n; ++i) {
      const double a0 = 2 * std::numbers::pi * i / n, a1 = 2 * std::numbers::pi * (i + 1) / n;
      BezierCurve e;
      e.degree = 1;
      e.cp[0] = {r * std::cos(a0), r * std::sin(a0), z};
      e.cp[1] = {r * std::cos(a1), r * std::sin(a1), z};
      if (i + 1 == n) e.cp[1] = {r, 0, z};  // closes exactly
      if (clockwise) std::swap(e.cp[0], e.cp[1]);
      edges.push_back(e);
    }
  return edges;
}

std::vector<BezierCurve> joined(std::vector<BezierCurve> a, const std::vector<BezierCurve>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

}  // namespace sealing

// A circle of cubic arcs against a 64-gon inscribed in it (sagitta 1 - cos(pi / 64) = 1.2e-3,
// the cubic within 2.7e-4 outside the circle): the loops retrace each other the opposite way
// within 1.5e-3, and only that way: the same direction, a polygon lifted off the circle by 5
// tolerances, a polygon that goes round twice, and a tolerance below the gap are left open.
TEST(SealCracks, OnlyLoopsThatRetraceEachOtherTheOtherWay) {
  using namespace sealing;
  const double tol = 3e-3;
  const SealedCracks sealed =
      seal_cracks(joined(circle_arcs(1, 0, false), polygon(64, 1, 0, true)), tol);
  // The polygon's vertices at the arcs' ends are junctions: four pairs of chains (an arc and
  // 16 edges), each between the same two of them.
  EXPECT_EQ(sealed.pairs, 4u);
  EXPECT_EQ(sealed.sealed_curves, 68u);
  EXPECT_TRUE(sealed.open.empty());
  // The widest gap: the polygon's sagitta plus the cubic's excess over the circle, at most.
  const double sagitta = 1 - std::cos(std::numbers::pi / 64);
  EXPECT_GT(sealed.gap, 0.9 * sagitta);
  EXPECT_LT(sealed.gap, sagitta + 2.8e-4);
  // A pair besides two loops that do not pair: all four loops' curves stay open but the pair's.
  const SealedCracks mixed =
      seal_cracks(joined(joined(circle_arcs(1, 0, false), polygon(64, 1, 0, true)),
                         joined(circle_arcs(2, 1, false), polygon(64, 2, 1, false))),
                  tol);
  EXPECT_EQ(mixed.pairs, 4u);
  EXPECT_EQ(mixed.open.size(), 68u);
  // A 63-gon meets the arcs at no vertex but the first: two whole loops (closed chains from
  // that junction), one pair.
  EXPECT_EQ(seal_cracks(joined(circle_arcs(1, 0, false), polygon(63, 1, 0, true)), tol).pairs, 1u);
  // The same in the plane x = 0 (every end at x = 0: the ends are joined through a grid, not
  // a sweep along x), with a 4096-gon.
  std::vector<BezierCurve> upright = joined(circle_arcs(1, 0, false), polygon(4096, 1, 0, true));
  for (BezierCurve& c : upright)
    for (DVec3& q : c.cp) q = {q.z, q.x, q.y};
  const SealedCracks planar = seal_cracks(upright, tol);
  EXPECT_EQ(planar.pairs, 4u);
  EXPECT_EQ(planar.sealed_curves, 4100u);
  // With each curve's patch: loops of different patches pair, loops of one patch (a sliver
  // of its trim) do not.
  const std::vector<BezierCurve> two = joined(circle_arcs(1, 0, false), polygon(63, 1, 0, true));
  std::vector<uint32_t> patches(two.size(), 0);
  EXPECT_EQ(seal_cracks(two, tol, patches).pairs, 0u);
  for (size_t i = 4; i < patches.size(); ++i) patches[i] = 1;
  EXPECT_EQ(seal_cracks(two, tol, patches).pairs, 1u);
  const struct {
    const char* name;
    std::vector<BezierCurve> curves;
    double tolerance;
  } open_cases[] = {
      {"same direction", joined(circle_arcs(1, 0, false), polygon(64, 1, 0, false)), tol},
      {"lifted", joined(circle_arcs(1, 0, false), polygon(64, 1, 5 * tol, true)), tol},
      {"twice round", joined(circle_arcs(1, 0, false), polygon(64, 1, 0, true, 2)), tol},
      {"below the gap", joined(circle_arcs(1, 0, false), polygon(64, 1, 0, true)), 0.5 * sagitta},
  };
  for (const auto& c : open_cases) {
    SCOPED_TRACE(c.name);
    const SealedCracks s = seal_cracks(c.curves, c.tolerance);
    EXPECT_EQ(s.pairs, 0u);
    EXPECT_EQ(s.open.size(), c.curves.size());
  }
}

// CrackSet::near and distance against brute force: the distance from random points and
// random segments to the capsules' axes sampled densely.
TEST(SealCracks, CrackSetAgreesWithBruteForce) {
  using namespace sealing;
  const std::vector<BezierCurve> loop = circle_arcs(1, 0, false);
  const double radius = 0.05;
  const CrackSet cracks = CrackSet::build(loop, radius);
  // The circle densely (the capsules' axes lie within radius / 4 of it).
  std::vector<DVec3> pts;
  for (int i = 0; i < 20000; ++i) {
    const double a = 2 * std::numbers::pi * i / 20000;
    pts.push_back({std::cos(a), std::sin(a), 0});
  }
  auto dist = [](const DVec3& a, const DVec3& b) {
    return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                     (a.z - b.z) * (a.z - b.z));
  };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.3, 1.3), h(-0.2, 0.2);
  int near = 0, far = 0;
  for (int k = 0; k < 3000; ++k) {
    const DVec3 p{u(rng), u(rng), h(rng)};
    double to_circle = 1e30;
    for (const DVec3& q : pts) to_circle = std::min(to_circle, dist(p, q));
    // distance(): a lower bound of the distance to the capsules (the axes are within
    // radius / 4 of the circle, plus the samples' spacing).
    const double d = cracks.distance(p, 10);
    EXPECT_LE(d, std::max(0.0, to_circle - radius) + 0.25 * radius + 1e-3) << k;
    EXPECT_GE(d, std::max(0.0, to_circle - radius) - 0.25 * radius - 1e-3) << k;
    // near(): a segment from p to a random end, against the circle's samples' distance to it.
    const DVec3 e{u(rng), u(rng), h(rng)};
    const DVec3 dir{e.x - p.x, e.y - p.y, e.z - p.z};
    double seg = 1e30;
    for (const DVec3& q : pts) {
      const double len2 = dir.x * dir.x + dir.y * dir.y + dir.z * dir.z;
      const double t = std::clamp(
          ((q.x - p.x) * dir.x + (q.y - p.y) * dir.y + (q.z - p.z) * dir.z) / len2, 0.0, 1.0);
      seg = std::min(seg, dist(q, {p.x + t * dir.x, p.y + t * dir.y, p.z + t * dir.z}));
    }
    if (seg < radius - 0.25 * radius - 1e-3) {
      EXPECT_TRUE(cracks.near(p, dir, 1.0)) << k;
      ++near;
    } else if (seg > radius + 0.25 * radius + 1e-3) {
      EXPECT_FALSE(cracks.near(p, dir, 1.0)) << k;
      ++far;
    }
    // The same segment as a ray (to infinity) passes at least as near.
    if (cracks.near(p, dir, 1.0)) {
      EXPECT_TRUE(cracks.near(p, dir, std::numeric_limits<double>::infinity()));
    }
  }
  EXPECT_GT(near, 300);
  EXPECT_GT(far, 300);
}

// The trimmed cup (examples/data/trimmed_cup.bpt): each flat part's trim polygon (128 edges
// per full circle) retraces a wall's cubic rim the opposite way, so its 528 border curves all
// seal, in 13 pairs (the rim arcs end at four of each polygon's vertices: chains between
// those junctions, and one pair of whole loops), and the sealed cup's winding number is the
// open cup's away from the cracks: equal sides, and w within the cracks' own solid angle
// (a strip of width g along the four circles: at most g x length / (4 pi d^2) at distance d
// from them); inside a crack, where every ray passes by it, the open cup's own value. The
// teapot has no crack to seal.
TEST(SealCracks, TheCupSealsAndAgreesWithTheOpenCupAwayFromItsCracks) {
  Result<PatchSet> set = load_bpt(std::string(HFRT_SOURCE_DIR) + "/examples/data/trimmed_cup.bpt");
  ASSERT_TRUE(set.ok()) << set.error().message;
  const auto sealed = PatchSurface::build(*set);
  ASSERT_FALSE(sealed->has_tessellation());
  EXPECT_TRUE(sealed->boundary().curves().empty());
  EXPECT_EQ(sealed->stats().sealed_curves, 528u);
  EXPECT_GT(sealed->stats().crack_gap, 2e-4);
  EXPECT_LT(sealed->stats().crack_gap, 1e-3);
  PatchSurface::Options open_options;
  open_options.seal_tolerance = 0;
  open_options.max_exact_curves = 1000;
  const auto open = PatchSurface::build(*set, open_options);
  ASSERT_FALSE(open->has_tessellation());
  EXPECT_EQ(open->boundary().curves().size(), 528u);
  EXPECT_EQ(open->stats().sealed_curves, 0u);
  const SealedCracks teapot_cracks = seal_cracks(BoundaryCurves::build(teapot()).curves(), 0.05);
  EXPECT_EQ(teapot_cracks.pairs, 0u);

  // The four circles (radius, height) the cracks run along.
  const double circles[4][2] = {{1, -1}, {1, 1}, {0.8, 1}, {0.8, -0.6}};
  const double length = 2 * std::numbers::pi * (1 + 1 + 0.8 + 0.8);
  const double gap = sealed->stats().crack_gap;
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(-1.3f, 1.3f), angle(0, 6.2831853f), off(-0.05f, 0.05f);
  int compared = 0;
  double worst = 0;
  for (int k = 0; k < 3000; ++k) {
    Vec3 p{u(rng), u(rng), u(rng)};
    if (k % 2 == 1) {  // near a rim
      const double* c = circles[k / 2 % 4];
      const float a = angle(rng);
      p = {float(c[0]) * std::cos(a) + off(rng), float(c[0]) * std::sin(a) + off(rng),
           float(c[1]) + off(rng)};
    }
    double d = 1e30;
    for (const auto& c : circles) {
      const double rho = std::hypot(double(p.x), double(p.y));
      d = std::min(d, std::hypot(rho - c[0], double(p.z) - c[1]));
    }
    if (d < 2e-3) continue;
    const double ws = sealed->exact_winding_number(p), wo = open->exact_winding_number(p);
    const double bound = gap * length / (4 * std::numbers::pi * d * d) + 2e-4;
    EXPECT_LE(std::abs(ws - wo), bound) << p.x << " " << p.y << " " << p.z;
    worst = std::max(worst, std::abs(ws - wo) / bound);
    EXPECT_EQ(sealed->inside(p), open->inside(p)) << p.x << " " << p.y << " " << p.z;
    // Sealed, the winding number is an integer (no boundary left) off the cracks.
    if (d > 0.05) {
      EXPECT_NEAR(ws, std::round(ws), 1e-9) << p.x << " " << p.y << " " << p.z;
    }
    ++compared;
  }
  EXPECT_GT(compared, 2500);
  std::printf("sealed cup: %d points, worst |w change| / bound %.3g\n", compared, worst);
  // Inside the crack under the base (between the polygon's edge midpoint, at radius
  // cos(pi / 128), and the cubic rim outside the circle): the open cup's own value.
  for (int i = 0; i < 8; ++i) {
    const double a = 2 * std::numbers::pi * (i + 0.5) / 128 + (i / 2) * std::numbers::pi / 2;
    const double r = 0.5 * (std::cos(std::numbers::pi / 128) + 1);
    const Vec3 p{float(r * std::cos(a)), float(r * std::sin(a)), -1.0f};
    EXPECT_EQ(sealed->exact_winding_number(p), open->exact_winding_number(p)) << i;
  }
}

}  // namespace
}  // namespace hfrt::geom
