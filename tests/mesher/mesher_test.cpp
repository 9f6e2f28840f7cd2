// The mesher on analytic fields with closed-form answers: a sphere, a box and a torus (volume
// and area against the formulas, every vertex on the analytic surface, the box's corners and
// edges reproduced), a closed oriented manifold in every case, the cap at the box, NaN
// regions, a field without intervals, and the same mesh on 1 and 2 threads.

#include "mesher/mesher.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <thread>

#include "mesher/simplify.h"
#include "tests/mesher/mesh_check.h"
#include "testsupport/analytic_fields.h"

namespace hfrt::mesher {
namespace {

using render::Interval;
using render::testing::AnalyticField;
using render::testing::HalfNanSphereField;
using render::testing::SphereField;
using render::testing::TorusField;
using render::testing::widen;
using testing::check_closed_manifold;
using testing::mesh_area;
using testing::mesh_volume;
using testing::point_mesh_distance;

/// A solid box: F = min_i (half_i - |p_i - c_i|).
class BoxField : public AnalyticField {
 public:
  BoxField(Vec3 c, Vec3 half) : c_(c), h_(half) {}
  double value(double x, double y, double z) const override {
    return std::min(
        {h_.x - std::abs(x - c_.x), h_.y - std::abs(y - c_.y), h_.z - std::abs(z - c_.z)});
  }
  Vec3 gradient(double x, double y, double z) const override {
    const double p[3] = {x - c_.x, y - c_.y, z - c_.z};
    const double d[3] = {h_.x - std::abs(p[0]), h_.y - std::abs(p[1]), h_.z - std::abs(p[2])};
    int k = d[0] <= d[1] && d[0] <= d[2] ? 0 : (d[1] <= d[2] ? 1 : 2);
    Vec3 g{0, 0, 0};
    g[k] = p[k] > 0 ? -1.0f : 1.0f;
    return g;
  }
  Interval interval(const Box& b) const override {
    double lo = 1e30, hi = 1e30;
    for (int a = 0; a < 3; ++a) {
      double l = double(b.lo[a]) - c_[a], u = double(b.hi[a]) - c_[a];
      double amin = l > 0 ? l : (u < 0 ? -u : 0.0), amax = std::max(std::abs(l), std::abs(u));
      lo = std::min(lo, h_[a] - amax);
      hi = std::min(hi, h_[a] - amin);
    }
    return widen(lo, hi);
  }
  /// Distance from p to the box's surface.
  double surface_distance(Vec3 p) const {
    double out2 = 0, in = 1e30;
    for (int a = 0; a < 3; ++a) {
      double d = std::abs(double(p[a]) - c_[a]) - h_[a];
      if (d > 0) out2 += d * d;
      in = std::min(in, -d);
    }
    return out2 > 0 ? std::sqrt(out2) : std::max(0.0, in);
  }

 private:
  Vec3 c_, h_;
};

/// "" when b is a's mesh bit for bit (the same triangles, every vertex coordinate ==), else
/// what differs first: for the tests that the mesh does not depend on how it was made.
std::string mesh_difference(const TriMesh& a, const TriMesh& b) {
  if (a.vertices.size() != b.vertices.size()) {
    return std::to_string(a.vertices.size()) + " vertices against " +
           std::to_string(b.vertices.size());
  }
  if (!(a.triangles == b.triangles)) return "the triangles differ";
  for (size_t i = 0; i < a.vertices.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      if (!(a.vertices[i][c] == b.vertices[i][c])) {
        return "vertex " + std::to_string(i) + " coordinate " + std::to_string(c) + ": " +
               std::to_string(a.vertices[i][c]) + " against " + std::to_string(b.vertices[i][c]);
      }
    }
  }
  return "";
}

MeshOptions options_for(Box box, int resolution, int threads = 0) {
  MeshOptions opt;
  opt.box = box;
  opt.resolution = resolution;
  opt.threads = threads;
  return opt;
}

TEST(Mesher, SphereVolumeAreaAndVerticesOnTheSurface) {
  const double r = 1.0;
  SphereField sphere({0.1f, -0.05f, 0.02f}, r);
  const Box box({-1.3f, -1.3f, -1.3f}, {1.3f, 1.3f, 1.3f});
  MeshStats stats;
  TriMesh m = mesh_field(sphere, options_for(box, 48), &stats);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  const double vol = 4.0 / 3.0 * std::numbers::pi * r * r * r, area = 4 * std::numbers::pi * r * r;
  EXPECT_NEAR(mesh_volume(m.vertices, m.triangles) / vol, 1.0, 0.005);
  EXPECT_NEAR(mesh_area(m.vertices, m.triangles) / area, 1.0, 0.005);
  double worst = 0;
  for (const Vec3& v : m.vertices) worst = std::max(worst, std::abs(sphere.value(v.x, v.y, v.z)));
  EXPECT_LT(worst, 1e-4 * 2.6);
  // Intervals pruned most of the box: far fewer blocks sampled than there are.
  EXPECT_LT(stats.blocks_sampled, stats.blocks_total);
  EXPECT_EQ(stats.closure_cells, 0u);
}

TEST(Mesher, TorusVolumeAreaAndVerticesOnTheSurface) {
  const double R = 1.0, r = 0.35;
  TorusField torus(R, r);
  const Box box({-1.5f, -0.5f, -1.5f}, {1.5f, 0.5f, 1.5f});
  TriMesh m = mesh_field(torus, options_for(box, 96));
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  const double pi = std::numbers::pi;
  EXPECT_NEAR(mesh_volume(m.vertices, m.triangles) / (2 * pi * pi * R * r * r), 1.0, 0.005);
  EXPECT_NEAR(mesh_area(m.vertices, m.triangles) / (4 * pi * pi * R * r), 1.0, 0.005);
  double worst = 0;
  for (const Vec3& v : m.vertices) worst = std::max(worst, std::abs(torus.value(v.x, v.y, v.z)));
  EXPECT_LT(worst, 1e-4 * 3.0);
}

/// The box test at `scale` times the size (box, solid and tolerances alike).
void expect_box_exact(float scale) {
  const Vec3 c = Vec3{0.05f, -0.02f, 0.03f} * scale, h = Vec3{0.61f, 0.43f, 0.37f} * scale;
  BoxField solid(c, h);
  const Box box(Vec3{-1, -1, -1} * scale, Vec3{1, 1, 1} * scale);
  MeshStats stats;
  TriMesh m = mesh_field(solid, options_for(box, 40), &stats);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  const double size = 2.0 * scale, tol = 1e-4 * size;
  const double vol = 8.0 * h.x * h.y * h.z, area = 8.0 * (h.x * h.y + h.y * h.z + h.z * h.x);
  // Sharp edges: a chamfer of one cell along the 12 edges would lose ~1% of the volume.
  EXPECT_NEAR(mesh_volume(m.vertices, m.triangles) / vol, 1.0, 2e-4);
  EXPECT_NEAR(mesh_area(m.vertices, m.triangles) / area, 1.0, 2e-4);
  double worst = 0;
  for (const Vec3& v : m.vertices) worst = std::max(worst, solid.surface_distance(v));
  EXPECT_LT(worst, tol);
  // Every corner is a vertex, and points along every edge lie on the mesh.
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner{c.x + ((k & 1) ? h.x : -h.x), c.y + ((k & 2) ? h.y : -h.y),
                      c.z + ((k & 4) ? h.z : -h.z)};
    double nearest = 1e30;
    for (const Vec3& v : m.vertices) nearest = std::min(nearest, double(length(v - corner)));
    EXPECT_LT(nearest, tol) << "corner " << k;
    for (int a = 0; a < 3; ++a) {
      if (corner[a] > c[a]) continue;  // each edge once: from its low end
      for (int s = 1; s < 10; ++s) {
        Vec3 p = corner;
        p[a] += 2 * h[a] * float(s) / 10;
        EXPECT_LT(point_mesh_distance(p, m.vertices, m.triangles), tol)
            << "corner " << k << " axis " << a << " step " << s;
      }
    }
  }
  EXPECT_GT(stats.sharp_vertices, 0u);
}

TEST(Mesher, BoxCornersAndEdgesAreExact) {
  expect_box_exact(1.0f);
}

// Nothing in the mesher depends on the model's units: cells of 5e-8.
TEST(Mesher, BoxCornersAndEdgesAreExactAtAMillionthOfTheSize) {
  expect_box_exact(1e-6f);
}

/// A wedge: F = min(d1 - n1 . p, d2 - n2 . p) (capped at the mesher's box), whose sharp edge
/// runs along (1, 1, 1): across the cells diagonally, where a quad's diagonal decides
/// whether the edge is kept or notched.
class WedgeField : public AnalyticField {
 public:
  explicit WedgeField(double scale) : scale_(scale) {}
  double value(double x, double y, double z) const override {
    return std::min(plane(0, x, y, z), plane(1, x, y, z));
  }
  Vec3 gradient(double x, double y, double z) const override {
    const int k = plane(0, x, y, z) <= plane(1, x, y, z) ? 0 : 1;
    return {float(-kN[k][0]), float(-kN[k][1]), float(-kN[k][2])};
  }
  Interval interval(const Box& b) const override {
    double lo[2], hi[2];
    for (int k = 0; k < 2; ++k) {
      lo[k] = hi[k] = kD[k] * scale_;
      for (int a = 0; a < 3; ++a) {
        const double u = -kN[k][a] * double(b.lo[a]), v = -kN[k][a] * double(b.hi[a]);
        lo[k] += std::min(u, v), hi[k] += std::max(u, v);
      }
    }
    return widen(std::min(lo[0], lo[1]), std::min(hi[0], hi[1]));
  }

 private:
  double plane(int k, double x, double y, double z) const {
    return kD[k] * scale_ - (kN[k][0] * x + kN[k][1] * y + kN[k][2] * z);
  }
  static constexpr double kR2 = 0.70710678118654752, kR6 = 0.40824829046386302;
  static constexpr double kN[2][3] = {{kR2, -kR2, 0}, {kR6, kR6, -2 * kR6}};
  static constexpr double kD[2] = {0.13, 0.07};
  double scale_;
};

/// The wedge meshed at `scale` times the size.
TriMesh wedge_mesh(float scale) {
  WedgeField wedge(scale);
  const Box box(Vec3{-1, -1, -1} * scale, Vec3{1, 1, 1} * scale);
  return mesh_field(wedge, options_for(box, 32));
}

// Regression: the faces' choice of diagonal is made in single precision on the corners in
// cells; on the corners in model units its products (~cell^8) underflowed at cells of ~6e-8,
// and every quad took the same diagonal. The same wedge a million times smaller is the same
// mesh, triangle for triangle.
TEST(Mesher, DiagonalsDoNotDependOnTheScale) {
  const TriMesh big = wedge_mesh(1.0f), small = wedge_mesh(1e-6f);
  ASSERT_EQ(check_closed_manifold(small.vertices, small.triangles), "");
  ASSERT_EQ(big.vertices.size(), small.vertices.size());
  ASSERT_EQ(big.triangles.size(), small.triangles.size());
  size_t differ = 0;
  for (size_t t = 0; t < big.triangles.size(); ++t)
    differ += big.triangles[t] != small.triangles[t];
  EXPECT_EQ(differ, 0u) << "of " << big.triangles.size();
}

TEST(Mesher, CapsTheSolidAtTheBox) {
  // A ball of radius 1 cut by the box [-0.5, 2]^3 (the ball sticks out on three sides).
  SphereField sphere({0, 0, 0}, 1.0);
  const Box box({-0.5f, -0.5f, -0.5f}, {2, 2, 2});
  TriMesh m = mesh_field(sphere, options_for(box, 80));
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  for (const Vec3& v : m.vertices) {
    EXPECT_GE(v.x, box.lo.x - 1e-6f);
    EXPECT_GE(v.y, box.lo.y - 1e-6f);
    EXPECT_GE(v.z, box.lo.z - 1e-6f);
  }
  // The capped solid: the part of the ball with x, y, z >= -0.5, by Monte Carlo with a fixed
  // stratified grid (an answer the mesher did not compute).
  const int n = 200;
  double inside = 0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        const double x = -0.5 + 1.5 * (i + 0.5) / n, y = -0.5 + 1.5 * (j + 0.5) / n,
                     z = -0.5 + 1.5 * (k + 0.5) / n;
        inside += x * x + y * y + z * z <= 1;
      }
  const double expected = inside / (double(n) * n * n) * 1.5 * 1.5 * 1.5;
  EXPECT_NEAR(mesh_volume(m.vertices, m.triangles) / expected, 1.0, 0.005);
}

TEST(Mesher, NanRegionCountsAsOutside) {
  HalfNanSphereField half({0, 0, 0}, 1.0);
  const Box box({-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f});
  MeshStats stats;
  TriMesh m = mesh_field(half, options_for(box, 40), &stats);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  const double half_ball = 2.0 / 3.0 * std::numbers::pi;
  EXPECT_NEAR(mesh_volume(m.vertices, m.triangles) / half_ball, 1.0, 0.03);
  EXPECT_GT(stats.nan_samples, 0u);
}

TEST(Mesher, WorksWithoutIntervals) {
  TorusField torus(1.0, 0.3);
  torus.set_has_interval(false);
  const Box box({-1.5f, -0.5f, -1.5f}, {1.5f, 0.5f, 1.5f});
  MeshStats stats;
  TriMesh m = mesh_field(torus, options_for(box, 40), &stats);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  EXPECT_EQ(stats.blocks_sampled, stats.blocks_total);
  EXPECT_EQ(torus.interval_calls.load(), 0);
}

// Smooth vertices end within 1e-4 of a cell of F = 0 (the Newton tolerance), though the point
// a step reaches is judged by F alone, with the slope at the step's origin (or, for a flat
// patch's first step, the mean slope of its edges).
TEST(Mesher, SmoothVerticesAreOnTheSurfaceToATenThousandthOfACell) {
  for (double r : {0.9, 0.31}) {
    SphereField sphere({0.013f, -0.021f, 0.007f}, r);
    const Box box({-1, -1, -1}, {1, 1, 1});
    const int res = 64;
    const double h = 2.0 / res;
    MeshStats stats;
    TriMesh m = mesh_field(sphere, options_for(box, res), &stats);
    ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
    EXPECT_EQ(stats.sharp_vertices, 0u);
    EXPECT_GT(stats.projected_vertices, m.vertices.size() / 2);
    double worst = 0;
    for (const Vec3& v : m.vertices) worst = std::max(worst, std::abs(sphere.value(v.x, v.y, v.z)));
    // 1e-4 h, plus the rounding of float coordinates near 1.
    EXPECT_LT(worst, 1e-4 * h + 2e-7) << r;
  }
}

// With sound intervals, pruning only skips blocks without a sign change, and the blocks are
// sampled in batches: the same mesh, bit for bit, as without intervals (nothing pruned).
TEST(Mesher, PruningGivesTheSameMeshAsSamplingEveryNode) {
  const Box box({-1.5f, -0.5f, -1.5f}, {1.5f, 0.5f, 1.5f});
  for (int res : {37, 64}) {
    TorusField pruned(1.0, 0.3), full(1.0, 0.3);
    full.set_has_interval(false);
    MeshStats sp, sf;
    TriMesh a = mesh_field(pruned, options_for(box, res), &sp);
    TriMesh b = mesh_field(full, options_for(box, res), &sf);
    EXPECT_LT(sp.blocks_sampled, sf.blocks_sampled);
    EXPECT_EQ(sp.closure_cells, 0u);
    EXPECT_EQ(mesh_difference(a, b), "") << res;
  }
}

/// A ball whose interval claims "inside" for every box in x > 0.55, where the sphere's surface
/// still runs: the interval and the point values disagree at nodes of pruned blocks.
class LyingSphereField : public SphereField {
 public:
  using SphereField::SphereField;
  Interval interval(const Box& b) const override {
    if (b.lo.x > 0.55f) return Interval{1, 2};
    return SphereField::interval(b);
  }
};

// Where they disagree, a sampled block's cell can have a crossing edge whose other cells lie in
// a pruned block, on either side of it: the closure adds them (it looked only from an edge's
// owning cell before, and hit an invariant check when the owner was the missing one).
TEST(Mesher, DisagreeingIntervalsStillGiveAClosedManifold) {
  LyingSphereField ball({0, 0, 0}, 1.0);
  const Box box({-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f});
  for (int res : {24, 40}) {
    MeshStats stats;
    TriMesh m = mesh_field(ball, options_for(box, res), &stats);
    ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "") << res;
    EXPECT_GT(mesh_volume(m.vertices, m.triangles), 0) << res;
    EXPECT_GT(stats.closure_cells, 0u) << res;
  }
}

TEST(Mesher, EmptyAndFullBoxes) {
  SphereField sphere({0, 0, 0}, 1.0);
  // No surface: the ball is outside the box.
  TriMesh none = mesh_field(sphere, options_for(Box({2, 2, 2}, {3, 3, 3}), 16));
  EXPECT_TRUE(none.triangles.empty());
  // The box is inside the ball: the mesh is the box itself.
  const Box inner({-0.3f, -0.3f, -0.3f}, {0.3f, 0.3f, 0.3f});
  TriMesh full = mesh_field(sphere, options_for(inner, 16));
  ASSERT_EQ(check_closed_manifold(full.vertices, full.triangles), "");
  EXPECT_NEAR(mesh_volume(full.vertices, full.triangles), 0.216, 0.216 * 1e-4);
}

TEST(Mesher, SameMeshOnOneAndTwoThreads) {
  TorusField torus(1.0, 0.3);
  const Box box({-1.5f, -0.5f, -1.5f}, {1.5f, 0.5f, 1.5f});
  TriMesh a = mesh_field(torus, options_for(box, 64, 1));
  TriMesh b = mesh_field(torus, options_for(box, 64, 2));
  EXPECT_EQ(mesh_difference(a, b), "");
}

// warm_up (app/mesh_job runs it on a thread of its own beside the compile) may run while a
// mesh is made on other threads, and asks for a thread count of its own: the meshes stay the
// same as without it, on one thread and on two.
TEST(Mesher, WarmUpBesideAMeshChangesNothing) {
  TorusField torus(1.0, 0.3);
  const Box box({-1.5f, -0.5f, -1.5f}, {1.5f, 0.5f, 1.5f});
  const TriMesh before = mesh_field(torus, options_for(box, 48, 2));
  for (int threads : {1, 2}) {
    std::thread warm([threads] { warm_up(3 - threads); });
    const TriMesh during = mesh_field(torus, options_for(box, 48, threads));
    warm.join();
    warm_up(threads);
    const TriMesh after = mesh_field(torus, options_for(box, 48, threads));
    EXPECT_EQ(mesh_difference(before, during), "") << threads << " threads, warm_up beside";
    EXPECT_EQ(mesh_difference(before, after), "") << threads << " threads, after warm_up";
  }
}

TEST(Mesher, ColoursFromAttributes) {
  render::testing::ColouredSphereField ball({0, 0, 0}, 1.0);
  TriMesh m = mesh_field(ball, options_for(Box({-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f}), 16));
  ASSERT_EQ(m.colors.size(), m.vertices.size());
  for (size_t i = 0; i < m.vertices.size(); ++i) {
    if (std::abs(m.vertices[i].x) < 1e-3f) continue;
    EXPECT_EQ(m.colors[i].x, m.vertices[i].x > 0 ? 1.0f : 0.0f);
    EXPECT_EQ(m.colors[i].z, m.vertices[i].x > 0 ? 0.0f : 1.0f);
  }
}

TEST(Simplify, BoxKeepsItsShapeWithFewTriangles) {
  const Vec3 c{0.05f, -0.02f, 0.03f}, h{0.61f, 0.43f, 0.37f};
  BoxField solid(c, h);
  TriMesh m = mesh_field(solid, options_for(Box({-1, -1, -1}, {1, 1, 1}), 40));
  const size_t before = m.triangles.size();
  const double vol = mesh_volume(m.vertices, m.triangles);
  SimplifyStats st;
  simplify_mesh(&m, 1e-4, &st);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  EXPECT_EQ(st.triangles_before, before);
  EXPECT_EQ(st.triangles_after, m.triangles.size());
  // Flat faces collapse to a handful of triangles each.
  EXPECT_LT(m.triangles.size() * 20, before);
  EXPECT_NEAR(mesh_volume(m.vertices, m.triangles) / vol, 1.0, 1e-4);
  double worst = 0;
  for (const Vec3& v : m.vertices) worst = std::max(worst, solid.surface_distance(v));
  EXPECT_LT(worst, 2e-4);
}

// The progress of a simplification (hfrt mesh's bar): every report has done <= total, done
// only grows, and the last report is the end (done == total).
TEST(Simplify, ReportsItsProgressAndItsEnd) {
  SphereField sphere({0, 0, 0}, 1.0);
  TriMesh m = mesh_field(sphere, options_for(Box({-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f}), 96));
  std::vector<std::pair<size_t, size_t>> reports;
  simplify_mesh(&m, 5e-3, nullptr,
                [&](size_t done, size_t total) { reports.emplace_back(done, total); });
  ASSERT_GE(reports.size(), 2u);  // ~300k candidates: reports every 65536, and the end
  for (size_t i = 0; i < reports.size(); ++i) {
    EXPECT_LE(reports[i].first, reports[i].second);
    if (i > 0) {
      EXPECT_GT(reports[i].first, reports[i - 1].first);
    }
  }
  EXPECT_EQ(reports.back().first, reports.back().second);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
}

// On flat faces every collapse's error is zero up to rounding. Ordered by the bare error,
// one vertex took its neighbours' edges one after another into a fan of hundreds of
// triangles, each further collapse looking at all of them (the corpus csg at 320 cells: 893
// s). Ordered by steps of the error and then the shorter edge, the work stays a small
// multiple of the triangles.
TEST(Simplify, FlatFacesGatherNoFans) {
  const Vec3 c{0.05f, -0.02f, 0.03f}, h{0.61f, 0.43f, 0.37f};
  BoxField solid(c, h);
  TriMesh m = mesh_field(solid, options_for(Box({-1, -1, -1}, {1, 1, 1}), 96));
  SimplifyStats st;
  simplify_mesh(&m, 1e-4, &st);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  EXPECT_LT(m.triangles.size() * 20, st.triangles_before);
  // ~18 triangles looked at per triangle; ~1000 in the bare error's order.
  EXPECT_LT(st.triangle_visits, 100 * st.triangles_before);
}

TEST(Simplify, SphereStaysWithinTheBound) {
  SphereField sphere({0, 0, 0}, 1.0);
  TriMesh m = mesh_field(sphere, options_for(Box({-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f}), 48));
  const size_t before = m.triangles.size();
  const double bound = 5e-3;
  simplify_mesh(&m, bound);
  ASSERT_EQ(check_closed_manifold(m.vertices, m.triangles), "");
  EXPECT_LT(m.triangles.size(), before / 2);
  double worst = 0;
  for (const Vec3& v : m.vertices) worst = std::max(worst, std::abs(sphere.value(v.x, v.y, v.z)));
  EXPECT_LT(worst, bound);
  EXPECT_NEAR(mesh_volume(m.vertices, m.triangles) / (4.0 / 3.0 * std::numbers::pi), 1.0, 0.01);
}

}  // namespace
}  // namespace hfrt::mesher
