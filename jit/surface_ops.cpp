// kSurface in every domain (see surface_ops.h).
#include "jit/surface_ops.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "geom/surface.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Points closer to the surface than this fraction of its bounding-box diagonal count as on
/// it for the gradient, which is then the closest primitive's normal.
constexpr float kOnSurface = 1e-5f;

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
  geom::Vec3 p(static_cast<float>(x.v), static_cast<float>(y.v), static_cast<float>(z.v));
  // Most calls come from the renderer's normals at ray hits, on the surface: a search
  // limited to the on-surface distance prunes nearly the whole BVH at once; only a point
  // farther away pays for the unlimited one.
  const float size = ::hfrt::length(s.bounds().diagonal());
  const float on_surface = kOnSurface * size + s.field_tolerance();
  geom::ClosestPoint c = s.closest_point(p, on_surface);
  if (c.prim == ~0u) c = s.closest_point(p);
  if (c.prim == ~0u) {
    // Nothing to be close to (patches all trimmed away): the field's own value, constant.
    r.v = static_cast<double>(s.signed_distance(p));
    return r;
  }
  geom::Vec3 g;
  bool inside;
  if (c.distance < on_surface) {
    // On the surface to rounding, or for patches within their tessellation's error (a ray
    // hit: where the renderer asks for normals, and a patch hit lies on the true patch, up to
    // field_tolerance() off the tessellation), the direction from the closest point is noise
    // and the winding number's side test is ambiguous (and at its most expensive, next to the
    // primitives). The closest primitive's normal is the gradient's direction there (the
    // winding number rises by 1 against it), and the side of its plane gives the value's
    // sign: |value| is within the surface's own uncertainty, so either sign is as good.
    g = -c.normal;
    inside = ::hfrt::dot(p - c.point, c.normal) <= 0;
  } else {
    // Off the surface: signed_distance's value and gradient, from the same closest point.
    inside = s.inside(p);
    const geom::Vec3 away = (p - c.point) / c.distance;
    g = inside ? away : -away;
  }
  r.v = static_cast<double>(inside ? c.distance : -c.distance);
  for (int k = 0; k < 3; ++k)
    r.d[k] = double(g.x) * x.d[k] + double(g.y) * y.d[k] + double(g.z) * z.d[k];
  return r;
}

namespace {

/// One recorded leaf ray (ray_sides_crossings).
struct RaySide {
  const geom::Surface* surface;
  double org[3], dir[3];
  double inv_dd;          // 1 / |dir|^2
  double tmin, tmax;      // the searched segment
  double tol2;            // squared distance from the line within which a point is on it
  double slack;           // rounding of the recovered t at the segment's ends
  uint32_t first, count;  // its crossings: RaySides::t[first, first + count)
  uint32_t wfirst;        // its count + 1 prefix sums: RaySides::wsum[wfirst, ...]
  // The reference: the prefix index k_ref (crossings below it) and w there; unknown until the
  // first query when the ray does not leave the surface's bounds inside the segment.
  bool ref_known = false;
  uint32_t k_ref = 0;
  int w_ref = 0;
};

struct RaySides {
  std::vector<RaySide> rays;
  std::vector<double> t;  // crossings' t, per ray
  std::vector<int> wsum;  // per ray: count + 1 prefix sums of the facings
  RaySideCounts counts;
};
thread_local RaySides t_sides;

/// The entry and exit t of the line org + t dir through `box` (slabs, in double); false when
/// the line misses it.
bool line_box(const double org[3], const double dir[3], const geom::Box& box, double* t_in,
              double* t_out) {
  double a = -kInf, b = kInf;
  for (int k = 0; k < 3; ++k) {
    const double lo = box.lo[k], hi = box.hi[k];
    if (dir[k] == 0) {
      if (org[k] < lo || org[k] > hi) return false;
      continue;
    }
    double t0 = (lo - org[k]) / dir[k], t1 = (hi - org[k]) / dir[k];
    if (t0 > t1) std::swap(t0, t1);
    a = std::max(a, t0);
    b = std::min(b, t1);
  }
  *t_in = a;
  *t_out = b;
  return a <= b;
}

/// The side of p from a recorded ray of `s`; 0 when no recorded ray passes through p.
int side_from_crossings(const geom::Surface* s, float x, float y, float z) {
  RaySides& rs = t_sides;
  for (RaySide& r : rs.rays) {
    if (r.surface != s) continue;
    const double px = x - r.org[0], py = y - r.org[1], pz = z - r.org[2];
    const double t = (px * r.dir[0] + py * r.dir[1] + pz * r.dir[2]) * r.inv_dd;
    if (!(t >= r.tmin - r.slack && t <= r.tmax + r.slack)) continue;
    const double ex = px - t * r.dir[0], ey = py - t * r.dir[1], ez = pz - t * r.dir[2];
    if (ex * ex + ey * ey + ez * ez > r.tol2) continue;
    const double* ts = rs.t.data() + r.first;
    const uint32_t k = uint32_t(std::lower_bound(ts, ts + r.count, t) - ts);
    const int* ws = rs.wsum.data() + r.wfirst;
    if (!r.ref_known) {
      // The first point asked: one winding number (an integer for a closed surface).
      r.w_ref = int(std::lround(s->winding_number(geom::Vec3(x, y, z))));
      r.k_ref = k;
      r.ref_known = true;
      rs.counts.winding++;
      return r.w_ref >= 1 ? 1 : -1;
    }
    rs.counts.from_crossings++;
    const int w = r.w_ref + ws[k] - ws[r.k_ref];
    return w >= 1 ? 1 : -1;
  }
  return 0;
}

}  // namespace

void ray_sides_clear() {
  t_sides.rays.clear();
  t_sides.t.clear();
  t_sides.wsum.clear();
}

namespace {

/// The segment whose crossings ray_sides_crossings asks `s` for: [tmin, end) with end = tmax,
/// or, for a closed surface (whose crossings are recorded), on to where the line leaves the
/// surface's bounds when the segment ends before (w = 0 there: the margin covers the slab
/// test's rounding; the crossings past tmax only serve the record).
struct SearchedSegment {
  bool record = false;  ///< a closed surface and a usable direction: the crossings are recorded
  float end = 0;
  bool meets = false;  ///< the line meets the bounds, at [t_in, t_out]
  double t_in = 0, t_out = 0;
  double org[3] = {0, 0, 0}, dir[3] = {0, 0, 0};
  double dd = 0;  ///< |dir|^2
};

SearchedSegment searched_segment(const geom::Surface& s, const geom::Ray& ray, float tmin,
                                 float tmax) {
  SearchedSegment g;
  g.end = tmax;
  if (!s.topology().closed) return g;
  for (int k = 0; k < 3; ++k) {
    g.org[k] = ray.org[k];
    g.dir[k] = ray.dir[k];
    g.dd += g.dir[k] * g.dir[k];
  }
  if (!(g.dd > 0) || !std::isfinite(g.dd)) return g;
  g.record = true;
  g.meets = line_box(g.org, g.dir, s.bounds(), &g.t_in, &g.t_out);
  if (g.meets) {
    const double margin = 1e-6 * (std::abs(g.t_out) + std::abs(g.t_in)) + 1e-6;
    if (g.t_out + margin >= tmax && g.t_out + 2 * margin < 3e38)
      g.end = float(g.t_out + 2 * margin);
  }
  return g;
}

/// Crossings traced ahead of their queries (ray_sides_prefetch), per thread.
struct Prefetched {
  struct Entry {
    const geom::Surface* surface;
    geom::Ray ray;
    float tmin, end;
    uint32_t first, count;  // in `crossings`
  };
  std::vector<Entry> entries;
  std::vector<geom::Crossing> crossings;
  // Where the next lookup starts: the queries come in the prefetch's order, some skipped (a
  // camera ray that misses the box is not searched); a lookup looks this far ahead.
  size_t next = 0;
  static constexpr size_t kLookAhead = 64;
  // Scratch of ray_sides_prefetch.
  std::vector<geom::Ray> rays;
  std::vector<float> tmin, tmax, end;
  std::vector<uint32_t> order;
  std::vector<std::vector<geom::Crossing>> out, group_out;
};
thread_local Prefetched t_prefetched;

bool same_bits(const geom::Ray& a, const geom::Ray& b) {
  return std::memcmp(&a, &b, sizeof(geom::Ray)) == 0;
}

/// s.crossings(ray, tmin, end, out), from the prefetched ones when this exact query was
/// prefetched on this thread (the same results: crossings_many answers what crossings does).
void crossings_of(const geom::Surface& s, const geom::Ray& ray, float tmin, float end,
                  std::vector<geom::Crossing>* out) {
  Prefetched& p = t_prefetched;
  const size_t last = std::min(p.entries.size(), p.next + Prefetched::kLookAhead);
  for (size_t i = p.next; i < last; ++i) {
    const Prefetched::Entry& e = p.entries[i];
    if (e.surface != &s || !same_bits(e.ray, ray) || std::memcmp(&e.tmin, &tmin, 4) != 0 ||
        std::memcmp(&e.end, &end, 4) != 0)
      continue;
    out->assign(p.crossings.begin() + e.first, p.crossings.begin() + e.first + e.count);
    p.next = i + 1;
    t_sides.counts.prefetched++;
    return;
  }
  s.crossings(ray, tmin, end, out);
}

}  // namespace

void ray_sides_prefetch(std::span<const PrefetchQuery> queries) {
  ray_sides_prefetch_clear();
  Prefetched& p = t_prefetched;
  const size_t n = queries.size();
  if (p.out.size() < n) p.out.resize(n);
  // Each surface's queries together (a model has one or a few surfaces), in query order.
  std::vector<uint32_t>& order = p.order;
  order.resize(n);
  for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
    return std::less<const geom::Surface*>()(queries[a].surface, queries[b].surface);
  });
  p.end.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const PrefetchQuery& q = queries[i];
    p.end[i] = searched_segment(*q.surface, q.ray, q.tmin, q.tmax).end;
  }
  for (size_t a = 0; a < n;) {
    const geom::Surface* s = queries[order[a]].surface;
    size_t b = a;
    p.rays.clear(), p.tmin.clear(), p.tmax.clear();
    for (; b < n && queries[order[b]].surface == s; ++b) {
      p.rays.push_back(queries[order[b]].ray);
      p.tmin.push_back(queries[order[b]].tmin);
      p.tmax.push_back(p.end[order[b]]);
    }
    p.group_out.resize(b - a);
    s->crossings_many(p.rays.data(), b - a, p.tmin.data(), p.tmax.data(), p.group_out.data());
    for (size_t k = a; k < b; ++k) std::swap(p.out[order[k]], p.group_out[k - a]);
    a = b;
  }
  for (size_t i = 0; i < n; ++i) {
    const PrefetchQuery& q = queries[i];
    p.entries.push_back({q.surface, q.ray, q.tmin, p.end[i], uint32_t(p.crossings.size()),
                         uint32_t(p.out[i].size())});
    p.crossings.insert(p.crossings.end(), p.out[i].begin(), p.out[i].end());
  }
}

void ray_sides_prefetch_clear() {
  t_prefetched.entries.clear();
  t_prefetched.crossings.clear();
  t_prefetched.next = 0;
}

void ray_sides_crossings(const geom::Surface& s, const geom::Ray& ray, float tmin, float tmax,
                         std::vector<geom::Crossing>* out) {
  const SearchedSegment g = searched_segment(s, ray, tmin, tmax);
  crossings_of(s, ray, tmin, g.end, out);
  if (!g.record) return;
  RaySides& rs = t_sides;
  RaySide r;
  r.surface = &s;
  for (int k = 0; k < 3; ++k) {
    r.org[k] = g.org[k];
    r.dir[k] = g.dir[k];
  }
  r.inv_dd = 1 / g.dd;
  const geom::Box b = s.bounds();
  const double t_in = g.t_in, t_out = g.t_out;
  const bool meets = g.meets;
  const float t_end = g.end;
  r.tmin = tmin;
  r.tmax = tmax;  // queries past the original segment are not the search's
  r.slack = 1e-6 * (std::abs(r.tmin) + std::abs(r.tmax));
  // The sample points come from the model's code in float (through the leaf's transform):
  // within rounding of the line. A point farther than this is not from this ray.
  const double size = ::hfrt::length(b.diagonal());
  double reach = 0;
  for (int k = 0; k < 3; ++k)
    reach =
        std::max({reach, std::abs(r.org[k]), double(std::abs(b.lo[k])), double(std::abs(b.hi[k]))});
  const double tol = 1e-5 * size + 1e-5 * reach;
  r.tol2 = tol * tol;
  r.first = uint32_t(rs.t.size());
  r.count = uint32_t(out->size());
  r.wfirst = uint32_t(rs.wsum.size());
  int w = 0;
  rs.wsum.push_back(0);
  for (const geom::Crossing& c : *out) {
    rs.t.push_back(c.t);
    w += c.facing;
    rs.wsum.push_back(w);
  }
  // The reference: past every crossing (k = count) with w = 0 when the search reached the
  // exit; before every crossing (k = 0) when the line enters the bounds inside the segment;
  // else the first point asked.
  if (!meets || double(t_end) > t_out) {
    r.ref_known = true;
    r.k_ref = r.count;
  } else if (t_in > tmin) {
    r.ref_known = true;
    r.k_ref = 0;
  }
  rs.rays.push_back(r);
  // The caller sees the original segment only.
  while (!out->empty() && !(out->back().t < tmax)) out->pop_back();
}

RaySideCounts ray_sides_counts() {
  return t_sides.counts;
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
  if (!hfrt::jit::t_sides.rays.empty()) {
    const int side =
        hfrt::jit::side_from_crossings(static_cast<const hfrt::geom::Surface*>(s), x, y, z);
    if (side != 0) return float(side);
  }
  hfrt::jit::t_sides.counts.winding++;
  // The same test as signed_distance's sign (geom/surface.h), without the distance query.
  return static_cast<const hfrt::geom::Surface*>(s)->inside(hfrt::geom::Vec3(x, y, z)) ? 1.0f
                                                                                       : -1.0f;
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
