// Bézier patches: the BPT loader and its errors, evaluation and sub-patches, ray hits against
// a dense tessellation (within its error), exactness of the hits, silhouettes, normals.

#include "geom/bezier.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "geom/patch_surface.h"
#include "test_meshes.h"

namespace hfrt::geom {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

std::string teapot_path() {
  return std::string(HFRT_CORPUS_DIR) + "/bezier/teapot.bpt";
}

const PatchSet& teapot() {
  static const PatchSet set = [] {
    Result<PatchSet> r = load_bpt(teapot_path());
    HFRT_CHECK_MSG(r.ok(), r.error().message);
    return std::move(r).value();
  }();
  return set;
}

const PatchSurface& teapot_surface() {
  static const std::unique_ptr<PatchSurface> s = PatchSurface::build(teapot());
  return *s;
}

/// The teapot with its field through the tessellation (as a trimmed set's is), for the tests
/// of that field and as a reference for the exact one.
const PatchSurface& teapot_tessellated() {
  static const std::unique_ptr<PatchSurface> s = [] {
    PatchSurface::Options options;
    options.exact_field = false;
    return PatchSurface::build(teapot(), options);
  }();
  return *s;
}

TEST(Bpt, LoadsTheTeapot) {
  const PatchSet& t = teapot();
  ASSERT_EQ(t.patches.size(), 32u);
  for (const BezierPatch& p : t.patches) {
    EXPECT_EQ(p.du, 3);
    EXPECT_EQ(p.dv, 3);
  }
  const Box b = t.bounds();
  EXPECT_NEAR(b.lo.z, 0.0f, 1e-5f);  // the base at z = 0
  EXPECT_NEAR(b.hi.z, 4.2f, 1e-5f);  // the lid's knob (corpus README)
}

std::string bpt_error(const std::string& text) {
  Result<PatchSet> r = parse_bpt(text, "m.bpt");
  EXPECT_FALSE(r.ok()) << text;
  return r.ok() ? std::string() : r.error().message;
}

TEST(Bpt, ErrorsHaveTheirLine) {
  EXPECT_NE(bpt_error("").find("empty"), std::string::npos);
  EXPECT_NE(bpt_error("0\n").find("positive"), std::string::npos);
  EXPECT_NE(bpt_error("1\n4 1\n").find("m.bpt:2:"), std::string::npos);
  std::string e = bpt_error("1\n1 1\n0 0 0\n1 0 0\n0 1 0\n1 1 oops\n");
  EXPECT_NE(e.find("m.bpt:6:"), std::string::npos) << e;
  EXPECT_NE(e.find("oops"), std::string::npos) << e;
  e = bpt_error("1\n1 1\n0 0 0\n1 0 0\n0 inf 0\n1 1 0\n");
  EXPECT_NE(e.find("m.bpt:5: non-finite"), std::string::npos) << e;
  e = bpt_error("1\n1 1\n0 0 0\n1 0 0\n0 1 0\n");
  EXPECT_NE(e.find("file ends inside patch 1"), std::string::npos) << e;
  e = bpt_error("1\n1 1\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n\n7\n");
  EXPECT_NE(e.find("m.bpt:8:"), std::string::npos) << e;
  Result<PatchSet> missing = load_bpt("/nonexistent/x.bpt");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("/nonexistent/x.bpt"), std::string::npos);
}

TEST(Bpt, MixedDegreesRowByRow) {
  // du = 2, dv = 1: two rows of three points; row 0 at y = 0, row 1 at y = 1.
  Result<PatchSet> r = parse_bpt("1\n2 1\n0 0 0  1 0 1  2 0 0\n0 1 0  1 1 1  2 1 0\n", "m");
  ASSERT_TRUE(r.ok()) << r.error().message;
  const BezierPatch& p = r->patches[0];
  const DVec3 mid = p.eval(0.5, 0.5);
  EXPECT_NEAR(mid.x, 1.0, 1e-12);
  EXPECT_NEAR(mid.y, 0.5, 1e-12);
  EXPECT_NEAR(mid.z, 0.5, 1e-12);  // quadratic in u: 2 * 0.5 * 0.5 * 1
}

TEST(Bezier, InlinePatchesAndErrors) {
  std::vector<double> p;
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) p.insert(p.end(), {double(i), double(j), 0.0});
  Result<PatchSet> r = patches_from_array(p);
  ASSERT_TRUE(r.ok());
  EXPECT_NEAR(r->patches[0].eval(0.5, 0.25).y, 0.75, 1e-12);
  p.pop_back();
  EXPECT_NE(patches_from_array(p).error().message.find("multiple of 48"), std::string::npos);
}

TEST(Bezier, SubPatchReproducesTheSurface) {
  const BezierPatch& p = teapot().patches[5];
  const BezierPatch s = p.sub_patch(0.25, 0.75, 0.1, 0.4);
  for (double a : {0.0, 0.3, 1.0})
    for (double b : {0.0, 0.6, 1.0}) {
      const DVec3 x = s.eval(a, b), y = p.eval(0.25 + 0.5 * a, 0.1 + 0.3 * b);
      EXPECT_NEAR(x.x, y.x, 1e-5);
      EXPECT_NEAR(x.y, y.y, 1e-5);
      EXPECT_NEAR(x.z, y.z, 1e-5);
    }
}

TEST(Bezier, DerivativesMatchFiniteDifferences) {
  const BezierPatch& p = teapot().patches[9];
  DVec3 pu, pv;
  p.eval(0.3, 0.7, &pu, &pv);
  const double h = 1e-6;
  const DVec3 a = p.eval(0.3 + h, 0.7), b = p.eval(0.3 - h, 0.7);
  EXPECT_NEAR(pu.x, (a.x - b.x) / (2 * h), 1e-4);
  EXPECT_NEAR(pu.z, (a.z - b.z) / (2 * h), 1e-4);
  const DVec3 c = p.eval(0.3, 0.7 + h), d = p.eval(0.3, 0.7 - h);
  EXPECT_NEAR(pv.y, (c.y - d.y) / (2 * h), 1e-4);
}

// Rays at the teapot from all around.
Ray random_ray(std::mt19937& rng, const Box& box) {
  const Vec3 org = box.center() + testing::random_direction(rng) * (2 * length(box.diagonal()));
  return {org, testing::random_point(rng, box) - org};
}

TEST(PatchSurface, HitsAreExactAndMatchADenseTessellation) {
  const PatchSurface& s = teapot_surface();
  float err = 0;
  const TriangleMesh dense = finish_mesh(tessellate(teapot(), 96, &err)).value();
  const auto mesh = MeshSurface::build(dense);
  ASSERT_LT(err, 2e-3f);
  std::mt19937 rng(12);
  const Box box = s.bounds();
  int both = 0, disagree = 0, n = 4000;
  for (int i = 0; i < n; ++i) {
    const Ray ray = random_ray(rng, box);
    const Vec3 d = normalize(ray.dir);
    SurfaceHit ph, mh;
    const bool p = s.intersect(ray, 0, kInf, &ph);
    const bool m = mesh->intersect(ray, 0, kInf, &mh);
    if (p) {
      // Exact: the patch point at (u, v) is on the ray, to 1e-6 of the patch size.
      const BezierPatch& patch = teapot().patches[ph.prim];
      const DVec3 q = patch.eval(ph.u, ph.v);
      const Vec3 on_ray = ray.org + ray.dir * ph.t;
      const float size = length(patch.control_bounds().diagonal());
      EXPECT_LT(length(to_f(q) - on_ray), 1e-6f * size * 4) << "ray " << i;
      // The normal is unit and perpendicular to the patch derivatives.
      EXPECT_NEAR(length(ph.normal), 1.0f, 1e-4f);
    }
    if (p && m) {
      ++both;
      const float cos = std::abs(dot(d, ph.normal));
      // Same surface point up to the tessellation error (stretched at grazing angles).
      const Vec3 a = ray.org + ray.dir * ph.t, b = ray.org + ray.dir * mh.t;
      if (cos > 0.2f) {
        EXPECT_LT(length(a - b), 2 * err / cos + 1e-4f) << "ray " << i;
        // Normals agree up to the facet angle (the sign depends on each patch's orientation).
        const float c = dot(ph.normal, mh.normal);
        EXPECT_GT(c * c, 0.98f) << "ray " << i;
      }
    } else if (p != m) {
      // Only a ray grazing the surface (a silhouette within the tessellation error) may differ.
      const SurfaceHit& h = p ? ph : mh;
      const float cos = std::abs(dot(d, h.normal));
      EXPECT_LT(cos, 0.25f) << "ray " << i << (p ? " patch-only" : " mesh-only");
      ++disagree;
    }
  }
  EXPECT_GT(both, n / 5);
  EXPECT_LT(disagree, n / 100);
}

TEST(PatchSurface, SilhouetteRays) {
  // Rays tangent to the body (patches 4..11, convex around the z axis), pushed inwards by
  // delta: they must cross the wall near the tangent point.
  const PatchSurface& s = teapot_surface();
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> uv(0.2, 0.8);
  int tested = 0;
  for (int i = 0; i < 400; ++i) {
    const uint32_t patch_id = 4 + rng() % 8;  // the body patches
    const double u = uv(rng), v = uv(rng);
    const BezierPatch& patch = teapot().patches[patch_id];
    DVec3 pu, pv;
    const Vec3 p = to_f(patch.eval(u, v, &pu, &pv));
    const Vec3 n = s.normal(patch_id, u, v);
    // A tangent direction, and the centre of the body (on the z axis) decides "inwards".
    const Vec3 tangent = normalize(cross(n, Vec3{0, 0, 1}));
    const Vec3 axis_point{0, 0, p.z};
    const Vec3 inward = normalize(axis_point - p);
    for (float delta : {1e-2f, 1e-3f}) {
      const Vec3 q = p + inward * delta;
      const Ray ray{q - tangent * 5.0f, tangent};
      // The crossing near the tangent point (the handle or spout may come first): on the near
      // side of the chord through q, within sqrt(2 R delta) of it (R < 2, the body's radius).
      std::vector<Crossing> cr;
      s.crossings(ray, 0, kInf, &cr);
      bool found = false;
      for (const Crossing& c : cr) found |= std::abs(c.t - 5.0f) < 1.5f * std::sqrt(4.0f * delta);
      EXPECT_TRUE(found) << "grazing ray missed: patch " << patch_id << " u " << u << " v " << v
                         << " delta " << delta;
      ++tested;
    }
  }
  EXPECT_GT(tested, 700);
}

TEST(PatchSurface, CrossingsAreSortedAndDeduplicated) {
  const PatchSurface& s = teapot_surface();
  std::vector<Crossing> cr;
  // Straight down the middle: knob, lid, ... bottom has no patch (open teapot).
  s.crossings({{0, 0, 10}, {0, 0, -1}}, 0, kInf, &cr);
  ASSERT_FALSE(cr.empty());
  for (size_t k = 1; k < cr.size(); ++k) EXPECT_LT(cr[k - 1].t, cr[k].t);
  SurfaceHit h;
  ASSERT_TRUE(s.intersect({{0, 0, 10}, {0, 0, -1}}, 0, kInf, &h));
  EXPECT_FLOAT_EQ(cr[0].t, h.t);
  // Horizontally through the body: in and out of the body wall on each side (4 crossings,
  // maybe more through the spout or handle: an even number far from them).
  s.crossings({{0, -10, 1.0f}, {0, 1, 0}}, 0, kInf, &cr);
  EXPECT_EQ(cr.size(), 2u);  // a single wall each side (the wall has no thickness)
}

/// crossings_many (packets of eight) against crossings, ray by ray, bit for bit.
void expect_many_matches_single(const PatchSurface& s, const std::vector<Ray>& rays,
                                const std::vector<float>& tmin, const std::vector<float>& tmax,
                                size_t* crossings_seen) {
  std::vector<std::vector<Crossing>> many(rays.size());
  s.crossings_many(rays.data(), rays.size(), tmin.data(), tmax.data(), many.data());
  std::vector<Crossing> single;
  for (size_t i = 0; i < rays.size(); ++i) {
    s.crossings(rays[i], tmin[i], tmax[i], &single);
    ASSERT_EQ(many[i].size(), single.size()) << "ray " << i;
    for (size_t k = 0; k < single.size(); ++k) {
      EXPECT_EQ(std::memcmp(&many[i][k].t, &single[k].t, sizeof(float)), 0) << i << " " << k;
      EXPECT_EQ(many[i][k].facing, single[k].facing) << i << " " << k;
      EXPECT_EQ(many[i][k].prim, single[k].prim) << i << " " << k;
    }
    *crossings_seen += single.size();
  }
}

TEST(PatchPackets, CameraRaysIncoherentRaysAndSegmentsEqualSingleRays) {
  // PatchSurface::crossings_many walks eight rays at once through the 4-wide BVH (the
  // renderer's prefetch of a tile's camera rays); each ray's crossings must be exactly its
  // single-ray walk's: a camera's rows (coherent), random rays (incoherent), partial packets
  // (a count not a multiple of 8), segments that start or end inside the teapot, empty ones;
  // on the teapot and on a trimmed cup.
  Result<PatchSet> cup = load_bpt(std::string(HFRT_SOURCE_DIR) + "/examples/data/trimmed_cup.bpt");
  ASSERT_TRUE(cup.ok());
  const std::unique_ptr<PatchSurface> cup_surface = PatchSurface::build(*cup);
  for (const PatchSurface* s :
       {&teapot_surface(), static_cast<const PatchSurface*>(cup_surface.get())}) {
    const Box box = s->bounds();
    const Vec3 eye = box.center() + Vec3{1.2f, -1.7f, 1.1f} * length(box.diagonal());
    std::vector<Ray> rays;
    std::vector<float> tmin, tmax;
    const int n = 61;  // not a multiple of the packet
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Vec3 f{(i + 0.5f) / n, 0.5f, (j + 0.5f) / n}, size = box.size();
        const Vec3 target = box.lo + Vec3{f.x * size.x, f.y * size.y, f.z * size.z};
        rays.push_back({eye, target - eye});
        tmin.push_back(0);
        tmax.push_back(kInf);
      }
    std::mt19937 rng(31);
    std::uniform_real_distribution<float> t01(0, 1);
    for (int i = 0; i < 2003; ++i) {
      rays.push_back(random_ray(rng, box));
      // Whole, starting or ending inside the box, or empty.
      const int kind = i % 4;
      tmin.push_back(kind == 1 ? t01(rng) : 0);
      tmax.push_back(kind == 2 ? t01(rng) : kind == 3 ? 0.0f : kInf);
    }
    size_t seen = 0;
    expect_many_matches_single(*s, rays, tmin, tmax, &seen);
    EXPECT_GT(seen, rays.size() / 2);
    // Partial packets: 1 to 7 rays.
    for (size_t m = 1; m < 8; ++m) {
      std::vector<Ray> r(rays.begin() + 1000, rays.begin() + 1000 + m);
      std::vector<float> a(tmin.begin() + 1000, tmin.begin() + 1000 + m),
          b(tmax.begin() + 1000, tmax.begin() + 1000 + m);
      expect_many_matches_single(*s, r, a, b, &seen);
    }
  }
}

TEST(PatchSurface, FieldIsTheTessellationsWithinItsError) {
  const PatchSurface& s = teapot_tessellated();
  ASSERT_TRUE(s.has_tessellation());
  EXPECT_LT(s.field_error(), 0.01f);
  // The teapot is not watertight (the lid sits on the rim with a gap), yet the body is
  // clearly inside and far points clearly outside.
  const double w = s.winding_number({0, 0, 1.2f});
  EXPECT_GT(w, 0.5);
  EXPECT_LT(s.winding_number({0, 0, 8}), 0.1);
  EXPECT_GT(s.signed_distance({0, 0, 1.2f}), 0.0f);
  EXPECT_LT(s.signed_distance({5, 5, 5}), 0.0f);
  const SurfaceStats st = s.stats();
  EXPECT_EQ(st.patches, 32u);
  EXPECT_GT(st.triangles, 32u * 32 * 32);
}

// An untrimmed set's field needs no tessellation (geom/boundary_winding.h, closest points
// on the pieces): its distances are the tessellation's within that one's error, its sides
// the tessellation's away from the surface, and its bounds over a box hold every value in
// the box (the magnitudes; for the open teapot the sign of a box clear of the patches is the
// centre's, exact for closed sets only, as MeshSurface's).
TEST(PatchSurface, ExactFieldIsTheTessellationsWithinItsErrorAndItsBoundsHoldIt) {
  const PatchSurface& s = teapot_surface();
  const PatchSurface& t = teapot_tessellated();
  ASSERT_TRUE(s.has_field());
  ASSERT_FALSE(s.has_tessellation());
  EXPECT_EQ(s.field_error(), 0.0f);
  EXPECT_EQ(s.stats().triangles, 0u);
  EXPECT_GT(s.winding_number({0, 0, 1.2f}), 0.5);
  EXPECT_LT(s.winding_number({0, 0, 8}), 0.1);
  EXPECT_GT(s.signed_distance({0, 0, 1.2f}), 0.0f);
  EXPECT_LT(s.signed_distance({5, 5, 5}), 0.0f);
  const float size = length(s.bounds().diagonal());
  const Box box = testing::grown(s.bounds(), 0.3f);
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(0, 1);
  auto point_in = [&](const Box& b) {
    return Vec3{b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                b.lo.z + u(rng) * (b.hi.z - b.lo.z)};
  };
  int compared = 0;
  for (int k = 0; k < 1500; ++k) {
    const Vec3 p = point_in(box);
    Vec3 g;
    const float f = s.signed_distance(p, &g), ft = t.signed_distance(p);
    EXPECT_NEAR(std::abs(f), std::abs(ft), t.field_error() + 1e-5f * size) << k;
    EXPECT_NEAR(length(g), 1.0f, 1e-4f) << k;
    EXPECT_EQ(f > 0, s.inside(p)) << k;
    if (std::abs(ft) > 20 * t.field_error()) {
      EXPECT_EQ(f > 0, ft > 0) << k << ": " << p.x << " " << p.y << " " << p.z;
      ++compared;
    }
  }
  EXPECT_GT(compared, 1000);
  for (int k = 0; k < 300; ++k) {
    const float side = size * std::pow(10.0f, -3.0f + 3.0f * u(rng));
    const Vec3 lo = point_in(box);
    const Box b(lo, lo + Vec3{side * (0.5f + u(rng)), side * (0.5f + u(rng)), side * u(rng)});
    const DistanceBounds db = s.signed_distance_bounds(b);
    ASSERT_LE(db.lo, db.hi) << k;
    for (int i = 0; i < 12; ++i) {
      const float f = std::abs(s.signed_distance(point_in(b)));
      const float mag_lo = db.lo > 0 ? db.lo : (db.hi < 0 ? -db.hi : 0.0f);
      EXPECT_LE(f, std::max(std::abs(db.lo), std::abs(db.hi)) + 1e-6f * size) << k;
      EXPECT_GE(f, mag_lo - 1e-6f * size) << k;
    }
  }
}

// Newton's evaluator (eval_bicubic: double control points, x, y, z in vector lanes) gives
// BezierPatch::eval's point and derivatives bit for bit.
TEST(Bezier, VectorBicubicEvaluationIsTheScalarOneBitForBit) {
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> t(0, 1);
  for (const BezierPatch& patch : teapot().patches) {
    const BicubicD d(patch);
    for (int k = 0; k < 50; ++k) {
      const double u = k == 0 ? 0.0 : k == 1 ? 1.0 : t(rng), v = k == 0 ? 1.0 : t(rng);
      DVec3 pu, pv, qu, qv;
      const DVec3 p = patch.eval(u, v, &pu, &pv), q = eval_bicubic(d, u, v, &qu, &qv);
      for (const auto& [a, b] : {std::pair{p, q}, std::pair{pu, qu}, std::pair{pv, qv}})
        ASSERT_TRUE(std::memcmp(&a, &b, sizeof a) == 0) << u << " " << v;
      // The copy for CPUs without AVX2 (this machine may run only the other one).
      DVec3 gu, gv;
      const DVec3 g = eval_bicubic_generic(d, u, v, &gu, &gv);
      for (const auto& [a, b] : {std::pair{p, g}, std::pair{pu, gu}, std::pair{pv, gv}})
        ASSERT_TRUE(std::memcmp(&a, &b, sizeof a) == 0) << "generic " << u << " " << v;
    }
  }
}

// At a point of the patches (a ray hit), closest_point carries the patch's own normal at that
// place (Pu x Pv where the closest tessellation point maps back to), not its tessellation
// triangle's: several times closer to the true normal on average (faceted shading before).
TEST(PatchSurface, ClosestPointCarriesThePatchNormal) {
  const PatchSurface& s = teapot_tessellated();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> t(0.05, 0.95);
  double worst = 0, worst_triangle = 0, sum = 0, sum_triangle = 0;
  for (int k = 0; k < 400; ++k) {
    const uint32_t patch = uint32_t(rng() % teapot().patches.size());
    const double u = t(rng), v = t(rng);
    const Vec3 p = to_f(teapot().patches[patch].eval(u, v));
    const Vec3 want = s.normal(patch, u, v);
    const ClosestPoint c = s.closest_point(p, 0.01f);
    ASSERT_NE(c.prim, ~0u);
    EXPECT_NEAR(length(c.normal), 1.0f, 1e-5f);
    worst = std::max(worst, double(length(c.normal - want)));
    sum += length(c.normal - want);
    const ClosestPoint f = s.field_mesh().closest_point(p, 0.01f);
    worst_triangle = std::max(worst_triangle, double(length(f.normal - want)));
    sum_triangle += length(f.normal - want);
  }
  EXPECT_LT(sum / 400, 2e-3) << "the triangles': " << sum_triangle / 400;
  EXPECT_LT(worst, 0.05);  // the rim's lip, curved within a quad of the tessellation
  EXPECT_GT(sum_triangle, 5 * sum) << "worst " << worst << ", the triangles' " << worst_triangle;
}

TEST(PatchSurface, ClosestPointsNearThePatchesAreThePatchesOwn) {
  // Within a finite limit (the gradient's query at a ray hit) the closest point is found on
  // the patches themselves (Newton in the pieces), not on the field tessellation: a point of a
  // patch is its own closest point, with the patch's normal there exactly (the tessellation's
  // were off by up to 0.05 on the rim's lip); a point moved off the surface by h is at most h
  // away, and no nearer than the tessellation's distance allows.
  const PatchSurface& s = teapot_surface();
  const float size = length(s.bounds().diagonal());
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> t(0.02, 0.98);
  double worst_normal = 0, worst_distance = 0;
  for (int k = 0; k < 1000; ++k) {
    const uint32_t patch = uint32_t(rng() % teapot().patches.size());
    const double u = t(rng), v = t(rng);
    const Vec3 p = to_f(teapot().patches[patch].eval(u, v));
    const Vec3 want = s.normal(patch, u, v);
    if (!(length2(want) > 0)) continue;
    const ClosestPoint c = s.closest_point(p, 1e-3f * size);
    ASSERT_NE(c.prim, ~0u) << k;
    worst_distance = std::max(worst_distance, double(c.distance));
    if (c.prim == patch) worst_normal = std::max(worst_normal, double(length(c.normal - want)));
    EXPECT_LT(length(c.point - p), 1e-5f * size) << k;
    // Moved off along the normal: within h (another part of the teapot may be nearer).
    const float h = 2e-3f * size;
    const Vec3 q = p + want * h;
    const ClosestPoint cq = s.closest_point(q, 2 * h);
    ASSERT_NE(cq.prim, ~0u) << k;
    EXPECT_LE(cq.distance, h * (1 + 1e-4f)) << k;
    const PatchSurface& t = teapot_tessellated();
    EXPECT_GE(cq.distance, t.field_mesh().closest_point(q).distance - t.field_error() - 1e-6f) << k;
    EXPECT_NEAR(length(cq.point - q), cq.distance, 1e-5f * size) << k;
  }
  EXPECT_LT(worst_distance, 1e-6 * size);
  EXPECT_LT(worst_normal, 1e-4);
  // Beyond the limit: nothing (prim ~0u), as the tessellation's search answers.
  const ClosestPoint far = s.closest_point(s.bounds().hi + Vec3{1, 1, 1} * size, 1e-3f * size);
  EXPECT_EQ(far.prim, ~0u);
}

// tessellate evaluates each patch on its half-step grid (rows contracted once per u): its
// vertices are BezierPatch::eval's bit for bit, for bicubic and mixed-degree patches.
TEST(PatchSurface, TessellationVerticesAreTheEvaluatedPatchBitForBit) {
  PatchSet set = teapot();
  BezierPatch mixed;
  mixed.du = 2, mixed.dv = 1;
  for (int k = 0; k < mixed.num_control_points(); ++k)
    mixed.cp[k] = {0.3f * float(k), std::sin(float(k)), 0.1f * float(k * k)};
  set.patches.push_back(mixed);
  const int n = 7;
  const TriangleMesh mesh = tessellate(set, n);
  ASSERT_EQ(mesh.vertices.size(), set.patches.size() * (n + 1) * (n + 1));
  for (size_t p = 0; p < set.patches.size(); ++p)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const Vec3 want = to_f(set.patches[p].eval(double(i) / n, double(j) / n));
        const Vec3 got = mesh.vertices[p * (n + 1) * (n + 1) + size_t(j) * (n + 1) + size_t(i)];
        ASSERT_EQ(std::memcmp(&want, &got, sizeof want), 0)
            << "patch " << p << " (" << i << ", " << j << ")";
      }
}

// The field tessellation's keys (tessellate, finish_mesh) name each triangle's patch and quad,
// in Morton order, and stay in step with the triangles when degenerate ones are dropped.
TEST(PatchSurface, TessellationKeysNameEachTrianglesQuad) {
  const int n = 8;
  std::vector<uint64_t> keys;
  TriangleMesh mesh = tessellate(teapot(), n, nullptr, &keys);
  ASSERT_EQ(keys.size(), mesh.triangles.size());
  const std::vector<std::array<uint32_t, 3>> all = mesh.triangles;
  const std::vector<uint64_t> all_keys = keys;
  Result<TriangleMesh> clean = finish_mesh(std::move(mesh), &keys);
  ASSERT_TRUE(clean.ok());
  EXPECT_GT(clean->degenerate_skipped, 0u);  // the lid's and the bottom's poles
  ASSERT_EQ(keys.size(), clean->triangles.size());
  // The kept triangles are the non-degenerate ones in order, each with its own key.
  size_t at = 0;
  for (size_t i = 0; i < all.size() && at < keys.size(); ++i) {
    if (all[i] == clean->triangles[at]) {
      EXPECT_EQ(keys[at++], all_keys[i]) << "triangle " << i;
    }
  }
  EXPECT_EQ(at, keys.size());
  const uint32_t side = n + 1;
  for (size_t t = 0; t < keys.size(); ++t) {
    if (t > 0) {
      EXPECT_LE(keys[t - 1], keys[t]);
    }
    const uint32_t patch = uint32_t(keys[t] >> 32), code = uint32_t(keys[t]);
    uint32_t i = 0, j = 0;
    for (int b = 0; b < 16; ++b) {
      i |= ((code >> (2 * b)) & 1u) << b;
      j |= ((code >> (2 * b + 1)) & 1u) << b;
    }
    ASSERT_EQ(morton2(i, j), code);
    for (uint32_t v : clean->triangles[t]) {
      // An untrimmed patch's grid vertices: patch * side^2 + row * side + column.
      ASSERT_EQ(v / (side * side), patch);
      const uint32_t col = v % side, row = v / side % side;
      EXPECT_TRUE(col == i || col == i + 1) << "triangle " << t;
      EXPECT_TRUE(row == j || row == j + 1) << "triangle " << t;
    }
  }
}

// The field's BVH follows the quad grids (build_bvh_grouped); its winding numbers stay within
// the hierarchy's error of the exact sum over the tessellation (no farther than those of the
// SAH tree over the same triangles), and on the same side.
TEST(PatchSurface, FieldWindingNumbersOfTheGroupedTreeMatchTheExactSum) {
  const MeshSurface& field = teapot_tessellated().field_mesh();
  Result<TriangleMesh> mesh = finish_mesh(tessellate(teapot(), 32));
  ASSERT_TRUE(mesh.ok());
  const std::unique_ptr<MeshSurface> sah = MeshSurface::build(*mesh);
  ASSERT_EQ(sah->num_triangles(), field.num_triangles());
  double worst_sah = 0;
  std::mt19937 rng(5);
  const Box box = testing::grown(field.bounds(), 0.2f);
  std::uniform_real_distribution<float> u(0, 1);
  double worst = 0;
  int inside = 0;
  for (int i = 0; i < 400; ++i) {
    const Vec3 p{box.lo.x + u(rng) * (box.hi.x - box.lo.x),
                 box.lo.y + u(rng) * (box.hi.y - box.lo.y),
                 box.lo.z + u(rng) * (box.hi.z - box.lo.z)};
    const double w = field.winding_number(p), exact = field.winding_number_exact(p);
    worst = std::max(worst, std::abs(w - exact));
    worst_sah = std::max(worst_sah, std::abs(sah->winding_number(p) - exact));
    if (std::abs(exact - 0.5) > 0.05) {
      EXPECT_EQ(w >= 0.5, exact >= 0.5);
    }
    inside += exact >= 0.5;
  }
  EXPECT_LT(worst, 0.06);  // (0.040 here; the SAH tree's 0.051)
  EXPECT_LE(worst, 1.25 * worst_sah);
  EXPECT_GT(inside, 40);
}

}  // namespace
}  // namespace hfrt::geom
