// Convolution primitives with the Cauchy kernel 1/(1 + S²r²)² (library.md §2).
#include <array>
#include <sstream>

#include "base/check.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

using P3 = std::array<V, 3>;

P3 point(Call& c, int i) {
  return {c.at(i, 0), c.at(i, 1), c.at(i, 2)};
}
P3 triple(Call& c, int i, int first) {
  return {c.at(i, first), c.at(i, first + 1), c.at(i, first + 2)};
}

std::string count_text(int per, int n, std::string_view of, std::string_view from) {
  std::ostringstream os;
  os << per << " per " << of << ", " << n << " " << of << "(s) from the size of '" << from << "'";
  return os.str();
}

/// The segment kernel K(P; A, B, S) of library.md §2, as the original codes it.
/// `q_from_sqrt`: hfConvLine/hfConvCurve square sqrt(q²) again; hfConvLineR uses q² itself.
/// A zero-length segment gives NaN (0/0 in the direction), where the original aborts.
V segment_kernel(const P3& p, const P3& a, const P3& b, V s, bool q_from_sqrt) {
  V l = sqrt(sq(b[0] - a[0]) + sq(b[1] - a[1]) + sq(b[2] - a[2]));
  V ax = (b[0] - a[0]) / l, ay = (b[1] - a[1]) / l, az = (b[2] - a[2]) / l;
  V dx = p[0] - a[0], dy = p[1] - a[1], dz = p[2] - a[2];
  V xx = dx * ax + dy * ay + dz * az;
  V d2 = sq(dx) + sq(dy) + sq(dz);
  V pp = sqrt(1.0 + sq(s) * (d2 - sq(xx)));
  V q2 = 1.0 + sq(s) * (d2 + sq(l) - 2.0 * l * xx);
  if (q_from_sqrt) {
    V q = sqrt(q2);
    q2 = q * q;
  }
  return xx / (2.0 * pp * pp * (pp * pp + s * s * xx * xx)) + (l - xx) / (2.0 * pp * pp * q2) +
         (atan(s * xx / pp) + atan(s * (l - xx) / pp)) / (2.0 * s * pp * pp * pp);
}

V conv_point(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  const int n = c.size(2);
  c.need(1, 3 * n, count_text(3, n, "point", c.arg_text(2)));
  P3 p = point(c, 0);
  V f = c.k(0);
  for (int i = 0; i < n; ++i) {
    P3 v = triple(c, 1, 3 * i);
    V r2 = sq(v[0] - p[0]) + sq(v[1] - p[1]) + sq(v[2] - p[2]);
    V s = c.at(2, i);
    f = f + 1.0 / sq(1.0 + sq(s) * r2);
  }
  return f - c.real(3);
}

V conv_line(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  const int n = c.size(3);
  c.need(1, 3 * n, count_text(3, n, "segment", c.arg_text(3)));
  c.need(2, 3 * n, count_text(3, n, "segment", c.arg_text(3)));
  P3 p = point(c, 0);
  V f = c.k(0);
  for (int i = 0; i < n; ++i) {
    f = f + segment_kernel(p, triple(c, 1, 3 * i), triple(c, 2, 3 * i), c.at(3, i), true);
  }
  return f - c.real(4);
}

V conv_curve(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  const int n = c.size(2);
  c.need(1, 3 * (n + 1), count_text(3, n + 1, "vertex", c.arg_text(2)));
  P3 p = point(c, 0);
  V f = c.k(0);
  for (int i = 0; i < n; ++i) {
    f = f + segment_kernel(p, triple(c, 1, 3 * i), triple(c, 1, 3 * i + 3), c.at(2, i), true);
  }
  return f - c.real(3);
}

V conv_line_r(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  const int n = c.size(2) / 3;
  c.need(1, 3 * n, count_text(3, n, "segment", c.arg_text(2)));
  if (n == 0) {
    c.warn(2,
           "hfConvLineR: the end-point array '" + c.arg_text(2) +
               "' has no complete segment; the threshold is taken as 0",
           "give at least 3 coordinates per segment");
  }
  P3 p = point(c, 0);
  V r = c.real(3);
  V s = sel(lt(r, 1.0), 1.0 / r, 1.0);
  V f = c.k(0);
  V t = c.k(0);
  for (int i = 0; i < n; ++i) {
    P3 b = triple(c, 1, 3 * i), e = triple(c, 2, 3 * i);
    V l = sqrt(sq(e[0] - b[0]) + sq(e[1] - b[1]) + sq(e[2] - b[2]));
    V pt = sqrt(1.0 + sq(s) * sq(r));
    V qt2 = 1.0 + sq(s) * (sq(r) + sq(l));
    t = l / (2.0 * sq(pt) * qt2) + atan(s * l / pt) / (2.0 * s * sq(pt) * pt);
    // Once f reaches 1 no further segment is added (the sum is clamped at 1).
    V added = f + segment_kernel(p, b, e, s, false);
    f = sel(lt(f, 1.0), sel(gt(added, 1.0), 1.0, added), f);
  }
  return f - t;
}

/// One triangle's contribution (library.md §2, as hfConvTriangle.c codes it).
V triangle_term(const P3& p, P3 a1, P3 a2, P3 a3, V s) {
  auto dist = [](const P3& u, const P3& v) {
    return sqrt(sq(v[0] - u[0]) + sq(v[1] - u[1]) + sq(v[2] - u[2]));
  };
  // Reorder so that A1A2 is the longest edge.
  V len0 = dist(a1, a2), len1 = dist(a2, a3), len2 = dist(a3, a1);
  V rot1 = land(ge(len1, len2), gt(len1, len0));  // (A2, A3, A1)
  V rot2 = land(ge(len2, len1), gt(len2, len0));  // (A3, A1, A2)
  P3 n1, n2, n3;
  for (int k = 0; k < 3; ++k) {
    n1[k] = sel(rot1, a2[k], sel(rot2, a3[k], a1[k]));
    n2[k] = sel(rot1, a3[k], sel(rot2, a1[k], a2[k]));
    n3[k] = sel(rot1, a1[k], sel(rot2, a2[k], a3[k]));
  }
  a1 = n1, a2 = n2, a3 = n3;
  len0 = dist(a1, a2);
  P3 a21 = {a2[0] - a1[0], a2[1] - a1[1], a2[2] - a1[2]};
  P3 a13 = {a1[0] - a3[0], a1[1] - a3[1], a1[2] - a3[2]};
  V t = -(a21[0] * a13[0] + a21[1] * a13[1] + a21[2] * a13[2]) / sq(len0);
  P3 bf = {a1[0] + t * a21[0], a1[1] + t * a21[1], a1[2] + t * a21[2]};
  P3 d = {p[0] - bf[0], p[1] - bf[1], p[2] - bf[2]};
  P3 uu = {a2[0] - bf[0], a2[1] - bf[1], a2[2] - bf[2]};
  V ul = sqrt(sq(uu[0]) + sq(uu[1]) + sq(uu[2]));
  for (V& x : uu) x = x / ul;
  P3 vv = {a3[0] - bf[0], a3[1] - bf[1], a3[2] - bf[2]};
  V vl = sqrt(sq(vv[0]) + sq(vv[1]) + sq(vv[2]));
  for (V& x : vv) x = x / vl;
  V d2 = sq(d[0]) + sq(d[1]) + sq(d[2]);
  V u = d[0] * uu[0] + d[1] * uu[1] + d[2] * uu[2];
  V v = d[0] * vv[0] + d[1] * vv[1] + d[2] * vv[2];
  V h = dist(bf, a3);
  V al1 = dist(bf, a1);
  V al2 = dist(bf, a2);
  V g = v - h;
  V m = al2 * g + u * h;
  V k = u * h - al1 * g;
  V c2 = 1.0 / sq(s) + d2 - sq(u);
  V cc = sqrt(c2);
  V q = c2 - sq(v);
  V w = c2 - 2.0 * v * h + sq(h);
  V big_a = sqrt(sq(al1) * w + sq(h) * (q + sq(u)) - 2.0 * al1 * h * u * g);
  V big_b = sqrt(sq(al2) * w + sq(h) * (q + sq(u)) + 2.0 * al2 * h * u * g);
  V m1 = al1 + u;
  V m2 = al2 - u;
  V m3 = al1 * m1 + v * h;
  V m4 = -al1 * u - g * h;
  V m5 = -al2 * m2 - v * h;
  V m6 = -al2 * u + g * h;
  V arc1 = k * (atan(m3 / big_a) + atan(m4 / big_a)) / big_a;
  V arc2 = m * (atan(m5 / big_b) + atan(m6 / big_b)) / big_b;
  V arc3 = v * (atan(m1 / cc) + atan(m2 / cc)) / cc;
  return (arc1 + arc2 + arc3) / (2.0 * q * s);
}

V conv_triangle(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  const int n = c.size(2);
  c.need(1, 9 * n, count_text(9, n, "triangle", c.arg_text(2)));
  P3 p = point(c, 0);
  V f = c.k(0);
  for (int i = 0; i < n; ++i) {
    f = f + triangle_term(p, triple(c, 1, 9 * i), triple(c, 1, 9 * i + 3), triple(c, 1, 9 * i + 6),
                          c.at(2, i));
  }
  return f - c.real(3);
}

V conv_mesh(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  const int n = c.size(3);
  c.need(2, 3 * n, count_text(3, n, "triangle", c.arg_text(3)));
  const int num_vertices = c.size(1) / 3;
  if (num_vertices == 0) {
    c.warn(1, "hfConvMesh: the vertex array '" + c.arg_text(1) +
                  "' has no complete vertex; the call returns NaN");
    return c.nan();
  }
  P3 p = point(c, 0);
  // Vertex k (1-based, truncated) of V; an index outside 1..size(V)/3 reads NaN (the
  // original reads whatever memory lies there).
  auto vertex = [&](V index) {
    V k = trunc(index);
    V valid = land(ge(k, 1.0), le(k, static_cast<double>(num_vertices)));
    V safe = sel(valid, k, 1.0);
    P3 out;
    for (int j = 0; j < 3; ++j) {
      V element = 3.0 * safe - static_cast<double>(2 - j);  // 1-based, in range
      out[j] = sel(valid, c.at_index(1, element), kNaN);
    }
    return out;
  };
  V f = c.k(0);
  for (int i = 0; i < n; ++i) {
    P3 a1 = vertex(c.at(2, 3 * i)), a2 = vertex(c.at(2, 3 * i + 1)),
       a3 = vertex(c.at(2, 3 * i + 2));
    f = f + triangle_term(p, a1, a2, a3, c.at(3, i));
  }
  return f - c.real(4);
}

/// ArcTerm(X, Y, Z; r, S, θ) of library.md §2, as hfConvArc.c codes it.
V arc_term(const P3& q, V r, V s, V th) {
  V x = q[0], y = q[1], z = q[2];
  V a = 2.0 * r * s * s;
  V d2 = sq(x) + sq(y) + sq(z);
  V b = 1.0 + sq(r) * sq(s) + sq(s) * d2;
  V p2 = -(sq(r) * sq(r)) * (sq(s) * sq(s)) +
         2.0 * sq(r) * sq(s) * (sq(s) * (d2 - 2.0 * sq(z)) - 1.0) - sq(1.0 + sq(s) * d2);
  V p1 = sqrt(abs(p2));
  V p3 = p1 * p2;
  V f1 = (b * y) / (x * p2 * (a * x - b)) +
         (a * (sq(x) + sq(y)) * sin(th) - b * y) / (x * p2 * (a * (x * cos(th) + y * sin(th)) - b));
  // p2 is always negative (library.md): the original's atanh branch is unreachable.
  V f2 = 2.0 * b * (atan(-a * y / p1) + atan((a * y - (a * x + b) * tan(th / 2.0)) / p1)) / p3;
  return f1 + f2;
}

V conv_arc(Call& c) {
  if (!c.point3(0)) return c.k(kFailure);
  const int n = c.size(6);
  c.need(1, 3 * n, count_text(3, n, "arc", c.arg_text(6)));
  c.need(2, n, count_text(1, n, "arc", c.arg_text(6)));
  c.need(3, n, count_text(1, n, "arc", c.arg_text(6)));
  c.need(4, 3 * n, count_text(3, n, "arc", c.arg_text(6)));
  c.need(5, n, count_text(1, n, "arc", c.arg_text(6)));
  const double rd = 3.141592 / 180.0;  // the original's PI
  P3 x = point(c, 0);
  V f = c.k(0);
  for (int i = 0; i < n; ++i) {
    P3 ctr = triple(c, 1, 3 * i);
    V r = c.at(2, i);
    c.put(5, i, c.at(5, i) + kEps);  // angle[n] += EPS, written back
    V ii = c.at(4, 3 * i) + kEps, jj = c.at(4, 3 * i + 1) + kEps, kk = c.at(4, 3 * i + 2) + kEps;
    V length = sqrt(ii * ii + jj * jj + kk * kk);
    length = sel(lt(length, kEps), kEps, length);
    ii = ii / length;
    jj = jj / length;
    kk = kk / length;
    V angle = c.at(5, i);
    V co = cos(rd * -angle);
    V si = sin(rd * -angle);
    V one_c = 1.0 - co;
    V i2 = ii * ii, j2 = jj * jj, k2 = kk * kk;
    V ij = ii * jj, jk = jj * kk, ki = kk * ii;
    V is = ii * si, js = jj * si, ks = kk * si;
    // theta clamped to 360, then to 180 with the excess as an extra arc (written back).
    V th0 = c.at(3, i);
    V th1 = sel(gt(th0, 360.0), 360.0, th0);
    V over = gt(th1, 180.0);
    V over_th = (th1 - 180.0) * rd;
    c.put(3, i, sel(over, 180.0, th1));
    V ex = x[0] - ctr[0], ey = x[1] - ctr[1], ez = x[2] - ctr[2];
    P3 local = {(co + i2 * one_c) * ex + (-ks + ij * one_c) * ey + (js + ki * one_c) * ez,
                (ks + ij * one_c) * ex + (co + j2 * one_c) * ey + (-is + jk * one_c) * ez,
                (-js + ki * one_c) * ex + (is + jk * one_c) * ey + (co + k2 * one_c) * ez};
    // Rotation by -180 degrees about the local z axis, with the same matrix formula.
    const double oc = std::cos(rd * -180.0), os = std::sin(rd * -180.0), ooc = 1.0 - oc;
    const double oi = 0.0, oj = 0.0, ok = 1.0;
    auto kc = [&](double v) { return c.k(v); };
    P3 ov = {kc(oc + oi * oi * ooc) * local[0] + kc(-(ok * os) + oi * oj * ooc) * local[1] +
                 kc(oj * os + ok * oi * ooc) * local[2],
             kc(ok * os + oi * oj * ooc) * local[0] + kc(oc + oj * oj * ooc) * local[1] +
                 kc(-(oi * os) + oj * ok * ooc) * local[2],
             kc(-(oj * os) + ok * oi * ooc) * local[0] + kc(oi * os + oj * ok * ooc) * local[1] +
                 kc(oc + ok * ok * ooc) * local[2]};
    V s = c.at(6, i);
    f = sel(over, f + arc_term(ov, r, s, over_th), f);
    V th = c.at(3, i) * rd;
    f = f + arc_term(local, r, s, th);
  }
  return f - c.real(7);
}

}  // namespace

V lower_convolution(Call& c) {
  switch (c.fn()) {
    case LibraryFn::kConvPoint:
      return conv_point(c);
    case LibraryFn::kConvLine:
      return conv_line(c);
    case LibraryFn::kConvCurve:
      return conv_curve(c);
    case LibraryFn::kConvLineR:
      return conv_line_r(c);
    case LibraryFn::kConvTriangle:
      return conv_triangle(c);
    case LibraryFn::kConvMesh:
      return conv_mesh(c);
    case LibraryFn::kConvArc:
      return conv_arc(c);
    default:
      HFRT_CHECK_MSG(false, "not a convolution primitive: " << c.name());
  }
}

}  // namespace hfrt::stdlib::detail
