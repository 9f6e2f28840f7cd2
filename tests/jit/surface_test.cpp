// The mesh and patch leaves (issue 10) through the compiled model: hfMesh, hfTriangles,
// hfBezierSurface and hfBezierPatches as kSurface in every evaluator (interpreter, scalar JIT
// in f64 and f32, interval and gradient domains), their compile-time diagnostics with text
// and location, instancing, the polynomial domain's surface leaves and the POV emitter's
// refusal.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "hfrt/model.h"
#include "jit/lower.h"
#include "jit/poly.h"
#include "jit/pov_emit.h"
#include "jit/surface_ops.h"
#include "lang/frontend.h"

namespace hfrt {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("hfrt_surface_test_" + std::to_string(getpid()));
  fs::create_directories(d);
  return d;
}

fs::path write_file(const std::string& name, const std::string& text) {
  fs::path p = temp_dir() / name;
  std::ofstream(p) << text;
  return p;
}

using P3 = std::array<double, 3>;
P3 sub(P3 a, P3 b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
double dot(P3 a, P3 b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
P3 cross(P3 a, P3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double norm(P3 a) {
  return std::sqrt(dot(a, a));
}

/// A closed, outward-oriented, non-convex triangle mesh: a latitude-longitude sphere whose
/// radius varies with direction (bumps and dents).
struct TestMesh {
  std::vector<P3> v;
  std::vector<std::array<int, 3>> t;

  static TestMesh bumpy(int rings = 10, int sectors = 16) {
    TestMesh m;
    auto radius = [](double th, double ph) {
      return 1 + 0.3 * std::sin(3 * th) * std::cos(2 * ph);
    };
    m.v.push_back({0, 0, radius(0, 0)});
    for (int i = 1; i < rings; ++i) {
      double th = M_PI * i / rings;
      for (int j = 0; j < sectors; ++j) {
        double ph = 2 * M_PI * j / sectors, r = radius(th, ph);
        m.v.push_back(
            {r * std::sin(th) * std::cos(ph), r * std::sin(th) * std::sin(ph), r * std::cos(th)});
      }
    }
    m.v.push_back({0, 0, -radius(M_PI, 0)});
    const int south = int(m.v.size()) - 1;
    auto at = [&](int i, int j) { return 1 + (i - 1) * sectors + (j % sectors); };
    for (int j = 0; j < sectors; ++j) m.t.push_back({0, at(1, j), at(1, j + 1)});
    for (int i = 1; i + 1 < rings; ++i) {
      for (int j = 0; j < sectors; ++j) {
        m.t.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
        m.t.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
    for (int j = 0; j < sectors; ++j)
      m.t.push_back({south, at(rings - 1, j + 1), at(rings - 1, j)});
    return m;
  }

  static TestMesh cube(double h) {
    TestMesh m;
    for (int k = 0; k < 8; ++k) m.v.push_back({k & 1 ? h : -h, k & 2 ? h : -h, k & 4 ? h : -h});
    const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                         {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (auto& f : q) {
      m.t.push_back({f[0], f[1], f[2]});
      m.t.push_back({f[0], f[2], f[3]});
    }
    return m;
  }

  std::string off() const {
    std::ostringstream s;
    s.precision(17);
    s << "OFF\n" << v.size() << " " << t.size() << " 0\n";
    for (const P3& p : v) s << p[0] << " " << p[1] << " " << p[2] << "\n";
    for (const auto& f : t) s << "3 " << f[0] << " " << f[1] << " " << f[2] << "\n";
    return s.str();
  }

  /// Closest point on triangle (Ericson, Real-Time Collision Detection 5.1.5).
  static P3 closest(P3 p, P3 a, P3 b, P3 c) {
    P3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
    double d1 = dot(ab, ap), d2 = dot(ac, ap);
    if (d1 <= 0 && d2 <= 0) return a;
    P3 bp = sub(p, b);
    double d3 = dot(ab, bp), d4 = dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) return b;
    double vc = d1 * d4 - d3 * d2;
    auto lerp = [](P3 x, P3 d, double s) {
      return P3{x[0] + s * d[0], x[1] + s * d[1], x[2] + s * d[2]};
    };
    if (vc <= 0 && d1 >= 0 && d3 <= 0) return lerp(a, ab, d1 / (d1 - d3));
    P3 cp = sub(p, c);
    double d5 = dot(ab, cp), d6 = dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) return c;
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) return lerp(a, ac, d2 / (d2 - d6));
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
      return lerp(b, sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    double denom = 1 / (va + vb + vc);
    double sv = vb * denom, sw = vc * denom;
    return {a[0] + ab[0] * sv + ac[0] * sw, a[1] + ab[1] * sv + ac[1] * sw,
            a[2] + ab[2] * sv + ac[2] * sw};
  }

  /// Brute force: distance to the closest triangle, sign from the exact winding number
  /// (solid angles, Van Oosterom and Strackee), positive inside; `second` is the distance
  /// gap to the runner-up closest point direction (to skip ambiguous gradients).
  double signed_distance(P3 p, P3* closest_point = nullptr) const {
    double best = 1e300, w = 0;
    for (const auto& f : t) {
      P3 a = v[f[0]], b = v[f[1]], c = v[f[2]];
      P3 q = closest(p, a, b, c);
      double d = norm(sub(p, q));
      if (d < best) {
        best = d;
        if (closest_point) *closest_point = q;
      }
      P3 ra = sub(a, p), rb = sub(b, p), rc = sub(c, p);
      double la = norm(ra), lb = norm(rb), lc = norm(rc);
      double num = dot(ra, cross(rb, rc));
      double den = la * lb * lc + dot(ra, rb) * lc + dot(rb, rc) * la + dot(rc, ra) * lb;
      w += 2 * std::atan2(num, den);
    }
    w /= 4 * M_PI;
    return w >= 0.5 ? best : -best;
  }
};

std::string mesh_model(const std::string& leaf) {
  return "my_model(x[3], a[1]) {\n  my_model = " + leaf + ";\n}\n";
}

CompileResult compile_in_temp(const std::string& name, const std::string& text,
                              Backend backend = Backend::kJit) {
  fs::path model = write_file(name, text);
  ModelOptions mo;
  mo.backend = backend;
  return Model::compile_file(model.string(), mo);
}

// ---- field conformance ------------------------------------------------------------------------

TEST(SurfaceLeaf, MeshFieldIsTheBruteForceSignedDistance) {
  const TestMesh mesh = TestMesh::bumpy();
  write_file("bumpy.off", mesh.off());
  CompileResult jit = compile_in_temp("bumpy.hf", mesh_model("hfMesh(x, \"bumpy.off\")"));
  ASSERT_TRUE(jit.ok()) << jit.rendered << jit.error;
  CompileResult interp =
      compile_in_temp("bumpy.hf", mesh_model("hfMesh(x, \"bumpy.off\")"), Backend::kInterp);
  ASSERT_TRUE(interp.ok()) << interp.rendered;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.6, 1.6);
  const int n = 400;
  std::vector<double> xs(3 * n), f64(n), grad(4 * n);
  std::vector<float> xf(3 * n), f32(n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) xs[k * n + i] = xf[k * n + i] = float(u(rng));  // exact in float
  }
  jit.model->eval_batch(n, xs.data(), f64.data());
  jit.model->eval_batch(n, xf.data(), f32.data());
  jit.model->eval_gradient_batch(n, xs.data(), grad.data());
  int inside = 0, checked_grad = 0;
  for (int i = 0; i < n; ++i) {
    const P3 p = {xs[i], xs[n + i], xs[2 * n + i]};
    P3 q = {0, 0, 0};
    const double ref = mesh.signed_distance(p, &q);
    const PointValue iv = interp.model->eval({p[0], p[1], p[2]});
    ASSERT_TRUE(iv.ok());
    // The surface works in float: 1e-5 of the mesh's size.
    EXPECT_NEAR(iv.f, ref, 1e-5) << "interpreter at " << p[0] << "," << p[1] << "," << p[2];
    EXPECT_EQ(iv.f, f64[i]) << "the JIT calls the same code as the interpreter";
    EXPECT_NEAR(f32[i], ref, 1e-5);
    EXPECT_EQ(grad[i], f64[i]) << "the gradient's value is the scalar value";
    inside += ref > 0;
    if (std::abs(ref) > 1e-3) {
      // The gradient is the unit vector from the closest point, into the solid.
      P3 g = {grad[n + i], grad[2 * n + i], grad[3 * n + i]};
      P3 want = sub(p, q);
      const double s = (ref > 0 ? 1 : -1) / norm(want);
      for (int k = 0; k < 3; ++k) want[k] *= s;
      if (norm(sub(g, want)) > 1e-3) {
        // Two triangles equally close (an edge or vertex region seen from the medial axis):
        // both directions are right.
        ASSERT_NEAR(std::abs(ref), norm(sub(p, q)), 1e-6);
      } else {
        ++checked_grad;
      }
    }
  }
  EXPECT_GT(inside, n / 8);
  EXPECT_LT(inside, n - n / 8);
  EXPECT_GT(checked_grad, n * 3 / 4);
}

TEST(SurfaceLeaf, IntervalsEncloseTheValuesAndGradientsChainThroughTransforms) {
  const TestMesh mesh = TestMesh::bumpy();
  write_file("bumpy2.off", mesh.off());
  // Under hfScale3D and hfShift3D: F(x) = mesh((x - (1, 0, 0)) / 2) in the mesh's space.
  const std::string text =
      "my_model(x[3], a[1]) {\n  array p[3];\n  p[1] = x[1]; p[2] = x[2]; p[3] = x[3];\n"
      "  t1 = hfShift3D(p, 1, 0, 0);\n  t2 = hfScale3D(p, 2, 2, 2);\n"
      "  my_model = hfMesh(p, \"bumpy2.off\");\n}\n";
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    CompileResult r = compile_in_temp("scaled.hf", text, backend);
    ASSERT_TRUE(r.ok()) << r.rendered;
    const Model& m = *r.model;
    if (backend == Backend::kJit) {
      // The interval and gradient JITs themselves (not an interpreter fallback) are checked.
      std::string err;
      ASSERT_TRUE(m.prepare_interval(&err)) << err;
      ASSERT_TRUE(m.prepare_gradient(Precision::kF64, &err)) << err;
      ASSERT_TRUE(m.prepare_gradient(Precision::kF32, &err)) << err;
      EXPECT_EQ(m.interval_engine(), DomainEngine::kJit);
      EXPECT_EQ(m.gradient_engine(Precision::kF32), DomainEngine::kJit);
      // The f32 gradient code (the renderer's normals) agrees with the f64 one.
      const float xf[3] = {1.3f, 0.4f, -0.2f};
      const double xd[3] = {1.3f, 0.4f, -0.2f};
      float gf[4];
      double gd[4];
      m.eval_gradient_batch(1, xf, gf);
      m.eval_gradient_batch(1, xd, gd);
      for (int k = 0; k < 4; ++k) EXPECT_NEAR(gf[k], gd[k], 1e-5) << k;
    }
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-3, 4), w(0.01, 0.8);
    for (int i = 0; i < 60; ++i) {
      double lo[3], hi[3];
      for (int k = 0; k < 3; ++k) {
        lo[k] = u(rng);
        hi[k] = lo[k] + w(rng);
      }
      IntervalValue iv = m.eval_interval(lo, hi);
      ASSERT_FALSE(iv.maybe_nan);
      for (int s = 0; s < 20; ++s) {
        double p[3];
        for (int k = 0; k < 3; ++k)
          p[k] = lo[k] + (hi[k] - lo[k]) * (s % 5) / 4.0 * ((s / 5 + k) % 2 ? 1 : 0.5);
        PointValue v = m.eval(std::span<const double>(p, 3));
        EXPECT_TRUE(iv.contains(v.f)) << v.f << " not in [" << iv.lo << ", " << iv.hi << "]";
      }
      // The value at the box's centre, against the brute force in the mesh's space.
      P3 c = {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])};
      P3 q = {(c[0] - 1) / 2, c[1] / 2, c[2] / 2};
      EXPECT_NEAR(m.eval({c[0], c[1], c[2]}).f, mesh.signed_distance(q), 1e-5);
      // Chain rule: d/dx mesh((x - s) / 2) = grad(q) / 2, a vector of length 1/2.
      GradientValue g = m.eval_gradient({c[0], c[1], c[2]});
      EXPECT_NEAR(std::sqrt(g.d[0] * g.d[0] + g.d[1] * g.d[1] + g.d[2] * g.d[2]), 0.5, 1e-4);
    }
  }
}

TEST(SurfaceLeaf, InlineTrianglesAndPatchesMatchTheirFileForms) {
  const TestMesh cube = TestMesh::cube(1);
  write_file("cube1.off", cube.off());
  std::string v, t;
  for (const P3& p : cube.v)
    v += (v.empty() ? "" : ", ") + std::to_string(p[0]) + ", " + std::to_string(p[1]) + ", " +
         std::to_string(p[2]);
  for (const auto& f : cube.t)
    t += (t.empty() ? "" : ", ") + std::to_string(f[0] + 1) + ", " + std::to_string(f[1] + 1) +
         ", " + std::to_string(f[2] + 1);
  const std::string text = "my_model(x[3], a[1]) {\n  array v[24], t[36];\n  v = [" + v +
                           "];\n  t = [" + t +
                           "];\n  my_model = hfTriangles(x, v, t) - hfMesh(x, \"cube1.off\");\n}\n";
  CompileResult r = compile_in_temp("inline.hf", text);
  ASSERT_TRUE(r.ok()) << r.rendered;
  for (double z : {-2.0, -0.5, 0.0, 0.7, 1.5}) EXPECT_EQ(r.model->eval({0.3, -0.2, z}).f, 0.0);
  EXPECT_NEAR(r.model->eval({0.3, -0.2, 0.1}).f, 0.0, 0.0);

  // One bilinear patch (degree 3 written as a plane z = 0 over [0,3]^2) in both forms.
  std::string p, bpt = "1\n3 3\n";
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 4; ++i) {
      p += (p.empty() ? "" : ", ") + std::to_string(i) + ", " + std::to_string(j) + ", 0";
      bpt += std::to_string(i) + " " + std::to_string(j) + " 0\n";
    }
  }
  write_file("plane.bpt", bpt);
  CompileResult pr = compile_in_temp(
      "patch.hf",
      "my_model(x[3], a[1]) {\n  array p[48];\n  p = [" + p +
          "];\n  my_model = hfBezierPatches(x, p) - hfBezierSurface(x, \"plane.bpt\");\n}\n");
  ASSERT_TRUE(pr.ok()) << pr.rendered;
  EXPECT_EQ(pr.model->eval({1.5, 1.5, 0.25}).f, 0.0);
  CompileResult one = compile_in_temp("patch1.hf", mesh_model("hfBezierSurface(x, \"plane.bpt\")"));
  ASSERT_TRUE(one.ok()) << one.rendered;
  // Above the middle of the open patch: the distance to the plane.
  EXPECT_NEAR(std::abs(one.model->eval({1.5, 1.5, 0.25}).f), 0.25, 1e-4);
}

TEST(SurfaceLeaf, SignOnlyEvaluationHasTheSignOfF) {
  // Model::eval_batch_sign (the analytic root search's samples): each mesh leaf gives +-1, and
  // on a set-operation skeleton F keeps its sign.
  const TestMesh mesh = TestMesh::bumpy();
  write_file("sign.off", mesh.off());
  CompileResult r = compile_in_temp(
      "sign.hf",
      "my_model(x[3], a[1]) {\n  array c[3];\n  c = [0.5, 0, 0];\n"
      "  my_model = (hfMesh(x, \"sign.off\") \\ hfSphere(x, c, 0.6)) | -hfMesh(x, \"sign.off\") "
      "& (x[3] - 1.2);\n}\n");
  ASSERT_TRUE(r.ok()) << r.rendered;
  ASSERT_TRUE(r.model->analytic_info().qualifies);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.7f, 1.7f);
  const int n = 300;
  std::vector<float> xs(3 * n), f(n), s(n);
  for (float& v : xs) v = u(rng);
  r.model->eval_batch(n, xs.data(), f.data());
  r.model->eval_batch_sign(n, xs.data(), s.data());
  int positive = 0;
  for (int i = 0; i < n; ++i) {
    if (std::abs(f[i]) < 1e-6f) continue;
    EXPECT_EQ(f[i] > 0, s[i] > 0) << i << ": " << f[i] << " vs " << s[i];
    positive += f[i] > 0;
  }
  EXPECT_GT(positive, n / 10);
  EXPECT_LT(positive, n - n / 10);
  // Without a mesh leaf it is eval_batch itself.
  CompileResult plain = Model::compile("m(x[3], a[1]) { m = 1 - x[1]*x[1] - x[2]*x[2]; }");
  ASSERT_TRUE(plain.ok());
  plain.model->eval_batch(n, xs.data(), f.data());
  plain.model->eval_batch_sign(n, xs.data(), s.data());
  EXPECT_EQ(f, s);
}

/// Two overlapping cubes in one file: closed, self-intersecting (w = 2 where they overlap).
std::string two_cubes_off() {
  TestMesh a = TestMesh::cube(1), b = TestMesh::cube(0.75);
  for (P3& p : b.v) p[0] += 0.9, p[1] += 0.3;
  for (auto f : b.t) a.t.push_back({f[0] + 8, f[1] + 8, f[2] + 8});
  a.v.insert(a.v.end(), b.v.begin(), b.v.end());
  return a.off();
}

/// A cube of half-size 0.5 without its last face (an open mesh), raised by 1.2 along z.
TestMesh open_cube_above() {
  TestMesh open = TestMesh::cube(0.5);
  open.t.resize(10);  // without its last face: open
  for (P3& p : open.v) p[2] += 1.2;
  return open;
}

TEST(SurfaceLeaf, CrossingsDecideTheSideOfClosedMeshesAlongARay) {
  // The analytic search's sign queries at the gaps between a ray's candidates: on closed
  // meshes they come from the ray's crossings (jit/surface_ops.h), and must equal F's sign as
  // eval_batch (a winding number per point) gives it: on a non-convex mesh, on two
  // overlapping shells in one file (w = 2), under a transform, and next to an open mesh that
  // keeps its winding numbers.
  write_file("rs_bumpy.off", TestMesh::bumpy().off());
  write_file("rs_two.off", two_cubes_off());
  write_file("rs_open.off", open_cube_above().off());
  const std::string text =
      "my_model(x[3], a[1]) {\n  array p[3];\n  p[1] = x[1]; p[2] = x[2]; p[3] = x[3];\n"
      "  t1 = hfShift3D(p, 0, 0, -0.4);\n  t2 = hfRotate3DZ(p, 0.7);\n"
      "  my_model = (hfMesh(x, \"rs_bumpy.off\") \\ hfMesh(p, \"rs_two.off\")) | "
      "hfMesh(x, \"rs_open.off\");\n}\n";
  CompileResult r = compile_in_temp("rs.hf", text);
  ASSERT_TRUE(r.ok()) << r.rendered;
  const Model& m = *r.model;
  ASSERT_TRUE(m.analytic_info().qualifies) << m.analytic_info().reason;
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  int compared = 0, inside = 0;
  const jit::RaySideCounts before = jit::ray_sides_counts();
  for (int i = 0; i < 300; ++i) {
    // From a point outside every bound towards a point near the origin.
    P3 dir = {u(rng), u(rng), u(rng)};
    const double len = norm(dir);
    if (len < 0.1) continue;
    const double o[3] = {-8 * dir[0] / len, -8 * dir[1] / len, -8 * dir[2] / len};
    const double d[3] = {dir[0] / len + 0.3 * u(rng), dir[1] / len + 0.3 * u(rng),
                         dir[2] / len + 0.3 * u(rng)};
    std::vector<double> t;
    m.ray_surface_crossings(o, d, 0, 20, &t);
    std::sort(t.begin(), t.end());
    std::vector<double> ts = {0.0};
    for (size_t k = 0; k < t.size(); ++k)
      ts.push_back(0.5 * (t[k] + (k + 1 < t.size() ? t[k + 1] : 20.0)));
    const int n = int(ts.size());
    std::vector<float> xs(3 * n), sign(n), ref(n);
    for (int k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c) xs[c * n + k] = float(o[c] + ts[k] * d[c]);
    m.eval_batch_sign(n, xs.data(), sign.data());  // right after the crossings: the record
    m.eval_batch(n, xs.data(), ref.data());        // distances and winding numbers
    for (int k = 0; k < n; ++k) {
      if (std::abs(ref[k]) < 1e-5f) continue;  // a gap narrower than rounding
      EXPECT_EQ(sign[k] > 0, ref[k] > 0) << "ray " << i << " sample " << k << " of " << n;
      ++compared;
      inside += ref[k] > 0;
    }
  }
  const jit::RaySideCounts after = jit::ray_sides_counts();
  EXPECT_GT(compared, 600);
  EXPECT_GT(inside, 30);
  // Every closed-mesh query was answered by crossings (the rays start outside the bounds);
  // the open mesh's were winding numbers, one per sample.
  EXPECT_GE(after.from_crossings - before.from_crossings, uint64_t(2 * compared - 50));
  EXPECT_GE(after.winding - before.winding, uint64_t(compared));
  EXPECT_LE(after.winding - before.winding, uint64_t(compared + 100));
}

TEST(SurfaceLeaf, PrefetchedCrossingsAreTheSameAndAnswerTheirRays) {
  // Model::prefetch_ray_surface_crossings traces a batch of rays' leaf crossings together (the
  // renderer: a tile's camera rays; meshes in packets); ray_surface_crossings calls for those
  // rays, in that order with some skipped, take them from there. Their candidates and the sign
  // queries after them are the same as without the prefetch, on a transformed closed mesh, an
  // instance of it and an open mesh.
  write_file("pf_bumpy.off", TestMesh::bumpy().off());
  write_file("pf_open.off", open_cube_above().off());
  const std::string text =
      "my_model(x[3], a[1]) {\n  array p[3];\n  p[1] = x[1]; p[2] = x[2]; p[3] = x[3];\n"
      "  t1 = hfRotate3DZ(p, 0.7);\n"
      "  my_model = (hfMesh(x, \"pf_bumpy.off\") \\ hfMesh(p, \"pf_bumpy.off\")) | "
      "hfMesh(x, \"pf_open.off\");\n}\n";
  CompileResult r = compile_in_temp("pf.hf", text);
  ASSERT_TRUE(r.ok()) << r.rendered;
  const Model& m = *r.model;
  ASSERT_TRUE(m.analytic_info().qualifies) << m.analytic_info().reason;
  // A camera's rows of rays (coherent, as the renderer's tiles), from an eye outside.
  const int n = 96;
  std::vector<double> o(3 * n), d(3 * n), t0(n), t1(n);
  for (int i = 0; i < n; ++i) {
    const double px = -0.9 + 1.8 * (i % 12) / 11.0, py = -0.9 + 1.8 * (i / 12) / 7.0;
    o[3 * i] = 0.3, o[3 * i + 1] = 0.2, o[3 * i + 2] = 6;
    d[3 * i] = px - 0.3, d[3 * i + 1] = py - 0.2, d[3 * i + 2] = -6;
    t0[i] = i % 7 == 3 ? 0.6 : 0.0;  // some segments start later,
    t1[i] = i % 5 == 1 ? 0.8 : 2.0;  // some end early (inside the solid)
  }
  auto search = [&](int i, std::vector<double>* t, std::vector<float>* sign) {
    t->clear();
    m.ray_surface_crossings(&o[3 * i], &d[3 * i], t0[i], t1[i], t);
    std::sort(t->begin(), t->end());
    // Sign queries at the gaps' midpoints, right after the crossings (the record).
    const int k = int(t->size()) + 1;
    std::vector<float> xs(3 * k);
    for (int j = 0; j < k; ++j) {
      const double a = j == 0 ? t0[i] : (*t)[j - 1], b = j + 1 < k ? (*t)[j] : t1[i];
      for (int c = 0; c < 3; ++c)
        xs[c * k + j] = float(o[3 * i + c] + 0.5 * (a + b) * d[3 * i + c]);
    }
    sign->resize(k);
    m.eval_batch_sign(k, xs.data(), sign->data());
  };
  std::vector<std::vector<double>> plain_t(n);
  std::vector<std::vector<float>> plain_sign(n);
  for (int i = 0; i < n; ++i) search(i, &plain_t[i], &plain_sign[i]);
  const jit::RaySideCounts before = jit::ray_sides_counts();
  m.prefetch_ray_surface_crossings(o.data(), d.data(), t0.data(), t1.data(), n);
  int asked = 0, crossings = 0;
  for (int i = 0; i < n; ++i) {
    if (i % 9 == 4) continue;  // skipped rays (a camera ray that misses the box)
    std::vector<double> t;
    std::vector<float> sign;
    search(i, &t, &sign);
    EXPECT_EQ(t, plain_t[i]) << "ray " << i;
    EXPECT_EQ(sign, plain_sign[i]) << "ray " << i;
    ++asked;
    crossings += int(t.size());
  }
  Model::clear_prefetched_surface_crossings();
  const jit::RaySideCounts after = jit::ray_sides_counts();
  // Three leaves per ray, every one from the prefetch.
  EXPECT_EQ(after.prefetched - before.prefetched, uint64_t(3 * asked));
  EXPECT_GT(crossings, 2 * asked);  // most rays cross the meshes: not vacuous
  // After the clear, nothing comes from a prefetch.
  std::vector<double> t;
  std::vector<float> sign;
  search(0, &t, &sign);
  EXPECT_EQ(jit::ray_sides_counts().prefetched, after.prefetched);
  EXPECT_EQ(t, plain_t[0]);
}

TEST(SurfaceLeaf, GradientOnTheSurfaceIsTheFaceNormal) {
  // At a ray hit the point lies on the surface to rounding: the closest-point direction is
  // noise there, and the gradient (the renderer's normal) must still be the inward normal.
  write_file("faces.off", TestMesh::cube(1).off());
  CompileResult r = compile_in_temp("faces.hf", mesh_model("hfMesh(x, \"faces.off\")"));
  ASSERT_TRUE(r.ok());
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-0.9, 0.9);
  for (int i = 0; i < 200; ++i) {
    const int axis = i % 3;
    const double side = (i / 3) % 2 ? 1 : -1;
    double p[3] = {u(rng), u(rng), u(rng)};
    // On the face, give or take a float rounding step.
    p[axis] = side * (1 + (i % 5 - 2) * 1e-7);
    GradientValue g = r.model->eval_gradient(std::span<const double>(p, 3));
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(g.d[k], k == axis ? -side : 0.0, 1e-3) << i << " axis " << axis;
    }
  }
}

// ---- instancing -------------------------------------------------------------------------------

TEST(SurfaceLeaf, OneLoadedSurfaceServesEveryLeafOfTheFile) {
  write_file("inst.off", TestMesh::cube(1).off());
  const std::string text =
      "my_model(x[3], a[1]) {\n  array p[3], q[3];\n  p[1] = x[1]; p[2] = x[2]; p[3] = x[3];\n"
      "  q[1] = x[1]; q[2] = x[2]; q[3] = x[3];\n  t1 = hfShift3D(p, 3, 0, 0);\n"
      "  t2 = hfRotate3DZ(q, 0.5);\n"
      "  my_model = max(hfMesh(x, \"inst.off\"), max(hfMesh(p, \"inst.off\"), hfMesh(q, "
      "\"./inst.off\")));\n}\n";
  CompileResult r = compile_in_temp("inst.hf", text);
  ASSERT_TRUE(r.ok()) << r.rendered;
  std::vector<SurfaceStats> st = r.model->surface_stats();
  ASSERT_EQ(st.size(), 1u);
  EXPECT_EQ(st[0].leaves, 3);
  EXPECT_EQ(st[0].triangles, 12u);
  EXPECT_GT(st[0].bvh_nodes, 0u);
  EXPECT_NE(st[0].source.find("inst.off"), std::string::npos);
  // A second model of the same file shares it too (a process-wide cache).
  CompileResult again = compile_in_temp("inst2.hf", mesh_model("hfMesh(x, \"inst.off\")"));
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again.model->surface_stats().size(), 1u);
  EXPECT_NEAR(r.model->eval({3.5, 0, 0}).f, 0.5, 1e-6);
}

// ---- compile-time diagnostics: text and location ----------------------------------------------

struct LoadCase {
  const char* id;
  const char* file;  ///< written next to the model (nullptr: none)
  std::string content;
  std::string leaf;         ///< the call, at line 2 column 14
  std::string message_has;  ///< the message contains this (file name and line)
};

class SurfaceLoadError : public ::testing::TestWithParam<LoadCase> {};

TEST_P(SurfaceLoadError, IsALocatedCompileError) {
  const LoadCase& c = GetParam();
  if (c.file) write_file(c.file, c.content);
  fs::path model = write_file(std::string(c.id) + ".hf", mesh_model(c.leaf));
  CompileResult r = Model::compile_file(model.string());
  ASSERT_FALSE(r.ok()) << c.id;
  EXPECT_TRUE(r.error.empty()) << r.error;  // a source diagnostic, not an environment failure
  ASSERT_FALSE(r.diagnostics.empty());
  const SourceDiagnostic& d = r.diagnostics.front();
  EXPECT_EQ(d.severity, SourceDiagnostic::Severity::kError);
  EXPECT_NE(d.message.find(c.message_has), std::string::npos) << d.message;
  EXPECT_EQ(d.file, model.string());
  EXPECT_EQ(d.line, 2);
  EXPECT_EQ(d.col, 14);
  EXPECT_FALSE(d.hint.empty());
  // Rendered with the model location and a caret under the call.
  const std::string loc = model.string() + ":2:14: error: ";
  EXPECT_NE(r.rendered.find(loc), std::string::npos) << r.rendered;
  EXPECT_NE(r.rendered.find("^"), std::string::npos) << r.rendered;
}

const LoadCase kLoadCases[] = {
    {"missing", nullptr, "", "hfMesh(x, \"nothere.off\")", "nothere.off: no such file"},
    {"missing_bpt", nullptr, "", "hfBezierSurface(x, \"nothere.bpt\")", "nothere.bpt: cannot read"},
    {"directory", nullptr, "", "hfMesh(x, \".\")", ": is a directory"},
    {"unknown_format", "m.xyz", "1 2 3\n", "hfMesh(x, \"m.xyz\")", "unknown mesh format"},
    {"empty_file", "empty.off", "", "hfMesh(x, \"empty.off\")", "empty.off: empty file"},
    {"malformed", "bad.off", "OFF\n3 1 0\n0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n",
     "hfMesh(x, \"bad.off\")", "bad.off:4: "},
    {"bad_index", "idx.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", "hfMesh(x, \"idx.off\")",
     "idx.off:6: "},
    {"non_finite", "nan.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n",
     "hfMesh(x, \"nan.off\")", "nan.off:4: "},
    {"no_triangle", "flat.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n",
     "hfMesh(x, \"flat.off\")", "flat.off: empty mesh"},
    {"bpt_degree", "deg.bpt", "1\n4 1\n" + std::string(30, '0'), "hfBezierSurface(x, \"deg.bpt\")",
     "deg.bpt:2: "},
    {"bpt_truncated", "short.bpt", "2\n1 1\n0 0 0 1 0 0 0 1 0 1 1 0\n",
     "hfBezierSurface(x, \"short.bpt\")", "short.bpt"},
    // Endless inputs are refused before reading (the fuzzer's hang, limits.md).
    {"dev_zero", nullptr, "", "hfMesh(x, \"/dev/zero\")",
     "hfMesh: /dev/zero: is not a regular file (a device, a pipe or a socket, which may never "
     "end)"},
    {"dev_zero_bpt", nullptr, "", "hfBezierSurface(x, \"/dev/zero\")",
     "hfBezierSurface: /dev/zero: is not a regular file"},
};

INSTANTIATE_TEST_SUITE_P(Files, SurfaceLoadError, ::testing::ValuesIn(kLoadCases),
                         [](const ::testing::TestParamInfo<LoadCase>& info) {
                           return std::string(info.param.id);
                         });

/// A model of `leaf` in the temp folder compiled within `limits`: its first diagnostic.
SourceDiagnostic limit_error(const std::string& name, const std::string& leaf,
                             const ModelLimits& limits) {
  fs::path model = write_file(name, mesh_model(leaf));
  ModelOptions mo;
  mo.limits = limits;
  CompileResult r = Model::compile_file(model.string(), mo);
  EXPECT_FALSE(r.ok()) << name;
  EXPECT_TRUE(r.error.empty()) << r.error;
  if (r.diagnostics.empty()) return {};
  EXPECT_EQ(r.diagnostics[0].line, 2) << name;
  EXPECT_EQ(r.diagnostics[0].col, 14) << name;
  return r.diagnostics[0];
}

TEST(SurfaceLimits, AFileOverTheByteLimitIsRefusedBeforeReading) {
  // A mesh that loads under the default limits.
  const std::string off =
      "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  write_file("lim.off", off);
  ASSERT_TRUE(compile_in_temp("lim_ok.hf", mesh_model("hfMesh(x, \"lim.off\")")).ok());
  ModelLimits small;
  small.max_mesh_bytes = 20;
  SourceDiagnostic d = limit_error("lim_bytes.hf", "hfMesh(x, \"lim.off\")", small);
  EXPECT_NE(d.message.find("lim.off: is " + std::to_string(off.size()) +
                           " bytes, more than the limit of 20 bytes"),
            std::string::npos)
      << d.message;
  EXPECT_NE(d.hint.find("--max-mesh-bytes N"), std::string::npos) << d.hint;
  // Patch files too.
  write_file("lim.bpt", "1\n1 1\n0 0 0 1 0 0 0 1 0 1 1 0\n");
  SourceDiagnostic b = limit_error("lim_bpt.hf", "hfBezierSurface(x, \"lim.bpt\")", small);
  EXPECT_NE(b.message.find("more than the limit of 20 bytes"), std::string::npos) << b.message;
}

TEST(SurfaceLimits, TooManyTrianglesOrPatchesAreLocatedErrors) {
  write_file("tri.off",
             "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  ModelLimits three;
  three.max_mesh_triangles = 3;
  SourceDiagnostic d = limit_error("tri.hf", "hfMesh(x, \"tri.off\")", three);
  EXPECT_NE(d.message.find("tri.off: 4 triangles, more than the limit of 3"), std::string::npos)
      << d.message;
  EXPECT_NE(d.hint.find("--max-mesh-triangles N"), std::string::npos) << d.hint;
  // One patch tessellates into 2 x 32 x 32 triangles for the field.
  write_file("one.bpt", "1\n1 1\n0 0 0 1 0 0 0 1 0 1 1 0\n");
  ModelLimits few;
  few.max_mesh_triangles = 2000;
  SourceDiagnostic p = limit_error("one.hf", "hfBezierSurface(x, \"one.bpt\")", few);
  EXPECT_NE(p.message.find("1 patches tessellate into 2048 triangles (2048 per patch), more than "
                           "the limit of 2000"),
            std::string::npos)
      << p.message;
  few.max_mesh_triangles = 2048;
  fs::path ok = write_file("one_ok.hf", mesh_model("hfBezierSurface(x, \"one.bpt\")"));
  ModelOptions mo;
  mo.limits = few;
  EXPECT_TRUE(Model::compile_file(ok.string(), mo).ok());
}

/// Inline forms: the messages name the function and the problem, at the call.
struct InlineCase {
  const char* id;
  std::string decls;  ///< array declarations and literals
  std::string leaf;
  std::string message_has;
  int line, col;
};

class SurfaceInlineError : public ::testing::TestWithParam<InlineCase> {};

TEST_P(SurfaceInlineError, IsALocatedCompileError) {
  const InlineCase& c = GetParam();
  CompileResult r = Model::compile("m(x[3], a[1]) {\n" + c.decls + "\n  m = " + c.leaf + ";\n}\n",
                                   {}, "inline.hf");
  ASSERT_FALSE(r.ok()) << c.id;
  ASSERT_FALSE(r.diagnostics.empty());
  const SourceDiagnostic& d = r.diagnostics.front();
  EXPECT_NE(d.message.find(c.message_has), std::string::npos) << d.message;
  EXPECT_EQ(d.line, c.line) << d.message;
  EXPECT_EQ(d.col, c.col) << d.message;
  EXPECT_FALSE(d.hint.empty());
  EXPECT_NE(r.rendered.find("inline.hf:" + std::to_string(c.line) + ":" + std::to_string(c.col) +
                            ": error: "),
            std::string::npos)
      << r.rendered;
}

const InlineCase kInlineCases[] = {
    {"vertex_length", "  array v[4], t[3];\n  v = [0, 0, 0, 1];\n  t = [1, 2, 3];",
     "hfTriangles(x, v, t)", "hfTriangles: the vertex array has 4", 5, 7},
    {"triangle_length", "  array v[9], t[2];\n  v = [0, 0, 0, 1, 0, 0, 0, 1, 0];\n  t = [1, 2];",
     "hfTriangles(x, v, t)", "hfTriangles: the triangle array has 2", 5, 7},
    {"index_range", "  array v[9], t[3];\n  v = [0, 0, 0, 1, 0, 0, 0, 1, 0];\n  t = [1, 2, 4];",
     "hfTriangles(x, v, t)", "hfTriangles: triangle 1 has vertex index 4", 5, 7},
    {"index_zero", "  array v[9], t[3];\n  v = [0, 0, 0, 1, 0, 0, 0, 1, 0];\n  t = [0, 1, 2];",
     "hfTriangles(x, v, t)", "hfTriangles: ", 5, 7},
    {"non_finite_vertex",
     "  array v[9], t[3];\n  v = [0, 0, 0, 1, 0, 0, 0, 1, 0];\n  v[8] = 1e308 * 10;\n  t = [1, 2, "
     "3];",
     "hfTriangles(x, v, t)", "hfTriangles: vertex 3 has a non-finite coordinate", 6, 7},
    {"not_constant",
     "  array v[9], t[3];\n  v = [0, 0, 0, 1, 0, 0, 0, 1, 0];\n  v[2] = x[1];\n  t = [1, 2, 3];",
     "hfTriangles(x, v, t)", "hfTriangles: the vertex array 'v' is not constant (element 2", 6, 22},
    {"patch_length", "  array p[3];\n  p = [0, 0, 0];", "hfBezierPatches(x, p)",
     "hfBezierPatches: ", 4, 7},
};

INSTANTIATE_TEST_SUITE_P(Inline, SurfaceInlineError, ::testing::ValuesIn(kInlineCases),
                         [](const ::testing::TestParamInfo<InlineCase>& info) {
                           return std::string(info.param.id);
                         });

// ---- the polynomial domain: surface leaves of the skeleton ------------------------------------

TEST(SurfaceLeaf, AffineLeavesAreAnalyticWithExactCrossings) {
  write_file("box.off", TestMesh::cube(1).off());
  const std::string text =
      "my_model(x[3], a[1]) {\n  array p[3], c[3];\n  p[1] = x[1]; p[2] = x[2]; p[3] = x[3];\n"
      "  c = [0, 0, 0];\n  t1 = hfShift3D(p, 5, 0, 0);\n  t2 = hfScale3D(p, 2, 1, 1);\n"
      "  t3 = hfRotate3DZ(p, 0.3);\n"
      "  my_model = hfMesh(p, \"box.off\") | (hfSphere(x, c, 1) \\ hfMesh(x, \"box.off\"));\n}\n";
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    CompileResult r = compile_in_temp("affine.hf", text, backend);
    ASSERT_TRUE(r.ok()) << r.rendered;
    AnalyticInfo info = r.model->analytic_info();
    ASSERT_TRUE(info.qualifies) << info.reason;
    EXPECT_EQ(info.num_leaves, 1);  // the sphere
    EXPECT_EQ(info.num_surface_leaves, 2);
    std::vector<double> poly(size_t(info.num_leaves) * 5);
    // Along the x axis from x = -10: the box at the origin (x = -1, 1) and the moved box.
    const double o[3] = {-10, 0, 0}, d[3] = {1, 0, 0};
    r.model->ray_polynomials(o, d, poly.data());
    EXPECT_NEAR(poly[0], 1 - 100, 1e-9);  // 1 - |o + t d|^2 at t = 0
    std::vector<double> t;
    r.model->ray_surface_crossings(o, d, 0, 100, &t);
    std::sort(t.begin(), t.end());
    // The moved box: p = rotate(scale(x - 5)), so x - 5 = +-2 / cos-ish... check by the field:
    ASSERT_EQ(t.size(), 4u);
    EXPECT_NEAR(t[0], 9, 1e-5);
    EXPECT_NEAR(t[1], 11, 1e-5);
    for (int k = 2; k < 4; ++k) {
      EXPECT_NEAR(r.model->eval({-10 + t[k], 0, 0}).f, 0.0, 1e-5) << t[k];
    }
    EXPECT_LT(t[2], 15);
    EXPECT_GT(t[3], 15);
  }
}

TEST(SurfaceLeaf, NonAffineMapsAndBlendsUseTheGeneralSearch) {
  write_file("nb.off", TestMesh::cube(1).off());
  CompileResult twist = compile_in_temp(
      "twist.hf",
      "my_model(x[3], a[1]) {\n  array p[3];\n  p[1] = x[1]; p[2] = x[2]; p[3] = x[3];\n"
      "  t1 = hfTwistZ(p, -1, 1, 0, 1);\n  my_model = hfMesh(p, \"nb.off\");\n}\n");
  ASSERT_TRUE(twist.ok()) << twist.rendered;
  AnalyticInfo ti = twist.model->analytic_info();
  EXPECT_FALSE(ti.qualifies);
  EXPECT_NE(
      ti.reason.find("'hfMesh' is not a polynomial and its point is not an affine image of x"),
      std::string::npos)
      << ti.reason;
  EXPECT_EQ(ti.line, 5);
  CompileResult blend = compile_in_temp(
      "blend.hf",
      "my_model(x[3], a[1]) {\n  array c[3];\n  c = [2, 0, 0];\n"
      "  my_model = hfBlendUni(hfMesh(x, \"nb.off\"), hfSphere(x, c, 1), 1, 1, 1);\n}\n");
  ASSERT_TRUE(blend.ok()) << blend.rendered;
  EXPECT_FALSE(blend.model->analytic_info().qualifies);
  // Arithmetic on the leaf is not a set operation either; a complement is.
  CompileResult arith =
      compile_in_temp("arith.hf", mesh_model("hfMesh(x, \"nb.off\") * hfMesh(x, \"nb.off\")"));
  ASSERT_TRUE(arith.ok());
  EXPECT_FALSE(arith.model->analytic_info().qualifies);
  CompileResult neg = compile_in_temp("neg.hf", mesh_model("-hfMesh(x, \"nb.off\")"));
  ASSERT_TRUE(neg.ok());
  EXPECT_TRUE(neg.model->analytic_info().qualifies);
}

// ---- IR text and the POV-Ray emitter ------------------------------------------------------------

TEST(SurfaceLeaf, IrPrintsTheOpAndPovEmitRefusesItWithALocation) {
  write_file("pov.off", TestMesh::cube(1).off());
  CompileResult r = compile_in_temp("pov.hf", mesh_model("hfMesh(x, \"pov.off\")"));
  ASSERT_TRUE(r.ok());
  EXPECT_NE(r.model->ir_text().find("surface S0, %"), std::string::npos) << r.model->ir_text();

  auto file = std::make_shared<const lang::SourceFile>((temp_dir() / "pov.hf").string(),
                                                       mesh_model("hfMesh(x, \"pov.off\")"));
  lang::DiagnosticSink sink(file);
  auto prog = lang::compile_source(file, sink);
  ASSERT_TRUE(prog);
  ir::Function fn = jit::lower_object(*prog, 0, &sink);
  ASSERT_FALSE(sink.has_errors()) << sink.render(false);
  lang::DiagnosticSink pov_sink(file);
  jit::PovEmitOptions opts;
  jit::PovFunction out;
  EXPECT_FALSE(jit::emit_pov_function(fn, opts, &out, &pov_sink));
  ASSERT_TRUE(pov_sink.has_errors());
  const lang::Diagnostic& d = pov_sink.diagnostics().front();
  EXPECT_EQ(d.message,
            "cannot write this model as a POV-Ray function: a mesh or Bezier patch leaf "
            "(POV-Ray functions cannot read files)");
  EXPECT_EQ(d.range.begin.line, 2u);
  EXPECT_EQ(d.range.begin.col, 14u);
}

}  // namespace
}  // namespace hfrt
