// Transformations (library.md §5): inverse maps that overwrite elements 1..3 of their array
// argument with the moved point and return 1. No argument checks (IEEE inf/NaN results).
#include <array>
#include <sstream>

#include "base/check.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

using P3 = std::array<V, 3>;

P3 load_point(Call& c) {
  c.need(0, 3, "the point's 3 coordinates");
  return {c.at(0, 0), c.at(0, 1), c.at(0, 2)};
}

V store_point(Call& c, const P3& p) {
  for (int k = 0; k < 3; ++k) c.put(0, k, p[k]);
  return c.k(1);
}

/// Rotation about axis `ax` by (co, si) as hfRotate3D{X,Y,Z}: with (u, v) the pair
/// (y, z), (z, x) or (x, y): (u, v) := (u co + v si, -u si + v co).
P3 rotate(P3 p, int ax, V co, V si) {
  const int u = (ax + 1) % 3, v = (ax + 2) % 3;
  V nu = p[u] * co + p[v] * si;
  V nv = -p[u] * si + p[v] * co;
  p[u] = nu;
  p[v] = nv;
  return p;
}

int axis_of(LibraryFn fn) {
  switch (fn) {
    case LibraryFn::kRotate3DX:
    case LibraryFn::kTwistX:
    case LibraryFn::kTaperX:
      return 0;
    case LibraryFn::kRotate3DY:
    case LibraryFn::kTwistY:
    case LibraryFn::kTaperY:
      return 1;
    default:
      return 2;
  }
}

V scale(Call& c) {
  P3 p = load_point(c);
  return store_point(c, {p[0] / c.real(1), p[1] / c.real(2), p[2] / c.real(3)});
}

V shift(Call& c) {
  P3 p = load_point(c);
  return store_point(c, {p[0] - c.real(1), p[1] - c.real(2), p[2] - c.real(3)});
}

V rotate3d(Call& c) {
  P3 p = load_point(c);
  V th = c.real(1);
  return store_point(c, rotate(p, axis_of(c.fn()), cos(th), sin(th)));
}

V twist(Call& c) {
  P3 p = load_point(c);
  const int ax = axis_of(c.fn());
  V z1 = c.real(1), z2 = c.real(2), th1 = c.real(3), th2 = c.real(4);
  V t = (p[ax] - z1) / (z2 - z1);
  V th = (1.0 - t) * th1 + t * th2;
  return store_point(c, rotate(p, ax, cos(th), sin(th)));
}

V taper(Call& c) {
  P3 p = load_point(c);
  const int ax = axis_of(c.fn());
  V z1 = c.real(1), z2 = c.real(2), s1 = c.real(3), s2 = c.real(4);
  V z = p[ax];
  V t = (z - z1) / (z2 - z1);
  V s = sel(lt(z, z1), s1, sel(gt(z, z2), s2, (1.0 - t) * s1 + t * s2));
  s = sel(lt(abs(s), kEps), 1.0, s);
  const int u = (ax + 1) % 3, v = (ax + 2) % 3;
  p[u] = p[u] / s;
  p[v] = p[v] / s;
  return store_point(c, p);
}

V stretch(Call& c) {
  P3 p = load_point(c);
  c.need(1, 3, "a centre of 3 coordinates");
  for (int k = 0; k < 3; ++k) {
    V x0 = c.at(1, k);
    p[k] = x0 + (p[k] - x0) / c.real(2 + k);
  }
  return store_point(c, p);
}

V space_map(Call& c, bool cubic) {
  P3 p = load_point(c);
  const int n = c.size(1);
  const int pairs = (n + 2) / 3;  // i = 0, 3, 6, ... < size(src)
  std::ostringstream why;
  why << "3 per point pair, " << pairs << " pair(s) from the size of '" << c.arg_text(1) << "'";
  c.need(1, 3 * pairs, why.str());
  c.need(2, 3 * pairs, why.str());
  c.need(3, 3 * pairs, why.str());
  for (int i = 0; i < 3 * pairs; i += 3) {
    P3 delta, q;
    for (int k = 0; k < 3; ++k) {
      V dst = c.at(2, i + k);
      delta[k] = dst - c.at(1, i + k);
      q[k] = (p[k] - dst) / (c.at(3, i + k) * (1.0 + abs(delta[k])));
    }
    V r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
    if (cubic) {
      V rho = sqrt(r2);
      V w = (1.0 - rho) * (1.0 - rho) * (1.0 - rho) / (1.0 + rho);
      V inside = le(rho, 1.0);
      for (int k = 0; k < 3; ++k) p[k] = sel(inside, p[k] - w * delta[k], p[k]);
    } else {
      V w = exp(-r2);
      for (int k = 0; k < 3; ++k) p[k] = p[k] - w * delta[k];
    }
  }
  return store_point(c, p);
}

}  // namespace

V lower_transform(Call& c) {
  switch (c.fn()) {
    case LibraryFn::kScale3D:
      return scale(c);
    case LibraryFn::kShift3D:
      return shift(c);
    case LibraryFn::kRotate3DX:
    case LibraryFn::kRotate3DY:
    case LibraryFn::kRotate3DZ:
      return rotate3d(c);
    case LibraryFn::kTwistX:
    case LibraryFn::kTwistY:
    case LibraryFn::kTwistZ:
      return twist(c);
    case LibraryFn::kTaperX:
    case LibraryFn::kTaperY:
    case LibraryFn::kTaperZ:
      return taper(c);
    case LibraryFn::kStretch3D:
      return stretch(c);
    case LibraryFn::kSpaceMapCubic:
      return space_map(c, true);
    case LibraryFn::kSpaceMapExp:
      return space_map(c, false);
    default:
      HFRT_CHECK_MSG(false, "not a transformation: " << c.name());
  }
}

}  // namespace hfrt::stdlib::detail
