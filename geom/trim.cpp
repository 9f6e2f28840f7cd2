#include "geom/trim.h"

#include <algorithm>
#include <cmath>

namespace hfrt::geom {
namespace {

constexpr double kClassifyMargin = 1e-9;

// Whether the segment [a, b] meets the closed rectangle [u0,u1] x [v0,v1] (Liang-Barsky).
bool segment_meets_box(UV a, UV b, double u0, double u1, double v0, double v1) {
  if (std::max(a.u, b.u) < u0 || std::min(a.u, b.u) > u1 || std::max(a.v, b.v) < v0 ||
      std::min(a.v, b.v) > v1)
    return false;
  double t0 = 0, t1 = 1;
  const double d[2] = {b.u - a.u, b.v - a.v};
  const double p[2] = {a.u, a.v};
  const double lo[2] = {u0, v0}, hi[2] = {u1, v1};
  for (int k = 0; k < 2; ++k) {
    if (d[k] == 0) {
      if (p[k] < lo[k] || p[k] > hi[k]) return false;
      continue;
    }
    double ta = (lo[k] - p[k]) / d[k], tb = (hi[k] - p[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

double cross(UV a, UV b) {
  return a.u * b.v - a.v * b.u;
}

}  // namespace

Trim::Trim(std::vector<std::vector<UV>> loops) : loops_(std::move(loops)) {
  for (const std::vector<UV>& loop : loops_)
    for (size_t i = 0; i < loop.size(); ++i)
      edges_.push_back({loop[i], loop[(i + 1) % loop.size()]});
  if (edges_.empty()) return;
  bands_ = static_cast<int>(std::clamp<size_t>(edges_.size() / 4, 1, 64));
  std::vector<std::vector<uint32_t>> per_band(bands_);
  for (uint32_t e = 0; e < edges_.size(); ++e) {
    const Edge& ed = edges_[e];
    // A little wider than the edge, so a query on a band border finds it either way.
    const int b0 = band(std::min(ed.a.v, ed.b.v) - 1e-12);
    const int b1 = band(std::max(ed.a.v, ed.b.v) + 1e-12);
    for (int b = b0; b <= b1; ++b) per_band[b].push_back(e);
  }
  band_start_.push_back(0);
  for (const std::vector<uint32_t>& b : per_band) {
    band_edges_.insert(band_edges_.end(), b.begin(), b.end());
    band_start_.push_back(static_cast<uint32_t>(band_edges_.size()));
  }
}

size_t Trim::memory_bytes() const {
  size_t bytes = loops_.capacity() * sizeof(std::vector<UV>) + edges_.capacity() * sizeof(Edge) +
                 (band_start_.capacity() + band_edges_.capacity()) * sizeof(uint32_t);
  for (const std::vector<UV>& loop : loops_) bytes += loop.capacity() * sizeof(UV);
  return bytes;
}

bool Trim::contains(double u, double v) const {
  if (edges_.empty()) return true;
  const int b = band(v);
  bool inside = false;
  for (uint32_t k = band_start_[b]; k < band_start_[b + 1]; ++k) {
    const Edge& e = edges_[band_edges_[k]];
    if ((e.a.v > v) == (e.b.v > v)) continue;
    const double x = e.a.u + (v - e.a.v) * (e.b.u - e.a.u) / (e.b.v - e.a.v);
    if (u < x) inside = !inside;
  }
  return inside;
}

Trim::Cover Trim::classify(double u0, double u1, double v0, double v1) const {
  if (edges_.empty()) return Cover::kKept;
  const double m = kClassifyMargin;
  for (const Edge& e : edges_)
    if (segment_meets_box(e.a, e.b, u0 - m, u1 + m, v0 - m, v1 + m)) return Cover::kPartial;
  return contains(0.5 * (u0 + u1), 0.5 * (v0 + v1)) ? Cover::kKept : Cover::kRemoved;
}

void Trim::clip(double u0, double u1, double v0, double v1,
                std::vector<std::array<UV, 3>>* out) const {
  if (!(u1 > u0 && v1 > v0)) return;
  // The edges that meet the cell.
  std::vector<const Edge*> es;
  for (const Edge& e : edges_)
    if (segment_meets_box(e.a, e.b, u0, u1, v0, v1)) es.push_back(&e);
  // Slab borders: no edge starts, ends, crosses another edge or the cell's top or bottom
  // strictly inside a slab, so inside one the edges are ordered by v and each lies either in
  // [v0, v1] or wholly above or below it.
  std::vector<double> xs{u0, u1};
  auto add = [&](double x) {
    if (x > u0 && x < u1) xs.push_back(x);
  };
  for (size_t i = 0; i < es.size(); ++i) {
    const Edge& e = *es[i];
    add(e.a.u);
    add(e.b.u);
    if (e.a.v != e.b.v)
      for (double h : {v0, v1})
        if ((e.a.v - h) * (e.b.v - h) < 0)
          add(e.a.u + (h - e.a.v) * (e.b.u - e.a.u) / (e.b.v - e.a.v));
    const UV d1{e.b.u - e.a.u, e.b.v - e.a.v};
    for (size_t j = i + 1; j < es.size(); ++j) {
      const Edge& f = *es[j];
      const UV d2{f.b.u - f.a.u, f.b.v - f.a.v};
      const double den = cross(d1, d2);
      if (den == 0) continue;  // parallel: collinear overlaps only bound empty intervals
      const UV w{f.a.u - e.a.u, f.a.v - e.a.v};
      const double t = cross(w, d2) / den, s = cross(w, d1) / den;
      if (t > 0 && t < 1 && s > 0 && s < 1) add(e.a.u + t * d1.u);
    }
  }
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  struct Bound {
    double ya, yb;  // v at the slab's left and right border
  };
  std::vector<Bound> bs;
  for (size_t k = 0; k + 1 < xs.size(); ++k) {
    const double xa = xs[k], xb = xs[k + 1], xm = 0.5 * (xa + xb);
    bs.assign({{v0, v0}, {v1, v1}});
    for (const Edge* e : es) {
      if (!(std::min(e->a.u, e->b.u) < xm && std::max(e->a.u, e->b.u) > xm)) continue;
      const double slope = (e->b.v - e->a.v) / (e->b.u - e->a.u);
      bs.push_back({std::clamp(e->a.v + (xa - e->a.u) * slope, v0, v1),
                    std::clamp(e->a.v + (xb - e->a.u) * slope, v0, v1)});
    }
    std::sort(bs.begin(), bs.end(),
              [](const Bound& p, const Bound& q) { return p.ya + p.yb < q.ya + q.yb; });
    for (size_t i = 0; i + 1 < bs.size(); ++i) {
      const Bound lo = bs[i], hi = bs[i + 1];
      if (!(hi.ya + hi.yb > lo.ya + lo.yb)) continue;  // an empty interval
      if (!contains(xm, 0.25 * (lo.ya + lo.yb + hi.ya + hi.yb))) continue;
      const UV a{xa, lo.ya}, b{xb, lo.yb}, c{xb, hi.yb}, d{xa, hi.ya};
      if (hi.yb > lo.yb) out->push_back({a, b, c});
      if (hi.ya > lo.ya) out->push_back({a, c, d});
    }
  }
}

std::vector<std::array<UV, 2>> Trim::border() const {
  // The candidate segments: the loop edges and the square's sides (counter-clockwise).
  std::vector<Edge> segs = edges_;
  const UV corner[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (int k = 0; k < 4; ++k) segs.push_back({corner[k], corner[(k + 1) % 4]});
  // Each split where another segment crosses it, or ends on it (a T, or collinear overlap):
  // the pairs whose u ranges overlap, by a sweep over the segments sorted by their lowest u
  // (a loop of thousands of edges meets few of them at any u).
  std::vector<std::vector<double>> ts(segs.size(), std::vector<double>{0, 1});
  // Where f ends on e's line, or crosses e: e's parameters there, into ts[ie].
  auto split_by = [&](size_t ie, size_t jf) {
    const Edge& e = segs[ie];
    const Edge& f = segs[jf];
    const UV d1{e.b.u - e.a.u, e.b.v - e.a.v};
    const double len2 = d1.u * d1.u + d1.v * d1.v;
    if (!(len2 > 0)) return;
    if (std::max(f.a.v, f.b.v) < std::min(e.a.v, e.b.v) ||
        std::min(f.a.v, f.b.v) > std::max(e.a.v, e.b.v))
      return;
    auto on_e = [&](UV q) {
      const UV w{q.u - e.a.u, q.v - e.a.v};
      if (std::abs(cross(d1, w)) > 1e-12 * std::sqrt(len2)) return;
      const double t = (w.u * d1.u + w.v * d1.v) / len2;
      if (t > 0 && t < 1) ts[ie].push_back(t);
    };
    on_e(f.a);
    on_e(f.b);
    const UV d2{f.b.u - f.a.u, f.b.v - f.a.v};
    const double den = cross(d1, d2);
    if (den == 0) return;
    const UV w{f.a.u - e.a.u, f.a.v - e.a.v};
    const double t = cross(w, d2) / den, s = cross(w, d1) / den;
    if (t > 0 && t < 1 && s >= 0 && s <= 1) ts[ie].push_back(t);
  };
  std::vector<uint32_t> order(segs.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  auto umin = [&](uint32_t i) { return std::min(segs[i].a.u, segs[i].b.u); };
  auto umax = [&](uint32_t i) { return std::max(segs[i].a.u, segs[i].b.u); };
  std::sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) { return umin(x) < umin(y); });
  for (size_t k = 0; k < order.size(); ++k) {
    const uint32_t i = order[k];
    for (size_t l = k + 1; l < order.size() && umin(order[l]) <= umax(i); ++l) {
      split_by(i, order[l]);
      split_by(order[l], i);
    }
  }
  std::vector<std::array<UV, 2>> parts;
  for (size_t i = 0; i < segs.size(); ++i) {
    const Edge& e = segs[i];
    const UV d1{e.b.u - e.a.u, e.b.v - e.a.v};
    if (!(d1.u * d1.u + d1.v * d1.v > 0)) continue;
    std::vector<double>& t = ts[i];
    std::sort(t.begin(), t.end());
    auto at = [&](double x) {
      return x == 0 ? e.a : x == 1 ? e.b : UV{e.a.u + x * d1.u, e.a.v + x * d1.v};
    };
    for (size_t k = 0; k + 1 < t.size(); ++k)
      if (t[k + 1] - t[k] > 1e-12) parts.push_back({at(t[k]), at(t[k + 1])});
  }
  // Repeats (the same piece from two segments, in either direction): one of each, by the
  // endpoints rounded to 1e-10 in canonical order.
  auto key = [](const std::array<UV, 2>& s) {
    std::array<int64_t, 4> k;
    auto r = [](double x) { return int64_t(std::llround(x * 1e10)); };
    std::array<int64_t, 2> a{r(s[0].u), r(s[0].v)}, b{r(s[1].u), r(s[1].v)};
    if (b < a) std::swap(a, b);
    k = {a[0], a[1], b[0], b[1]};
    return k;
  };
  std::vector<std::pair<std::array<int64_t, 4>, size_t>> keys(parts.size());
  for (size_t i = 0; i < parts.size(); ++i) keys[i] = {key(parts[i]), i};
  std::sort(keys.begin(), keys.end());
  auto kept = [&](UV q) {
    return q.u >= 0 && q.u <= 1 && q.v >= 0 && q.v <= 1 && contains(q.u, q.v);
  };
  std::vector<std::array<UV, 2>> out;
  for (size_t k = 0; k < keys.size(); ++k) {
    if (k > 0 && keys[k].first == keys[k - 1].first) continue;
    const std::array<UV, 2>& s = parts[keys[k].second];
    const UV d{s[1].u - s[0].u, s[1].v - s[0].v};
    const double len = std::sqrt(d.u * d.u + d.v * d.v);
    // The probes' offset, per unit of d: 1e-10 in (u, v), far above the rounding of the
    // crossing test (~1e-16) and below any gap between two edges that matters (a loop edge
    // 1e-9 from a side of the square must not be jumped over).
    const double h = std::min(1e-10, 0.01 * len) / len;
    const UV m{0.5 * (s[0].u + s[1].u), 0.5 * (s[0].v + s[1].v)};
    const bool left = kept({m.u - h * d.v, m.v + h * d.u});
    const bool right = kept({m.u + h * d.v, m.v - h * d.u});
    if (left == right) continue;
    out.push_back(left ? s : std::array<UV, 2>{s[1], s[0]});
  }
  return out;
}

bool Trim::near_edge(double u, double v, double eps) const {
  if (edges_.empty()) return false;
  for (int b = band(v - eps); b <= band(v + eps); ++b) {
    for (uint32_t k = band_start_[b]; k < band_start_[b + 1]; ++k) {
      const Edge& e = edges_[band_edges_[k]];
      const UV d{e.b.u - e.a.u, e.b.v - e.a.v}, w{u - e.a.u, v - e.a.v};
      const double len2 = d.u * d.u + d.v * d.v;
      const double t = len2 > 0 ? std::clamp((w.u * d.u + w.v * d.v) / len2, 0.0, 1.0) : 0.0;
      const double du = w.u - t * d.u, dv = w.v - t * d.v;
      if (du * du + dv * dv <= eps * eps) return true;
    }
  }
  return false;
}

}  // namespace hfrt::geom
