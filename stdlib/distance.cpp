// Distance primitives (library.md §6): signed distances, positive inside.
#include <array>

#include "base/check.h"
#include "ir/builder.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

using P3 = std::array<V, 3>;

/// The cone and cylinder functions have their own failure values.
constexpr double kConeFailure = -11111111111.0;
constexpr double kCylinderFailure = -11111111111.1;

P3 point(Call& c, int i) {
  return {c.at(i, 0), c.at(i, 1), c.at(i, 2)};
}

P3 offset(Call& c) {
  c.need(1, 3, "a centre of 3 coordinates");
  P3 p = point(c, 0);
  return {p[0] - c.at(1, 0), p[1] - c.at(1, 1), p[2] - c.at(1, 2)};
}

V dcone(Call& c) {
  if (!c.point3(0, kConeFailure)) return c.k(kConeFailure);
  P3 d = offset(c);
  V tau = atan(c.real(2));
  V radial = c.k(0), along = c.k(0);
  switch (c.fn()) {
    case LibraryFn::kDConeX:
      radial = sqrt(d[2] * d[2] + d[1] * d[1]), along = abs(d[0]);
      break;
    case LibraryFn::kDConeY:
      radial = sqrt(d[2] * d[2] + d[0] * d[0]), along = abs(d[1]);
      break;
    default:
      radial = sqrt(d[0] * d[0] + d[1] * d[1]), along = abs(d[2]);
      break;
  }
  V dist = radial * cos(tau) - along * sin(tau);
  return -dist;
}

V dcylinder(Call& c) {
  if (!c.point3(0, kCylinderFailure)) return c.k(kCylinderFailure);
  c.need(1, 3, "a point on the axis");
  c.need(2, 3, "the axis direction");
  P3 p = point(c, 0), ctr = point(c, 1), u = point(c, 2);
  P3 e, w;
  for (int k = 0; k < 3; ++k) {
    e[k] = (ctr[k] + u[k]) - ctr[k];
    w[k] = ctr[k] - p[k];
  }
  V cp0 = e[1] * w[2] - w[1] * e[2];
  V cp1 = e[2] * w[0] - e[0] * w[2];
  V cp2 = e[0] * w[1] - e[1] * w[0];
  V num = cp0 * cp0 + cp1 * cp1 + cp2 * cp2;
  V den = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
  return c.real(3) - sqrt(num / den);
}

// Newton iteration on the ellipsoid's distance parameter t: a kLoop of at most 128 steps
// that stops when |s| < 1e-6, as the original.
V dellipsoid(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  c.need(1, 3, "a centre of 3 coordinates");
  IrBuilder& b = c.builder();
  P3 p = point(c, 0), ctr = point(c, 1);
  V a = c.real(2), bb = c.real(3), cc = c.real(4);
  V xx = p[0] - ctr[0], yy = p[1] - ctr[1], zz = p[2] - ctr[2];
  V a2 = a * a, b2 = bb * bb, c2 = cc * cc;
  V a2u2 = a2 * (xx * xx), b2v2 = b2 * (yy * yy), c2w2 = c2 * (zz * zz);
  V ur = xx / a, vr = yy / bb, wr = zz / cc;
  V length = sqrt(xx * xx + yy * yy + zz * zz);
  V inside = lt(ur * ur + vr * vr + wr * wr, 1.0);
  V mx = sel(gt(bb, a), bb, a);
  mx = sel(gt(cc, mx), cc, mx);
  V t0 = sel(inside, 0.0, mx * length);

  const int t_slot = b.new_slot(0), i_slot = b.new_slot(0), done_slot = b.new_slot(0);
  b.store(t_slot, t0.id);
  b.store(i_slot, c.k(0).id);
  b.store(done_slot, c.k(0).id);
  b.begin_loop();
  {
    V i{&b, b.load(i_slot)};
    V done{&b, b.load(done_slot)};
    b.loop_test(land(lt(i, 128.0), lnot(done)).id);
  }
  {
    V t{&b, b.load(t_slot)};
    V i{&b, b.load(i_slot)};
    V pp = t + a2, q = t + b2, r = t + c2;
    V p2 = pp * pp, q2 = q * q, r2 = r * r;
    V s = p2 * q2 * r2 - a2u2 * q2 * r2 - b2v2 * p2 * r2 - c2w2 * p2 * q2;
    V stop = lt(abs(s), 1e-6);
    V pq = pp * q, pr = pp * r, qr = q * r, pqr = pp * q * r;
    V ds = 2.0 * (pqr * (qr + pr + pq) - a2u2 * qr * (q + r) - b2v2 * pr * (pp + r) -
                  c2w2 * pq * (pp + q));
    b.store(t_slot, sel(stop, t, t - s / ds).id);
    b.store(done_slot, stop.id);
    b.store(i_slot, (i + 1.0).id);
  }
  b.end_loop();
  V t{&b, b.load(t_slot)};
  V kx = (a2 * p[0] + t * ctr[0]) / (t + a2);
  V ky = (b2 * p[1] + t * ctr[1]) / (t + b2);
  V kz = (c2 * p[2] + t * ctr[2]) / (t + c2);
  V dx = kx - p[0], dy = ky - p[1], dz = kz - p[2];
  V dist = sqrt(dx * dx + dy * dy + dz * dz);
  V f = sel(inside, dist, -dist);
  V bad = lor(lor(lt(abs(a), kEps), lt(abs(bb), kEps)), lt(abs(cc), kEps));
  return sel(bad, kFailure, f);
}

V dtorus(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c);
  V big_r = c.real(2), r0 = c.real(3);
  V g = c.k(0), axis2 = c.k(0);
  switch (c.fn()) {
    case LibraryFn::kDTorusX:
      g = sqrt(d[1] * d[1] + d[2] * d[2]) - big_r, axis2 = d[0] * d[0];
      break;
    case LibraryFn::kDTorusY:
      g = sqrt(d[0] * d[0] + d[2] * d[2]) - big_r, axis2 = d[1] * d[1];
      break;
    default:
      g = sqrt(d[0] * d[0] + d[1] * d[1]) - big_r, axis2 = d[2] * d[2];
      break;
  }
  return -(sqrt(g * g + axis2) - r0);
}

}  // namespace

V lower_distance(Call& c) {
  switch (c.fn()) {
    case LibraryFn::kDConeX:
    case LibraryFn::kDConeY:
    case LibraryFn::kDConeZ:
      return dcone(c);
    case LibraryFn::kDCylinder:
      return dcylinder(c);
    case LibraryFn::kDEllipsoid:
      return dellipsoid(c);
    case LibraryFn::kDTorusX:
    case LibraryFn::kDTorusY:
    case LibraryFn::kDTorusZ:
      return dtorus(c);
    default:
      HFRT_CHECK_MSG(false, "not a distance primitive: " << c.name());
  }
}

}  // namespace hfrt::stdlib::detail
