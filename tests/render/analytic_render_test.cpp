// Renders with the analytic root search checked pixel by pixel against exact answers: the depth
// AOV (Z) of every pixel equals the first hit along the camera ray, computed here in
// double, independently of the renderer, of its float rays and of the polynomial solvers, by
// sphere tracing the exact 1-Lipschitz distance functions of CsgField (no overshoot, converged
// to 1e-13).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "render/renderer.h"
#include "testsupport/analytic_fields.h"

namespace hfrt::render {
namespace {

using testing::CsgField;
using Leaf = CsgField::Leaf;

// ---------------------------------------------------------------------------------------------
// The camera contract (docs/rendering.md), in double.

struct RayD {
  double o[3], d[3];  // d unit
};

void normalize3(double v[3]) {
  double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  for (int i = 0; i < 3; ++i) v[i] /= l;
}

void cross3(const double a[3], const double b[3], double out[3]) {
  out[0] = a[1] * b[2] - a[2] * b[1];
  out[1] = a[2] * b[0] - a[0] * b[2];
  out[2] = a[0] * b[1] - a[1] * b[0];
}

/// Pixel (i, j)'s ray with --spp 1: d = normalize(look_at - eye), r = normalize(d x up),
/// u = r x d; orthographic: from eye + ((i+0.5)/W - 0.5) w r + (0.5 - (j+0.5)/H) w (H/W) u along
/// d; perspective: from the eye along normalize(d + ((i+0.5)/W - 0.5) 2 tan(fov/2) (W/H) r +
/// (0.5 - (j+0.5)/H) 2 tan(fov/2) u).
RayD contract_ray(const Camera& cam, int W, int H, int i, int j) {
  double d[3] = {double(cam.look_at.x) - cam.eye.x, double(cam.look_at.y) - cam.eye.y,
                 double(cam.look_at.z) - cam.eye.z};
  normalize3(d);
  double up[3] = {cam.up.x, cam.up.y, cam.up.z}, r[3], u[3];
  cross3(d, up, r);
  normalize3(r);
  cross3(r, d, u);
  double sx = (i + 0.5) / W - 0.5, sy = 0.5 - (j + 0.5) / H;
  RayD ray;
  if (cam.kind == Camera::Kind::kOrthographic) {
    double w = cam.ortho_width;
    for (int k = 0; k < 3; ++k) {
      ray.o[k] = double((&cam.eye.x)[k]) + sx * w * r[k] + sy * w * (double(H) / W) * u[k];
      ray.d[k] = d[k];
    }
  } else {
    double tn = 2 * std::tan(double(cam.fov_deg) * M_PI / 360.0);
    for (int k = 0; k < 3; ++k) {
      ray.o[k] = (&cam.eye.x)[k];
      ray.d[k] = d[k] + sx * tn * (double(W) / H) * r[k] + sy * tn * u[k];
    }
    normalize3(ray.d);
  }
  return ray;
}

/// The first t >= 0 where F >= 0 along `ray`, by sphere tracing (F is 1-Lipschitz, so a step of
/// |F| never crosses the surface). `closest` gets the smallest |F| seen before the hit (or on
/// the whole ray): small values mean the ray grazes a surface.
struct RefHit {
  bool hit = false;
  bool converged = true;
  double t = 0, closest = INFINITY;
};

RefHit trace(const CsgField& f, const RayD& ray, double t_max) {
  RefHit h;
  double t = 0;
  for (int step = 0; step < 200000; ++step) {
    double v = f.value(ray.o[0] + t * ray.d[0], ray.o[1] + t * ray.d[1], ray.o[2] + t * ray.d[2]);
    if (v >= -1e-13) {
      h.hit = true;
      h.t = t;
      return h;
    }
    h.closest = std::min(h.closest, -v);
    t += -v;
    if (t > t_max) return h;
  }
  h.converged = false;
  return h;
}

/// |cos| of the angle between the ray and the surface normal at the hit (numerical gradient).
double hit_cosine(const CsgField& f, const RayD& ray, double t) {
  double p[3];
  for (int k = 0; k < 3; ++k) p[k] = ray.o[k] + t * ray.d[k];
  Vec3 g = f.gradient(p[0], p[1], p[2]);
  double gl = std::sqrt(double(g.x) * g.x + double(g.y) * g.y + double(g.z) * g.z);
  if (!(gl > 0)) return 0;
  return std::abs(g.x * ray.d[0] + g.y * ray.d[1] + g.z * ray.d[2]) / gl;
}

struct DepthReport {
  int hits = 0, misses = 0, checked = 0, sensitive = 0, graze_mismatch = 0;
  double worst = 0;
};

/// Renders `field` with the analytic search and compares every pixel's Z with the reference.
/// Z must agree to tol = 1e-6 of the box size wherever float rays can express that: a pixel is
/// skipped (counted as `sensitive`) when the float ray's own rounding (a few 1e-7 of the
/// distance, turned into depth by the slope of the surface) could move Z by tol / 2. Hit and
/// miss must agree except where the reference ray passes within 1e-4 of the box size of a
/// surface (grazing).
DepthReport check_depth(const CsgField& field, const RenderOptions& o) {
  RenderResult res = render(field, o);
  EXPECT_EQ(res.stats.root_used, RootMode::kAnalytic);
  EXPECT_GT(res.stats.evals.candidate_calls, 0u);
  const Image& img = res.image;
  const double size = o.bbox.max_extent(), tol = 1e-6 * size;
  DepthReport rep;
  for (int j = 0; j < o.height; ++j) {
    for (int i = 0; i < o.width; ++i) {
      size_t px = size_t(j) * o.width + i;
      RayD ray = contract_ray(o.camera, o.width, o.height, i, j);
      RefHit ref = trace(field, ray, 1e3);
      EXPECT_TRUE(ref.converged);
      bool got = img.alpha[px] > 0;
      if (got != ref.hit) {
        EXPECT_LT(ref.closest, 1e-4 * size) << "pixel " << i << "," << j << ": rendered " << got
                                            << ", reference " << ref.hit << " at " << ref.t;
        rep.graze_mismatch++;
        continue;
      }
      if (!got) {
        EXPECT_TRUE(std::isinf(img.depth[px])) << i << "," << j;
        rep.misses++;
        continue;
      }
      rep.hits++;
      double cosine = hit_cosine(field, ray, ref.t);
      double tan = std::sqrt(std::max(0.0, 1 - cosine * cosine)) / std::max(cosine, 1e-12);
      double float_error = ref.t * 6e-8 + (ref.t * 6e-8 + 1e-7 * size) * tan;
      double err = std::abs(double(img.depth[px]) - ref.t);
      if (float_error > 0.5 * tol) {
        // Grazing incidence: float rays alone move Z by more than the tolerance.
        rep.sensitive++;
        EXPECT_LE(err, 4 * float_error + tol) << "pixel " << i << "," << j;
        continue;
      }
      rep.checked++;
      rep.worst = std::max(rep.worst, err);
      EXPECT_LE(err, tol) << "pixel " << i << "," << j << " Z " << img.depth[px] << " expected "
                          << ref.t << " cos " << cosine;
    }
  }
  return rep;
}

RenderOptions base_options(int size) {
  RenderOptions o;
  o.width = o.height = size;
  o.bbox = {{-2.5f, -2.5f, -2.5f}, {2.5f, 2.5f, 2.5f}};
  o.root = RootMode::kAnalytic;
  o.shadows = false;
  return o;
}

CsgField tilted_torus(double R, double r) {
  const double c[3] = {0.1, -0.2, 0.05}, axis[3] = {1, 2, 0.5};
  return CsgField({{CsgField::torus(c, axis, R, r)}});
}

std::string describe(const DepthReport& r) {
  return "hits " + std::to_string(r.hits) + " checked " + std::to_string(r.checked) +
         " sensitive " + std::to_string(r.sensitive) + " misses " + std::to_string(r.misses) +
         " grazing mismatches " + std::to_string(r.graze_mismatch) + " worst " +
         std::to_string(r.worst);
}

TEST(AnalyticRender, TiltedTorusDepthIsExact) {
  CsgField torus = tilted_torus(1.5, 0.5);
  for (bool ortho : {false, true}) {
    RenderOptions o = base_options(160);
    o.camera.eye = {2, 3, 7};
    o.camera.look_at = {0, 0, 0};
    o.camera.fov_deg = 40;
    if (ortho) {
      o.camera.kind = Camera::Kind::kOrthographic;
      o.camera.ortho_width = 5.5f;
    }
    DepthReport r = check_depth(torus, o);
    SCOPED_TRACE(describe(r));
    std::printf("%s\n", describe(r).c_str());
    EXPECT_GT(r.hits, 5000);
    EXPECT_GT(r.checked, r.hits * 7 / 10);
    EXPECT_GT(r.misses, 5000);
    EXPECT_LT(r.graze_mismatch, 20);
  }
}

TEST(AnalyticRender, TorusInAUnionWithQuadricsDepthIsExact) {
  const double c0[3] = {0, 0, 0}, ay[3] = {0.2, 1, 0.1};
  const double cb[3] = {1.3, 1.2, 0.3}, cc[3] = {-1.3, -1.0, 0}, az[3] = {0, 0.3, 1};
  const double top[3] = {0, 0, 1.6}, bottom[3] = {0, 0, -1.6}, nz[3] = {0, 0, 1},
               nzm[3] = {0, 0, -1};
  CsgField scene({
      {CsgField::torus(c0, ay, 1.4, 0.35)},
      {CsgField::ball(cb, 0.6)},
      {CsgField::ball(c0, 0.7)},
      // A capped, tilted cylinder: cylinder & z <= 1.6 & z >= -1.6.
      {CsgField::cylinder(cc, az, 0.4), CsgField::half_space(top, nz),
       CsgField::half_space(bottom, nzm)},
  });
  for (bool ortho : {false, true}) {
    RenderOptions o = base_options(160);
    o.camera.eye = {-3, 2.5, 6.5};
    o.camera.fov_deg = 42;
    if (ortho) {
      o.camera.kind = Camera::Kind::kOrthographic;
      o.camera.ortho_width = 5.5f;
    }
    DepthReport r = check_depth(scene, o);
    SCOPED_TRACE(describe(r));
    std::printf("%s\n", describe(r).c_str());
    EXPECT_GT(r.hits, 5000);
    EXPECT_GT(r.checked, r.hits * 6 / 10);
    EXPECT_LT(r.graze_mismatch, 40);
  }
}

TEST(AnalyticRender, BoxWithCylindricalHoleDepthIsExact) {
  const double lo[3] = {-1.5, -1.2, -1}, hi[3] = {1.5, 1.2, 1};
  const double c[3] = {0.3, 0.1, 0}, az[3] = {0, 0, 1};
  CsgField::Part part = CsgField::box(lo, hi);
  part.push_back(CsgField::subtract(CsgField::cylinder(c, az, 0.6)));
  CsgField block({part});
  // An oblique perspective view, and an orthographic one straight down the hole's axis: there
  // every ray is parallel to the cylinder (its polynomial drops to a constant) and the hole is
  // seen through.
  for (bool down_the_axis : {false, true}) {
    RenderOptions o = base_options(160);
    if (down_the_axis) {
      o.camera.kind = Camera::Kind::kOrthographic;
      o.camera.eye = {0, 0, 8};
      o.camera.ortho_width = 4;
    } else {
      o.camera.eye = {3, 4, 6};
      o.camera.fov_deg = 38;
    }
    DepthReport r = check_depth(block, o);
    SCOPED_TRACE(describe(r));
    std::printf("%s\n", describe(r).c_str());
    EXPECT_GT(r.hits, 5000);
    EXPECT_GT(r.checked, r.hits * 6 / 10);
    EXPECT_LT(r.graze_mismatch, 40);
    if (down_the_axis) {
      // The centre of the hole is seen through; the box top at z = 1 is at Z = 7.
      int ci = int((0.3 / 4 + 0.5) * o.width), cj = int((0.5 - 0.1 / 4) * o.height);
      RenderResult res = render(block, o);
      EXPECT_EQ(res.image.alpha[size_t(cj) * o.width + ci], 0);
      EXPECT_NEAR(res.image.depth[size_t(48) * o.width + 40], 7.0, 1e-6 * 5);
    }
  }
}

TEST(AnalyticRender, ThinTorusHasNoGaps) {
  // Tube radius 1/100 of the box (5): 0.05. Every pixel whose reference ray hits the tube
  // (other than grazing) is hit, with exact depth.
  CsgField torus = tilted_torus(1.8, 0.05);
  RenderOptions o = base_options(256);
  o.camera.eye = {2, 3, 7};
  o.camera.fov_deg = 40;
  DepthReport r = check_depth(torus, o);
  SCOPED_TRACE(describe(r));
  std::printf("%s\n", describe(r).c_str());
  EXPECT_GT(r.hits, 1500);
  EXPECT_LT(r.graze_mismatch, r.hits / 50 + 10);
  // The sign-change march with a step wider than the tube does leave gaps: the test can tell.
  RenderOptions s = o;
  s.root = RootMode::kSign;
  s.step = 0.2f;
  s.tile_culling = false;
  RenderResult sign = render(torus, s);
  int sign_hits = 0;
  for (float a : sign.image.alpha) sign_hits += a > 0;
  EXPECT_LT(sign_hits, r.hits * 9 / 10);
}

TEST(AnalyticRender, ShadowRaysUseTheAnalyticSearch) {
  CsgField torus = tilted_torus(1.5, 0.5);
  RenderOptions o = base_options(64);
  o.camera.eye = {2, 3, 7};
  o.shadows = true;
  RenderResult lit = render(torus, o);
  EXPECT_EQ(lit.stats.root_used, RootMode::kAnalytic);
  EXPECT_GT(lit.stats.shadow_rays, 0u);
  // One candidate call per primary ray that reaches the search, plus one per shadow ray.
  EXPECT_GE(lit.stats.evals.candidate_calls, lit.stats.shadow_rays);
  // Same image as the interval search, up to shading noise at a few pixels.
  o.root = RootMode::kInterval;
  RenderResult ref = render(torus, o);
  int differ = 0;
  for (size_t i = 0; i < ref.image.rgb.size(); ++i)
    differ += std::abs(ref.image.rgb[i] - lit.image.rgb[i]) > 0.05f;
  EXPECT_LT(differ, int(ref.image.rgb.size() / 100));
}

}  // namespace
}  // namespace hfrt::render
