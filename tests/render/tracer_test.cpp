// The scene tracer (render/tracer.h) against closed forms: Beer-Lambert transmission, Fresnel
// reflectance at normal incidence, the lateral shift of a tilted slab (Snell's law), the image
// of a sphere in a mirror floor, total internal reflection in a prism, the penumbra of a sphere
// light and the blur circle of a thin lens. Each for the sign, interval and analytic searches.
// The expected values come from the formulas computed here, never from an earlier render.

#include "render/tracer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <vector>

#include "render/texture.h"
#include "tests/render/box_coverage.h"
#include "testsupport/analytic_fields.h"

namespace hfrt::render {
namespace {

using testing::CsgField;
using testing::ShellField;
using testing::SphereField;

Material emitter(Vec3 c) {
  Material m;
  m.color = c;
  m.ambient = 1;
  m.diffuse = 0;
  m.specular = 0;
  return m;
}

Material glass(float ior, bool fresnel, Vec3 absorb = {0, 0, 0}) {
  Material m;
  m.color = {1, 1, 1};
  m.ambient = 0;
  m.diffuse = 0;
  m.specular = 0;
  m.transmit = 1;
  m.ior = ior;
  m.fresnel = fresnel;
  m.absorb = absorb;
  return m;
}

Material mirror() {
  Material m;
  m.ambient = 0;
  m.diffuse = 0;
  m.specular = 0;
  m.reflect = 1;
  return m;
}

std::unique_ptr<CsgField> box_field(Vec3 lo, Vec3 hi) {
  double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
  return std::make_unique<CsgField>(std::vector<CsgField::Part>{CsgField::box(l, h)});
}

Box grown(Vec3 lo, Vec3 hi, float g) {
  return Box{lo - Vec3{g, g, g}, hi + Vec3{g, g, g}};
}

SceneObject object(const Field& f, Box bbox, int material, RootMode mode,
                   Transform xf = Transform{}) {
  SceneObject o;
  o.field = &f;
  o.bbox = bbox;
  o.material = material;
  o.root = mode;
  o.transform = xf;
  return o;
}

TraceOptions ortho(Vec3 eye, Vec3 look_at, Vec3 up, float width, int w, int h) {
  TraceOptions opt;
  opt.width = w;
  opt.height = h;
  opt.camera.kind = Camera::Kind::kOrthographic;
  opt.camera.eye = eye;
  opt.camera.look_at = look_at;
  opt.camera.up = up;
  opt.camera.ortho_width = width;
  opt.background = {0, 0, 0};
  opt.threads = 2;
  return opt;
}

Vec3 pixel(const Image& img, int x, int y) {
  size_t i = size_t(y) * img.width + x;
  return {img.rgb[3 * i], img.rgb[3 * i + 1], img.rgb[3 * i + 2]};
}

class TracerTest : public ::testing::TestWithParam<RootMode> {};

// A slab of thickness d with ior 1 in front of a white background transmits exp(-sigma d).
TEST_P(TracerTest, AbsorptionFollowsBeerLambert) {
  const float d = 0.8f;
  auto slab = box_field({-2, -2, -d / 2}, {2, 2, d / 2});
  const Vec3 sigma{0.7f, 1.4f, 2.1f};
  std::vector<Material> mats{glass(1.0f, true, sigma)};
  std::vector<SceneObject> objs{
      object(*slab, grown({-2, -2, -d / 2}, {2, 2, d / 2}, 0.5f), 0, GetParam())};
  TraceOptions opt = ortho({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 2, 16, 16);
  opt.background = {1, 1, 1};
  TraceResult r = trace(objs, mats, opt);
  for (int y = 0; y < 16; y += 5) {
    for (int x = 0; x < 16; x += 5) {
      Vec3 c = pixel(r.image, x, y);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(c[k], std::exp(-sigma[k] * d), 2e-4) << x << "," << y;
    }
  }
  EXPECT_EQ(r.stats.root_used[0], GetParam());
}

// Reflectance at normal incidence is ((n - 1) / (n + 1))^2 with fresnel = true (the transmitted
// part is absorbed: absorb is large).
TEST_P(TracerTest, FresnelReflectanceAtNormalIncidence) {
  for (float n : {1.5f, 2.0f}) {
    auto slab = box_field({-2, -2, -1}, {2, 2, 0});
    std::vector<Material> mats{glass(n, true, {60, 60, 60})};
    std::vector<SceneObject> objs{
        object(*slab, grown({-2, -2, -1}, {2, 2, 0}, 0.5f), 0, GetParam())};
    TraceOptions opt = ortho({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 2, 8, 8);
    opt.background = {1, 1, 1};
    TraceResult r = trace(objs, mats, opt);
    const float expect = ((n - 1) / (n + 1)) * ((n - 1) / (n + 1));
    EXPECT_NEAR(pixel(r.image, 4, 4).x, expect, 1e-4) << "ior " << n;
    EXPECT_NEAR(pixel(r.image, 1, 6).y, expect, 1e-4) << "ior " << n;
  }
}

// A glass slab tilted by theta about y shifts what lies behind it sideways by
// d sin(theta - theta_t) / cos(theta_t): the image of an emitter's edge moves by that much.
TEST_P(TracerTest, TiltedSlabShiftsByLateralDisplacement) {
  const float d = 0.5f, n = 1.5f, theta_deg = 40;
  auto slab = box_field({-3, -3, -d / 2}, {3, 3, d / 2});
  auto target = box_field({0, -5, -4}, {5, 5, -3});
  std::vector<Material> mats{glass(n, false), emitter({1, 1, 1})};
  const int w = 400;
  const float width = 4;  // 0.01 world units per pixel
  auto edge_column = [&](bool with_slab) {
    std::vector<SceneObject> objs{
        object(*target, grown({0, -5, -4}, {5, 5, -3}, 0.5f), 1, GetParam())};
    if (with_slab) {
      objs.push_back(object(*slab, grown({-3, -3, -d / 2}, {3, 3, d / 2}, 0.2f), 0, GetParam(),
                            Transform::from_srt(1, {0, theta_deg, 0}, {0, 0, 0})));
    }
    TraceOptions opt = ortho({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, width, w, 4);
    TraceResult r = trace(objs, mats, opt);
    for (int x = 0; x < w; ++x)
      if (pixel(r.image, x, 2).x > 0.5f) return x;
    return -1;
  };
  // Closed form: the shift perpendicular to the ray. The refracted ray bends towards the inward
  // normal -(sin theta, 0, cos theta), i.e. towards -x, so the edge's image moves to +x.
  const double th = theta_deg * M_PI / 180, tt = std::asin(std::sin(th) / n);
  const double shift = d * std::sin(th - tt) / std::cos(tt);
  const double px = width / w;
  int plain = edge_column(false), shifted = edge_column(true);
  EXPECT_NEAR(plain, (0 + width / 2) / px, 1.0);
  EXPECT_NEAR(shifted, (shift + width / 2) / px, 1.0) << "shift " << shift;
}

// A sphere above a mirror floor: its mirrored image lies where the unfolded camera rays meet the
// sphere mirrored in the floor plane.
TEST_P(TracerTest, MirrorFloorShowsMirroredSphere) {
  auto floor = box_field({-6, -1, -6}, {6, 0, 6});
  SphereField ball({0, 2, 0}, 0.5);
  if (GetParam() != RootMode::kAnalytic) ball.set_has_ray_candidates(false);
  std::vector<Material> mats{mirror(), emitter({1, 1, 1})};
  std::vector<SceneObject> objs{object(*floor, grown({-6, -1, -6}, {6, 0, 6}, 1), 0, GetParam()),
                                object(ball, Box{{-1, 1, -1}, {1, 3, 1}}, 1, GetParam())};
  const int w = 120;
  const float width = 6, px = width / w;
  TraceOptions opt = ortho({0, 5, 5}, {0, 0, 0}, {0, 1, 0}, width, w, w);
  TraceResult r = trace(objs, mats, opt);
  // Screen "up" is (0, 1, -1)/sqrt2: the real sphere projects to +sqrt2, its image to -sqrt2.
  double sum = 0, sum_row = 0, sum_col = 0;
  for (int y = w / 2; y < w; ++y)
    for (int x = 0; x < w; ++x) {
      float v = pixel(r.image, x, y).x;
      sum += v, sum_row += v * (y + 0.5), sum_col += v * (x + 0.5);
    }
  const double expect_row = w / 2 + 2 / std::sqrt(2.0) / px;
  ASSERT_GT(sum, 0);
  EXPECT_NEAR(sum_row / sum, expect_row, 0.3);
  EXPECT_NEAR(sum_col / sum, w / 2, 0.3);
  const double disc = M_PI * (0.5 / px) * (0.5 / px);
  EXPECT_NEAR(sum, disc, 0.03 * disc);
}

// A 45-degree prism: light entering the top face meets the hypotenuse at 45 degrees: beyond the
// critical angle for ior 1.5 (41.8 degrees) it is totally reflected towards the red emitter;
// for ior 1.3 (critical angle 50.3 degrees) it leaves through the hypotenuse instead.
TEST_P(TracerTest, TotalInternalReflectionPastTheCriticalAngle) {
  double top_c[3] = {0, 0, 1}, top_n[3] = {0, 0, 1};
  double leg_c[3] = {-1, 0, 0}, leg_n[3] = {-1, 0, 0};
  double hyp_c[3] = {0, 0, 0}, hyp_n[3] = {1, 0, -1};
  CsgField prism({{CsgField::half_space(top_c, top_n), CsgField::half_space(leg_c, leg_n),
                   CsgField::half_space(hyp_c, hyp_n)}});
  auto red = box_field({-4, -2, -1}, {-3, 2, 1});
  for (float n : {1.5f, 1.3f}) {
    std::vector<Material> mats{glass(n, false), emitter({1, 0, 0})};
    std::vector<SceneObject> objs{
        object(prism, Box{{-1.5f, -1, -1.5f}, {1.5f, 1, 1.5f}}, 0, GetParam()),
        object(*red, grown({-4, -2, -1}, {-3, 2, 1}, 0.2f), 1, GetParam())};
    TraceOptions opt = ortho({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 1, 8, 8);
    TraceResult r = trace(objs, mats, opt);
    for (int y = 1; y < 8; y += 3)
      for (int x = 1; x < 8; x += 3) {
        EXPECT_NEAR(pixel(r.image, x, y).x, n == 1.5f ? 1.0f : 0.0f, 1e-4) << "ior " << n;
      }
  }
}

// The lit fraction at floor point p of a sphere light (centre c, radius R) behind the edge of a
// plate: quadrature over the light's disk as seen from p (perpendicular to the direction to c),
// each point weighted by its Lambert factor on the floor (normal +y) and counted when the line
// to it passes above the plate's top corner (0, top) — the plate lies at x < 0. Its full width
// is the similar-triangles 2 R top / (H - top).
double lit_fraction(Vec3 p, Vec3 c, double radius, double top) {
  Vec3 w = normalize(c - p);
  Vec3 u = normalize(cross(w, Vec3{0, 0, 1})), v = cross(w, u);
  double lit = 0, all = 0;
  const int n = 200;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      double a = (2 * (i + 0.5) / n - 1), b = (2 * (j + 0.5) / n - 1);
      if (a * a + b * b > 1) continue;
      Vec3 q = c + (u * float(a) + v * float(b)) * float(radius);
      Vec3 l = normalize(q - p);
      double ndotl = l.y;
      if (ndotl <= 0) continue;
      all += ndotl;
      // Where the line p -> q reaches the height of the plate's top, is it right of the edge?
      double s = (top - p.y) / (q.y - p.y);
      if (p.x + s * (q.x - p.x) >= 0) lit += ndotl;
    }
  return lit / all;
}

// The penumbra of a sphere light behind a plate's straight edge: per pixel of the floor, the lit
// fraction (the render with the plate over the one without) against the disk-segment closed
// form, whose width is the similar-triangles 2 R h / (H - h).
TEST_P(TracerTest, SphereLightPenumbraFollowsSimilarTriangles) {
  const float H = 4, h = 1, R = 0.6f, xl = -1.5f;
  auto floor = box_field({-4, -1, -4}, {4, 0, 4});
  auto plate = box_field({-4, h, -4}, {0, h + 0.05f, 4});
  Material diffuse;
  diffuse.color = {1, 1, 1};
  diffuse.ambient = 0;
  diffuse.specular = 0;
  std::vector<Material> mats{diffuse};
  Light light;
  light.kind = Light::Kind::kSphere;
  light.v = {xl, H, 0};
  light.radius = R;
  light.samples = 1024;
  const int w = 60;
  const float x0 = -0.1f, width = 1.2f;
  auto render_floor = [&](bool with_plate) {
    std::vector<SceneObject> objs{
        object(*floor, grown({-4, -1, -4}, {4, 0, 4}, 0.5f), 0, GetParam())};
    if (with_plate) {
      objs.push_back(object(*plate, grown({-4, h, -4}, {0, h + 0.05f, 4}, 0.2f), 0, GetParam()));
    }
    TraceOptions opt =
        ortho({x0 + width / 2, 5, 0}, {x0 + width / 2, 0, 0}, {0, 0, -1}, width, w, 3);
    opt.lights = {light};
    return trace(objs, mats, opt);
  };
  TraceResult lit = render_floor(false), shadowed = render_floor(true);
  // Seen from the floor right of the plate, the occluding edge is the plate's top corner.
  const float he = h + 0.05f;
  const float edge = xl + (0 - xl) * H / (H - he);  // where the light centre's shadow edge falls
  const float half_width = R * he / (H - he);
  int in_penumbra = 0;
  for (int x = 0; x < w; ++x) {
    float wx = x0 + (x + 0.5f) * width / w;
    if (wx < 0.05f) continue;  // under the plate as seen from above
    float ratio = pixel(shadowed.image, x, 1).x / pixel(lit.image, x, 1).x;
    double expect = lit_fraction({wx, 0, 0}, light.v, R, he);
    // The sign-change march may step over the plate's corner where a shadow ray only clips it
    // (a chord shorter than its step): a looser bound for it.
    EXPECT_NEAR(ratio, expect, GetParam() == RootMode::kSign ? 0.06 : 0.04) << "x = " << wx;
    if (wx < edge - half_width - 0.02f) {
      EXPECT_LT(ratio, 0.02f) << "umbra at x = " << wx;
    }
    if (wx > edge + half_width + 0.02f) {
      EXPECT_GT(ratio, 0.98f) << "lit at x = " << wx;
    }
    if (ratio > 0.05f && ratio < 0.95f) in_penumbra++;
  }
  // The penumbra spans about 2 R h / (H - h) = 0.43 world units, i.e. 21 pixels (less its
  // nearly dark and nearly lit ends).
  EXPECT_GT(in_penumbra, 12);
  EXPECT_LT(in_penumbra, 22);
}

// A thin lens blurs a point off the focal plane into a disk of radius A |z - f| / z (on the
// focal plane); the image's second moment about its centre is (B^2 + rho^2) / 2 + 1/6 px^2
// (the lens disk convolved with the sphere's own disk of radius rho, plus the pixel's box).
TEST_P(TracerTest, ThinLensBlurCircleFollowsSimilarTriangles) {
  SphereField dot_field({0, 0, -5}, 0.05);
  if (GetParam() != RootMode::kAnalytic) dot_field.set_has_ray_candidates(false);
  std::vector<Material> mats{emitter({1, 1, 1})};
  std::vector<SceneObject> objs{
      object(dot_field, Box{{-0.1f, -0.1f, -5.1f}, {0.1f, 0.1f, -4.9f}}, 0, GetParam())};
  const int w = 64;
  for (float aperture : {0.0f, 0.4f}) {
    TraceOptions opt;
    opt.width = opt.height = w;
    opt.camera.eye = {0, 0, 10};
    opt.camera.look_at = {0, 0, 0};
    opt.camera.fov_deg = 10;
    opt.aperture = aperture;
    opt.focus_distance = 10;
    opt.spp = 256;
    opt.background = {0, 0, 0};
    opt.threads = 2;
    TraceResult r = trace(objs, mats, opt);
    double sum = 0, sx = 0, sy = 0, sxx = 0;
    for (int y = 0; y < w; ++y)
      for (int x = 0; x < w; ++x) {
        double v = pixel(r.image, x, y).x;
        sum += v, sx += v * (x + 0.5), sy += v * (y + 0.5);
      }
    ASSERT_GT(sum, 0);
    double cx = sx / sum, cy = sy / sum;
    for (int y = 0; y < w; ++y)
      for (int x = 0; x < w; ++x) {
        double v = pixel(r.image, x, y).x;
        sxx += v * ((x + 0.5 - cx) * (x + 0.5 - cx) + (y + 0.5 - cy) * (y + 0.5 - cy));
      }
    const double f = 10, z = 15;
    const double px = 2 * f * std::tan(5 * M_PI / 180) / w;  // pixel size on the focal plane
    const double blur = aperture * std::abs(z - f) / z / px;
    const double rho = 0.05 * f / std::sqrt(z * z - 0.05 * 0.05) / px;
    const double expect = (blur * blur + rho * rho) / 2 + 1.0 / 6;
    EXPECT_NEAR(sxx / sum, expect, 0.1 * expect) << "aperture " << aperture;
    EXPECT_NEAR(cx, w / 2.0, 0.1);
    EXPECT_NEAR(cy, w / 2.0, 0.1);
  }
}

// A planar image texture on an emitting face: with one pixel per texel, each pixel centre is a
// texel centre and shows exactly that texel (the image's top row at the top, v = 0 at the
// bottom, as POV-Ray's image_map).
TEST_P(TracerTest, PlanarTextureShowsItsTexels) {
  const int n = 4;
  std::vector<float> texels;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      texels.push_back(float(i) / n);
      texels.push_back(float(j) / n);
      texels.push_back(0.5f);
    }
  std::string path = (std::filesystem::temp_directory_path() /
                      ("hfrt_tracer_texture_" + std::to_string(::getpid()) + ".exr"))
                         .string();
  ASSERT_TRUE(write_pixels(path, n, n, 3, texels, false).ok());
  auto image = load_texture(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(image.ok());
  auto face = box_field({0, 0, -1}, {1, 1, 0});
  Material m = emitter({1, 1, 1});
  m.texture_image = image.value();
  m.mapping = TextureMapping::kPlanar;
  std::vector<Material> mats{m};
  std::vector<SceneObject> objs{object(*face, grown({0, 0, -1}, {1, 1, 0}, 0.25f), 0, GetParam())};
  TraceOptions opt = ortho({0.5f, 0.5f, 5}, {0.5f, 0.5f, 0}, {0, 1, 0}, 1, n, n);
  TraceResult r = trace(objs, mats, opt);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      Vec3 c = pixel(r.image, x, y);
      EXPECT_NEAR(c.x, float(x) / n, 1e-5) << x << "," << y;
      EXPECT_NEAR(c.y, float(y) / n, 1e-5) << x << "," << y;
      EXPECT_NEAR(c.z, 0.5f, 1e-5);
    }
}

INSTANTIATE_TEST_SUITE_P(Roots, TracerTest,
                         ::testing::Values(RootMode::kSign, RootMode::kInterval,
                                           RootMode::kAnalytic),
                         [](const ::testing::TestParamInfo<RootMode>& info) {
                           return std::string(root_mode_name(info.param));
                         });

TEST(Fresnel, ClosedForms) {
  EXPECT_NEAR(fresnel_dielectric(1, 1, 1.5f), 0.04f, 1e-6);
  EXPECT_NEAR(fresnel_dielectric(1, 1.5f, 1), 0.04f, 1e-6);
  // Brewster's angle: rp = 0, so R = rs^2 / 2.
  float tb = std::atan(1.5f), ti = std::asin(std::sin(tb) / 1.5f);
  float rs = std::sin(ti - tb) / std::sin(ti + tb);
  EXPECT_NEAR(fresnel_dielectric(std::cos(tb), 1, 1.5f), 0.5f * rs * rs, 1e-5);
  // Beyond the critical angle from inside: total reflection.
  EXPECT_EQ(fresnel_dielectric(std::cos(45 * float(M_PI) / 180), 1.5f, 1), 1.0f);
  EXPECT_LT(fresnel_dielectric(std::cos(40 * float(M_PI) / 180), 1.5f, 1), 1.0f);
}

TEST(Transform, ScaleRotateTranslateInThatOrder) {
  Transform t = Transform::from_srt(2, {90, 0, 90}, {1, 2, 3});
  // (1,0,0) scaled: (2,0,0); about x: (2,0,0); about z by 90: (0,2,0); +t: (1,4,3).
  Vec3 p = t.point_to_world({1, 0, 0});
  EXPECT_NEAR(p.x, 1, 1e-6);
  EXPECT_NEAR(p.y, 4, 1e-6);
  EXPECT_NEAR(p.z, 3, 1e-6);
  Vec3 q = t.point_to_object(p);
  EXPECT_NEAR(q.x, 1, 1e-6);
  EXPECT_NEAR(q.y, 0, 1e-6);
  EXPECT_NEAR(q.z, 0, 1e-6);
  // (0,1,0): about x by 90 -> (0,0,1), about z unchanged.
  Vec3 n = t.normal_to_world({0, 1, 0});
  EXPECT_NEAR(n.z, 1, 1e-6);
}

// The same image for any thread count, with glossy surfaces, sphere lights, a lens and adaptive
// sampling (every random choice is a hash of the pixel, sample and bounce).
TEST(Tracer, BoxCapsSeenInPerspectiveHaveNoHoles) {
  // The scene tracer's per-tile culling had the renderer's bug (tests/render/renderer_test.cpp,
  // Renderer.BoxCapsSeenInPerspectiveHaveNoHoles): a slab inside the object where it overlaps
  // the object's box ended the tile's culling for rays that enter the box later.
  for (RootMode mode : {RootMode::kSign, RootMode::kInterval, RootMode::kAnalytic}) {
    ShellField shell(30, 25);
    const Box bbox{{-10, -10, -10}, {10, 10, 10}};
    std::vector<Material> mats{Material{}};
    std::vector<SceneObject> objs{object(shell, bbox, 0, mode)};
    TraceOptions opt;
    opt.width = opt.height = 96;
    opt.camera.eye = {30.5f, 24.8f, 43.6f};
    opt.camera.look_at = {0, 0, 0};
    opt.camera.fov_deg = 35;
    opt.background = {0, 0, 0};
    opt.threads = 2;
    TraceResult r = trace(objs, mats, opt);
    const hfrt::testing::BoxCoverage c = hfrt::testing::box_coverage(opt.camera, bbox, r.image);
    EXPECT_GT(c.meets, 2000u);
    EXPECT_EQ(c.wrong, 0u) << "root mode " << int(mode);
  }
}

TEST(Tracer, BitIdenticalForAnyThreadCount) {
  SphereField ball({0, 0, 0}, 1);
  auto floor = box_field({-4, -2, -4}, {4, -1, 4});
  Material g = glass(1.5f, true, {0.3f, 0.1f, 0.05f});
  g.roughness = 0.1f;
  Material m = mirror();
  m.roughness = 0.05f;
  std::vector<Material> mats{g, m};
  std::vector<SceneObject> objs{
      object(ball, Box{{-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f}}, 0, RootMode::kAuto),
      object(*floor, grown({-4, -2, -4}, {4, -1, 4}, 0.5f), 1, RootMode::kInterval)};
  TraceOptions opt;
  opt.width = opt.height = 48;
  opt.camera.eye = {2, 2, 5};
  opt.camera.look_at = {0, 0, 0};
  opt.aperture = 0.05f;
  opt.spp = 8;
  opt.adaptive = true;
  Light l;
  l.kind = Light::Kind::kSphere;
  l.v = {3, 5, 2};
  l.radius = 0.5f;
  l.samples = 4;
  opt.lights = {l};
  opt.threads = 1;
  TraceResult a = trace(objs, mats, opt);
  opt.threads = 2;
  opt.tile_size = 16;
  TraceResult b = trace(objs, mats, opt);
  EXPECT_EQ(a.image.rgb, b.image.rgb);
  EXPECT_GT(a.stats.secondary_rays, 0u);
  EXPECT_GT(a.stats.refined_pixels, 0u);
  EXPECT_LT(a.stats.refined_pixels, uint64_t(48 * 48));
}

TEST(Tracer, MaxDepthZeroTracesNoSecondaryRays) {
  SphereField ball({0, 0, 0}, 1);
  std::vector<Material> mats{glass(1.5f, true)};
  std::vector<SceneObject> objs{
      object(ball, Box{{-1.2f, -1.2f, -1.2f}, {1.2f, 1.2f, 1.2f}}, 0, RootMode::kAuto)};
  TraceOptions opt;
  opt.width = opt.height = 16;
  opt.camera.eye = {0, 0, 5};
  opt.max_depth = 0;
  TraceResult r = trace(objs, mats, opt);
  EXPECT_EQ(r.stats.secondary_rays, 0u);
  EXPECT_GT(r.stats.hits, 0u);
}

}  // namespace
}  // namespace hfrt::render
