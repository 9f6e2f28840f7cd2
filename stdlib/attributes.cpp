// Attribute functions hfA_* without noise (library.md §10, constructive texturing by
// B. Schmitt): scalar tools, colour tables, splines and colour-space conversion. Results that
// go into arrays are written through the arrays' slots, in the original's order.
#include <algorithm>
#include <sstream>

#include "base/check.h"
#include "ir/builder.h"
#include "stdlib/lib_util.h"

namespace hfrt::stdlib::detail {
namespace {

V wave(Call& c) {
  V t = c.real(0), c1 = c.real(1), c2 = c.real(2), freq = c.real(3);
  V w = (1.0 + sin(freq * t)) / 2.0;
  return sel(gt(c1, c2), w * (c1 - c2) + c2, w * (c2 - c1) + c1);
}

V checker_board(Call& c) {
  // hfA_CheckerBoard(x, bs, gs, out, cb, cg)
  c.need(0, 3, "the point's 3 coordinates");
  c.need(1, 3, "3 block sizes");
  c.need(2, 3, "3 gap sizes");
  V inside = c.k(1);
  for (int k = 0; k < 3; ++k) {
    V p = c.at(0, k), bs = c.at(1, k), gs = c.at(2, k);
    V period = gs + bs;
    V lo = period * floor(p / period);
    V in_k = land(lt(lo, p), lt(p, lo + bs));
    inside = k == 0 ? in_k : land(inside, in_k);
  }
  if (c.size(4) != c.size(5)) {
    c.warn(-1,
           "hfA_CheckerBoard: the colour arrays '" + c.arg_text(4) + "' and '" + c.arg_text(5) +
               "' differ in size; the output array is left unchanged",
           "give both colours the same number of elements");
    return c.k(1);
  }
  const int m = c.size(4);
  if (m > c.size(3)) {
    c.warn(3, "hfA_CheckerBoard: the output array '" + c.arg_text(3) + "' is shorter than the " +
                  "colours; the extra elements are dropped");
  }
  for (int j = 0; j < m; ++j) c.put(3, j, sel(inside, c.at(4, j), c.at(5, j)));
  return c.k(1);
}

V a_union(Call& c) {
  // hfA_Union(f1, f2, out, c1, c2, op)
  V f1 = c.real(0), f2 = c.real(1), op = trunc(c.real(5));
  V u = f1 + f2 + sqrt(f1 * f1 + f2 * f2);
  const int m = c.size(2);
  c.need(3, m, "one value per element of the output array");
  c.need(4, m, "one value per element of the output array");
  V set = gt(u, -kEps);
  V only1 = land(ge(f1, 0.0), lt(f2, 0.0));
  V only2 = land(ge(f2, 0.0), lt(f1, 0.0));
  for (int j = 0; j < m; ++j) {
    V a = c.at(3, j), b = c.at(4, j), old = c.at(2, j);
    V by_op = sel(eq(op, 0.0), a,
                  sel(eq(op, 1.0), b,
                      sel(eq(op, 2.0), a + b,
                          sel(eq(op, 3.0), sel(lt(a, b), a, b),
                              sel(eq(op, 4.0), sel(gt(a, b), a, b), old)))));
    V v = sel(only1, a, sel(only2, b, by_op));
    c.put(2, j, sel(set, v, old));
  }
  return u;
}

/// The "set i" of a colour table: elements m*i .. m*i+m-1 (0-based i).
V set_elem(Call& c, int col, int m, int i, int j) {
  return c.at(col, m * i + j);
}

V circles(Call& c) {
  // hfA_Circles(x, out, col, map)
  c.need(0, 3, "the point's 3 coordinates");
  const int n = c.size(3), m = c.size(1);
  V xt = c.at(0, 0), yt = c.at(0, 1), zt = c.at(0, 2);
  V noise = fmod(sqrt(xt * xt + yt * yt + zt * zt), 1.0);
  if (n < c.size(2)) {
    c.put(2, n, c.k(1.0 + 0.1));
  } else {
    c.warn(2,
           "hfA_Circles: the original writes 1.1 into element " + std::to_string(n + 1) + " of '" +
               c.arg_text(2) + "', past its end; the write is dropped",
           "declare the colour array with at least size(map) + 1 elements");
  }
  if (n >= 2) c.need(2, m * (n - 1), "one set of size(out) values per map interval");
  std::vector<V> match;
  for (int i = 0; i + 1 < n; ++i) {
    match.push_back(land(ge(noise, c.at(3, i)), lt(noise, c.at(3, i + 1))));
  }
  // The first matching interval wins.
  for (int j = 0; j < m; ++j) {
    V v = c.at(1, j);
    for (int i = n - 2; i >= 0; --i) v = sel(match[i], set_elem(c, 2, m, i, j), v);
    c.put(1, j, v);
  }
  return c.k(1);
}

V set_color(Call& c) {
  // hfA_SetColor(f, s, r, g, b)
  c.need(1, 3, "3 colour components");
  V inside = ge(c.real(0), 0.0);
  for (int k = 0; k < 3; ++k) c.put(1, k, sel(inside, c.real(2 + k), c.at(1, k)));
  return c.k(1);
}

V set_attributes(Call& c) {
  // hfA_SetAttributes(f, s, s1)
  V inside = ge(c.real(0), 0.0);
  const int m = std::min(c.size(1), c.size(2));
  for (int k = 0; k < m; ++k) c.put(1, k, sel(inside, c.at(2, k), c.at(1, k)));
  return c.k(1);
}

V lerp(Call& c) {
  // hfA_Lerp / hfA_Cerp(s, s1, s2, f, fmin, fmax); returns t, not clamped.
  V f = c.real(3), fmin = c.real(4), fmax = c.real(5);
  V t = (f - fmin) / (fmax - fmin);
  const int m = c.size(0);
  c.need(1, m, "one value per element of the output array");
  c.need(2, m, "one value per element of the output array");
  for (int k = 0; k < m; ++k) {
    V a = c.at(1, k), b = c.at(2, k);
    c.put(0, k, sel(lt(t, 0.0), a, sel(gt(t, 1.0), b, (1.0 - t) * a + t * b)));
  }
  return t;
}

V clamp(Call& c) {
  V f = c.real(0), lo = c.real(1), hi = c.real(2);
  return sel(lt(f, lo), lo, sel(gt(f, hi), hi, f));
}

V pulse(Call& c) {
  V f = c.real(0), p2 = c.real(1), p3 = c.real(2);
  return sel(lt(f, p3), 0.0, sel(gt(f, p2), 0.0, c.k(1)));
}

V step(Call& c) {
  return sel(lt(c.real(0), c.real(1)), 0.0, c.k(1));
}

V smooth_step(Call& c) {
  V f = c.real(3), a = c.real(4), b = c.real(5);
  V u = (f - a) / (b - a);
  return sel(gt(f, b), 1.0, sel(lt(f, a), 0.0, u * u * (3.0 - 2.0 * u)));
}

V modulo(Call& c) {
  V a = c.real(0), b = c.real(1);
  V k = trunc(a / b);
  V r = a - k * b;
  return sel(lt(r, 0.0), r + b, r);
}

V look_up(Call& c, bool smooth) {
  // hfA_LookUpTable / hfA_SmoothLookUpTable(t, out, col, map)
  V t = c.real(0);
  const int n = c.size(3), m = c.size(1);
  std::ostringstream why;
  why << "size(map) = " << n << " sets of size(out) = " << m << " values";
  c.need(2, n * m, why.str());
  if (n == 0) {
    c.warn(3, "hfA_LookUpTable: the map array is empty; the output array is left unchanged");
    return c.k(1);
  }
  std::vector<V> mp;
  for (int i = 0; i < n; ++i) mp.push_back(c.at(3, i));
  V above_first = ge(t, mp[0]);
  std::vector<V> match, lambda;
  for (int i = 0; i + 1 < n; ++i) {
    match.push_back(land(above_first, land(ge(t, mp[i]), lt(t, mp[i + 1]))));
    lambda.push_back((t - mp[i]) / (mp[i + 1] - mp[i]));
  }
  for (int j = 0; j < m; ++j) {
    V v = set_elem(c, 2, m, n - 1, j);  // none matching (also t < map_1): the last set
    for (int i = n - 2; i >= 0; --i) {
      V in = set_elem(c, 2, m, i, j);
      if (smooth) {
        in = (1.0 - lambda[i]) * in + lambda[i] * set_elem(c, 2, m, i + 1, j);
      }
      v = sel(match[i], in, v);
    }
    c.put(1, j, v);
  }
  return c.k(1);
}

V spline(Call& c) {
  // hfA_Spline(s, K, t, tmin, tmax): Catmull-Rom through knots of m = size(s) values.
  const int m = c.size(0);
  if (m == 0) return c.k(1);
  const int nk = c.size(1) / m;
  if (nk < 4) {
    c.warn(1,
           "hfA_Spline: the knot array '" + c.arg_text(1) + "' holds " + std::to_string(nk) +
               " knots of " + std::to_string(m) + " values, fewer than 4; the output is NaN",
           "give at least 4 knots of size(s) values each");
  }
  V t = c.real(2), tmin = c.real(3), tmax = c.real(4);
  V u = (t - tmin) / (tmax - tmin);
  const double ns = nk - 3;
  V uu = u * ns;
  V span = trunc(uu);
  span = sel(ge(span, ns), ns - 3.0, span);  // the original's wrong span at u = 1
  uu = uu - span;
  // Knot element (span + q, j) at run time; outside K (nk < 6 at u = 1) reads NaN.
  auto knot = [&](int q, int j) {
    V index1 =
        (span + static_cast<double>(q)) * static_cast<double>(m) + static_cast<double>(j + 1);
    V valid = land(ge(index1, 1.0), le(index1, static_cast<double>(c.size(1))));
    if (c.size(1) == 0) return c.nan();
    return sel(valid, c.at_index(1, sel(valid, index1, 1.0)), kNaN);
  };
  for (int j = 0; j < m; ++j) {
    V k0 = knot(0, j), k1 = knot(1, j), k2 = knot(2, j), k3 = knot(3, j);
    V c3 = -0.5 * k0 + 1.5 * k1 - 1.5 * k2 + 0.5 * k3;
    V c2 = k0 - 2.5 * k1 + 2.0 * k2 - 0.5 * k3;
    V c1 = -0.5 * k0 + 0.5 * k2;
    V c0 = k1;
    V inner = ((c3 * uu + c2) * uu + c1) * uu + c0;
    V first = nk >= 1 ? c.at(1, j) : c.nan();
    V last = nk >= 1 ? c.at(1, (nk - 1) * m + j) : c.nan();
    V v = sel(lt(u, 0.0), first, sel(gt(u, 1.0), last, inner));
    if (nk < 4) v = c.nan();
    c.put(0, j, v);
  }
  return c.k(1);
}

V rgb_to_hsv(Call& c) {
  c.need(0, 3, "r, g, b");
  c.need(1, 3, "h, s, v");
  V r = c.at(0, 0), g = c.at(0, 1), b = c.at(0, 2);
  V mn = sel(lt(r, g), r, g);
  mn = sel(lt(b, mn), b, mn);
  V mx = sel(gt(r, g), r, g);
  mx = sel(gt(b, mx), b, mx);
  V delta = mx - mn;
  V s = sel(gt(mx, 0.0), delta / mx, 0.0);
  V h = c.k(0);
  h = sel(land(eq(mx, r), lnot(eq(mx, g))), h + (g - b) / delta, h);
  h = sel(land(eq(mx, g), lnot(eq(mx, b))), h + (2.0 + (b - r) / delta), h);
  h = sel(land(eq(mx, b), lnot(eq(mx, r))), h + (4.0 + (r - g) / delta), h);
  h = sel(gt(delta, 0.0), 60.0 * h, 0.0);
  c.put(1, 0, h);
  c.put(1, 1, s);
  c.put(1, 2, mx);
  return c.k(1);
}

// The original wraps the hue with `while` loops; they become kLoops here, capped so that a
// huge hue (which never changes when 360 is added) cannot hang the evaluation.
constexpr double kHueMaxSteps = 1e6;

V wrap_hue(Call& c, V h0) {
  IrBuilder& b = c.builder();
  const int h_slot = b.new_slot(0), n_slot = b.new_slot(0);
  b.store(h_slot, h0.id);
  b.store(n_slot, c.k(0).id);
  for (int pass = 0; pass < 2; ++pass) {
    b.store(n_slot, c.k(0).id);
    b.begin_loop();
    {
      V h{&b, b.load(h_slot)};
      V n{&b, b.load(n_slot)};
      V cond = pass == 0 ? lt(h, 0.0) : gt(h, 360.0);
      b.loop_test(land(cond, lt(n, kHueMaxSteps)).id);
    }
    {
      V h{&b, b.load(h_slot)};
      V n{&b, b.load(n_slot)};
      b.store(h_slot, (pass == 0 ? h + 360.0 : h - 360.0).id);
      b.store(n_slot, (n + 1.0).id);
    }
    b.end_loop();
  }
  return V{&b, b.load(h_slot)};
}

V hsv_to_rgb(Call& c) {
  c.need(0, 3, "h, s, v");
  c.need(1, 3, "r, g, b");
  V h0 = c.at(0, 0), s = c.at(0, 1), v = c.at(0, 2);
  V h = wrap_hue(c, h0);
  V lo = lt(h, 120.0), mid = lt(h, 240.0);
  V cr = sel(lo, (120.0 - h) / 60.0, sel(mid, c.k(0), (h - 240.0) / 60.0));
  V cg = sel(lo, h / 60.0, sel(mid, (240.0 - h) / 60.0, c.k(0)));
  V cb = sel(lo, c.k(0), sel(mid, (h - 120.0) / 60.0, (360.0 - h) / 60.0));
  V comps[3] = {cr, cg, cb};
  for (int k = 0; k < 3; ++k) {
    V ck = sel(gt(comps[k], 1.0), 1.0, comps[k]);
    c.put(1, k, (1.0 - s + s * ck) * v);
  }
  return c.k(1);
}

}  // namespace

V lower_attribute(Call& c) {
  switch (c.fn()) {
    case LibraryFn::kAWave:
      return wave(c);
    case LibraryFn::kACheckerBoard:
      return checker_board(c);
    case LibraryFn::kAUnion:
      return a_union(c);
    case LibraryFn::kACircles:
      return circles(c);
    case LibraryFn::kASetColor:
      return set_color(c);
    case LibraryFn::kASetAttributes:
      return set_attributes(c);
    case LibraryFn::kALerp:
    case LibraryFn::kACerp:
      return lerp(c);
    case LibraryFn::kAClamp:
      return clamp(c);
    case LibraryFn::kAFloor:
      return trunc(c.real(0));
    case LibraryFn::kAPulse:
      return pulse(c);
    case LibraryFn::kALookUpTable:
      return look_up(c, false);
    case LibraryFn::kASmoothLookUpTable:
      return look_up(c, true);
    case LibraryFn::kAStep:
      return step(c);
    case LibraryFn::kASmoothStep:
      return smooth_step(c);
    case LibraryFn::kAModulo:
      return modulo(c);
    case LibraryFn::kASpline:
      return spline(c);
    case LibraryFn::kARGBToHSV:
      return rgb_to_hsv(c);
    case LibraryFn::kAHSVToRGB:
      return hsv_to_rgb(c);
    default:
      HFRT_CHECK_MSG(false, "not an attribute function: " << c.name());
  }
}

}  // namespace hfrt::stdlib::detail
