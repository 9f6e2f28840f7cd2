// ModelField's analytic ray candidates (app/model_field.h): the leaf roots that
// Model::ray_polynomials + render::solve_polynomial give must contain every zero crossing of F
// on the segment, for thin and tilted tori, set operations and boxes, and must stay inside it.
#include "app/model_field.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "hfrt/model.h"
#include "render/framing.h"

namespace hfrt::app {
namespace {

struct Seg {
  render::Vec3 o, d;
  float t0, t1;
};

/// A ray from outside the box [-2, 2]^3 through `target`, as the renderer would clip it.
Seg ray_through(std::mt19937& rng, render::Vec3 target) {
  std::normal_distribution<float> g;
  render::Vec3 d{g(rng), g(rng), g(rng)};
  const float n = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
  d = {d.x / n, d.y / n, d.z / n};
  render::Vec3 o{target.x - 4 * d.x, target.y - 4 * d.y, target.z - 4 * d.z};
  return {o, d, 0.5f, 7.5f};
}

/// Sign changes of F (f64 scalar evaluator) along the segment, refined by bisection.
std::vector<double> crossings(const Model& m, const Seg& s, int samples) {
  auto f = [&](double t) {
    return m.eval({s.o.x + t * s.d.x, s.o.y + t * s.d.y, s.o.z + t * s.d.z}).f;
  };
  std::vector<double> out;
  double pt = s.t0, pv = f(pt);
  for (int i = 1; i <= samples; ++i) {
    const double t = s.t0 + (double(s.t1) - s.t0) * i / samples, v = f(t);
    if ((pv < 0) != (v < 0) && !std::isnan(v) && !std::isnan(pv)) {
      double a = pt, b = t, fa = pv;
      for (int k = 0; k < 60 && b - a > 1e-12; ++k) {
        const double mid = 0.5 * (a + b), fm = f(mid);
        if ((fa < 0) == (fm < 0)) {
          a = mid;
          fa = fm;
        } else {
          b = mid;
        }
      }
      out.push_back(0.5 * (a + b));
    }
    pt = t;
    pv = v;
  }
  return out;
}

struct Scene {
  const char* name;
  const char* text;
  float target_radius;  ///< rays aim near points of a circle of this radius in the y = 0 plane
  float tilt;           ///< ... or, when non-zero, of the circle x^2 + y^2 = r^2 rotated about x
};

const Scene kScenes[] = {
    {"thin_torus",
     "my_model(x[3], a[1]) { array c[3]; c = [0, 0, 0]; d = hfRotate3DX(x, 0.4);\n"
     "  my_model = hfTorusZ(x, c, 1, 0.01); }",
     1.0f, 0.4f},
    {"torus_union_quadrics",
     "my_model(x[3], a[1]) { array c[3], e[3]; c = [0, 0, 0]; e = [0, 0, 0.8];\n"
     "  t = hfTorusY(x, c, 1, 0.3); sp = hfSphere(x, e, 0.5); k = hfCylinderX(x, c, 0.2);\n"
     "  my_model = (t | sp) | (k & (1.5 - x[1]) & (x[1] + 1.5)); }",
     1.0f, 0.0f},
    {"box_with_hole",
     "my_model(x[3], a[1]) { array v[3], c[3]; v = [-1, -1, -0.5]; c = [0, 0, 0];\n"
     "  my_model = hfBlock(x, v, 2, 2, 1) \\ hfCylinderZ(x, c, 0.5); }",
     0.6f, 0.0f},
};

TEST(ModelFieldAnalytic, CandidatesContainEveryCrossing) {
  for (const Scene& sc : kScenes) {
    auto compiled = Model::compile(sc.text);
    ASSERT_TRUE(compiled.ok()) << compiled.rendered;
    ModelField field(*compiled.model, sc.name);
    ASSERT_TRUE(field.has_ray_candidates()) << field.analytic_info().reason;
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> ang(0, 6.2831853f), jitter(-0.02f, 0.02f);
    int hits = 0;
    for (int r = 0; r < 300; ++r) {
      const float a = ang(rng);
      // Points on the (untilted) circle plus jitter: many rays meet a thin tube.
      const float ca = sc.target_radius * std::cos(a), sa = sc.target_radius * std::sin(a);
      render::Vec3 target = sc.tilt == 0
                                ? render::Vec3{ca, 0, sa}
                                : render::Vec3{ca, sa * std::cos(sc.tilt), sa * std::sin(sc.tilt)};
      target = {target.x + jitter(rng), target.y + jitter(rng), target.z + jitter(rng)};
      Seg s = ray_through(rng, target);
      std::vector<double> cand;
      field.ray_candidates(s.o, s.d, s.t0, s.t1, &cand);
      for (double t : cand) {
        EXPECT_GE(t, s.t0);
        EXPECT_LE(t, s.t1);
      }
      for (double t : crossings(*compiled.model, s, 20000)) {
        double best = INFINITY;
        for (double c : cand) best = std::min(best, std::fabs(c - t));
        EXPECT_LT(best, 1e-6) << sc.name << " ray " << r << " crossing t=" << t;
        ++hits;
      }
    }
    EXPECT_GT(hits, 20) << sc.name;  // the rays do meet the surface
  }
}

TEST(ModelFieldAnalytic, NonPolynomialModelHasNoCandidates) {
  auto compiled = Model::compile(
      "my_model(x[3], a[1]) { f1 = 1 - x[1]^2; f2 = 0.5 - x[2]^2 - x[3];\n"
      "  my_model = hfBlendUni(f1, f2, 0.5, 1.5, 2); }");
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  ModelField field(*compiled.model, "blend");
  EXPECT_FALSE(field.has_ray_candidates());
  EXPECT_NE(field.analytic_info().reason.find("hfBlendUni"), std::string::npos);
  EXPECT_EQ(field.analytic_info().line, 2);
}

TEST(ModelFieldAnalytic, SphereRootsAreExact) {
  auto compiled =
      Model::compile("my_model(x[3], a[1]) { my_model = 4 - x[1]^2 - x[2]^2 - x[3]^2; }");
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  ModelField field(*compiled.model, "sphere");
  std::vector<double> cand;
  // Along x from x = -10: the sphere of radius 2 is met at t = 8 and t = 12.
  field.ray_candidates({-10, 0.5f, 0}, {1, 0, 0}, 0, 100, &cand);
  std::sort(cand.begin(), cand.end());
  ASSERT_EQ(cand.size(), 2u);
  const double h = std::sqrt(4.0 - 0.25);
  EXPECT_NEAR(cand[0], 10 - h, 1e-12);
  EXPECT_NEAR(cand[1], 10 + h, 1e-12);
  cand.clear();
  field.ray_candidates({-10, 0.5f, 0}, {1, 0, 0}, 0, 9, &cand);  // the segment ends before the exit
  EXPECT_EQ(cand.size(), 1u);
}

// Time (issue 24): x[4] of a model reaches every evaluator the renderer uses as the number
// Model::set_time holds, without a recompile: the analytic candidates, points, intervals and
// gradients all see the sphere at its centre for that time.
TEST(ModelFieldTime, EveryDomainSeesTheSphereWhereTimePutsIt) {
  auto compiled = Model::compile(
      "my_model(x[4], a[1]) { cx = -2 + 4 * x[4];\n"
      "  my_model = 1 - (x[1] - cx)^2 - x[2]^2 - x[3]^2; }");
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  Model& model = *compiled.model;
  ModelField field(model, "moving");
  ASSERT_TRUE(field.has_ray_candidates()) << field.analytic_info().reason;
  double poly_ms = -1, interval_ms = -1;
  for (double t : {0.0, 0.25, 0.5, 1.0}) {
    model.set_time(t);
    EXPECT_EQ(model.time(), t);
    const double cx = -2 + 4 * t;
    // Analytic: along x from -10 the unit sphere is met at cx - 1 + 10 and cx + 1 + 10.
    std::vector<double> cand;
    field.ray_candidates({-10, 0, 0}, {1, 0, 0}, 0, 100, &cand);
    std::sort(cand.begin(), cand.end());
    ASSERT_EQ(cand.size(), 2u) << "t = " << t;
    EXPECT_NEAR(cand[0], cx - 1 + 10, 1e-9);
    EXPECT_NEAR(cand[1], cx + 1 + 10, 1e-9);
    // Points: F = 1 at the centre, 1 - 4 = -3 two units to the side.
    const float xs[2] = {float(cx), float(cx + 2)}, zeros[2] = {0, 0};
    float f[2];
    field.eval(2, xs, zeros, zeros, f);
    EXPECT_NEAR(f[0], 1.0f, 1e-5f);
    EXPECT_NEAR(f[1], -3.0f, 1e-5f);
    // Intervals: a small box around the centre is inside, one far away is outside.
    bool maybe_nan = false;
    render::Interval in = field.eval_interval(
        render::Box{{float(cx) - 0.1f, -0.1f, -0.1f}, {float(cx) + 0.1f, 0.1f, 0.1f}}, &maybe_nan);
    EXPECT_GT(in.lo, 0) << "t = " << t;
    render::Interval out = field.eval_interval(
        render::Box{{float(cx) + 3, -0.1f, -0.1f}, {float(cx) + 3.2f, 0.1f, 0.1f}}, &maybe_nan);
    EXPECT_LT(out.hi, 0) << "t = " << t;
    // Gradient: dF/dx = -2 (x - cx), time held constant.
    const float gx[1] = {float(cx + 0.5)}, z1[1] = {0};
    float gf, dx, dy, dz;
    field.eval_gradient(1, gx, z1, z1, &gf, &dx, &dy, &dz);
    EXPECT_NEAR(dx, -1.0f, 1e-5f);
    // Time is a number, not a recompile: the code compiled for the first time serves all.
    const ModelStats st = model.stats();
    ASSERT_TRUE(st.polynomial.compiled);
    ASSERT_TRUE(st.interval.compiled);
    if (poly_ms < 0) poly_ms = st.polynomial.compile_ms, interval_ms = st.interval.compile_ms;
    EXPECT_EQ(st.polynomial.compile_ms, poly_ms);
    EXPECT_EQ(st.interval.compile_ms, interval_ms);
  }
}

TEST(ModelFieldTime, ThreeDimensionalModelIgnoresTime) {
  auto compiled = Model::compile("my_model(x[3], a[1]) { my_model = 1 - x[1]^2 - x[2]^2; }");
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  compiled.model->set_time(5);
  ModelField field(*compiled.model, "still");
  const float x[1] = {0}, z[1] = {0};
  float f = 0;
  field.eval(1, x, z, z, &f);
  EXPECT_EQ(f, 1.0f);
}

// The mesher's batches hold x, y, z (and Fc, then the gradient) as consecutive rows of one
// buffer, the model's own layout, which ModelField evaluates without packing a copy. Both
// ways must give the same bits, and a model of time (x[4]) must still get its time row.
TEST(ModelFieldLayout, ConsecutiveRowsGiveTheSameBitsAsSeparateArrays) {
  for (const char* src :
       {"my_model(x[3], a[1]) { my_model = 1 - x[1]^2 - sin(x[2]) * x[3]; }",
        "my_model(x[4], a[1]) { my_model = 1 - (x[1] - x[4])^2 - x[2] * x[3]; }"}) {
    auto compiled = Model::compile(src);
    ASSERT_TRUE(compiled.ok()) << compiled.rendered;
    compiled.model->set_time(0.75);
    ModelField field(*compiled.model, "layout");
    constexpr size_t kN = 37;  // not a multiple of any vector width
    std::vector<float> rows(3 * kN), x(kN), y(kN), z(kN);
    for (size_t i = 0; i < kN; ++i) {
      x[i] = rows[i] = -1.5f + 0.08f * float(i);
      y[i] = rows[kN + i] = 0.3f - 0.05f * float(i);
      z[i] = rows[2 * kN + i] = 0.01f * float(i * i);
    }
    std::vector<float> f_rows(kN), f_sep(kN);
    field.eval(kN, rows.data(), rows.data() + kN, rows.data() + 2 * kN, f_rows.data());
    field.eval(kN, x.data(), y.data(), z.data(), f_sep.data());
    std::vector<float> g_rows(4 * kN), gf(kN), gx(kN), gy(kN), gz(kN);
    field.eval_gradient(kN, rows.data(), rows.data() + kN, rows.data() + 2 * kN, g_rows.data(),
                        g_rows.data() + kN, g_rows.data() + 2 * kN, g_rows.data() + 3 * kN);
    field.eval_gradient(kN, x.data(), y.data(), z.data(), gf.data(), gx.data(), gy.data(),
                        gz.data());
    for (size_t i = 0; i < kN; ++i) {
      const double t = compiled.model->num_inputs() > 3 ? 0.75 : 0.0;
      const double expect = compiled.model->eval({x[i], y[i], z[i], t}).f;
      EXPECT_NEAR(f_sep[i], expect, 1e-5 * (1 + std::abs(expect))) << src << " at " << i;
      EXPECT_EQ(f_rows[i], f_sep[i]) << src << " at " << i;
      EXPECT_EQ(g_rows[i], gf[i]) << src << " at " << i;
      EXPECT_EQ(g_rows[kN + i], gx[i]) << src << " at " << i;
      EXPECT_EQ(g_rows[2 * kN + i], gy[i]) << src << " at " << i;
      EXPECT_EQ(g_rows[3 * kN + i], gz[i]) << src << " at " << i;
    }
  }
}

/// The old framing: every side by eval() (the distance query of each mesh or patch leaf).
class SidesByValues final : public render::FieldView {
 public:
  explicit SidesByValues(const render::Field& f) : render::FieldView(f) {}
  void eval_sides(size_t n, const float* x, const float* y, const float* z,
                  float* out_f) const override {
    base().eval(n, x, y, z, out_f);
  }
};

TEST(ModelFieldSides, SurfaceLeavesGiveTheSidesOfTheirValuesAndTheSameFrame) {
  // eval_sides of a mesh or patch leaf on a set-operation skeleton is its winding number's
  // side (the sign-only code), not a distance query: framing samples through it (the teapot's
  // framing took ~0.7 s of closest-point searches). Every side must be eval()'s, so the frame
  // is the same box.
  for (const char* file : {"/examples/teapot.hf", "/examples/armadillo.hf"}) {
    SCOPED_TRACE(file);
    CompileResult r = Model::compile_file(std::string(HFRT_SOURCE_DIR) + file);
    ASSERT_TRUE(r.ok()) << r.rendered;
    ModelField field(*r.model, file);
    ASSERT_TRUE(field.analytic_info().qualifies);
    ASSERT_GT(field.analytic_info().num_surface_leaves, 0);
    const render::Box box{{-5, -5, -5}, {5, 5, 5}};
    const render::Box framed = render::find_extent(field, box, 6);
    const render::Box by_values = render::find_extent(SidesByValues(field), box, 6);
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(framed.lo[a], by_values.lo[a]);
      EXPECT_EQ(framed.hi[a], by_values.hi[a]);
    }
    EXPECT_LT(framed.max_extent(), 9.5f);  // a frame, not the box
    // The sides on a grid over the frame.
    const int n = 24;
    const render::Vec3 step = framed.size() / float(n);
    std::vector<float> x, y, z;
    for (int k = 0; k <= n; ++k)
      for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
          x.push_back(framed.lo.x + step.x * float(i));
          y.push_back(framed.lo.y + step.y * float(j));
          z.push_back(framed.lo.z + step.z * float(k));
        }
    std::vector<float> values(x.size()), sides(x.size());
    field.eval(x.size(), x.data(), y.data(), z.data(), values.data());
    field.eval_sides(x.size(), x.data(), y.data(), z.data(), sides.data());
    size_t inside = 0, differ = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      inside += values[i] >= 0;
      differ += values[i] != sides[i];  // sign-only values are +-1, not distances
      EXPECT_EQ(values[i] >= 0, sides[i] >= 0) << x[i] << " " << y[i] << " " << z[i];
    }
    EXPECT_GT(inside, x.size() / 20);
    EXPECT_GT(differ, x.size() / 2);
  }
}

TEST(OpenSurfaceWarnings, NameTheOpenMeshAtItsCall) {
  // A unit square pyramid without its base: 4 triangles, an open rim of 4 edges. Only the
  // open leaf on the skeleton is named, at the position of its call.
  namespace fs = std::filesystem;
  const fs::path dir =
      fs::temp_directory_path() / ("hfrt_open_warning_" + std::to_string(getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "cap.off") << "OFF\n5 4 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n"
                                    "3 0 1 4\n3 1 2 4\n3 2 3 4\n3 3 0 4\n";
  std::ofstream(dir / "tet.off") << "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                                    "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  const std::string model = (dir / "open.hf").string();
  std::ofstream(model) << "open(x[3], a[1])\n{\n  open = hfMesh(x, \"tet.off\") |\n"
                          "         hfMesh(x, \"cap.off\");\n}\n";
  CompileResult r = Model::compile_file(model);
  ASSERT_TRUE(r.ok()) << r.rendered;
  const std::vector<std::string> w = open_surface_warnings(*r.model, "open.hf");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0], "open.hf:4:10: warning: the mesh '" + (dir / "cap.off").string() +
                      "' is not closed (4 boundary edges): inside and outside come from a "
                      "winding number at every ray candidate (slower than from the ray's "
                      "crossings)");
  EXPECT_NE(describe_surfaces(*r.model).find("open: 4 boundary edges"), std::string::npos)
      << describe_surfaces(*r.model);
  EXPECT_NE(describe_surfaces(*r.model).find(", closed"), std::string::npos);
  fs::remove_all(dir);
}

TEST(DescribeSurfaces, SaysWhatEachFieldIsMadeOf) {
  // The teapot's field is exact (its 16 open borders, no tessellation); the trimmed cup's too,
  // its 528 border curves (its trim polygons' edges and the walls' rims) all in cracks sealed
  // (PatchSurface::Options::seal_tolerance), none left open; a mesh's is its triangles.
  const struct {
    const char* file;
    const char* says;
  } cases[] = {
      {"/examples/teapot.hf",
       "32 patches, 14216 pieces, exact field (16 open border curves, no tessellation)"},
      {"/examples/trimmed.hf",
       "11 patches, 2051 pieces, exact field (0 open border curves, 528 sealed in cracks up to "
       "0.00057 wide, no tessellation)"},
      {"/examples/armadillo.hf", "52000 triangles, 0 degenerate skipped"},
  };
  for (const auto& c : cases) {
    CompileResult r = Model::compile_file(std::string(HFRT_SOURCE_DIR) + c.file);
    ASSERT_TRUE(r.ok()) << r.rendered;
    const std::string text = describe_surfaces(*r.model);
    EXPECT_NE(text.find(c.says), std::string::npos) << text;
  }
  // ModelLimits::max_exact_curves below the teapot's 16 open curves: its field is tessellated,
  // and the text says why.
  ModelOptions few;
  few.limits.max_exact_curves = 8;
  CompileResult r = Model::compile_file(std::string(HFRT_SOURCE_DIR) + "/examples/teapot.hf", few);
  ASSERT_TRUE(r.ok()) << r.rendered;
  const std::string text = describe_surfaces(*r.model);
  EXPECT_NE(text.find("65280 triangles (field tessellation), 32 patches, 14216 pieces"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("16 open border curves (too many for the exact field)"), std::string::npos)
      << text;
}

}  // namespace
}  // namespace hfrt::app
