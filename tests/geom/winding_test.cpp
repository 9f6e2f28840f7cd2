// Winding numbers against crossing parity, and the signed distance against brute force.

#include <gtest/gtest.h>

#include <random>
#include <thread>

#include "geom/mesh_surface.h"
#include "geom/triangle.h"
#include "test_meshes.h"

namespace hfrt::geom {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Inside by parity: the number of crossings of a ray from p, in a random direction.
bool inside_by_parity(const MeshSurface& s, Vec3 p, std::mt19937& rng) {
  std::vector<Crossing> cr;
  s.crossings({p, testing::random_direction(rng)}, 0, kInf, &cr);
  return cr.size() % 2 == 1;
}

TEST(Winding, HeightfieldBoxIsOneInsideZeroOutside) {
  const auto s = MeshSurface::build(testing::heightfield_box(12, 1));
  // The hierarchical sum is first order (dipoles) in the far field: within 0.1 at beta = 2.
  EXPECT_NEAR(s->winding_number({6, 6, 2}), 1.0, 0.1);
  EXPECT_NEAR(s->winding_number({6, 6, -2}), 0.0, 0.1);
  EXPECT_NEAR(s->winding_number({6, 6, 12}), 0.0, 0.1);
  EXPECT_NEAR(s->winding_number({100, 6, 2}), 0.0, 1e-3);
  EXPECT_NEAR(s->winding_number_exact({6, 6, 2}), 1.0, 1e-9);
  EXPECT_NEAR(s->winding_number_exact({6, 6, 12}), 0.0, 1e-9);
}

TEST(Winding, ArmadilloWindingAgreesWithCrossingParity) {
  const MeshSurface& s = testing::armadillo_surface();
  std::mt19937 rng(77);
  const Box box = testing::grown(s.bounds(), 0.05f);
  int inside = 0, n = 4000;
  for (int i = 0; i < n; ++i) {
    const Vec3 p = testing::random_point(rng, box);
    const double w = s.winding_number(p);
    const bool parity = inside_by_parity(s, p, rng);
    ASSERT_EQ(w >= 0.5, parity) << "p=(" << p.x << "," << p.y << "," << p.z << ") w=" << w;
    // Closed mesh: the winding number is an integer up to the far-field approximation.
    EXPECT_NEAR(w, parity ? 1.0 : 0.0, 0.1);
    inside += parity;
  }
  EXPECT_GT(inside, n / 20);  // enough points inside for the test to mean something
}

// inside() answers points of cells that no triangle's box meets from one winding number per
// cell: on a closed mesh (a constant winding number there) it is the point's own side, for
// points far from, near and on the surface, asked from two threads at once; the cells it made
// count in memory_bytes().
TEST(Winding, InsideFromTheCellGridIsThePointsSideOnAClosedMesh) {
  const std::unique_ptr<MeshSurface> s = MeshSurface::build(testing::armadillo());
  const size_t before = s->memory_bytes();
  const TriangleMesh& mesh = testing::armadillo();
  std::mt19937 rng(12);
  const Box box = testing::grown(s->bounds(), 0.1f);
  std::vector<Vec3> points;
  for (int i = 0; i < 6000; ++i) {
    Vec3 p = testing::random_point(rng, box);
    if (i % 3 == 0) {  // next to the surface
      p = mesh.vertices[mesh.triangles[rng() % mesh.triangles.size()][0]] +
          testing::random_direction(rng) * (0.01f + 2.0f * float(i % 7));
    }
    points.push_back(p);
  }
  std::vector<int> side(points.size());
  std::thread other([&] {
    for (size_t i = 0; i < points.size(); i += 2) side[i] = s->inside(points[i]);
  });
  for (size_t i = 1; i < points.size(); i += 2) side[i] = s->inside(points[i]);
  other.join();
  int inside = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3 p = points[i];
    ASSERT_EQ(side[i] != 0, s->winding_number(p) >= 0.5)
        << "p=(" << p.x << "," << p.y << "," << p.z << ")";
    EXPECT_EQ(s->signed_distance(p) > 0, side[i] != 0);
    inside += side[i];
  }
  EXPECT_GT(inside, 300);
  EXPECT_GT(s->memory_bytes(), before);  // the cells, made on first use
}

TEST(Winding, HierarchicalConvergesToTheExactSum) {
  // The far-field dipole error shrinks as the acceptance ratio beta grows (measured on the
  // armadillo: 0.08 at beta = 2, 0.03 at 3, 0.017 at 4).
  std::mt19937 rng(5);
  const Box box = testing::grown(testing::armadillo_surface().bounds(), 0.3f);
  std::vector<Vec3> points;
  for (int i = 0; i < 100; ++i) points.push_back(testing::random_point(rng, box));
  double previous = 1;
  for (double beta : {2.0, 4.0, 8.0}) {
    MeshSurface::Options o;
    o.winding_beta = beta;
    const auto s = MeshSurface::build(testing::armadillo(), o);
    double worst = 0;
    for (Vec3 p : points)
      worst = std::max(worst, std::abs(s->winding_number(p) - s->winding_number_exact(p)));
    EXPECT_LT(worst, 0.2 / beta) << "beta " << beta;
    EXPECT_LT(worst, previous) << "beta " << beta;
    previous = worst;
  }
}

// The hierarchical sum (4-wide, float far field) on an open surface, next to it and away
// from it: within the dipoles' error of the exact sum, and on the exact sum's side of 1/2
// wherever that is more than the error away. The armadillo with its top cut off (an open
// surface whose winding number takes every value between 0 and 1 near the cut).
TEST(Winding, HierarchicalMatchesTheExactSumOnAnOpenMesh) {
  const TriangleMesh& full = testing::armadillo();
  const Box fb = full.bounds();
  const float cut = fb.lo.y + 0.7f * (fb.hi.y - fb.lo.y);
  TriangleMesh open = full;
  open.triangles.clear();
  for (size_t i = 0; i < full.triangles.size(); ++i) {
    if (full.corner(i, 0).y < cut || full.corner(i, 1).y < cut || full.corner(i, 2).y < cut)
      open.triangles.push_back(full.triangles[i]);
  }
  ASSERT_LT(open.triangles.size(), full.triangles.size() * 9 / 10);
  const auto s = MeshSurface::build(open);
  EXPECT_FALSE(s->topology().closed);
  std::mt19937 rng(31);
  const Box box = testing::grown(s->bounds(), 0.1f);
  double worst = 0;
  int fractional = 0;
  for (int i = 0; i < 600; ++i) {
    // A third next to the surface (a vertex plus a small offset), a third near the cut.
    Vec3 p = testing::random_point(rng, box);
    if (i % 3 == 0) {
      p = open.vertices[open.triangles[rng() % open.triangles.size()][0]] +
          testing::random_direction(rng) * 0.3f;
    } else if (i % 3 == 1) {
      p.y = cut + (p.y - box.lo.y) / (box.hi.y - box.lo.y) * 20 - 10;
    }
    const double w = s->winding_number(p), exact = s->winding_number_exact(p);
    worst = std::max(worst, std::abs(w - exact));
    if (std::abs(exact - 0.5) > 0.1) {
      EXPECT_EQ(w >= 0.5, exact >= 0.5) << "p=(" << p.x << "," << p.y << "," << p.z << ")";
    }
    fractional += std::abs(exact - std::round(exact)) > 0.1;
  }
  EXPECT_LT(worst, 0.1);
  EXPECT_GT(fractional, 50);  // the open part was reached
}

// The near field alone (beta so large that no node is far): every triangle's solid angle in
// the hierarchy's float lanes against the exact sum in double, at points on every side of the
// open armadillo's triangles, some of them a thousandth of a triangle away.
TEST(Winding, NearFieldTrianglesInFloatMatchTheExactSum) {
  MeshSurface::Options o;
  o.winding_beta = 1e9;
  const TriangleMesh& m = testing::armadillo();
  const auto s = MeshSurface::build(m, o);
  std::mt19937 rng(12);
  const Box box = testing::grown(s->bounds(), 0.2f);
  double worst = 0;
  for (int i = 0; i < 60; ++i) {
    Vec3 p = testing::random_point(rng, box);
    if (i % 2 == 0) {
      // Next to a triangle's centre, off its plane by 1e-3 of its size.
      const size_t t = rng() % m.triangles.size();
      const Vec3 a = m.corner(t, 0), b = m.corner(t, 1), c = m.corner(t, 2);
      const Vec3 n = cross(b - a, c - a);
      p = (a + b + c) / 3.0f + n / length(n) * (1e-3f * length(b - a)) * (i % 4 ? 1.0f : -1.0f);
    }
    worst = std::max(worst, std::abs(s->winding_number(p) - s->winding_number_exact(p)));
  }
  EXPECT_LT(worst, 1e-5);
}

// The hierarchy's float arithmetic works in units of the mesh's size (a power of two): the
// armadillo scaled by 2^-64 (coordinates ~1e-18, cubed distances ~1e-54, below float's range)
// and by 2^64 (areas ~1e42, above it) has, at the same scaled points, the winding numbers of
// the armadillo itself up to the dipoles' error (the BVH's SAH, in float, is not the same
// tree at those scales) and the same sides.
TEST(Winding, MeshesOfAnySizeHaveTheSameWindingNumbers) {
  const TriangleMesh& m = testing::armadillo();
  const MeshSurface& s = testing::armadillo_surface();
  std::mt19937 rng(3);
  std::vector<Vec3> points;
  const Box box = testing::grown(s.bounds(), 0.3f);
  for (int i = 0; i < 200; ++i) {
    // Half of them next to the surface (a vertex plus a small offset): about half inside.
    points.push_back(i % 2 ? testing::random_point(rng, box)
                           : m.vertices[rng() % m.vertices.size()] +
                                 testing::random_direction(rng) * 0.7f);
  }
  for (const float scale : {std::ldexp(1.0f, -64), std::ldexp(1.0f, 64)}) {
    TriangleMesh scaled = m;
    for (Vec3& v : scaled.vertices) v = v * scale;
    const auto t = MeshSurface::build(scaled);
    int inside = 0;
    for (const Vec3 p : points) {
      const double w = s.winding_number(p), ws = t->winding_number(p * scale);
      ASSERT_NEAR(ws, w, 0.15) << "scale " << scale;
      ASSERT_EQ(ws >= 0.5, w >= 0.5) << "scale " << scale;
      inside += w >= 0.5;
    }
    EXPECT_GT(inside, 10);
  }
}

// Brute-force distance: every triangle.
float brute_distance(const TriangleMesh& m, Vec3 p) {
  float best = kInf;
  for (size_t i = 0; i < m.triangles.size(); ++i)
    best = std::min(
        best,
        length(closest_point_on_triangle(p, m.corner(i, 0), m.corner(i, 1), m.corner(i, 2)) - p));
  return best;
}

TEST(SignedDistance, ArmadilloEqualsBruteForce) {
  const TriangleMesh& m = testing::armadillo();
  const MeshSurface& s = testing::armadillo_surface();
  std::mt19937 rng(99);
  const Box box = testing::grown(s.bounds(), 0.2f);
  for (int i = 0; i < 400; ++i) {
    // Half the points near the surface (a vertex plus a small offset).
    Vec3 p = i % 2 ? testing::random_point(rng, box)
                   : m.vertices[rng() % m.vertices.size()] + testing::random_direction(rng) * 0.7f;
    const float d = brute_distance(m, p);
    const bool inside = inside_by_parity(s, p, rng);
    Vec3 g;
    const float sd = s.signed_distance(p, &g);
    ASSERT_NEAR(std::abs(sd), d, 1e-5f * (1 + d)) << i;
    ASSERT_EQ(sd >= 0, inside) << i << " d=" << d;
    // The gradient is unit and points away from the closest point (inside) or towards it.
    EXPECT_NEAR(length(g), 1.0f, 1e-4f);
    const ClosestPoint c = s.closest_point(p);
    EXPECT_NEAR(length(c.point - p), d, 1e-5f * (1 + d));
    if (d > 1e-3f) {
      const Vec3 towards = normalize(c.point - p);
      EXPECT_NEAR(dot(g, towards), inside ? -1.0f : 1.0f, 1e-3f);
    }
  }
}

// closest_point and distance_lower_bound walk the 4-wide tree: the same distances as the
// binary walk (closest_point_binary) and as brute force over the triangles' boxes, with and
// without a search limit.
TEST(SignedDistance, WideDistanceQueriesEqualTheBinaryWalkAndBruteForce) {
  const TriangleMesh& m = testing::armadillo();
  const MeshSurface& s = testing::armadillo_surface();
  std::mt19937 rng(41);
  const Box box = testing::grown(s.bounds(), 0.2f);
  int limited = 0;
  for (int i = 0; i < 300; ++i) {
    const Vec3 p =
        i % 2 ? testing::random_point(rng, box)
              : m.vertices[rng() % m.vertices.size()] + testing::random_direction(rng) * 0.5f;
    for (const float limit : {std::numeric_limits<float>::infinity(), 1.0f, 0.3f}) {
      const ClosestPoint w = s.closest_point(p, limit), b = s.closest_point_binary(p, limit);
      ASSERT_EQ(w.prim == ~0u, b.prim == ~0u) << i;
      if (w.prim == ~0u) continue;
      EXPECT_EQ(w.distance, b.distance) << i;
      limited += limit < 1e30f;
    }
    // A box around p: the distance to the nearest triangle's box, by brute force.
    const Vec3 half{0.5f * float(i % 5), 0.3f, 0.2f * float(i % 3)};
    const Box q(p - half, p + half);
    float best = std::numeric_limits<float>::infinity();
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      Box tb;
      for (int k = 0; k < 3; ++k) tb.extend(m.corner(t, k));
      best = std::min(best, tb.distance2(q));
    }
    const float want = best == 0 ? 0.0f : std::sqrt(best) * (1.0f - 1e-6f);
    EXPECT_EQ(s.distance_lower_bound(q), want) << i;
  }
  EXPECT_GT(limited, 100);  // the limited searches found points
}

TEST(SignedDistance, GradientMatchesFiniteDifferences) {
  const MeshSurface& s = testing::armadillo_surface();
  std::mt19937 rng(4);
  const Box box = testing::grown(s.bounds(), 0.1f);
  int good = 0, n = 300;
  const float h = 1e-2f;
  for (int i = 0; i < n; ++i) {
    const Vec3 p = testing::random_point(rng, box);
    Vec3 g;
    const float f = s.signed_distance(p, &g);
    const float f2 = s.signed_distance(p + g * h);
    // Along its gradient a distance field grows at rate 1 (off the medial axis).
    good += std::abs((f2 - f) / h - 1.0f) < 0.05f;
  }
  EXPECT_GT(good, n * 9 / 10);
}

/// Checks that `s`'s bounds over `b` hold F at 20 random points of it; true when they give F
/// one sign over the box.
bool bounds_enclose_samples(const MeshSurface& s, const Box& b, std::mt19937& rng, int i) {
  const DistanceBounds db = s.signed_distance_bounds(b);
  EXPECT_LE(db.lo, db.hi) << "box " << i;
  for (int k = 0; k < 20; ++k) {
    const Vec3 p = testing::random_point(rng, b);
    const float f = s.signed_distance(p);
    EXPECT_GE(f, db.lo) << "box " << i;
    EXPECT_LE(f, db.hi) << "box " << i;
  }
  return db.lo > 0 || db.hi < 0;
}

TEST(SignedDistance, BoxBoundsEncloseSamples) {
  const MeshSurface& s = testing::armadillo_surface();
  std::mt19937 rng(8);
  const Box box = testing::grown(s.bounds(), 0.2f);
  const float scale = box.diagonal().x;
  int constant_sign = 0;
  for (int i = 0; i < 300; ++i) {
    const Vec3 c = testing::random_point(rng, box);
    const float half = scale * std::pow(2.0f, -2.0f - static_cast<float>(i % 8));
    const Box b{c - Vec3{half, half, half}, c + Vec3{half, half, half}};
    constant_sign += bounds_enclose_samples(s, b, rng, i);
  }
  EXPECT_GT(constant_sign, 50);  // small boxes away from the surface get one sign
}

// Boxes that no triangle's box meets take their upper bound from a corner of the nearest
// triangle rather than from a closest-point search at the centre (a hundred nodes for a far
// box): still an enclosure, still decided, for boxes of every size around and inside the mesh.
TEST(SignedDistance, BoundsOfBoxesApartFromTheMeshEncloseAndDecide) {
  const MeshSurface& s = testing::armadillo_surface();
  std::mt19937 rng(21);
  const Box around = testing::grown(s.bounds(), 1.5f);
  const float scale = s.bounds().diagonal().x;
  int apart = 0, decided = 0;
  for (int i = 0; i < 400; ++i) {
    const Vec3 c = testing::random_point(rng, around);
    const float half = scale * std::pow(2.0f, -1.0f - static_cast<float>(i % 7));
    const Box b{c - Vec3{half, half, half}, c + Vec3{half, half, half}};
    if (!(s.distance_lower_bound(b) > 0)) continue;
    ++apart;
    decided += bounds_enclose_samples(s, b, rng, i);
  }
  EXPECT_GT(apart, 100);
  EXPECT_EQ(decided, apart);  // apart from every triangle: one sign over the box
}

TEST(Winding, OpenMeshHasAFractionalWindingNumber) {
  // One triangle: 0 far away, +-1/2 just behind / in front of its centre.
  const double v[] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const double t[] = {1, 2, 3};
  auto s = MeshSurface::build(mesh_from_arrays(v, t).value());
  EXPECT_NEAR(s->winding_number({0.25f, 0.25f, -1e-4f}), 0.5, 1e-3);
  EXPECT_NEAR(s->winding_number({0.25f, 0.25f, 1e-4f}), -0.5, 1e-3);
  EXPECT_NEAR(s->winding_number({50, 50, 50}), 0.0, 1e-4);
  // A single leaf (no wide BVH): rays still work.
  SurfaceHit h;
  ASSERT_TRUE(s->intersect({{0.25f, 0.25f, 1}, {0, 0, -1}}, 0, kInf, &h));
  EXPECT_FLOAT_EQ(h.t, 1.0f);
  EXPECT_FLOAT_EQ(h.normal.z, 1.0f);
  std::vector<Crossing> cr;
  s->crossings({{0.25f, 0.25f, 1}, {0, 0, -1}}, 0, kInf, &cr);
  ASSERT_EQ(cr.size(), 1u);
  EXPECT_EQ(cr[0].facing, 1);
  s->crossings({{0.75f, 0.75f, 1}, {0, 0, -1}}, 0, kInf, &cr);
  EXPECT_TRUE(cr.empty());
}

TEST(Topology, ClosedMeshesAreClosedAndHolesAreCounted) {
  // The heightfield box and the armadillo are closed; the vertices are matched by coordinates,
  // so the same box with every triangle's corners repeated (as STL stores them) is too.
  EXPECT_TRUE(MeshSurface::build(testing::heightfield_box(6, 3))->topology().closed);
  EXPECT_TRUE(testing::armadillo_surface().topology().closed);
  const TriangleMesh box = testing::heightfield_box(4, 5);
  std::vector<double> v, t;
  for (size_t i = 0; i < box.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const Vec3 c = box.corner(i, k);
      v.insert(v.end(), {c.x, c.y, c.z});
      t.push_back(double(v.size() / 3));
    }
  const SurfaceTopology soup = MeshSurface::build(mesh_from_arrays(v, t).value())->topology();
  EXPECT_TRUE(soup.closed);
  EXPECT_EQ(soup.boundary_edges, 0u);
  // Without its first two triangles (one top quad): a hole of four edges.
  TriangleMesh holed = box;
  holed.triangles.erase(holed.triangles.begin(), holed.triangles.begin() + 2);
  const SurfaceTopology open = MeshSurface::build(holed)->topology();
  EXPECT_FALSE(open.closed);
  EXPECT_EQ(open.boundary_edges, 4u);
  // One triangle turned over: its three edges meet partners going the same way.
  TriangleMesh flipped = box;
  std::swap(flipped.triangles[7][1], flipped.triangles[7][2]);
  const SurfaceTopology inconsistent = MeshSurface::build(flipped)->topology();
  EXPECT_FALSE(inconsistent.closed);
  EXPECT_EQ(inconsistent.boundary_edges, 6u);  // its three and their three partners
}

TEST(Topology, ClosestPointCarriesTheFaceNormal) {
  // Just outside the middle of each triangle, the closest point lies on that triangle and its
  // normal is the triangle's own (outward, unit), on the walls and the bottom as on the top.
  const TriangleMesh m = testing::heightfield_box(3, 1);
  auto s = MeshSurface::build(m);
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const Vec3 a = m.corner(i, 0), b = m.corner(i, 1), c = m.corner(i, 2);
    const Vec3 n = normalize(cross(b - a, c - a));
    const ClosestPoint cp = s->closest_point((a + b + c) / 3.0f + n * 1e-3f);
    ASSERT_NE(cp.prim, ~0u);
    EXPECT_NEAR(dot(cp.normal, n), 1.0f, 1e-5f) << "triangle " << i;
    EXPECT_NEAR(length(cp.normal), 1.0f, 1e-6f);
  }
}

}  // namespace
}  // namespace hfrt::geom
