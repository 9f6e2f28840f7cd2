// Algebraic primitives, blobs, Gardner noise and the Bezier volume (library.md §1, §3).
#include <array>
#include <sstream>

#include "base/check.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

using P3 = std::array<V, 3>;

/// The point (elements 1..3 of array argument i).
P3 point(Call& c, int i) {
  return {c.at(i, 0), c.at(i, 1), c.at(i, 2)};
}

/// d = P - centre (centre = array argument ci, 3 elements needed).
P3 offset(Call& c, int pi, int ci) {
  c.need(ci, 3, "a centre of 3 coordinates");
  P3 p = point(c, pi);
  return {p[0] - c.at(ci, 0), p[1] - c.at(ci, 1), p[2] - c.at(ci, 2)};
}

/// The axis index (0 = x) of an X/Y/Z variant.
int axis_of(LibraryFn fn) {
  switch (fn) {
    case LibraryFn::kCylinderX:
    case LibraryFn::kEllCylX:
    case LibraryFn::kConeX:
    case LibraryFn::kEllConeX:
    case LibraryFn::kTorusX:
      return 0;
    case LibraryFn::kCylinderY:
    case LibraryFn::kEllCylY:
    case LibraryFn::kConeY:
    case LibraryFn::kEllConeY:
    case LibraryFn::kTorusY:
      return 1;
    default:
      return 2;
  }
}

/// The two other axes in x, y, z order.
std::array<int, 2> others(int axis) {
  if (axis == 0) return {1, 2};
  if (axis == 1) return {0, 2};
  return {0, 1};
}

V any_small(Call& c, std::initializer_list<V> vs) {
  V r = c.k(0);
  bool first = true;
  for (V v : vs) {
    V small = lt(abs(v), kEps);
    r = first ? small : lor(r, small);
    first = false;
  }
  return r;
}

V sphere(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c, 0, 1);
  V r = c.real(2);
  return r * r - d[0] * d[0] - d[1] * d[1] - d[2] * d[2];
}

V ellipsoid(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c, 0, 1);
  V a = c.real(2), b = c.real(3), cc = c.real(4);
  V f = 1.0 - sq(d[0] / a) - sq(d[1] / b) - sq(d[2] / cc);
  return sel(any_small(c, {a, b, cc}), kFailure, f);
}

V cylinder(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c, 0, 1);
  auto [o1, o2] = others(axis_of(c.fn()));
  V r = c.real(2);
  return r * r - d[o1] * d[o1] - d[o2] * d[o2];
}

V ell_cylinder(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c, 0, 1);
  auto [o1, o2] = others(axis_of(c.fn()));
  V a = c.real(2), b = c.real(3);
  V f = 1.0 - sq(d[o1] / a) - sq(d[o2] / b);
  return sel(any_small(c, {a, b}), kFailure, f);
}

// hfCone* (a = b = R) and hfEllCone*: no parameter checks.
V cone(Call& c, bool elliptic) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c, 0, 1);
  const int ax = axis_of(c.fn());
  auto [o1, o2] = others(ax);
  V a = c.real(2), b = elliptic ? c.real(3) : c.real(2);
  return d[ax] * d[ax] - sq(d[o1] / a) - sq(d[o2] / b);
}

V torus(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c, 0, 1);
  V big_r = c.real(2), r0 = c.real(3);
  V rho2 = c.k(0);
  switch (axis_of(c.fn())) {
    case 0:
      rho2 = d[2] * d[2] + d[1] * d[1];
      break;
    case 1:
      rho2 = d[2] * d[2] + d[0] * d[0];
      break;
    default:
      rho2 = d[0] * d[0] + d[1] * d[1];
      break;
  }
  return r0 * r0 - d[0] * d[0] - d[1] * d[1] - d[2] * d[2] - big_r * big_r +
         2.0 * big_r * sqrt(rho2);
}

V block(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  c.need(1, 3, "a corner of 3 coordinates");
  P3 p = point(c, 0);
  V v1 = c.at(1, 0), v2 = c.at(1, 1), v3 = c.at(1, 2);
  V dx = c.real(2), dy = c.real(3), dz = c.real(4);
  V p1 = (p[0] - v1) * (v1 + dx - p[0]);
  V p2 = (p[1] - v2) * (v2 + dy - p[1]);
  V p3 = (p[2] - v3) * (v3 + dz - p[2]);
  V g = p1 + p2 - sqrt(p1 * p1 + p2 * p2);
  V f = g + p3 - sqrt(g * g + p3 * p3);
  V bad = lor(lor(lt(dx, 0.0), lt(dy, 0.0)), lt(dz, 0.0));
  return sel(bad, kFailure, f);
}

V superell(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 d = offset(c, 0, 1);
  V a = c.real(2), b = c.real(3), cc = c.real(4), s1 = c.real(5), s2 = c.real(6);
  V u = d[0] / a, v = d[1] / b, w = d[2] / cc;
  V e2 = 2.0 / s2, e1 = 2.0 / s1;
  V f = 1.0 - pow(pow(abs(u), e2) + pow(abs(v), e2), s2 / s1) - pow(abs(w), e1);
  return sel(any_small(c, {a, b, cc, s1, s2}), kFailure, f);
}

/// Shared by hfBlobby, hfMetaball, hfSoft: N = size(x0), the other per-blob arrays need N.
/// Arrays 2..last_extra are per-blob. `contribution(i, r2)` gives blob i's term; the sum starts at
/// 0, in index order.
template <typename Fn>
V blob_sum(Call& c, int last_extra, V threshold, Fn contribution) {
  c.need(0, 3, "the point's 3 coordinates");
  const int n = c.size(1);
  for (int i = 2; i <= last_extra; ++i) {
    c.need(i, n, "one entry per blob; N is the size of the x0 array");
  }
  P3 p = point(c, 0);
  V f = c.k(0);
  for (int i = 0; i < n; ++i) {
    V r2 = sq(p[0] - c.at(1, i)) + sq(p[1] - c.at(2, i)) + sq(p[2] - c.at(3, i));
    f = f + contribution(i, r2);
  }
  return f - threshold;
}

V blobby(Call& c) {
  return blob_sum(c, 5, c.real(6), [&](int i, V r2) {
    V a = c.at(4, i), b = c.at(5, i);
    return b * exp(-a * r2);
  });
}

V metaball(Call& c) {
  return blob_sum(c, 5, c.real(6), [&](int i, V r2) {
    V b = c.at(4, i), d = c.at(5, i);
    V r = sqrt(r2);
    V q = r / d;
    V near = b * (1.0 - 3.0 * q * q);
    V mid = 1.5 * b * (1.0 - q) * (1.0 - q);
    V term = sel(le(r, d / 3.0), near, sel(lt(r, d), mid, 0.0));
    return sel(gt(d, 0.0), term, 0.0);
  });
}

V soft(Call& c) {
  return blob_sum(c, 4, c.real(5), [&](int i, V r2) {
    V d = c.at(4, i);
    V dd = d * d;
    V term = 1.0 - 22.0 * r2 / (9.0 * dd) + 17.0 * r2 * r2 / (9.0 * dd * dd) -
             4.0 * r2 * r2 * r2 / (9.0 * dd * dd * dd);
    return sel(le(sqrt(r2), d), term, 0.0);
  });
}

V noise_g(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  P3 p = point(c, 0);
  V amp = c.real(1), freq = c.real(2), phase = c.real(3);
  V u1 = freq * p[0], u2 = freq * p[1], u3 = freq * p[2];
  V s1 = sin(u1), s2 = sin(u2), s3 = sin(u3);
  V a = amp / 1.17;
  V sx = amp * s1 + a * sin(u1 / 1.35 + phase * s3);
  V sy = amp * s2 + a * sin(u2 / 1.35 + phase * s1);
  V sz = amp * s3 + a * sin(u3 / 1.35 + phase * s2);
  return sx * sy * sz;
}

double binomial(int n, int k) {
  double r = 1;
  for (int i = 1; i <= k; ++i) r = r * (n - k + i) / i;
  return r;
}

}  // namespace

V lower_primitive(Call& c) {
  switch (c.fn()) {
    case LibraryFn::kSphere:
      return sphere(c);
    case LibraryFn::kEllipsoid:
      return ellipsoid(c);
    case LibraryFn::kCylinderX:
    case LibraryFn::kCylinderY:
    case LibraryFn::kCylinderZ:
      return cylinder(c);
    case LibraryFn::kEllCylX:
    case LibraryFn::kEllCylY:
    case LibraryFn::kEllCylZ:
      return ell_cylinder(c);
    case LibraryFn::kConeX:
    case LibraryFn::kConeY:
    case LibraryFn::kConeZ:
      return cone(c, false);
    case LibraryFn::kEllConeX:
    case LibraryFn::kEllConeY:
    case LibraryFn::kEllConeZ:
      return cone(c, true);
    case LibraryFn::kTorusX:
    case LibraryFn::kTorusY:
    case LibraryFn::kTorusZ:
      return torus(c);
    case LibraryFn::kBlock:
      return block(c);
    case LibraryFn::kSuperell:
      return superell(c);
    case LibraryFn::kBlobby:
      return blobby(c);
    case LibraryFn::kMetaball:
      return metaball(c);
    case LibraryFn::kSoft:
      return soft(c);
    case LibraryFn::kNoiseG:
      return noise_g(c);
    default:
      HFRT_CHECK_MSG(false, "not a primitive: " << c.name());
  }
}

// hfBezierVolume(x, l, m, n, bb, w). The counts are real arguments; since the loops unroll
// at compile time they must be compile-time constants (they are in every known model).
V lower_bezier(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  double counts[3];
  for (int i = 0; i < 3; ++i) {
    if (!c.real_constant(i + 1, &counts[i])) {
      c.warn(i + 1,
             "hfBezierVolume: the number of control weights must be a constant here; "
             "the call returns NaN",
             "write the count as a number");
      return c.nan();
    }
  }
  const int l = static_cast<int>(std::trunc(counts[0]));
  const int m = static_cast<int>(std::trunc(counts[1]));
  const int n = static_cast<int>(std::trunc(counts[2]));
  for (int i = 0; i < 3; ++i) {
    const int v = static_cast<int>(std::trunc(counts[i]));
    if (v < 1 || v > 21) {
      c.warn(i + 1,
             "hfBezierVolume: a count of control weights must be between 1 and 21 (the "
             "original's limit); the call returns NaN");
      return c.nan();
    }
  }
  c.need(4, 6, "the box [xmin, ymin, zmin, xmax, ymax, zmax]");
  std::ostringstream why;
  why << "l*m*n = " << l * m * n << " control weights";
  c.need(5, l * m * n, why.str());

  P3 p = point(c, 0);
  V bb[6];
  for (int i = 0; i < 6; ++i) bb[i] = c.at(4, i);
  V u = (p[0] - bb[0]) / (bb[3] - bb[0]);
  V v = (p[1] - bb[1]) / (bb[4] - bb[1]);
  V w = (p[2] - bb[2]) / (bb[5] - bb[2]);
  // Bern(i, N, t) = binom(N, i) (1 - t)^(N - i) t^i; m goes with z (W), n with y (V).
  auto bern = [&](int count, V t) {
    std::vector<V> out;
    const int deg = count - 1;
    for (int i = 0; i <= deg; ++i) {
      out.push_back(binomial(deg, i) * pow(1.0 - t, static_cast<double>(deg - i)) *
                    pow(t, static_cast<double>(i)));
    }
    return out;
  };
  std::vector<V> bu = bern(l, u), bw = bern(m, w), bv = bern(n, v);
  V sum = c.k(0);
  for (int i = 0; i < l; ++i) {
    for (int j = 0; j < m; ++j) {
      for (int k = 0; k < n; ++k) {
        sum = sum + bu[i] * bw[j] * bv[k] * c.at(5, i * m * n + j * n + k);
      }
    }
  }
  V px = (bb[3] - p[0]) * (p[0] - bb[0]);
  V py = (bb[4] - p[1]) * (p[1] - bb[1]);
  V pz = (bb[5] - p[2]) * (p[2] - bb[2]);
  auto inter = [](V a, V b) { return a + b - sqrt(a * a + b * b); };
  return inter(inter(inter(px, py), pz), sum);
}

}  // namespace hfrt::stdlib::detail
