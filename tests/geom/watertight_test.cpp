// Watertightness: no ray slips between triangles that share an edge or a vertex, and a ray
// through an edge or a vertex counts exactly once (symbolic tie-breaking), so every ray from
// outside a closed mesh has an even number of crossings alternating enter / exit.

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "geom/mesh_surface.h"
#include "geom/triangle.h"
#include "test_meshes.h"

namespace hfrt::geom {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

int count_hits(const Ray& ray, const std::vector<std::array<Vec3, 3>>& tris) {
  const WatertightRay r(ray);
  int n = 0;
  for (const auto& t : tris) {
    TriangleHitInfo h;
    n += intersect_triangle(r, t[0], t[1], t[2], 0, kInf, &h);
  }
  return n;
}

TEST(TriangleKernel, FacingAndBarycentrics) {
  const Vec3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};  // normal +z
  TriangleHitInfo h;
  ASSERT_TRUE(
      intersect_triangle(WatertightRay({{0.25f, 0.5f, 2}, {0, 0, -1}}), a, b, c, 0, kInf, &h));
  EXPECT_EQ(h.facing, 1);  // against the normal: entering
  EXPECT_FLOAT_EQ(h.t, 2);
  EXPECT_FLOAT_EQ(h.b1, 0.25f);
  EXPECT_FLOAT_EQ(h.b2, 0.5f);
  ASSERT_TRUE(
      intersect_triangle(WatertightRay({{0.25f, 0.5f, -2}, {0, 0, 3}}), a, b, c, 0, kInf, &h));
  EXPECT_EQ(h.facing, -1);
  EXPECT_FLOAT_EQ(h.t, 2.0f / 3);
  EXPECT_FALSE(
      intersect_triangle(WatertightRay({{0.75f, 0.5f, 2}, {0, 0, -1}}), a, b, c, 0, kInf, &h));
  EXPECT_FALSE(
      intersect_triangle(WatertightRay({{0.25f, 0.5f, 2}, {0, 0, -1}}), a, b, c, 0, 1.5f, &h));
}

TEST(TriangleKernel, SharedEdgeAndVertexCountOnce) {
  // A fan of 6 triangles around (0,0,0) in the plane z = 0 (a hexagon), consistently oriented.
  std::vector<std::array<Vec3, 3>> fan;
  const Vec3 ring[6] = {{2, 0, 0}, {1, 2, 0}, {-1, 2, 0}, {-2, 0, 0}, {-1, -2, 0}, {1, -2, 0}};
  for (int k = 0; k < 6; ++k) fan.push_back({Vec3{0, 0, 0}, ring[k], ring[(k + 1) % 6]});
  for (Vec3 dir : {Vec3{0, 0, -1}, Vec3{0, 0, 1}, Vec3{0.25f, 0.5f, -1}, Vec3{-0.5f, 0.125f, 1}}) {
    auto through = [&](Vec3 p) { return Ray{p - dir * 4.0f, dir}; };
    EXPECT_EQ(count_hits(through({0, 0, 0}), fan), 1) << "centre vertex";
    EXPECT_EQ(count_hits(through({1, 0, 0}), fan), 1) << "edge to (2,0)";
    EXPECT_EQ(count_hits(through({0.5f, 1, 0}), fan), 1) << "edge to (1,2)";
    EXPECT_EQ(count_hits(through({-1, 0, 0}), fan), 1) << "edge to (-2,0)";
    EXPECT_EQ(count_hits(through({-0.5f, -1, 0}), fan), 1) << "edge to (-1,-2)";
    EXPECT_EQ(count_hits(through({-1, -1, 0}), fan), 1) << "interior";
  }
  // The opposite orientation (the other side of a closed surface) behaves the same.
  for (auto& t : fan) std::swap(t[1], t[2]);
  EXPECT_EQ(count_hits({{0, 0, 5}, {0, 0, -1}}, fan), 1);
  EXPECT_EQ(count_hits({{1, 0, 5}, {0, 0, -1}}, fan), 1);
}

TEST(TriangleKernel, SilhouetteEdgeCountsZeroOrTwice) {
  // A wedge: two triangles folded over a shared edge on the x = 0 line, both on the x >= 0
  // side (one below, one above). A ray down through the edge touches the surface: it must not
  // count one crossing.
  std::vector<std::array<Vec3, 3>> wedge = {{Vec3{0, 0, 0}, Vec3{0, 4, 0}, Vec3{2, 0, -1}},
                                            {Vec3{0, 4, 0}, Vec3{0, 0, 0}, Vec3{2, 0, 1}}};
  for (float y : {0.0f, 1.0f, 2.0f, 4.0f}) {
    const int n = count_hits({{0, y, 5}, {0, 0, -1}}, wedge);
    EXPECT_EQ(n % 2, 0) << "y=" << y << " hits " << n;
  }
  // Seen along x the same edge is a regular one (the triangles project to both sides of it):
  // exactly one of the two is hit.
  EXPECT_EQ(count_hits({{-5, 1, 0}, {1, 0, 0}}, wedge), 1);
}

void expect_alternating(const std::vector<Crossing>& c, const std::string& what) {
  ASSERT_EQ(c.size() % 2, 0u) << what;
  for (size_t k = 0; k < c.size(); ++k)
    ASSERT_EQ(c[k].facing, k % 2 == 0 ? 1 : -1) << what << " crossing " << k;
}

TEST(Watertight, MillionRandomRaysThroughTheArmadillo) {
  const MeshSurface& s = testing::armadillo_surface();
  const Box box = s.bounds();
  const Vec3 c = box.center();
  const float radius = length(box.diagonal());
  std::mt19937 rng(10);
  std::vector<Crossing> cr;
  long entered = 0;
  for (int i = 0; i < 1000000; ++i) {
    // From a sphere around the mesh towards a random point of its box.
    const Vec3 org = c + testing::random_direction(rng) * radius;
    const Ray ray{org, testing::random_point(rng, box) - org};
    s.crossings(ray, 0, kInf, &cr);
    if (cr.size() % 2 != 0 || (!cr.empty() && cr[0].facing != 1)) {
      expect_alternating(cr, "random ray " + std::to_string(i));
      FAIL();
    }
    for (size_t k = 0; k < cr.size(); ++k)
      if (cr[k].facing != (k % 2 == 0 ? 1 : -1)) FAIL() << "ray " << i << " crossing " << k;
    entered += !cr.empty();
  }
  EXPECT_GT(entered, 300000);  // most rays do enter: the test is not vacuous
}

TEST(Watertight, AxisRaysExactlyThroughArmadilloVertices) {
  const TriangleMesh& m = testing::armadillo();
  const MeshSurface& s = testing::armadillo_surface();
  const Box box = s.bounds();
  std::vector<Crossing> cr;
  int entered = 0;
  for (size_t v = 0; v < m.vertices.size(); ++v) {
    const Vec3 p = m.vertices[v];
    for (int axis = 0; axis < 3; ++axis) {
      // org differs from p only along `axis`: the ray passes exactly through the vertex.
      Vec3 org = p, dir{0, 0, 0};
      org[axis] = box.lo[axis] - 10;
      dir[axis] = 1;
      s.crossings({org, dir}, 0, kInf, &cr);
      expect_alternating(cr, "vertex " + std::to_string(v) + " axis " + std::to_string(axis));
      if (::testing::Test::HasFatalFailure()) return;
      entered += !cr.empty();
    }
  }
  // A ray through a vertex meets the surface there: only silhouette vertices may be touched
  // without a crossing.
  EXPECT_GT(entered, static_cast<int>(3 * m.vertices.size() * 9 / 10));
}

/// The top surface of heightfield_box(n) above half-grid point (i/2, j/2), i, j in [0, 2n]: a
/// vertex (both even) or an edge midpoint, with the vertices' own or averaged heights.
Vec3 grid_point(const TriangleMesh& m, int n, int i, int j) {
  const int i0 = i / 2, j0 = j / 2, i1 = (i + 1) / 2, j1 = (j + 1) / 2;
  return (m.vertices[j0 * (n + 1) + i0] + m.vertices[j1 * (n + 1) + i1]) * 0.5f;
}

TEST(Watertight, HeightfieldBoxEdgesAndVerticesExactly) {
  const int n = 24;
  const TriangleMesh m = testing::heightfield_box(n, 5);
  const auto s = MeshSurface::build(m);
  std::vector<Crossing> cr;
  // Vertical rays through every vertex, edge midpoint and diagonal midpoint of the grid.
  for (int j = 0; j <= 2 * n; ++j)
    for (int i = 0; i <= 2 * n; ++i) {
      const float x = 0.5f * i, y = 0.5f * j;
      for (float dz : {-1.0f, 1.0f}) {
        s->crossings({{x, y, dz < 0 ? 20.0f : -20.0f}, {0, 0, dz}}, 0, kInf, &cr);
        const std::string what = "x=" + std::to_string(x) + " y=" + std::to_string(y);
        expect_alternating(cr, what);
        const bool interior = i > 0 && j > 0 && i < 2 * n && j < 2 * n;
        if (interior) {
          ASSERT_EQ(cr.size(), 2u) << what;  // nothing slips, nothing doubles
        }
      }
    }
  // Oblique rays exactly through vertices and edge midpoints: the direction's ratios are
  // powers of two, so the shear maps these points exactly onto the ray.
  // All steeper than the top's slope, so the crossing at p is a true crossing, not a touch.
  const Vec3 dirs[] = {{1, 2, -8}, {-2, 1, -4}, {0.5f, -1, 8}, {1, 1, -4}};
  for (const Vec3& d : dirs)
    for (int j = 0; j <= 2 * n; ++j)
      for (int i = 0; i <= 2 * n; ++i) {
        const Vec3 p = grid_point(m, n, i, j);
        const Ray ray{p - d * 16.0f, d};
        s->crossings(ray, 0, kInf, &cr);
        expect_alternating(cr, "oblique through (" + std::to_string(p.x) + "," +
                                   std::to_string(p.y) + "," + std::to_string(p.z) + ")");
        if (::testing::Test::HasFatalFailure()) return;
        if (i > 0 && j > 0 && i < 2 * n && j < 2 * n) {
          EXPECT_GE(cr.size(), 2u);
          // The crossing at p itself is there, exactly once.
          int at_p = 0;
          for (const Crossing& c : cr) at_p += std::abs(c.t - 16.0f) < 1e-4f;
          EXPECT_EQ(at_p, 1) << "through (" << p.x << "," << p.y << "," << p.z << ")";
        }
      }
}

// The nearest-hit query tests a leaf's triangles four at a time (SSE) and sends a triangle with
// a zero edge function to the scalar kernel: rays exactly through vertices and edges must still
// hit, and hit the very triangle the all-crossings query (and the binary BVH's scalar loop)
// picks, with bitwise the same t and barycentrics.
void expect_nearest_is_first_crossing(const MeshSurface& s, const Ray& ray,
                                      const std::string& what) {
  std::vector<Crossing> cr;
  s.crossings(ray, 0, kInf, &cr);
  SurfaceHit h, b;
  const bool hit = s.intersect(ray, 0, kInf, &h);
  ASSERT_EQ(hit, !cr.empty()) << what;
  ASSERT_EQ(s.intersect_binary(ray, 0, kInf, &b), hit) << what;
  if (!hit) return;
  const Crossing* first = &cr[0];
  for (const Crossing& c : cr)
    if (c.t < first->t) first = &c;
  EXPECT_EQ(h.t, first->t) << what;
  EXPECT_EQ(b.t, h.t) << what;
  // Two triangles hit at exactly the same t (at the box's rim, a touched silhouette vertex):
  // either may be the nearest.
  if (std::count_if(cr.begin(), cr.end(), [&](const Crossing& c) { return c.t == h.t; }) > 1)
    return;
  EXPECT_EQ(h.prim, first->prim) << what;
  EXPECT_EQ(b.prim, h.prim) << what;
  EXPECT_EQ(b.u, h.u) << what;
  EXPECT_EQ(b.v, h.v) << what;
}

TEST(Watertight, NearestHitExactlyThroughVerticesAndEdges) {
  const int n = 24;
  const TriangleMesh m = testing::heightfield_box(n, 5);
  const auto s = MeshSurface::build(m);
  const Vec3 dirs[] = {{0, 0, -1}, {0, 0, 1}, {1, 2, -8}, {-2, 1, -4}, {0.5f, -1, 8}, {1, 1, -4}};
  for (const Vec3& d : dirs)
    for (int j = 0; j <= 2 * n; ++j)
      for (int i = 0; i <= 2 * n; ++i) {
        const Vec3 p = grid_point(m, n, i, j);
        const Ray ray{p - d * 16.0f, d};
        expect_nearest_is_first_crossing(*s, ray,
                                         "through (" + std::to_string(p.x) + "," +
                                             std::to_string(p.y) + "," + std::to_string(p.z) + ")");
        if (::testing::Test::HasFatalFailure()) return;
      }
  // Armadillo: axis rays exactly through every 7th vertex.
  const TriangleMesh& arm = testing::armadillo();
  const MeshSurface& as = testing::armadillo_surface();
  for (size_t v = 0; v < arm.vertices.size(); v += 7)
    for (int axis = 0; axis < 3; ++axis) {
      Vec3 org = arm.vertices[v], dir{0, 0, 0};
      org[axis] = as.bounds().lo[axis] - 10;
      dir[axis] = 1;
      expect_nearest_is_first_crossing(as, {org, dir}, "vertex " + std::to_string(v));
      if (::testing::Test::HasFatalFailure()) return;
    }
}

TEST(Watertight, RandomRaysThroughTheHeightfieldBox) {
  const TriangleMesh m = testing::heightfield_box(16, 9);
  const auto s = MeshSurface::build(m);
  std::mt19937 rng(3);
  std::vector<Crossing> cr;
  const Box box = s->bounds();
  for (int k = 0; k < 100000; ++k) {
    const Vec3 org = box.center() + testing::random_direction(rng) * 60.0f;
    s->crossings({org, testing::random_point(rng, box) - org}, 0, kInf, &cr);
    expect_alternating(cr, "ray " + std::to_string(k));
    if (::testing::Test::HasFatalFailure()) return;
  }
}

}  // namespace
}  // namespace hfrt::geom
