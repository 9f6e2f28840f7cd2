#include "geom/boundary_winding.h"

#include <immintrin.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <unordered_map>

namespace hfrt::geom {
namespace {

DVec3 operator-(const DVec3& a, const DVec3& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
double ddot(const DVec3& a, const DVec3& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
DVec3 lerp(const DVec3& a, const DVec3& b, double t) {
  return {a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t};
}

/// Gauss-Legendre nodes and weights on [0, 1], six points: exact for degree 11; on a piece
/// within half its distance (see kFar) the integrand's error is ~0.5^12 of it.
constexpr int kGauss = BoundaryCurves::kGauss;
constexpr double kNode[kGauss] = {0.033765242898423975, 0.16939530676686776, 0.3806904069584016,
                                  0.6193095930415985,   0.8306046932331322,  0.966234757101576};
constexpr double kWeight[kGauss] = {0.08566224618958517, 0.1803807865240693, 0.23395696728634552,
                                    0.23395696728634552, 0.1803807865240693, 0.08566224618958517};

/// A piece is summed directly when its control points' bounding sphere has a radius below
/// kFar x its distance from p and its angle from the string is above kAngle x its angular
/// radius; otherwise it is halved, at most kMaxDepth times.
constexpr double kFar = 0.5, kAngle = 2.0;
constexpr int kMaxDepth = 40;
/// Levels of halves made once per curve (BoundaryCurves::tree_).
constexpr int kTreeDepth = 4;

/// De Casteljau at t of the degree-n control points q[0], q[stride], ...: the part over
/// [0, t] into left (the first point of each level), the part over [t, 1] into right (the
/// last), both contiguous.
void split_at(int n, const DVec3* q, int stride, double t, DVec3* left, DVec3* right) {
  std::array<DVec3, 7> r;
  for (int i = 0; i <= n; ++i) r[size_t(i)] = q[i * stride];
  left[0] = r[0];
  right[n] = r[size_t(n)];
  for (int level = 1; level <= n; ++level) {
    for (int i = 0; i + level <= n; ++i) r[size_t(i)] = lerp(r[size_t(i)], r[size_t(i) + 1], t);
    left[level] = r[0];
    right[n - level] = r[size_t(n - level)];
  }
}

/// The two halves of a curve (split_at 1/2).
void halve(const BezierCurve& c, BezierCurve* left, BezierCurve* right) {
  *left = c, *right = c;
  split_at(c.degree, c.cp.data(), 1, 0.5, left->cp.data(), right->cp.data());
}

/// The box of a curve's control points (which holds the curve).
void control_box(const BezierCurve& c, DVec3* lo, DVec3* hi) {
  *lo = c.cp[0], *hi = c.cp[0];
  for (int i = 1; i <= c.degree; ++i) {
    const DVec3& q = c.cp[size_t(i)];
    *lo = {std::min(lo->x, q.x), std::min(lo->y, q.y), std::min(lo->z, q.z)};
    *hi = {std::max(hi->x, q.x), std::max(hi->y, q.y), std::max(hi->z, q.z)};
  }
}

/// The bounding sphere of a curve's control points (centre: their box's).
void bounding_sphere(const BezierCurve& c, DVec3* centre, double* radius2) {
  const int n = c.degree;
  DVec3 lo, hi;
  control_box(c, &lo, &hi);
  const DVec3 m{0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y), 0.5 * (lo.z + hi.z)};
  double rho2 = 0;
  for (int i = 0; i <= n; ++i) {
    const DVec3 d = c.cp[i] - m;
    rho2 = std::max(rho2, ddot(d, d));
  }
  *centre = m;
  *radius2 = rho2;
}

/// The length of a curve's control polygon (at least the curve's).
double polygon_length(const BezierCurve& c) {
  double length = 0;
  for (int i = 0; i < c.degree; ++i) {
    const DVec3 d = c.cp[i + 1] - c.cp[i];
    length += std::sqrt(ddot(d, d));
  }
  return length;
}

/// Whether a piece with bounding sphere (m, rho2) is summed directly from p: within kFar of
/// its distance, and its angle from s above kAngle = 2 times its angular radius a (cos 2a
/// from sin a = rho / dist by the double-angle formula: no trigonometric call).
bool direct(const DVec3& m, double rho2, const DVec3& p, const DVec3& s) {
  const DVec3 r = m - p;
  const double dist2 = ddot(r, r);
  if (!(rho2 < kFar * kFar * dist2)) return false;
  static_assert(kAngle == 2.0 && kFar * kFar <= 0.5);
  // cos 2a = 1 - 2 sin^2 a > 0 here, so r.s < cos 2a |r| holds for r.s <= 0 and otherwise
  // compares as squares (no square root).
  const double cos2a = 1 - 2 * rho2 / dist2, along = ddot(r, s);
  return along <= 0 || along * along < cos2a * cos2a * dist2;
}

/// The sum of A(r) . w over a piece's eight samples (r from p to the point, w the weighted
/// derivative), in single precision, four lanes at a time: SSE, in the x86-64 baseline
/// (std::sqrt would not vectorise, as it may set errno). Near the string |r| - s.r is
/// computed as |r x s|^2 / (|r| + s.r), without cancellation.
double direct_sum(const BoundaryCurves::Samples& sm, float px, float py, float pz, float sx,
                  float sy, float sz) {
  __m128 acc = _mm_setzero_ps();
  const __m128 vpx = _mm_set1_ps(px), vpy = _mm_set1_ps(py), vpz = _mm_set1_ps(pz);
  const __m128 vsx = _mm_set1_ps(sx), vsy = _mm_set1_ps(sy), vsz = _mm_set1_ps(sz);
  const __m128 zero = _mm_setzero_ps();
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  for (int g = 0; g < 8; g += 4) {
    const __m128 rx = _mm_sub_ps(_mm_loadu_ps(sm.x + g), vpx);
    const __m128 ry = _mm_sub_ps(_mm_loadu_ps(sm.y + g), vpy);
    const __m128 rz = _mm_sub_ps(_mm_loadu_ps(sm.z + g), vpz);
    const __m128 len = _mm_sqrt_ps(
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(rx, rx), _mm_mul_ps(ry, ry)), _mm_mul_ps(rz, rz)));
    const __m128 along =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(rx, vsx), _mm_mul_ps(ry, vsy)), _mm_mul_ps(rz, vsz));
    const __m128 cx = _mm_sub_ps(_mm_mul_ps(ry, vsz), _mm_mul_ps(rz, vsy));
    const __m128 cy = _mm_sub_ps(_mm_mul_ps(rz, vsx), _mm_mul_ps(rx, vsz));
    const __m128 cz = _mm_sub_ps(_mm_mul_ps(rx, vsy), _mm_mul_ps(ry, vsx));
    const __m128 cc =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, cx), _mm_mul_ps(cy, cy)), _mm_mul_ps(cz, cz));
    // |r| - s.r, as |r x s|^2 / (|r| + s.r) where s.r > 0 (no cancellation near the string).
    const __m128 near_string = _mm_div_ps(cc, _mm_add_ps(len, _mm_and_ps(along, abs_mask)));
    const __m128 away = _mm_sub_ps(len, along);
    const __m128 pos = _mm_cmpgt_ps(along, zero);
    const __m128 gap = _mm_or_ps(_mm_and_ps(pos, near_string), _mm_andnot_ps(pos, away));
    const __m128 dot = _mm_add_ps(_mm_add_ps(_mm_mul_ps(cx, _mm_loadu_ps(sm.wx + g)),
                                             _mm_mul_ps(cy, _mm_loadu_ps(sm.wy + g))),
                                  _mm_mul_ps(cz, _mm_loadu_ps(sm.wz + g)));
    acc = _mm_add_ps(acc, _mm_div_ps(dot, _mm_mul_ps(len, gap)));
  }
  float lanes[4];
  _mm_storeu_ps(lanes, acc);
  return double((lanes[0] + lanes[1]) + (lanes[2] + lanes[3]));
}

/// Bernstein basis values (degree 0..6) and derivatives (1..6) at the Gauss-Legendre nodes.
struct BernsteinTables {
  double b[7][kGauss][7] = {}, db[7][kGauss][7] = {};
  BernsteinTables() {
    for (int n = 0; n <= 6; ++n)
      for (int g = 0; g < kGauss; ++g) {
        const double t = kNode[g];
        double binom = 1;
        for (int i = 0; i <= n; ++i) {
          b[n][g][i] = binom * std::pow(t, i) * std::pow(1 - t, n - i);
          binom = binom * (n - i) / (i + 1);
        }
        // d/dt of the degree-n basis: n (B_{i-1,n-1} - B_{i,n-1}).
        for (int i = 0; n > 0 && i <= n; ++i)
          db[n][g][i] = n * ((i > 0 ? b[n - 1][g][i - 1] : 0.0) - (i < n ? b[n - 1][g][i] : 0.0));
      }
  }
};
const BernsteinTables& bernstein() {
  static const BernsteinTables tables;
  return tables;
}

/// Curve c's Gauss-Legendre points less `origin` and its derivatives there times the weights
/// (the lanes past kGauss: a copy of the last point, weight 0).
void samples_of(const BezierCurve& c, const DVec3& origin, BoundaryCurves::Samples* sm) {
  const BernsteinTables& t = bernstein();
  const int n = c.degree;
  for (int g = 0; g < 8; ++g) {
    const int k = std::min(g, kGauss - 1);
    DVec3 x{0, 0, 0}, dx{0, 0, 0};
    for (int i = 0; i <= n; ++i) {
      const double w = t.b[n][k][i], dw = t.db[n][k][i];
      x = {x.x + w * c.cp[i].x, x.y + w * c.cp[i].y, x.z + w * c.cp[i].z};
      dx = {dx.x + dw * c.cp[i].x, dx.y + dw * c.cp[i].y, dx.z + dw * c.cp[i].z};
    }
    const double wt = g < kGauss ? kWeight[g] : 0.0;
    sm->x[g] = float(x.x - origin.x), sm->y[g] = float(x.y - origin.y);
    sm->z[g] = float(x.z - origin.z);
    sm->wx[g] = float(wt * dx.x), sm->wy[g] = float(wt * dx.y), sm->wz[g] = float(wt * dx.z);
  }
}

/// Curve c (at halving depth `depth`) in halves until accept(centre, radius2) takes a piece's
/// bounding sphere, each taken piece given to leaf(piece); pieces of no length (a point) are
/// skipped. False when a piece is still not taken at kMaxDepth (the others are all visited).
template <typename Accept, typename Leaf>
bool by_halves(const BezierCurve& c, int depth, const Accept& accept, const Leaf& leaf) {
  DVec3 m;
  double rho2;
  bounding_sphere(c, &m, &rho2);
  if (rho2 == 0) return true;
  if (accept(m, rho2)) {
    leaf(c);
    return true;
  }
  if (depth >= kMaxDepth) return false;
  BezierCurve left, right;
  halve(c, &left, &right);
  const bool a = by_halves(left, depth + 1, accept, leaf);
  const bool b = by_halves(right, depth + 1, accept, leaf);
  return a && b;
}

}  // namespace

namespace {

/// The point of curve c at t and its first two derivatives (de Casteljau: the second
/// difference of the three points of level n - 2, the difference of the two of level n - 1).
void eval_curve(const BezierCurve& c, double t, DVec3* x, DVec3* d1, DVec3* d2) {
  const int n = c.degree;
  std::array<DVec3, 7> q = c.cp;
  for (int level = 1; level <= n - 2; ++level)
    for (int i = 0; i + level <= n; ++i) q[i] = lerp(q[i], q[i + 1], t);
  *d2 = {0, 0, 0};
  if (n >= 2) {
    const double k = double(n) * (n - 1);
    *d2 = {k * (q[0].x - 2 * q[1].x + q[2].x), k * (q[0].y - 2 * q[1].y + q[2].y),
           k * (q[0].z - 2 * q[1].z + q[2].z)};
    q[0] = lerp(q[0], q[1], t), q[1] = lerp(q[1], q[2], t);
  }
  *d1 = {n * (q[1].x - q[0].x), n * (q[1].y - q[0].y), n * (q[1].z - q[0].z)};
  *x = lerp(q[0], q[1], t);
}

/// The point of the degree-n Bézier curve q at t (de Casteljau; the end control points
/// themselves at t = 0 and 1).
DVec3 point_at(int n, const DVec3* q, double t) {
  if (t == 0) return q[0];
  if (t == 1) return q[n];
  std::array<DVec3, 7> r;
  for (int i = 0; i <= n; ++i) r[i] = q[i];
  for (int level = 1; level <= n; ++level)
    for (int i = 0; i + level <= n; ++i) r[i] = lerp(r[i], r[i + 1], t);
  return r[0];
}

/// Restricts the degree-n curve q (stride apart) from [0,1] to [t0, t1] (t0 < t1), reparametrised
/// over [0,1]: de Casteljau at t1, the left part, then at t0 / t1, the right part. [0,1] is left
/// as it is.
void restrict_to(int n, DVec3* q, int stride, double t0, double t1) {
  std::array<DVec3, 7> c, other;
  for (int i = 0; i <= n; ++i) c[size_t(i)] = q[i * stride];
  if (t1 < 1) split_at(n, c.data(), 1, t1, c.data(), other.data());
  if (t0 > 0) split_at(n, c.data(), 1, t0 / t1, other.data(), c.data());
  for (int i = 0; i <= n; ++i) q[i * stride] = c[size_t(i)];
}

double binomial(int n, int k) {
  double b = 1;
  for (int i = 1; i <= k; ++i) b = b * (n - k + i) / i;
  return b;
}

}  // namespace

BezierCurve curve_on_patch(const BezierPatch& patch, UV a, UV b) {
  const int du = patch.du, dv = patch.dv;
  std::array<DVec3, 16> s;  // s[j * (du + 1) + i]
  for (int j = 0; j <= dv; ++j)
    for (int i = 0; i <= du; ++i) s[size_t(j * (du + 1) + i)] = to_d(patch.control(i, j));
  BezierCurve c;
  if (a.v == b.v || a.u == b.u) {
    // Along u (v constant) or along v: the patch's curve at that v (u), cut to the segment.
    const bool along_u = a.v == b.v;
    const int n = along_u ? du : dv, m = along_u ? dv : du;
    c.degree = n;
    for (int i = 0; i <= n; ++i) {
      std::array<DVec3, 4> q;
      for (int j = 0; j <= m; ++j)
        q[size_t(j)] = along_u ? s[size_t(j * (du + 1) + i)] : s[size_t(i * (du + 1) + j)];
      c.cp[size_t(i)] = point_at(m, q.data(), along_u ? a.v : a.u);
    }
    const double t0 = along_u ? a.u : a.v, t1 = along_u ? b.u : b.v;
    restrict_to(n, c.cp.data(), 1, std::min(t0, t1), std::max(t0, t1));
    if (t0 > t1) std::reverse(c.cp.begin(), c.cp.begin() + n + 1);
    return c;
  }
  // The sub-patch over the segment's rectangle, flipped so that the segment runs from its
  // (0, 0) corner to its (1, 1) corner: the curve is the sub-patch's diagonal.
  for (int j = 0; j <= dv; ++j)
    restrict_to(du, &s[size_t(j * (du + 1))], 1, std::min(a.u, b.u), std::max(a.u, b.u));
  for (int i = 0; i <= du; ++i)
    restrict_to(dv, &s[size_t(i)], du + 1, std::min(a.v, b.v), std::max(a.v, b.v));
  const bool flip_u = a.u > b.u, flip_v = a.v > b.v;
  const int n = du + dv;
  c.degree = n;
  for (int k = 0; k <= n; ++k) c.cp[size_t(k)] = {0, 0, 0};
  for (int i = 0; i <= du; ++i) {
    for (int j = 0; j <= dv; ++j) {
      const DVec3& q = s[size_t((flip_v ? dv - j : j) * (du + 1) + (flip_u ? du - i : i))];
      const double w = binomial(du, i) * binomial(dv, j) / binomial(n, i + j);
      DVec3& o = c.cp[size_t(i + j)];
      o = {o.x + w * q.x, o.y + w * q.y, o.z + w * q.z};
    }
  }
  return c;
}

std::vector<CurveOnPatch> kept_borders(const PatchSet& set) {
  std::vector<CurveOnPatch> out;
  for (uint32_t p = 0; p < set.patches.size(); ++p) {
    const Trim* trim = set.trim(p);
    // The untrimmed square's sides, counter-clockwise: v = 0 (u from 0 to 1), u = 1, v = 1 (u
    // from 1 to 0), u = 0.
    std::vector<std::array<UV, 2>> segments =
        trim ? trim->border()
             : std::vector<std::array<UV, 2>>{{UV{0, 0}, UV{1, 0}},
                                              {UV{1, 0}, UV{1, 1}},
                                              {UV{1, 1}, UV{0, 1}},
                                              {UV{0, 1}, UV{0, 0}}};
    for (const auto& [a, b] : segments)
      out.push_back({curve_on_patch(set.patches[p], a, b), p, a, b});
  }
  return out;
}

BoundaryCurves BoundaryCurves::build(const std::vector<CurveOnPatch>& kept) {
  std::vector<BezierCurve> borders;
  for (const CurveOnPatch& c : kept) borders.push_back(c.curve);
  // Borders by their control points in a canonical direction (the lexicographically smaller
  // of the two): a border and its reverse land together and cancel in pairs.
  using Key = std::vector<double>;
  auto key_of = [](const BezierCurve& c, bool reversed) {
    Key k;
    for (int i = 0; i <= c.degree; ++i) {
      const DVec3& q = c.cp[reversed ? c.degree - i : i];
      k.insert(k.end(), {q.x, q.y, q.z});
    }
    return k;
  };
  std::map<Key, std::vector<std::pair<size_t, bool>>> groups;  // (border, reversed)
  for (size_t i = 0; i < borders.size(); ++i) {
    const BezierCurve& c = borders[i];
    bool collapsed = true;
    for (int k = 1; k <= c.degree; ++k)
      collapsed =
          collapsed && c.cp[k].x == c.cp[0].x && c.cp[k].y == c.cp[0].y && c.cp[k].z == c.cp[0].z;
    if (collapsed) continue;
    Key fwd = key_of(c, false), rev = key_of(c, true);
    const bool reversed = rev < fwd;
    groups[reversed ? std::move(rev) : std::move(fwd)].push_back({i, reversed});
  }
  std::vector<BezierCurve> open;
  std::vector<uint32_t> patches;
  for (auto& [key, members] : groups) {
    std::vector<size_t> fwd, rev;
    for (const auto& [i, reversed] : members) (reversed ? rev : fwd).push_back(i);
    const size_t cancelled = std::min(fwd.size(), rev.size());
    for (size_t k = cancelled; k < fwd.size(); ++k)
      open.push_back(borders[fwd[k]]), patches.push_back(kept[fwd[k]].patch);
    for (size_t k = cancelled; k < rev.size(); ++k)
      open.push_back(borders[rev[k]]), patches.push_back(kept[rev[k]].patch);
  }
  return of(std::move(open), std::move(patches));
}

BoundaryCurves BoundaryCurves::of(std::vector<BezierCurve> curves, std::vector<uint32_t> patches) {
  HFRT_CHECK(patches.empty() || patches.size() == curves.size());
  BoundaryCurves out;
  out.curves_ = std::move(curves);
  out.patches_ = std::move(patches);
  // The pieces' trees, level by level (a curve's root first, so that tree_[i] is curve i).
  auto add_node = [&](const BezierCurve& c) {
    TreeNode t;
    bounding_sphere(c, &t.centre, &t.radius2);
    t.length = polygon_length(c);
    t.children = 0;
    t.curve = ~0u;
    out.tree_.push_back(t);
    Samples sm;
    samples_of(c, DVec3{0, 0, 0}, &sm);
    out.samples_.push_back(sm);
  };
  std::vector<std::pair<uint32_t, BezierCurve>> level;  // (node, its control points)
  for (const BezierCurve& c : out.curves_) {
    level.push_back({uint32_t(out.tree_.size()), c});
    add_node(c);
  }
  for (int depth = 1; depth <= kTreeDepth; ++depth) {
    std::vector<std::pair<uint32_t, BezierCurve>> next;
    for (const auto& [node, c] : level) {
      BezierCurve left, right;
      halve(c, &left, &right);
      out.tree_[node].children = uint32_t(out.tree_.size());
      next.push_back({uint32_t(out.tree_.size()), left});
      add_node(left);
      next.push_back({uint32_t(out.tree_.size()), right});
      add_node(right);
    }
    level.swap(next);
  }
  for (const auto& [node, c] : level) {
    out.tree_[node].curve = uint32_t(out.pieces_.size());
    out.pieces_.push_back(c);
  }
  return out;
}

namespace {

/// The nearest point to p of the segment [a, b]'s parameter (clamped to [0, 1]).
double segment_parameter(const DVec3& a, const DVec3& b, const DVec3& p) {
  const DVec3 ab = b - a;
  const double len2 = ddot(ab, ab);
  return len2 > 0 ? std::clamp(ddot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
}

/// The squared distance between the segment [a, b] and the segment o + t d, 0 <= t <= tmax
/// (tmax finite): the closest pair of points, each clamped to its segment (Ericson, Real-Time
/// Collision Detection 5.1.9).
double segments_distance2(const DVec3& a, const DVec3& b, const DVec3& o, const DVec3& d,
                          double tmax) {
  const DVec3 d1 = b - a, d2{d.x * tmax, d.y * tmax, d.z * tmax}, r = a - o;
  const double aa = ddot(d1, d1), ee = ddot(d2, d2), f = ddot(d2, r);
  double s = 0, t = 0;
  if (aa <= 0 && ee <= 0) {
    s = t = 0;
  } else if (aa <= 0) {
    t = std::clamp(f / ee, 0.0, 1.0);
  } else {
    const double c = ddot(d1, r);
    if (ee <= 0) {
      s = std::clamp(-c / aa, 0.0, 1.0);
    } else {
      const double bb = ddot(d1, d2), denom = aa * ee - bb * bb;
      s = denom > 0 ? std::clamp((bb * f - c * ee) / denom, 0.0, 1.0) : 0.0;
      t = (bb * s + f) / ee;
      if (t < 0) {
        t = 0, s = std::clamp(-c / aa, 0.0, 1.0);
      } else if (t > 1) {
        t = 1, s = std::clamp((bb - c) / aa, 0.0, 1.0);
      }
    }
  }
  const DVec3 p1{a.x + d1.x * s, a.y + d1.y * s, a.z + d1.z * s};
  const DVec3 p2{o.x + d2.x * t, o.y + d2.y * t, o.z + d2.z * t};
  return ddot(p1 - p2, p1 - p2);
}

/// The arc length of a curve (the string term's Gauss-Legendre points on the speed: exact
/// enough for a comparison within 1 %).
double arc_length(const BezierCurve& c) {
  double length = 0;
  for (int g = 0; g < kGauss; ++g) {
    DVec3 x, d1, d2;
    eval_curve(c, kNode[g], &x, &d1, &d2);
    length += kWeight[g] * std::sqrt(ddot(d1, d1));
  }
  return length;
}

/// Curve c halved (de Casteljau) until straight(piece, depth) takes each piece; each is given
/// to emit(piece, t0, t1), left to right, with its parameter range on c. What the crack
/// capsules and the closest points' pieces share.
template <typename Straight, typename Emit>
void straight_pieces(const BezierCurve& c, const Straight& straight, const Emit& emit) {
  struct Todo {
    BezierCurve cp;
    double t0, t1;
    int depth;
  };
  std::vector<Todo> todo{{c, 0.0, 1.0, 0}};
  while (!todo.empty()) {
    const Todo t = todo.back();
    todo.pop_back();
    if (straight(t.cp, t.depth)) {
      emit(t.cp, t.t0, t.t1);
      continue;
    }
    BezierCurve left, right;
    halve(t.cp, &left, &right);
    const double tm = 0.5 * (t.t0 + t.t1);
    todo.push_back({right, tm, t.t1, t.depth + 1});
    todo.push_back({left, t.t0, tm, t.depth + 1});
  }
}

}  // namespace

SealedCracks seal_cracks(const std::vector<BezierCurve>& curves, double tolerance,
                         const std::vector<uint32_t>& patches) {
  HFRT_CHECK(patches.empty() || patches.size() == curves.size());
  SealedCracks out;
  const size_t n = curves.size();
  auto first = [&](size_t i) { return curves[i].cp[0]; };
  auto last = [&](size_t i) { return curves[i].cp[size_t(curves[i].degree)]; };
  double scale = 0;
  for (const BezierCurve& c : curves)
    for (int k = 0; k <= c.degree; ++k)
      scale = std::max({scale, std::abs(c.cp[k].x), std::abs(c.cp[k].y), std::abs(c.cp[k].z)});
  // Nothing to seal at a tolerance that is no distance, or among coordinates that overflow.
  if (!(tolerance > 0) || !std::isfinite(tolerance) || !std::isfinite(scale)) {
    out.open = curves;
    return out;
  }
  const double eps = 1e-9 * std::max(scale, 1e-300);
  // 1. The curves' ends as vertices: an end within eps (on every axis) of an earlier one is
  // its vertex, found through a hash grid of cells 2 eps wide (the 27 around it), so that
  // many ends on one plane cost no more than ends anywhere.
  const size_t ne = 2 * n;
  auto end_point = [&](size_t e) { return e % 2 == 0 ? first(e / 2) : last(e / 2); };
  const double cell = 2 * eps;
  auto cell_of = [&](const DVec3& q) {
    return std::array<int64_t, 3>{int64_t(std::floor(q.x / cell)), int64_t(std::floor(q.y / cell)),
                                  int64_t(std::floor(q.z / cell))};
  };
  struct CellHash {
    size_t operator()(const std::array<int64_t, 3>& k) const {
      return size_t(k[0] * 73856093) ^ size_t(k[1] * 19349663) ^ size_t(k[2] * 83492791);
    }
  };
  std::unordered_map<std::array<int64_t, 3>, std::vector<uint32_t>, CellHash> grid;
  std::vector<uint32_t> vertex(ne);
  uint32_t vertices = 0;
  for (uint32_t e = 0; e < ne; ++e) {
    const DVec3 p = end_point(e);
    const std::array<int64_t, 3> c = cell_of(p);
    uint32_t v = ~0u;
    for (int d = 0; d < 27 && v == ~0u; ++d) {
      const std::array<int64_t, 3> k{c[0] + d % 3 - 1, c[1] + d / 3 % 3 - 1, c[2] + d / 9 - 1};
      const auto it = grid.find(k);
      if (it == grid.end()) continue;
      for (uint32_t other : it->second) {
        const DVec3 q = end_point(other);
        if (std::abs(q.x - p.x) <= eps && std::abs(q.y - p.y) <= eps &&
            std::abs(q.z - p.z) <= eps) {
          v = vertex[other];
          break;
        }
      }
    }
    vertex[e] = v != ~0u ? v : vertices++;
    grid[c].push_back(e);
  }
  std::vector<uint32_t> in(vertices, 0), out_degree(vertices, 0), out_curve(vertices, ~0u);
  for (uint32_t i = 0; i < n; ++i) {
    ++out_degree[vertex[2 * i]], ++in[vertex[2 * i + 1]];
    out_curve[vertex[2 * i]] = i;
  }
  auto simple = [&](uint32_t v) { return in[v] == 1 && out_degree[v] == 1; };
  // 2. Chains: maximal paths through simple vertices (one curve in, one out), from a junction
  // to a junction; then the closed loops of simple vertices alone.
  struct Chain {
    std::vector<uint32_t> curves;
    uint32_t from, to;  // vertices (equal for a closed loop)
  };
  std::vector<Chain> loops;
  std::vector<char> seen(n, 0);
  for (int pass = 0; pass < 2; ++pass) {
    for (uint32_t i = 0; i < n; ++i) {
      if (seen[i] || (pass == 0 && simple(vertex[2 * i]))) continue;
      Chain chain;
      chain.from = vertex[2 * i];
      uint32_t k = i;
      while (true) {
        seen[k] = 1;
        chain.curves.push_back(k);
        const uint32_t v = vertex[2 * k + 1];
        if (!simple(v) || v == chain.from) {
          chain.to = v;
          break;
        }
        k = out_curve[v];
        if (seen[k]) {  // cannot happen: a simple vertex has one curve in
          chain.to = ~0u;
          break;
        }
      }
      if (chain.to != ~0u) loops.push_back(std::move(chain));
    }
  }
  // 3. Pairs of loops, by their boxes first.
  struct LoopInfo {
    DVec3 lo, hi;
    double length = 0;
    NearestOnCurves nearest;
  };
  std::vector<LoopInfo> info(loops.size());
  for (size_t l = 0; l < loops.size(); ++l) {
    LoopInfo& li = info[l];
    li.lo = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, li.hi = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    std::vector<CurveOnPatch> on;
    for (uint32_t k : loops[l].curves) {
      DVec3 a, b;
      control_box(curves[k], &a, &b);
      li.lo = {std::min(li.lo.x, a.x), std::min(li.lo.y, a.y), std::min(li.lo.z, a.z)};
      li.hi = {std::max(li.hi.x, b.x), std::max(li.hi.y, b.y), std::max(li.hi.z, b.z)};
      li.length += arc_length(curves[k]);
      on.push_back({curves[k], k, {0, 0}, {1, 1}});
    }
    li.nearest = NearestOnCurves::build(std::move(on));
  }
  // Every sample of loop a within tolerance of loop b, b running the other way there.
  auto follows = [&](size_t a, size_t b, double* gap) {
    for (uint32_t k : loops[a].curves) {
      const BezierCurve& c = curves[k];
      double leg = 0;
      for (int i = 0; i < c.degree; ++i)
        leg = std::max(leg, std::sqrt(ddot(c.cp[i + 1] - c.cp[i], c.cp[i + 1] - c.cp[i])));
      // |x'| <= degree x the longest leg: samples at most `tolerance` apart.
      const int m = int(std::min(1e6, std::ceil(c.degree * leg / tolerance))) + 1;
      for (int j = 0; j <= m; ++j) {
        DVec3 x, d1, d2;
        eval_curve(c, double(j) / m, &x, &d1, &d2);
        double best2 = tolerance * tolerance;
        NearestOnCurves::Hit hit;
        if (!info[b].nearest.nearest(x, &best2, &hit)) return false;
        *gap = std::max(*gap, std::sqrt(best2));
        if (hit.t > 1e-6 && hit.t < 1 - 1e-6 && j > 0 && j < m) {
          DVec3 y, e1, e2;
          eval_curve(info[b].nearest.curves()[hit.curve].curve, hit.t, &y, &e1, &e2);
          if (!(ddot(d1, e1) < 0)) return false;
        }
      }
    }
    return true;
  };
  auto share_patch = [&](const Chain& a, const Chain& b) {
    std::vector<uint32_t> in_a;
    for (uint32_t i : a.curves) in_a.push_back(patches[i]);
    std::sort(in_a.begin(), in_a.end());
    for (uint32_t k : b.curves)
      if (std::binary_search(in_a.begin(), in_a.end(), patches[k])) return true;
    return false;
  };
  std::vector<char> paired(loops.size(), 0);
  std::vector<char> sealed(n, 0);
  for (size_t a = 0; a < loops.size(); ++a) {
    for (size_t b = a + 1; b < loops.size() && !paired[a]; ++b) {
      // Two closed loops, or two chains between the same junctions the opposite way.
      const Chain &ca = loops[a], &cb = loops[b];
      const bool closed = ca.from == ca.to && cb.from == cb.to;
      if (paired[b] || !(closed || (ca.from == cb.to && ca.to == cb.from))) continue;
      if (!patches.empty() && share_patch(ca, cb)) continue;
      const LoopInfo &la = info[a], &lb = info[b];
      const bool boxes =
          std::abs(la.lo.x - lb.lo.x) <= tolerance && std::abs(la.lo.y - lb.lo.y) <= tolerance &&
          std::abs(la.lo.z - lb.lo.z) <= tolerance && std::abs(la.hi.x - lb.hi.x) <= tolerance &&
          std::abs(la.hi.y - lb.hi.y) <= tolerance && std::abs(la.hi.z - lb.hi.z) <= tolerance;
      if (!boxes || !(std::abs(la.length - lb.length) <=
                      0.01 * std::max(la.length, lb.length) + 4 * tolerance))
        continue;
      double gap = 0;
      if (!follows(a, b, &gap) || !follows(b, a, &gap)) continue;
      paired[a] = paired[b] = 1;
      ++out.pairs;
      out.gap = std::max(out.gap, gap);
      for (uint32_t k : ca.curves) sealed[k] = 1, out.sealed.push_back(curves[k]);
      for (uint32_t k : cb.curves) sealed[k] = 1;
      out.sealed_curves += ca.curves.size() + cb.curves.size();
    }
  }
  for (size_t i = 0; i < n; ++i)
    if (!sealed[i]) out.open.push_back(curves[i]);
  return out;
}

CrackSet CrackSet::build(const std::vector<BezierCurve>& loops, double radius) {
  CrackSet out;
  out.radius_ = radius;
  // Each curve halved until its control points lie within radius / 4 of its chord (or 20
  // halvings deep: at most a million pieces a curve).
  std::vector<Segment> segments;
  for (const BezierCurve& curve : loops)
    straight_pieces(
        curve,
        [&](const BezierCurve& c, int depth) {
          const DVec3 a = c.cp[0], b = c.cp[size_t(c.degree)];
          double dev2 = 0;
          for (int i = 1; i < c.degree; ++i) {
            const double t = segment_parameter(a, b, c.cp[i]);
            const DVec3 q{a.x + (b.x - a.x) * t, a.y + (b.y - a.y) * t, a.z + (b.z - a.z) * t};
            dev2 = std::max(dev2, ddot(c.cp[i] - q, c.cp[i] - q));
          }
          return depth >= 20 || dev2 <= radius * radius / 16;
        },
        [&](const BezierCurve& c, double, double) {
          segments.push_back({c.cp[0], c.cp[size_t(c.degree)]});
        });
  if (segments.empty()) return out;
  // The boxes in float, grown by the radius and a little (so that they hold the capsules).
  std::vector<Box> boxes(segments.size());
  for (size_t i = 0; i < segments.size(); ++i) {
    const Segment& sg = segments[i];
    const double far = std::max({std::abs(sg.a.x), std::abs(sg.a.y), std::abs(sg.a.z),
                                 std::abs(sg.b.x), std::abs(sg.b.y), std::abs(sg.b.z)});
    const double g = radius * (1 + 1e-6) + 1e-6 * far;
    boxes[i] = Box(to_f(DVec3{std::min(sg.a.x, sg.b.x) - g, std::min(sg.a.y, sg.b.y) - g,
                              std::min(sg.a.z, sg.b.z) - g}),
                   to_f(DVec3{std::max(sg.a.x, sg.b.x) + g, std::max(sg.a.y, sg.b.y) + g,
                              std::max(sg.a.z, sg.b.z) + g}));
  }
  Bvh bvh = build_bvh(boxes, BvhBuildOptions{.max_leaf_size = 2});
  out.nodes_ = std::move(bvh.nodes);
  out.segments_.resize(segments.size());
  for (size_t i = 0; i < segments.size(); ++i) out.segments_[i] = segments[bvh.prim_order[i]];
  return out;
}

bool CrackSet::near(const DVec3& o, const DVec3& d, double tmax) const {
  if (segments_.empty()) return false;
  // An infinite ray: cut where it leaves the root box (beyond it no capsule is near).
  if (!std::isfinite(tmax)) {
    const Box root = nodes_[0].bounds();
    tmax = 0;
    const double dv[3] = {d.x, d.y, d.z}, ov[3] = {o.x, o.y, o.z};
    for (int a = 0; a < 3; ++a) {
      if (dv[a] == 0) continue;
      const double lo = (double(root.lo[a]) - ov[a]) / dv[a],
                   hi = (double(root.hi[a]) - ov[a]) / dv[a];
      tmax = std::max(tmax, std::max(lo, hi));
    }
    if (!(tmax > 0)) return false;
  }
  // Slab test of the segment against a node's box (grown by a little: conservative).
  auto hits = [&](const BvhNode& node) {
    double t0 = 0, t1 = tmax;
    const double dv[3] = {d.x, d.y, d.z}, ov[3] = {o.x, o.y, o.z};
    for (int a = 0; a < 3; ++a) {
      const double lo = double(node.lo[a]), hi = double(node.hi[a]);
      if (dv[a] == 0) {
        if (ov[a] < lo || ov[a] > hi) return false;
        continue;
      }
      double ta = (lo - ov[a]) / dv[a], tb = (hi - ov[a]) / dv[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta - 1e-9 * std::abs(ta)), t1 = std::min(t1, tb + 1e-9 * std::abs(tb));
      if (t0 > t1) return false;
    }
    return true;
  };
  const double r2 = radius_ * radius_;
  double bound = 0;
  bool near = false;
  walk_nearest(
      nodes_, [&](const BvhNode& node) { return hits(node) ? 0.0 : 1.0; }, &bound,
      [&](const BvhNode& node, double) {
        for (uint32_t k = node.index; k < node.index + node.count && !near; ++k)
          near = segments_distance2(segments_[k].a, segments_[k].b, o, d, tmax) <= r2;
        return !near;
      });
  return near;
}

double CrackSet::distance(const DVec3& p, double cap) const {
  if (segments_.empty()) return cap;
  const Vec3 pf = to_f(p);
  double best2 = (cap + radius_) * (cap + radius_);
  walk_nearest(
      nodes_, [&](const BvhNode& n) { return double(n.bounds().distance2(pf)) * (1 - 1e-5); },
      &best2,
      [&](const BvhNode& n, double) {
        for (uint32_t k = n.index; k < n.index + n.count; ++k) {
          const Segment& sg = segments_[k];
          const double t = segment_parameter(sg.a, sg.b, p);
          const DVec3 q{sg.a.x + (sg.b.x - sg.a.x) * t, sg.a.y + (sg.b.y - sg.a.y) * t,
                        sg.a.z + (sg.b.z - sg.a.z) * t};
          best2 = std::min(best2, ddot(q - p, q - p));
        }
        return best2 > 0;
      });
  return std::clamp(std::sqrt(best2) - radius_, 0.0, cap);
}

namespace {

/// The sum of length / distance^power over curve c's pieces seen from the ball (c, r): a piece
/// whose sphere is nearer than a quarter of its radius is halved (a tighter bound), at most
/// kBoundDepth times (+inf when a piece's sphere then still meets the ball).
constexpr int kBoundDepth = 8;
double gradient_bound(const BezierCurve& curve, const DVec3& c, double r, int power, int depth) {
  DVec3 m;
  double rho2;
  bounding_sphere(curve, &m, &rho2);
  const double rho = std::sqrt(rho2);
  const DVec3 d = m - c;
  const double gap = std::sqrt(ddot(d, d)) - rho - r;
  if (gap > 0.25 * rho || (gap > 0 && depth >= kBoundDepth))
    return polygon_length(curve) / (power == 2 ? gap * gap : gap * gap * gap);
  if (depth >= kBoundDepth) return std::numeric_limits<double>::infinity();
  BezierCurve left, right;
  halve(curve, &left, &right);
  const double a = gradient_bound(left, c, r, power, depth + 1);
  return std::isfinite(a) ? a + gradient_bound(right, c, r, power, depth + 1) : a;
}

/// The Biot-Savart sum over a piece's samples at p: the weighted derivative x (p - x) /
/// |p - x|^3 at each point (lanes of weight 0 add nothing), into *g; the sum of the terms'
/// magnitudes into *magnitude (what the quadrature's relative error scales with). In single
/// precision, four lanes at a time, as direct_sum (p - origin rounded to float once; the
/// samples of a piece made on the fly are relative to p).
void field_sum(const BoundaryCurves::Samples& sm, const DVec3& origin, const DVec3& p, DVec3* g,
               double* magnitude) {
  const __m128 qx = _mm_set1_ps(float(p.x - origin.x)), qy = _mm_set1_ps(float(p.y - origin.y)),
               qz = _mm_set1_ps(float(p.z - origin.z));
  __m128 gx = _mm_setzero_ps(), gy = _mm_setzero_ps(), gz = _mm_setzero_ps(),
         mag = _mm_setzero_ps();
  for (int k = 0; k < 8; k += 4) {
    const __m128 rx = _mm_sub_ps(qx, _mm_loadu_ps(sm.x + k));
    const __m128 ry = _mm_sub_ps(qy, _mm_loadu_ps(sm.y + k));
    const __m128 rz = _mm_sub_ps(qz, _mm_loadu_ps(sm.z + k));
    const __m128 wx = _mm_loadu_ps(sm.wx + k), wy = _mm_loadu_ps(sm.wy + k),
                 wz = _mm_loadu_ps(sm.wz + k);
    const __m128 len2 =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(rx, rx), _mm_mul_ps(ry, ry)), _mm_mul_ps(rz, rz));
    const __m128 inv3 = _mm_div_ps(_mm_set1_ps(1.0f), _mm_mul_ps(len2, _mm_sqrt_ps(len2)));
    const __m128 tx = _mm_mul_ps(_mm_sub_ps(_mm_mul_ps(wy, rz), _mm_mul_ps(wz, ry)), inv3);
    const __m128 ty = _mm_mul_ps(_mm_sub_ps(_mm_mul_ps(wz, rx), _mm_mul_ps(wx, rz)), inv3);
    const __m128 tz = _mm_mul_ps(_mm_sub_ps(_mm_mul_ps(wx, ry), _mm_mul_ps(wy, rx)), inv3);
    gx = _mm_add_ps(gx, tx), gy = _mm_add_ps(gy, ty), gz = _mm_add_ps(gz, tz);
    mag = _mm_add_ps(mag, _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(tx, tx), _mm_mul_ps(ty, ty)),
                                                 _mm_mul_ps(tz, tz))));
  }
  auto total = [](__m128 v) {
    float lanes[4];
    _mm_storeu_ps(lanes, v);
    return double((lanes[0] + lanes[1]) + (lanes[2] + lanes[3]));
  };
  *g = {g->x + total(gx), g->y + total(gy), g->z + total(gz)};
  *magnitude += total(mag);
}

/// Above this first-order bound, smooth_change tries the second-order one.
constexpr double kSecondOrderFrom = 0.05;

}  // namespace

template <typename Accept, typename Node, typename Piece>
bool BoundaryCurves::for_each_piece(const Accept& accept, const Node& node,
                                    const Piece& piece) const {
  bool all = true;
  uint32_t stack[2 * kTreeDepth + 2];
  for (uint32_t i = 0; i < curves_.size(); ++i) {
    int top = 0;
    stack[top++] = i;
    while (top > 0) {
      const uint32_t k = stack[--top];
      const TreeNode& t = tree_[k];
      if (t.radius2 == 0) continue;  // a point: no length
      if (accept(t.centre, t.radius2)) {
        node(samples_[k]);
      } else if (t.children != 0) {
        stack[top++] = t.children + 1;
        stack[top++] = t.children;
      } else {
        all = by_halves(pieces_[t.curve], kTreeDepth + 1, accept, piece) && all;
      }
    }
  }
  return all;
}

DVec3 BoundaryCurves::field(const DVec3& p, double* magnitude, bool* ok) const {
  DVec3 g{0, 0, 0};
  *magnitude = 0;
  const DVec3 zero{0, 0, 0};
  *ok = for_each_piece(
      [&](const DVec3& m, double rho2) { return rho2 < kFar * kFar * ddot(m - p, m - p); },
      [&](const Samples& sm) { field_sum(sm, zero, p, &g, magnitude); },
      [&](const BezierCurve& c) {
        Samples sm;
        samples_of(c, p, &sm);
        field_sum(sm, p, p, &g, magnitude);
      });
  const double k = 1 / (4 * std::numbers::pi);
  *magnitude *= k;
  return {g.x * k, g.y * k, g.z * k};
}

double BoundaryCurves::tree_bound(uint32_t k, const DVec3& c, double r, int power,
                                  int depth) const {
  // gradient_bound's steps on the stored pieces (the same spheres and lengths, the same sums).
  static_assert(kTreeDepth < kBoundDepth);
  const TreeNode& t = tree_[k];
  const double rho = std::sqrt(t.radius2);
  const DVec3 d = t.centre - c;
  const double gap = std::sqrt(ddot(d, d)) - rho - r;
  if (gap > 0.25 * rho) return t.length / (power == 2 ? gap * gap : gap * gap * gap);
  double a;
  if (t.children == 0) {
    BezierCurve left, right;
    halve(pieces_[t.curve], &left, &right);
    a = gradient_bound(left, c, r, power, depth + 1);
    return std::isfinite(a) ? a + gradient_bound(right, c, r, power, depth + 1) : a;
  }
  a = tree_bound(t.children, c, r, power, depth + 1);
  return std::isfinite(a) ? a + tree_bound(t.children + 1, c, r, power, depth + 1) : a;
}

double BoundaryCurves::smooth_change(const DVec3& c, double r) const {
  // The sum over the curves of length / distance^power (+inf as soon as one is).
  auto bound_sum = [&](int power) {
    double sum = 0;
    for (size_t i = 0; i < curves_.size() && std::isfinite(sum); ++i)
      sum += tree_bound(uint32_t(i), c, r, power, 0);
    return sum;
  };
  // Rounding: a little more.
  const double first = bound_sum(2) * r / (4 * std::numbers::pi) * (1 + 1e-6);
  if (!(first > kSecondOrderFrom)) return first;
  // Second order: |grad w(c)| exactly (its quadrature's error, ~1e-4 of the terms, covered by
  // 1e-3 of their magnitudes) and the Hessian's bound, (1 / 4 pi) x the sum of
  // 2 length / distance^3 (the kernel r / |r|^3 has Jacobian (I - 3 r r^T) / |r|^3, of norm
  // 2 / |r|^3): change <= r |grad w(c)| + r^2 / 2 x that. Much tighter where curves cancel
  // (a trim loop along a wall's rim) or lie far beside the ball.
  const double hessian = bound_sum(3);
  if (!std::isfinite(hessian)) return first;
  double magnitude;
  bool ok;
  const DVec3 g = field(c, &magnitude, &ok);
  if (!ok) return first;
  const double second =
      r * (std::sqrt(ddot(g, g)) + 1e-3 * magnitude) + r * r / (4 * std::numbers::pi) * hessian;
  return std::min(first, second * (1 + 1e-6));
}

double BoundaryCurves::string_term(const DVec3& p, const DVec3& s, bool* reliable) const {
  const float px = float(p.x), py = float(p.y), pz = float(p.z);
  const float sx = float(s.x), sy = float(s.y), sz = float(s.z);
  double sum = 0;
  *reliable =
      for_each_piece([&](const DVec3& m, double rho2) { return direct(m, rho2, p, s); },
                     [&](const Samples& sm) { sum += direct_sum(sm, px, py, pz, sx, sy, sz); },
                     [&](const BezierCurve& c) {
                       // The points relative to p in double, then the float sum (p at the origin:
                       // no rounding of p's coordinates against the points' when the piece is small
                       // and near).
                       Samples sm;
                       samples_of(c, p, &sm);
                       sum += direct_sum(sm, 0, 0, 0, sx, sy, sz);
                     });
  return sum / (4 * std::numbers::pi);
}

namespace {

/// Whether a piece is straight enough for nearest_on_straight: its inner control points
/// within 1e-3 of its chord's length of the chord (or 30 halvings deep).
bool straight_enough(const BezierCurve& piece, int depth) {
  const int n = piece.degree;
  const DVec3 chord = piece.cp[n] - piece.cp[0];
  const double len2 = ddot(chord, chord);
  double dev2 = 0;
  for (int i = 1; i < n; ++i) {
    const DVec3 r = piece.cp[i] - piece.cp[0];
    const double along = len2 > 0 ? ddot(r, chord) / len2 : 0;
    const DVec3 off = {r.x - along * chord.x, r.y - along * chord.y, r.z - along * chord.z};
    dev2 = std::max(dev2, ddot(off, off));
  }
  return depth >= 30 || !(dev2 > 1e-6 * len2);
}

/// The nearest point to p of a straight `piece`, the part [t0, t1] of `whole`, if nearer
/// than sqrt(*best2) (then *best2, *best_t and *best_x are set and true is returned): Newton
/// on (x(t) - p) . x'(t) = 0 in the whole curve's parameter, from the chord's nearest point,
/// clamped to [t0, t1]; its ends are candidates too.
bool nearest_on_straight(const BezierCurve& whole, const BezierCurve& piece, double t0, double t1,
                         const DVec3& p, double* best2, double* best_t, DVec3* best_x) {
  const int n = piece.degree;
  const DVec3 chord = piece.cp[n] - piece.cp[0];
  const double len2 = ddot(chord, chord);
  bool found = false;
  auto consider = [&](double t, const DVec3& x) {
    const DVec3 r = x - p;
    const double d2 = ddot(r, r);
    if (d2 < *best2) *best2 = d2, *best_t = t, *best_x = x, found = true;
  };
  consider(t0, piece.cp[0]);
  consider(t1, piece.cp[n]);
  double t = t0;
  if (len2 > 0) t = t0 + std::clamp(ddot(p - piece.cp[0], chord) / len2, 0.0, 1.0) * (t1 - t0);
  DVec3 x, d1, d2;
  for (int it = 0; it < 12; ++it) {
    eval_curve(whole, t, &x, &d1, &d2);
    const DVec3 r = x - p;
    const double g = ddot(r, d1), h = ddot(d1, d1) + ddot(r, d2);
    if (!(h > 0)) break;
    const double next = std::clamp(t - g / h, t0, t1);
    if (std::abs(next - t) <= 1e-14 * std::max(1.0, std::abs(t))) break;
    t = next;
  }
  eval_curve(whole, t, &x, &d1, &d2);
  consider(t, x);
  return found;
}

}  // namespace

NearestOnCurves NearestOnCurves::build(std::vector<CurveOnPatch> curves) {
  NearestOnCurves out;
  out.curves_ = std::move(curves);
  if (out.curves_.empty()) return out;
  // Every curve's straight pieces (halves of halves, once here rather than at every query).
  std::vector<Piece> pieces;
  for (uint32_t i = 0; i < out.curves_.size(); ++i)
    straight_pieces(out.curves_[i].curve, straight_enough,
                    [&](const BezierCurve& c, double t0, double t1) {
                      pieces.push_back({c, t0, t1, i});
                    });
  std::vector<Box> boxes(pieces.size());
  for (size_t i = 0; i < pieces.size(); ++i) {
    const BezierCurve& c = pieces[i].cp;
    Box b;
    for (int k = 0; k <= c.degree; ++k) b.extend(to_f(c.cp[size_t(k)]));
    // Rounded to float: grown by a little, so that the box still holds the piece.
    const float far = std::max({std::abs(b.lo.x), std::abs(b.lo.y), std::abs(b.lo.z),
                                std::abs(b.hi.x), std::abs(b.hi.y), std::abs(b.hi.z)});
    const float m = 1e-6f * (b.max_extent() + far);
    boxes[i] = Box(b.lo - Vec3{m, m, m}, b.hi + Vec3{m, m, m});
  }
  Bvh bvh = build_bvh(boxes, BvhBuildOptions{.max_leaf_size = 2});
  out.nodes_ = std::move(bvh.nodes);
  out.pieces_.resize(pieces.size());
  for (size_t i = 0; i < pieces.size(); ++i) out.pieces_[i] = pieces[bvh.prim_order[i]];
  return out;
}

bool NearestOnCurves::nearest(const DVec3& p, double* best2, Hit* hit) const {
  if (pieces_.empty()) return false;
  const Vec3 pf = to_f(p);
  // The float box distance, shrunk by a little: a lower bound.
  auto dist2 = [&](const BvhNode& n) { return double(n.bounds().distance2(pf)) * (1 - 1e-5); };
  bool found = false;
  walk_nearest(nodes_, dist2, best2, [&](const BvhNode& n, double) {
    for (uint32_t k = n.index; k < n.index + n.count; ++k) {
      const Piece& piece = pieces_[k];
      double t;
      DVec3 x;
      if (nearest_on_straight(curves_[piece.curve].curve, piece.cp, piece.t0, piece.t1, p, best2,
                              &t, &x)) {
        *hit = {piece.curve, t, x};
        found = true;
      }
    }
    return true;
  });
  return found;
}

}  // namespace hfrt::geom
