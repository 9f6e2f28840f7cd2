// kSurface in every domain (see surface_ops.h).
#include "jit/surface_ops.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "geom/surface.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Points closer to the surface than this fraction of its bounding-box diagonal count as on
/// it for the gradient, which is then taken by central differences of step kNormalStep.
constexpr float kOnSurface = 1e-5f;
constexpr float kNormalStep = 1e-4f;

/// The float nearest to v on the side of -inf / +inf.
float down(double v) {
  float f = static_cast<float>(v);
  return static_cast<double>(f) > v ? std::nextafter(f, -std::numeric_limits<float>::infinity())
                                    : f;
}
float up(double v) {
  float f = static_cast<float>(v);
  return static_cast<double>(f) < v ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

}  // namespace

double surface_value(const geom::Surface& s, double x, double y, double z) {
  if (x != x || y != y || z != z) return std::numeric_limits<double>::quiet_NaN();
  geom::Vec3 p(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  return static_cast<double>(s.signed_distance(p));
}

Interval surface_interval(const geom::Surface& s, const Interval& x, const Interval& y,
                          const Interval& z) {
  const bool nan = x.maybe_nan || y.maybe_nan || z.maybe_nan;
  // A box that is not finite in float (or not a box) gets the whole line: the distance
  // bounds need a centre and a diagonal.
  geom::Box box(geom::Vec3(down(x.lo), down(y.lo), down(z.lo)),
                geom::Vec3(up(x.hi), up(y.hi), up(z.hi)));
  if (!::hfrt::is_finite(box.lo) || !::hfrt::is_finite(box.hi) || box.empty()) {
    return Interval::of(-kInf, kInf, nan);
  }
  geom::DistanceBounds b = s.signed_distance_bounds(box);
  // One float step outwards: the bounds are computed in float like the value they enclose.
  double lo = std::nextafter(b.lo, -std::numeric_limits<float>::infinity());
  double hi = std::nextafter(b.hi, std::numeric_limits<float>::infinity());
  if (!(lo <= hi)) return Interval::of(-kInf, kInf, true);
  return Interval::of(lo, hi, nan);
}

Dual surface_dual(const geom::Surface& s, const Dual& x, const Dual& y, const Dual& z) {
  Dual r;
  if (x.v != x.v || y.v != y.v || z.v != z.v) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, {nan, nan, nan}};
  }
  geom::Vec3 g;
  geom::Vec3 p(static_cast<float>(x.v), static_cast<float>(y.v), static_cast<float>(z.v));
  r.v = static_cast<double>(s.signed_distance(p, &g));
  const float size = ::hfrt::length(s.bounds().diagonal());
  if (std::abs(r.v) < kOnSurface * size) {
    // On the surface to rounding (a ray hit: where the renderer asks for normals), the
    // direction from the closest point is rounding noise and the side test is ambiguous, so
    // the gradient could point anywhere, even outwards. Central differences a little farther
    // out give the face's normal (the distance is linear across a face).
    const float h = kNormalStep * size;
    geom::Vec3 fd;
    for (int k = 0; k < 3; ++k) {
      geom::Vec3 a = p, b = p;
      a[k] += h;
      b[k] -= h;
      fd[k] = (s.signed_distance(a) - s.signed_distance(b)) / (2 * h);
    }
    const float len = ::hfrt::length(fd);
    if (len > 0 && std::isfinite(len)) g = fd / len;
  }
  for (int k = 0; k < 3; ++k)
    r.d[k] = double(g.x) * x.d[k] + double(g.y) * y.d[k] + double(g.z) * z.d[k];
  return r;
}

}  // namespace hfrt::jit

extern "C" {

double hfrt_surface_f64(const void* s, double x, double y, double z) noexcept {
  return hfrt::jit::surface_value(*static_cast<const hfrt::geom::Surface*>(s), x, y, z);
}

float hfrt_surface_f32(const void* s, float x, float y, float z) noexcept {
  if (x != x || y != y || z != z) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<const hfrt::geom::Surface*>(s)->signed_distance(hfrt::geom::Vec3(x, y, z));
}

double hfrt_surface_sign_f64(const void* s, double x, double y, double z) noexcept {
  return hfrt_surface_sign_f32(s, static_cast<float>(x), static_cast<float>(y),
                               static_cast<float>(z));
}

float hfrt_surface_sign_f32(const void* s, float x, float y, float z) noexcept {
  if (x != x || y != y || z != z) return std::numeric_limits<float>::quiet_NaN();
  // The same test as signed_distance's sign (geom/surface.h), without the distance query.
  const double w =
      static_cast<const hfrt::geom::Surface*>(s)->winding_number(hfrt::geom::Vec3(x, y, z));
  return w >= 0.5 ? 1.0f : -1.0f;
}

void hfrt_surface_interval(const void* s, const double* in, double* out) noexcept {
  using ::hfrt::Interval;
  // A block with fewer boxes than lanes repeats its last box in the spare lanes (one box per
  // call from a bisection): reuse the previous lane's bound, a BVH walk of ~26 us, when the
  // surface and the box are the same bits.
  struct Last {
    const void* surface = nullptr;
    double in[9];
    double out[3];
  };
  thread_local Last last;
  if (last.surface == s && std::memcmp(last.in, in, sizeof last.in) == 0) {
    std::memcpy(out, last.out, sizeof last.out);
    return;
  }
  Interval r = hfrt::jit::surface_interval(
      *static_cast<const hfrt::geom::Surface*>(s), Interval::of(in[0], in[1], in[2] != 0),
      Interval::of(in[3], in[4], in[5] != 0), Interval::of(in[6], in[7], in[8] != 0));
  out[0] = r.lo;
  out[1] = r.hi;
  out[2] = r.maybe_nan ? 1.0 : 0.0;
  last.surface = s;
  std::memcpy(last.in, in, sizeof last.in);
  std::memcpy(last.out, out, sizeof last.out);
}

void hfrt_surface_dual(const void* s, const double* in, double* out) noexcept {
  using hfrt::jit::Dual;
  Dual a[3];
  for (int k = 0; k < 3; ++k) a[k] = {in[4 * k], {in[4 * k + 1], in[4 * k + 2], in[4 * k + 3]}};
  Dual r = hfrt::jit::surface_dual(*static_cast<const hfrt::geom::Surface*>(s), a[0], a[1], a[2]);
  out[0] = r.v;
  for (int k = 0; k < 3; ++k) out[k + 1] = r.d[k];
}

}  // extern "C"
