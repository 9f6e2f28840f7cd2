// Trimmed Bézier patches (issue 17): the `trim` records of BPT files and their errors, ray hits
// and crossings of trimmed patches against hand-computed kept regions, the clipped field
// tessellation (exact areas, distances within field_error()), and patches trimmed away.

#include "geom/trim.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "geom/bezier.h"
#include "geom/patch_surface.h"
#include "test_meshes.h"

namespace hfrt::geom {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr double kPi = 3.14159265358979323846;

// The unit square in z = 0 as one bilinear patch: P(u, v) = (u, v, 0), normal +z.
const std::string kFlatSquare = "1\n1 1\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n";

// A regular polygon of n vertices on the circle of radius r about (cx, cy), as a BPT loop.
std::string polygon_loop(int n, double r, double cx = 0.5, double cy = 0.5) {
  std::string s = std::to_string(n) + "\n";
  char buf[96];
  for (int k = 0; k < n; ++k) {
    const double a = 2 * kPi * k / n;
    std::snprintf(buf, sizeof buf, "%.17g %.17g\n", cx + r * std::cos(a), cy + r * std::sin(a));
    s += buf;
  }
  return s;
}

PatchSet parse_ok(const std::string& text) {
  Result<PatchSet> r = parse_bpt(text, "m.bpt");
  HFRT_CHECK_MSG(r.ok(), r.error().message);
  return std::move(r).value();
}

std::string trim_error(const std::string& trim_text) {
  Result<PatchSet> r = parse_bpt(kFlatSquare + trim_text, "m.bpt");
  EXPECT_FALSE(r.ok()) << trim_text;
  return r.ok() ? std::string() : r.error().message;
}

// ---- The format -------------------------------------------------------------------------

TEST(TrimFormat, UntrimmedFilesHaveNoTrims) {
  const PatchSet set = parse_ok(kFlatSquare);
  EXPECT_TRUE(set.trims.empty());
  EXPECT_EQ(set.trim(0), nullptr);
  Result<PatchSet> teapot = load_bpt(std::string(HFRT_CORPUS_DIR) + "/bezier/teapot.bpt");
  ASSERT_TRUE(teapot.ok());
  EXPECT_TRUE(teapot->trims.empty());
}

TEST(TrimFormat, RecordsLoopsAndMerging) {
  // Two patches; patch 2 trimmed by two records (their loops add up), comments anywhere, a
  // loop closed explicitly (its repeated last point dropped), a point 1e-7 outside clamped.
  const std::string text = "2\n" + kFlatSquare.substr(2) + "1 1 0 0 1 1 0 1 0 1 1 1 1 1\n" +
                           "trim 2 1 # patch 2, one loop\n"
                           "4  0.1 0.1  0.9 0.1  0.9 0.9  0.1 0.9\n"
                           "trim 2 2\n"
                           "5  0.3 0.3  0.7 0.3  0.7 0.7  0.3 0.7  0.3 0.3\n"
                           "3  -1e-7 0  0.05 0  0 0.05\n";
  const PatchSet set = parse_ok(text);
  ASSERT_EQ(set.patches.size(), 2u);
  ASSERT_EQ(set.trims.size(), 2u);
  EXPECT_EQ(set.trim(0), nullptr);
  const Trim* t = set.trim(1);
  ASSERT_NE(t, nullptr);
  ASSERT_EQ(t->loops().size(), 3u);
  EXPECT_EQ(t->loops()[0].size(), 4u);
  EXPECT_EQ(t->loops()[1].size(), 4u);  // closing point dropped
  EXPECT_EQ(t->loops()[2][0].u, 0.0);   // clamped
  EXPECT_EQ(t->num_edges(), 11u);
  // Even-odd: the ring between the two squares, and the small corner triangle.
  EXPECT_TRUE(t->contains(0.2, 0.5));
  EXPECT_FALSE(t->contains(0.5, 0.5));
  EXPECT_FALSE(t->contains(0.95, 0.5));
  EXPECT_TRUE(t->contains(0.01, 0.01));
}

TEST(TrimFormat, EveryErrorWithItsLine) {
  EXPECT_EQ(trim_error("trim 2 1\n3 0 0 1 0 0 1\n"),
            "m.bpt:7: trim patch index 2 out of range 1..1");
  EXPECT_EQ(trim_error("\ntrim\n0 1\n"), "m.bpt:9: trim patch index 0 out of range 1..1");
  EXPECT_EQ(trim_error("trim x\n"),
            "m.bpt:7: expected the patch index of a trim record, found 'x'");
  EXPECT_EQ(trim_error("trim\n"), "m.bpt:7: file ends before the patch index of a trim record");
  EXPECT_EQ(trim_error("trim 1\n"),
            "m.bpt:7: file ends before the number of loops of the trim record of patch 1");
  EXPECT_EQ(trim_error("trim 1 one\n"),
            "m.bpt:7: expected the number of loops of the trim "
            "record of patch 1, found 'one'");
  EXPECT_EQ(trim_error("trim 1\n0\n"),
            "m.bpt:8: the trim record of patch 1: the number of loops must be positive, found 0");
  EXPECT_EQ(trim_error("trim 1 1\n"),
            "m.bpt:7: file ends before the number of points of loop 1 "
            "of the trim record of patch 1");
  EXPECT_EQ(trim_error("trim 1 2\n3 0 0 1 0 0 1\n2 0 0 1 1\n"),
            "m.bpt:9: loop 2 of the trim record of patch 1 has 2 points, at least 3 are needed");
  EXPECT_EQ(trim_error("trim 1 1\n3 0 0\n1 0\n0.5 oops\n"),
            "m.bpt:10: malformed trim coordinate 'oops' in loop 1 of the trim record of patch 1");
  EXPECT_EQ(trim_error("trim 1 1\n3 0 0\nnan 0\n0.5 1\n"),
            "m.bpt:9: non-finite trim coordinate 'nan' in loop 1 of the trim record of patch 1");
  EXPECT_EQ(trim_error("trim 1 1\n3 0 0\n1 0\n0.5 1.5\n"),
            "m.bpt:10: trim coordinate 1.5 in loop 1 of the trim record of patch 1 is outside "
            "the parameter range [0, 1]");
  EXPECT_EQ(trim_error("trim 1 1\n3 0 -0.001\n1 0\n0.5 1\n"),
            "m.bpt:8: trim coordinate -0.001 in loop 1 of the trim record of patch 1 is outside "
            "the parameter range [0, 1]");
  EXPECT_EQ(trim_error("trim 1 1\n3 0 0\n1 0\n"),
            "m.bpt:9: file ends inside loop 1 of the trim record of patch 1 (point 3 of 3)");
  // A huge point count is a truncated file, not an allocation.
  EXPECT_EQ(trim_error("trim 1 1\n99999999999 0 0\n"),
            "m.bpt:8: file ends inside loop 1 of the trim record of patch 1 (point 2 of "
            "99999999999)");
  // Anything else after the patches is still trailing data, before or after trim records.
  EXPECT_EQ(trim_error("trim 1 1\n3 0 0 1 0 0 1\nfoo\n"),
            "m.bpt:9: unexpected 'foo' after the "
            "1 patches");
  EXPECT_EQ(trim_error("7\ntrim 1 1\n3 0 0 1 0 0 1\n"),
            "m.bpt:7: unexpected '7' after the 1 "
            "patches");
}

// ---- Rays -------------------------------------------------------------------------------

constexpr int kCircleSides = 64;
constexpr double kRadius = 0.3;
constexpr double kMargin = 1e-3;

// Hand-computed classification of (x, y) against the 64-gon inscribed in the circle of radius
// 0.3 about (0.5, 0.5), by its distance to the centre: surely inside below the inscribed
// circle's radius r cos(pi/n), surely outside beyond r; 0 = too close to tell.
int disk_side(double x, double y) {
  const double d = std::hypot(x - 0.5, y - 0.5);
  if (d < kRadius * std::cos(kPi / kCircleSides) - kMargin) return 1;
  if (d > kRadius + kMargin) return -1;
  return 0;
}

void check_flat_grid(const PatchSurface& s, bool keep_disk) {
  int tested = 0, hits = 0;
  std::vector<Crossing> cr;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) {
      const double x = 0.005 + 0.01 * i, y = 0.005 + 0.01 * j;
      const int side = disk_side(x, y);
      if (side == 0) continue;
      const bool expect = keep_disk ? side > 0 : side < 0;
      const Ray ray{{float(x), float(y), 1}, {0, 0, -1}};
      SurfaceHit h;
      const bool hit = s.intersect(ray, 0, kInf, &h);
      EXPECT_EQ(hit, expect) << "x " << x << " y " << y;
      s.crossings(ray, 0, kInf, &cr);
      EXPECT_EQ(cr.size(), expect ? 1u : 0u) << "x " << x << " y " << y;
      if (hit) {
        ++hits;
        EXPECT_NEAR(h.t, 1.0f, 1e-6f);
        EXPECT_NEAR(h.u, x, 1e-6);
        EXPECT_NEAR(h.v, y, 1e-6);
        EXPECT_EQ(cr[0].facing, 1);  // against the patch's normal (+z): an entry
      }
      ++tested;
    }
  EXPECT_GT(tested, 9000);
  EXPECT_GT(hits, 2000);
}

TEST(TrimRays, FlatSquareKeepsTheDisk) {
  const PatchSet set = parse_ok(kFlatSquare + "trim 1 1\n" + polygon_loop(kCircleSides, kRadius));
  const auto s = PatchSurface::build(set);
  check_flat_grid(*s, /*keep_disk=*/true);
}

TEST(TrimRays, FlatSquareWithAHole) {
  const PatchSet set =
      parse_ok(kFlatSquare + "trim 1 2\n4 0 0 1 0 1 1 0 1\n" + polygon_loop(kCircleSides, kRadius));
  const auto s = PatchSurface::build(set);
  check_flat_grid(*s, /*keep_disk=*/false);
}

// A curved bicubic patch: x(u) = cubic with control values 0, 0.1, 0.6, 1 (increasing, not
// linear), y = v, z(u) = 2.4 u (1 - u) (control values 0, 0.8, 0.8, 0), trimmed to the
// parameter rectangle [0.25, 0.75] x [0, 1].
std::string curved_bpt() {
  const double xs[4] = {0, 0.1, 0.6, 1}, zs[4] = {0, 0.8, 0.8, 0};
  std::string s = "1\n3 3\n";
  char buf[96];
  for (int j = 0; j < 4; ++j)
    for (int i = 0; i < 4; ++i) {
      std::snprintf(buf, sizeof buf, "%g %g %g\n", xs[i], j / 3.0, zs[i]);
      s += buf;
    }
  return s + "trim 1 1\n4  0.25 0  0.75 0  0.75 1  0.25 1\n";
}

double curve_x(double u) {
  const double s = 1 - u;
  return 3 * u * s * s * 0.1 + 3 * u * u * s * 0.6 + u * u * u;
}

// x(u) = x by bisection (x is increasing).
double solve_u(double x) {
  double lo = 0, hi = 1;
  for (int k = 0; k < 80; ++k) (curve_x(0.5 * (lo + hi)) < x ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

TEST(TrimRays, CurvedPatchTrimmedToARectangle) {
  const PatchSet set = parse_ok(curved_bpt());
  const auto s = PatchSurface::build(set);
  int tested = 0, hits = 0;
  std::vector<Crossing> cr;
  for (int i = 0; i < 200; ++i)
    for (double y : {0.1, 0.5, 0.93}) {
      const double x = 0.0025 + 0.005 * i;
      const double u = solve_u(x);
      if (std::abs(u - 0.25) < kMargin || std::abs(u - 0.75) < kMargin) continue;
      const bool expect = u > 0.25 && u < 0.75;
      const Ray ray{{float(x), float(y), 2}, {0, 0, -1}};
      SurfaceHit h;
      const bool hit = s->intersect(ray, 0, kInf, &h);
      EXPECT_EQ(hit, expect) << "x " << x << " u " << u;
      s->crossings(ray, 0, kInf, &cr);
      EXPECT_EQ(cr.size(), expect ? 1u : 0u) << "x " << x << " u " << u;
      if (hit) {
        ++hits;
        EXPECT_NEAR(h.u, u, 1e-5);
        EXPECT_NEAR(h.v, y, 1e-5);
        EXPECT_NEAR(h.t, 2 - 2.4 * u * (1 - u), 1e-5);
      }
      ++tested;
    }
  EXPECT_GT(tested, 550);
  EXPECT_GT(hits, 250);
}

TEST(TrimRays, CrossingsOfTheCurvedPatchCountTheKeptRoots) {
  // Rays along +x at height z0 meet z(u) = 2.4 u (1 - u) = z0 at u = (1 -+ sqrt(1 - z0/0.6))/2,
  // both kept when the smaller is above 0.25 (z0 > 0.45), neither below.
  const PatchSet set = parse_ok(curved_bpt());
  const auto s = PatchSurface::build(set);
  std::vector<Crossing> cr;
  int two = 0;
  for (int k = 1; k < 59; ++k) {
    const double z0 = 0.01 * k + 0.001;
    const double u1 = 0.5 * (1 - std::sqrt(1 - z0 / 0.6)), u2 = 1 - u1;
    if (std::abs(u1 - 0.25) < kMargin) continue;
    const bool kept = u1 > 0.25;
    s->crossings({{-1, 0.4f, float(z0)}, {1, 0, 0}}, 0, kInf, &cr);
    ASSERT_EQ(cr.size(), kept ? 2u : 0u) << "z0 " << z0;
    if (kept) {
      ++two;
      EXPECT_NEAR(cr[0].t, 1 + curve_x(u1), 1e-5);
      EXPECT_NEAR(cr[1].t, 1 + curve_x(u2), 1e-5);
      EXPECT_EQ(cr[0].facing, -cr[1].facing);
    }
  }
  EXPECT_GT(two, 10);
}

TEST(TrimRays, TrimmedTeapotBodyAgreesWithTheUntrimmedOne) {
  // The body patches (4..11) get a hole of radius 0.2 about (0.5, 0.5); their pieces straddle,
  // keep or lose it. A ray's nearest untrimmed hit stays when its (u, v) is kept, and moves
  // farther (or away) when it is in a hole.
  Result<PatchSet> teapot = load_bpt(std::string(HFRT_CORPUS_DIR) + "/bezier/teapot.bpt");
  ASSERT_TRUE(teapot.ok());
  PatchSet trimmed = *teapot;
  std::vector<UV> hole;
  for (int k = 0; k < 48; ++k)
    hole.push_back(
        {0.5 + 0.2 * std::cos(2 * kPi * k / 48), 0.5 + 0.2 * std::sin(2 * kPi * k / 48)});
  trimmed.trims.resize(trimmed.patches.size());
  for (int p = 4; p < 12; ++p)
    trimmed.trims[p] = Trim(std::vector<std::vector<UV>>{{{0, 0}, {1, 0}, {1, 1}, {0, 1}}, hole});
  const auto full = PatchSurface::build(*teapot);
  const auto cut = PatchSurface::build(trimmed);
  EXPECT_LT(cut->num_pieces(), full->num_pieces());
  std::mt19937 rng(7);
  const Box box = full->bounds();
  int kept = 0, removed = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vec3 org = box.center() + testing::random_direction(rng) * (2 * length(box.diagonal()));
    const Ray ray{org, testing::random_point(rng, box) - org};
    SurfaceHit a, b;
    if (!full->intersect(ray, 0, kInf, &a)) {
      EXPECT_FALSE(cut->intersect(ray, 0, kInf, &b));
      continue;
    }
    const bool body = a.prim >= 4 && a.prim < 12;
    const double d = std::hypot(a.u - 0.5, a.v - 0.5);
    if (!body || d > 0.2 + kMargin) {
      ASSERT_TRUE(cut->intersect(ray, 0, kInf, &b)) << "ray " << i;
      EXPECT_EQ(b.prim, a.prim);
      EXPECT_FLOAT_EQ(b.t, a.t);
      ++kept;
    } else if (d < 0.2 * std::cos(kPi / 48) - kMargin) {
      if (cut->intersect(ray, 0, kInf, &b)) {
        EXPECT_GT(b.t, a.t) << "ray " << i;
      }
      ++removed;
    }
  }
  EXPECT_GT(kept, 500);
  EXPECT_GT(removed, 50);
}

TEST(TrimRays, UntrimmedPatchesTraceAsBefore) {
  // A trims vector of empty Trims is the untrimmed surface, hit for hit.
  Result<PatchSet> teapot = load_bpt(std::string(HFRT_CORPUS_DIR) + "/bezier/teapot.bpt");
  ASSERT_TRUE(teapot.ok());
  PatchSet same = *teapot;
  same.trims.resize(same.patches.size());
  const auto a = PatchSurface::build(*teapot), b = PatchSurface::build(same);
  EXPECT_EQ(a->num_pieces(), b->num_pieces());
  EXPECT_EQ(a->field_error(), b->field_error());
  std::mt19937 rng(3);
  const Box box = a->bounds();
  std::vector<Crossing> ca, cb;
  for (int i = 0; i < 300; ++i) {
    const Vec3 org = box.center() + testing::random_direction(rng) * (2 * length(box.diagonal()));
    const Ray ray{org, testing::random_point(rng, box) - org};
    SurfaceHit ha, hb;
    ASSERT_EQ(a->intersect(ray, 0, kInf, &ha), b->intersect(ray, 0, kInf, &hb));
    EXPECT_EQ(ha.t, hb.t);
    a->crossings(ray, 0, kInf, &ca);
    b->crossings(ray, 0, kInf, &cb);
    ASSERT_EQ(ca.size(), cb.size());
  }
}

// ---- The field tessellation -------------------------------------------------------------

double shoelace(const std::vector<UV>& loop) {
  double a = 0;
  for (size_t k = 0; k < loop.size(); ++k) {
    const UV p = loop[k], q = loop[(k + 1) % loop.size()];
    a += p.u * q.v - q.u * p.v;
  }
  return 0.5 * std::abs(a);
}

// The tessellation's total area (the flat square maps (u, v) to (u, v, 0)); every triangle
// counter-clockwise (normal +z, as the patch's).
double tessellated_area(const PatchSet& set, int n) {
  const TriangleMesh m = tessellate(set, n);
  double area = 0;
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const Vec3 a = m.corner(t, 0), b = m.corner(t, 1), c = m.corner(t, 2);
    const double z =
        (double(b.x) - a.x) * (double(c.y) - a.y) - (double(b.y) - a.y) * (double(c.x) - a.x);
    EXPECT_GE(z, 0) << "triangle " << t;
    area += 0.5 * z;
  }
  return area;
}

TEST(TrimField, ClippedTessellationHasTheExactArea) {
  const PatchSet disk = parse_ok(kFlatSquare + "trim 1 1\n" + polygon_loop(kCircleSides, kRadius));
  const double polygon = shoelace(disk.trims[0].loops()[0]);
  // The float vertices round the area by ~1e-7 per triangle edge.
  for (int n : {1, 7, 32}) {
    EXPECT_NEAR(tessellated_area(disk, n), polygon, 2e-6) << n;
    const PatchSet ring = parse_ok(kFlatSquare + "trim 1 2\n4 0 0 1 0 1 1 0 1\n" +
                                   polygon_loop(kCircleSides, kRadius));
    EXPECT_NEAR(tessellated_area(ring, n), 1 - polygon, 2e-6) << n;
    // Two overlapping squares, even-odd: 0.25 + 0.25 - 2 x 0.04.
    const PatchSet two = parse_ok(kFlatSquare +
                                  "trim 1 2\n4 0.1 0.1 0.6 0.1 0.6 0.6 0.1 0.6\n"
                                  "4 0.4 0.4 0.9 0.4 0.9 0.9 0.4 0.9\n");
    EXPECT_NEAR(tessellated_area(two, n), 0.42, 2e-6) << n;
    // A self-crossing bow tie: two triangles of area 0.09 (a signed area would cancel).
    const PatchSet bow = parse_ok(kFlatSquare + "trim 1 1\n4 0.2 0.2 0.8 0.8 0.8 0.2 0.2 0.8\n");
    EXPECT_NEAR(tessellated_area(bow, n), 0.18, 2e-6) << n;
  }
}

// The even-odd area of loops by horizontal scanlines (independent of Trim): at each height the
// sorted crossings with the edges pair up into kept intervals; midpoint rule over v.
double scanline_area(const std::vector<std::vector<UV>>& loops, int lines) {
  double area = 0;
  std::vector<double> xs;
  for (int k = 0; k < lines; ++k) {
    const double v = (k + 0.5) / lines;
    xs.clear();
    for (const std::vector<UV>& loop : loops)
      for (size_t i = 0; i < loop.size(); ++i) {
        const UV a = loop[i], b = loop[(i + 1) % loop.size()];
        if ((a.v > v) != (b.v > v)) xs.push_back(a.u + (v - a.v) * (b.u - a.u) / (b.v - a.v));
      }
    std::sort(xs.begin(), xs.end());
    for (size_t i = 0; i + 1 < xs.size(); i += 2) area += (xs[i + 1] - xs[i]) / lines;
  }
  return area;
}

TEST(TrimField, ClipMatchesScanlinesOnRandomLoops) {
  // Random loops of 3 to 12 points, 1 to 3 per patch: self-crossing, overlapping, touching
  // the border. The clipped tessellation's area = the scanline area; its triangles are
  // counter-clockwise and each lies in its grid cell.
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int trial = 0; trial < 60; ++trial) {
    std::vector<std::vector<UV>> loops(1 + rng() % 3);
    for (std::vector<UV>& loop : loops) {
      loop.resize(3 + rng() % 10);
      for (UV& p : loop) p = {unit(rng), unit(rng)};
      if (trial % 5 == 0) loop[0].u = 0;  // on the patch border
    }
    const Trim trim(loops);
    const double expect = scanline_area(loops, 40000);
    for (int n : {1, 5, 32}) {
      double area = 0;
      std::vector<std::array<UV, 3>> tris;
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const double u0 = double(i) / n, u1 = double(i + 1) / n, v0 = double(j) / n,
                       v1 = double(j + 1) / n;
          tris.clear();
          switch (trim.classify(u0, u1, v0, v1)) {
            case Trim::Cover::kKept:
              area += (u1 - u0) * (v1 - v0);
              break;
            case Trim::Cover::kRemoved:
              break;
            case Trim::Cover::kPartial:
              trim.clip(u0, u1, v0, v1, &tris);
              break;
          }
          for (const std::array<UV, 3>& t : tris) {
            const double a = 0.5 * ((t[1].u - t[0].u) * (t[2].v - t[0].v) -
                                    (t[1].v - t[0].v) * (t[2].u - t[0].u));
            EXPECT_GE(a, -1e-15);
            area += a;
            for (const UV& q : t) {
              EXPECT_TRUE(q.u >= u0 && q.u <= u1 && q.v >= v0 && q.v <= v1);
            }
          }
        }
      EXPECT_NEAR(area, expect, 1e-5) << "trial " << trial << " n " << n;
    }
  }
}

TEST(TrimField, FlatDiskDistances) {
  const PatchSet set = parse_ok(kFlatSquare + "trim 1 1\n" + polygon_loop(kCircleSides, kRadius));
  const auto s = PatchSurface::build(set);
  ASSERT_TRUE(s->has_field());
  EXPECT_LT(s->field_error(), 1e-6f);
  // Above the centre; beside the polygon vertex (0.8, 0.5) in its plane (untrimmed: 0); and in
  // the cut-away corner, nearest to the vertex at 45 degrees.
  EXPECT_NEAR(s->signed_distance({0.5f, 0.5f, 0.25f}), -0.25f, 1e-5f);
  EXPECT_NEAR(s->signed_distance({1.0f, 0.5f, 0}), -0.2f, 1e-5f);
  const float corner = static_cast<float>(std::hypot(0.5, 0.5) - kRadius);
  EXPECT_NEAR(s->signed_distance({1, 1, 0}), -corner, 1e-5f);
  EXPECT_LT(s->winding_number({0.5f, 0.5f, 0.1f}), 0.5);  // an open disk has no inside
  const DistanceBounds b =
      s->signed_distance_bounds({{0.95f, 0.45f, -0.05f}, {1.05f, 0.55f, 0.05f}});
  EXPECT_LE(b.lo, -0.2f);
  EXPECT_LT(b.hi, 0);

  const PatchSet ring =
      parse_ok(kFlatSquare + "trim 1 2\n4 0 0 1 0 1 1 0 1\n" + polygon_loop(kCircleSides, kRadius));
  const auto r = PatchSurface::build(ring);
  const float d = -r->signed_distance({0.5f, 0.5f, 0});  // to the hole's rim
  EXPECT_GE(d, kRadius * std::cos(kPi / kCircleSides) - 1e-5);
  EXPECT_LE(d, kRadius + 1e-5);
}

TEST(TrimField, CurvedPatchWithinFieldError) {
  const PatchSet set = parse_ok(curved_bpt());
  for (const bool exact : {true, false}) {
    SCOPED_TRACE(exact ? "exact field" : "tessellated field");
    PatchSurface::Options options;
    options.exact_field = exact;
    const auto s = PatchSurface::build(set, options);
    const float err = s->field_error();
    if (exact) {
      EXPECT_FALSE(s->has_tessellation());
      EXPECT_EQ(err, 0.0f);
    } else {
      EXPECT_GT(err, 0.0f);
      EXPECT_LT(err, 1e-3f);
    }
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> unit(0, 1);
    for (int i = 0; i < 2000; ++i) {
      const double u = unit(rng), v = unit(rng);
      const Vec3 p = to_f(set.patches[0].eval(u, v));
      const float d = std::abs(s->signed_distance(p));
      if (u > 0.25 && u < 0.75) {
        // A kept point is on the tessellation, up to its error.
        EXPECT_LE(d, err + 1e-6f) << "u " << u << " v " << v;
      } else {
        // A trimmed-away point is at least as far as the difference in x from the kept part
        // (x(u) is increasing), less the error.
        const double gap = u < 0.25 ? curve_x(0.25) - curve_x(u) : curve_x(u) - curve_x(0.75);
        EXPECT_GE(d, gap - err - 1e-6) << "u " << u << " v " << v;
      }
    }
  }
}

// ---- Nothing left ------------------------------------------------------------------------

TEST(TrimField, PatchesTrimmedAway) {
  // One loop twice: inside two loops, so nothing is kept.
  const std::string twice = "trim 1 2\n3 0 0 1 0 0 1\n3 0 0 1 0 0 1\n";
  const PatchSet set = parse_ok(kFlatSquare + twice);
  const auto s = PatchSurface::build(set);
  EXPECT_FALSE(s->has_field());
  SurfaceHit h;
  EXPECT_FALSE(s->intersect({{0.2f, 0.2f, 1}, {0, 0, -1}}, 0, kInf, &h));
  std::vector<Crossing> cr{{1, 1, 0}};
  s->crossings({{0.2f, 0.2f, 1}, {0, 0, -1}}, 0, kInf, &cr);
  EXPECT_TRUE(cr.empty());
  EXPECT_LT(s->signed_distance({0.2f, 0.2f, 0}), 0);
  EXPECT_EQ(s->winding_number({0.2f, 0.2f, 0}), 0.0);
  EXPECT_LT(s->signed_distance_bounds({{0, 0, 0}, {1, 1, 1}}).hi, 0);
  EXPECT_EQ(s->stats().triangles, 0u);

  // Of two patches (the second one unit higher), the trimmed-away one is gone, the other stays.
  const PatchSet two =
      parse_ok("2\n" + kFlatSquare.substr(2) + "1 1 0 0 1 1 0 1 0 1 1 1 1 1\n" + twice);
  const auto t = PatchSurface::build(two);
  ASSERT_TRUE(t->intersect({{0.2f, 0.2f, 2}, {0, 0, -1}}, 0, kInf, &h));
  EXPECT_EQ(h.prim, 1u);
  EXPECT_FALSE(t->intersect({{0.2f, 0.2f, 0.5f}, {0, 0, -1}}, 0, kInf, &h));
  EXPECT_NEAR(t->signed_distance({0.5f, 0.5f, 0}), -1.0f, 1e-5f);
}

TEST(TrimField, ClosestPointsNearTrimLoopsAreKeptPoints) {
  // A closest-point query within a finite distance is answered on the patches themselves
  // (PatchSurface::closest_point_on_patches), where a trimmed piece's projection counts only
  // if the trim keeps it. Near a trim loop the kept closest point may lie on the loop: the
  // exact field finds it on the loop's curve (NearestOnCurves); the tessellated field's search,
  // which does not, must leave the answer to the tessellation (clipped to the kept region)
  // rather than return a farther point. Points around the rim's hole and the flat disks'
  // edges of the cup: both distances are the tessellation's within its error.
  Result<PatchSet> set = load_bpt(std::string(HFRT_SOURCE_DIR) + "/examples/data/trimmed_cup.bpt");
  ASSERT_TRUE(set.ok()) << set.error().message;
  PatchSurface::Options tessellated;
  tessellated.exact_field = false;
  const auto t = PatchSurface::build(*set, tessellated);
  PatchSurface::Options all_curves;  // the cup has more border curves than the default takes
  all_curves.max_exact_curves = 1000;
  const auto e = PatchSurface::build(*set, all_curves);
  ASSERT_TRUE(t->has_tessellation());
  ASSERT_FALSE(e->has_tessellation());
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> angle(0, 6.2831853f), off(-0.08f, 0.08f);
  int checked = 0;
  for (int k = 0; k < 2000; ++k) {
    // Near the rim's inner loop (radius 0.8 at z = 1), the floor's edge (radius 0.8 at
    // z = -0.6) and the base's edge (radius 1 at z = -1).
    const float a = angle(rng);
    const float r[3] = {0.8f, 0.8f, 1.0f}, z[3] = {1.0f, -0.6f, -1.0f};
    const int which = k % 3;
    const Vec3 q{(r[which] + off(rng)) * std::cos(a), (r[which] + off(rng)) * std::sin(a),
                 z[which] + off(rng)};
    const ClosestPoint f = t->field_mesh().closest_point(q);
    for (const PatchSurface* s : {t.get(), e.get()}) {
      const ClosestPoint c = s->closest_point(q, 0.3f);
      ASSERT_NE(c.prim, ~0u) << k;
      EXPECT_NEAR(c.distance, f.distance, t->field_error() + 1e-5f)
          << k << " at " << q.x << " " << q.y << " " << q.z;
    }
    ++checked;
  }
  EXPECT_EQ(checked, 2000);
}

// ---- The example ------------------------------------------------------------------------

TEST(TrimExample, TheCupIsASolid) {
  // examples/data/trimmed_cup.bpt: walls of radius 1 and 0.8, a base disk at z = -1, a floor
  // disk at z = -0.6 and a ring-shaped rim at z = 1, the flat parts trimmed squares.
  Result<PatchSet> set = load_bpt(std::string(HFRT_SOURCE_DIR) + "/examples/data/trimmed_cup.bpt");
  ASSERT_TRUE(set.ok()) << set.error().message;
  ASSERT_EQ(set->patches.size(), 11u);
  const auto s = PatchSurface::build(*set);
  // Down the axis: through the rim's hole onto the cavity's floor, then out through the base.
  std::vector<Crossing> cr;
  s->crossings({{0, 0, 3}, {0, 0, -1}}, 0, kInf, &cr);
  ASSERT_EQ(cr.size(), 2u);
  EXPECT_NEAR(cr[0].t, 3.6f, 1e-5f);
  EXPECT_EQ(cr[0].facing, 1);
  EXPECT_NEAR(cr[1].t, 4.0f, 1e-5f);
  EXPECT_EQ(cr[1].facing, -1);
  // Down the wall: onto the rim, out through the base.
  s->crossings({{0.9f, 0, 3}, {0, 0, -1}}, 0, kInf, &cr);
  ASSERT_EQ(cr.size(), 2u);
  EXPECT_NEAR(cr[0].t, 2.0f, 1e-5f);
  EXPECT_NEAR(cr[1].t, 4.0f, 1e-5f);
  // Outside the base's disk, beside the cup: nothing (untrimmed, the square's corner).
  s->crossings({{0.9f, 0.9f, 3}, {0, 0, -1}}, 0, kInf, &cr);
  EXPECT_TRUE(cr.empty());
  // Sideways at mid height: wall, cavity, wall.
  s->crossings({{-3, 0, 0}, {1, 0, 0}}, 0, kInf, &cr);
  ASSERT_EQ(cr.size(), 4u);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(cr[k].facing, k % 2 == 0 ? 1 : -1);
  // The field: inside the wall and the base, outside in the cavity and around.
  EXPECT_GT(s->winding_number({0.9f, 0, 0}), 0.9);
  EXPECT_GT(s->winding_number({0, 0, -0.8f}), 0.9);
  // In the cavity: 0. The exact field's cracks sealed (the trim polygons along the walls'
  // rims), no boundary is left: the winding number is the crossings' count, an integer.
  EXPECT_FALSE(s->has_tessellation());
  EXPECT_EQ(s->winding_number({0, 0, 0}), 0.0);
  EXPECT_LT(s->winding_number({0.9f, 0.9f, -1}), 0.1);
  EXPECT_GT(s->signed_distance({0.9f, 0, 0}), 0.09f - 1e-3f);
  EXPECT_LT(s->signed_distance({0, 0, 0.5f}), -0.6f);
  EXPECT_LT(s->field_error(), 1e-3f);
}

// ---- The kept region's border (Trim::border, the exact field's trim curves) -----------------

// The border's segments run with the kept region on their left, so the shoelace sum over them
// is the kept area (the even-odd region within the square), and every segment has a kept point
// just left of its middle and a removed one just right.
TEST(TrimBorder, EnclosesTheKeptAreaWithItOnTheLeft) {
  auto loop = [](std::initializer_list<UV> pts) { return std::vector<UV>(pts); };
  std::vector<UV> circle;
  for (int k = 0; k < 20000; ++k)
    circle.push_back(
        {0.5 + 0.4 * std::cos(2 * kPi * k / 20000), 0.5 + 0.4 * std::sin(2 * kPi * k / 20000)});
  const struct {
    const char* name;
    std::vector<std::vector<UV>> loops;
    double area;
  } cases[] = {
      // Two overlapping squares: their overlap is inside both, so removed.
      {"overlap",
       {loop({{0.1, 0.1}, {0.6, 0.1}, {0.6, 0.6}, {0.1, 0.6}}),
        loop({{0.4, 0.4}, {0.9, 0.4}, {0.9, 0.9}, {0.4, 0.9}})},
       0.25 + 0.25 - 2 * 0.04},
      // A bow tie (a loop crossing itself): both lobes, each a triangle of area 0.08 (base 0.4 at u
      // = 0.1 or 0.9, height 0.4).
      {"bow tie", {loop({{0.1, 0.1}, {0.9, 0.5}, {0.9, 0.1}, {0.1, 0.5}})}, 2 * 0.5 * 0.4 * 0.4},
      // Along three sides of the square, clockwise.
      {"lower half", {loop({{0, 0.5}, {1, 0.5}, {1, 0}, {0, 0}})}, 0.5},
      // The whole square less a square hole touching its left side.
      {"notch",
       {loop({{0, 0}, {1, 0}, {1, 1}, {0, 1}}),
        loop({{0, 0.25}, {0.5, 0.25}, {0.5, 0.75}, {0, 0.75}})},
       1 - 0.25},
      // A loop edge 1e-9 from the square's left side: the sliver between them is not kept, so
      // the side is no border (probes 1e-7 apart jumped over the sliver and kept both).
      {"sliver", {loop({{1e-9, 0.2}, {0.5, 0.2}, {0.5, 0.8}, {1e-9, 0.8}})}, 0.6 * (0.5 - 1e-9)},
      // A polygon of 20000 edges (the sweep over sorted segments keeps this fast).
      {"circle", {circle}, 0.5 * 20000 * 0.4 * 0.4 * std::sin(2 * kPi / 20000)},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    const Trim trim(c.loops);
    const std::vector<std::array<UV, 2>> border = trim.border();
    ASSERT_FALSE(border.empty());
    double area = 0;
    for (const auto& [a, b] : border) {
      area += 0.5 * (a.u * b.v - b.u * a.v);
      const UV m{0.5 * (a.u + b.u), 0.5 * (a.v + b.v)}, d{b.u - a.u, b.v - a.v};
      const double len = std::hypot(d.u, d.v), h = std::min(1e-11, 0.01 * len) / len;
      const UV left{m.u - h * d.v, m.v + h * d.u}, right{m.u + h * d.v, m.v - h * d.u};
      auto kept = [&](UV q) {
        return q.u >= 0 && q.u <= 1 && q.v >= 0 && q.v <= 1 && trim.contains(q.u, q.v);
      };
      EXPECT_TRUE(kept(left) && !kept(right)) << a.u << " " << a.v << " -> " << b.u << " " << b.v;
    }
    EXPECT_NEAR(area, c.area, 1e-12);
    if (std::string(c.name) == "sliver") {
      EXPECT_EQ(border.size(), 4u);
    }
  }
  // Nothing kept (a loop twice): no border.
  const auto tri = loop({{0, 0}, {1, 0}, {0, 1}});
  EXPECT_TRUE(Trim({tri, tri}).border().empty());
}

}  // namespace
}  // namespace hfrt::geom
