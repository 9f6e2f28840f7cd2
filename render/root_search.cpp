#include "render/root_search.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hfrt::render {

EvalCounters& EvalCounters::operator+=(const EvalCounters& o) {
  eval_calls += o.eval_calls;
  eval_points += o.eval_points;
  interval_calls += o.interval_calls;
  gradient_calls += o.gradient_calls;
  gradient_points += o.gradient_points;
  attribute_calls += o.attribute_calls;
  attribute_points += o.attribute_points;
  nan_samples += o.nan_samples;
  interval_fallbacks += o.interval_fallbacks;
  candidate_calls += o.candidate_calls;
  candidates += o.candidates;
  return *this;
}

Box segment_box(const Ray& ray, float a, float b) {
  Vec3 p = ray.o + ray.d * a, q = ray.o + ray.d * b;
  Box box{vmin(p, q), vmax(p, q)};
  for (int i = 0; i < 3; ++i) {
    // o + t d rounds twice: a relative pad of a few ulps of the operands keeps it sound.
    float scale = std::abs(ray.o[i]) + std::max(std::abs(a), std::abs(b)) * std::abs(ray.d[i]);
    float pad = 4e-7f * scale + 1e-30f;
    box.lo[i] -= pad;
    box.hi[i] += pad;
  }
  return box;
}

namespace {

/// The points o + t d of `ray` at the n parameters t[i], into x, y, z.
void points_on_ray(const Ray& ray, size_t n, const float* t, float* x, float* y, float* z) {
  for (size_t i = 0; i < n; ++i) {
    x[i] = ray.o.x + t[i] * ray.d.x;
    y[i] = ray.o.y + t[i] * ray.d.y;
    z[i] = ray.o.z + t[i] * ray.d.z;
  }
}

}  // namespace

void RootSearcher::eval_params(const Ray& ray, size_t n, size_t first) {
  if (xs_.size() < first + n) {
    xs_.resize(first + n);
    ys_.resize(first + n);
    zs_.resize(first + n);
    fs_.resize(first + n);
  }
  points_on_ray(ray, n, ts_.data() + first, xs_.data() + first, ys_.data() + first,
                zs_.data() + first);
  eval_points(n, xs_.data() + first, ys_.data() + first, zs_.data() + first, fs_.data() + first);
}

void RootSearcher::eval_points(size_t n, const float* x, const float* y, const float* z, float* f) {
  field_.eval(n, x, y, z, f);
  counters_.eval_calls++;
  counters_.eval_points += n;
  for (size_t i = 0; i < n; ++i) {
    if (std::isnan(f[i])) {
      counters_.nan_samples++;
      if (!has_nan_point_) {
        has_nan_point_ = true;
        nan_point_ = {x[i], y[i], z[i]};
      }
    }
  }
}

namespace {

/// The refinement's next kRefineBatch parameters for bracket `b` into ts (RootSearcher::refine
/// and sign_search_batch share it, so that both sample the same points).
void refine_points(const RootSearcher::Bracket& b, float* ts) {
  constexpr int kBatch = RootSearcher::kRefineBatch, kWindow = RootSearcher::kRefineWindow;
  const float ta = b.ta, fa = b.fa, tb = b.tb, fb = b.fb, eps = b.eps;
  const float width = tb - ta;
  const bool secant = std::isfinite(fa) && std::isfinite(fb) && fa < 0 && fb >= 0 && fb - fa > 0 &&
                      width > kWindow * eps;
  if (!secant) {
    for (int i = 0; i < kBatch; ++i) ts[i] = ta + width * float(i + 1) / float(kBatch + 1);
    return;
  }
  // Where the chord between the ends crosses 0, a window of kRefineWindow points eps apart (a
  // smooth F is nearly linear across a bracket this short, so the root is usually in it and
  // this call ends the refinement), among points that split the bracket evenly (which narrow
  // it kRefineBatch - kRefineWindow + 1-fold if it is not).
  constexpr int kEven = kBatch - kWindow;
  const float est = ta + width * (-fa / (fb - fa));
  // (max: in float, tb - kRefineWindow eps may round below ta; clamp needs lo <= hi.)
  const float lo = std::clamp(est - 0.5f * float(kWindow - 1) * eps, ta,
                              std::max(ta, tb - float(kWindow) * eps));
  float window[kWindow], even[kEven];
  for (int i = 0; i < kWindow; ++i) window[i] = lo + float(i) * eps;
  for (int i = 0; i < kEven; ++i) even[i] = ta + width * float(i + 1) / float(kEven + 1);
  std::merge(window, window + kWindow, even, even + kEven, ts);
}

/// Narrows bracket `b` by the values fs at the parameters ts that refine_points gave; marks
/// it stuck when it stops narrowing (float resolution reached).
void refine_update(RootSearcher::Bracket& b, const float* ts, const float* fs) {
  constexpr int kBatch = RootSearcher::kRefineBatch;
  int first_in = -1;
  for (int i = 0; i < kBatch; ++i) {
    if (fs[i] >= 0) {
      first_in = i;
      break;
    }
  }
  float na = b.ta, nfa = b.fa, nb = b.tb, nfb = b.fb;
  if (first_in >= 0) {
    nb = ts[first_in];
    nfb = fs[first_in];
    if (first_in > 0) {
      na = ts[first_in - 1];
      nfa = fs[first_in - 1];
    }
  } else {
    na = ts[kBatch - 1];
    nfa = fs[kBatch - 1];
  }
  if (!(nb - na < b.tb - b.ta)) {
    b.stuck = true;
    return;
  }
  b.ta = na, b.fa = nfa, b.tb = nb, b.fb = nfb;
}

/// Whether bracket `b` needs another round of refine_points / refine_update.
bool refine_open(const RootSearcher::Bracket& b) {
  return !b.stuck && b.tb - b.ta > b.eps;
}

/// The root of a refined bracket: one regula falsi step inside it when both ends have values.
float refine_result(const RootSearcher::Bracket& b) {
  if (std::isfinite(b.fa) && std::isfinite(b.fb) && b.fa < 0 && b.fb >= 0 && b.fb - b.fa > 0) {
    float t = b.ta + (b.tb - b.ta) * (-b.fa / (b.fb - b.fa));
    return std::clamp(t, b.ta, b.tb);
  }
  return b.tb;
}

/// The number of the last sample of a march of [t0, t1] by `step` (sample k at t0 + k step,
/// the last exactly at t1).
int64_t march_last(float t0, float t1, float step) {
  const double count = std::ceil(double(t1 - t0) / double(step));
  return int64_t(std::min(count, double(1 << 26)));
}

/// Sample k of a march of [t0, t1] by `step` whose last sample is `last` (computed from k, so
/// no drift).
float march_param(float t0, float t1, float step, int64_t k, int64_t last) {
  return k == last ? t1 : std::min(t1, float(double(t0) + double(k) * double(step)));
}

}  // namespace

float RootSearcher::refine(const Ray& ray, float ta, float fa, float tb, float fb, float eps) {
  ts_.resize(std::max<size_t>(ts_.size(), kRefineBatch));
  Bracket b{ta, fa, tb, fb, eps};
  while (refine_open(b)) {
    refine_points(b, ts_.data());
    eval_params(ray, kRefineBatch);
    refine_update(b, ts_.data(), fs_.data());
  }
  return refine_result(b);
}

RootHit RootSearcher::sign_search(const Ray& ray, float t0, float t1, float step, float eps,
                                  bool any_hit) {
  // sign_search_batch's march for one ray, kept apart for speed: as sign_search_batch(1, ...)
  // the sign-change search's renders took ~20 % longer (s3_blend --root sign, 512x512: 55 ->
  // 66 ms, its shadow rays march piece by piece). The two share march_last, march_param and
  // the refinement's steps; RootSearch.BatchedMarchesGiveSignSearchesAnswersBitForBit holds
  // them to the same answers.
  if (!(t0 <= t1) || !(step > 0)) return {};
  const int64_t last = march_last(t0, t1, step);
  float prev_t = t0, prev_f = 0;
  ts_.resize(std::max<size_t>(ts_.size(), kMarchBatch));
  for (int64_t base = 0; base <= last; base += kMarchBatch) {
    int n = int(std::min<int64_t>(kMarchBatch, last + 1 - base));
    for (int i = 0; i < n; ++i) ts_[i] = march_param(t0, t1, step, base + i, last);
    eval_params(ray, n);
    for (int i = 0; i < n; ++i) {
      float f = fs_[i];
      if (f >= 0) {
        if (base + i == 0) return {true, t0, true};
        if (any_hit) return {true, ts_[i], false};
        float t = ts_[i];
        return {true, refine(ray, prev_t, prev_f, t, f, eps), false};
      }
      prev_t = ts_[i];
      prev_f = f;
    }
  }
  return {};
}

void RootSearcher::batch_points_place(size_t n) {
  if (bts_.size() < n) {
    bts_.resize(n), bxs_.resize(n), bys_.resize(n), bzs_.resize(n), bfs_.resize(n);
  }
}

void RootSearcher::batch_points_at(size_t first, size_t count, const Ray& ray) {
  points_on_ray(ray, count, bts_.data() + first, bxs_.data() + first, bys_.data() + first,
                bzs_.data() + first);
}

void RootSearcher::eval_batch_points(size_t n) {
  if (n > 0) eval_points(n, bxs_.data(), bys_.data(), bzs_.data(), bfs_.data());
}

void RootSearcher::sign_search_batch(size_t n, const MarchRequest* req, RootHit* out) {
  march_.clear();
  for (size_t i = 0; i < n; ++i) {
    const MarchRequest& q = req[i];
    out[i] = {};
    if (!(q.t0 <= q.t1) || !(q.step > 0)) continue;
    march_.push_back({uint32_t(i), 0, march_last(q.t0, q.t1, q.step), q.t0, 0.0f});
  }
  brackets_.clear();
  bracket_of_.clear();
  // Rounds of the marches: the next kMarchBatch samples of each march still going.
  while (!march_.empty()) {
    size_t total = 0;
    for (const MarchState& m : march_) {
      total += size_t(std::min<int64_t>(m.next + kMarchBatch, m.last + 1) - m.next);
    }
    batch_points_place(total);
    size_t at = 0;
    for (const MarchState& m : march_) {
      const MarchRequest& q = req[m.request];
      const int64_t end = std::min<int64_t>(m.next + kMarchBatch, m.last + 1);
      for (int64_t k = m.next; k < end; ++k) {
        bts_[at + size_t(k - m.next)] = march_param(q.t0, q.t1, q.step, k, m.last);
      }
      batch_points_at(at, size_t(end - m.next), q.ray);
      at += size_t(end - m.next);
    }
    eval_batch_points(total);
    size_t kept = 0;
    at = 0;
    for (MarchState m : march_) {
      const MarchRequest& q = req[m.request];
      const int64_t end = std::min<int64_t>(m.next + kMarchBatch, m.last + 1);
      const size_t count = size_t(end - m.next);
      bool settled = false;
      for (size_t i = 0; i < count; ++i) {
        const float t = bts_[at + i], f = bfs_[at + i];
        if (f >= 0) {
          settled = true;
          if (m.next + int64_t(i) == 0) {
            out[m.request] = {true, q.t0, true};
          } else if (q.any_hit) {
            out[m.request] = {true, t, false};
          } else {
            brackets_.push_back({m.prev_t, m.prev_f, t, f, q.eps});
            bracket_of_.push_back(m.request);
          }
          break;
        }
        m.prev_t = t;
        m.prev_f = f;
      }
      at += count;
      m.next = end;
      if (!settled && m.next <= m.last) march_[kept++] = m;
    }
    march_.resize(kept);
  }
  // Rounds of the refinement: kRefineBatch points of each bracket still open.
  open_.clear();
  for (size_t j = 0; j < brackets_.size(); ++j) {
    if (refine_open(brackets_[j])) open_.push_back(uint32_t(j));
  }
  while (!open_.empty()) {
    batch_points_place(open_.size() * kRefineBatch);
    for (size_t k = 0; k < open_.size(); ++k) {
      refine_points(brackets_[open_[k]], &bts_[k * kRefineBatch]);
      batch_points_at(k * kRefineBatch, kRefineBatch, req[bracket_of_[open_[k]]].ray);
    }
    eval_batch_points(open_.size() * kRefineBatch);
    size_t kept = 0;
    for (size_t k = 0; k < open_.size(); ++k) {
      Bracket& b = brackets_[open_[k]];
      refine_update(b, &bts_[k * kRefineBatch], &bfs_[k * kRefineBatch]);
      if (refine_open(b)) open_[kept++] = open_[k];
    }
    open_.resize(kept);
  }
  for (size_t j = 0; j < brackets_.size(); ++j) {
    out[bracket_of_[j]] = {true, refine_result(brackets_[j]), false};
  }
}

RootHit RootSearcher::interval_search(const Ray& ray, float t0, float t1, float eps,
                                      float fallback_step, bool any_hit) {
  if (!(t0 <= t1)) return {};
  int budget = kIntervalBudget;
  stack_.clear();
  if (any_hit) {
    // A shadow ray starts next to the surface it leaves, where only short pieces can be proven
    // empty: start with pieces growing geometrically away from t0 (one march step, then
    // doubling) instead of halving [t0, t1] down to them. Pushed back to front.
    float len = fallback_step > 0 ? fallback_step : t1 - t0;
    size_t first = stack_.size();
    for (float a = t0; a < t1; len *= 2) {
      float b = len < t1 - a ? a + len : t1;
      if (!(b > a)) b = t1;
      stack_.push_back({a, b, false});
      a = b;
    }
    if (stack_.size() == first) stack_.push_back({t0, t1, false});  // t0 == t1: one point
    std::reverse(stack_.begin() + first, stack_.end());
    return bisect(ray, t0, eps, fallback_step, any_hit, &budget);
  }
  if (plain_bisection_) {
    stack_.push_back({t0, t1, false});
    return bisect(ray, t0, eps, fallback_step, false, &budget);
  }
  // Find the first crossing cheaply: a march with point samples (many per call, each far
  // cheaper than an interval evaluation) and the refinement of its bracket.
  RootHit m = sign_search(ray, t0, t1, fallback_step, eps * 0.25f, false);
  if (!m.hit) {
    // No sample inside: only the bisection can tell a miss from a feature thinner than the step.
    stack_.push_back({t0, t1, false});
    return bisect(ray, t0, eps, fallback_step, false, &budget);
  }
  if (m.at_start) return m;
  // Then prove with intervals that nothing lies before it: [t0, m.t - kVerifyGap eps] is
  // covered by pieces that grow by kVerifyGrowth away from the root, so that one interval
  // evaluation usually excludes each; a piece that is not excluded is bisected as usual and its
  // first leaf that may hold the surface is the hit.
  // The last few eps before the root are left out: there the bisection itself cannot tell a
  // feature from the root (the enclosures of pieces that close to a root reach 0 too) and
  // reports a leaf within about that distance. So the answer is the bisection's to within a few
  // eps, at a fraction of its interval evaluations, which near a root are spent on pieces too
  // close to it to be excluded.
  float len = kVerifyGap * eps;
  for (float b = m.t - kVerifyGap * eps; b > t0; len *= kVerifyGrowth) {
    float a = len < b - t0 ? b - len : t0;
    if (!(a < b)) a = t0;
    stack_.push_back({a, b, false});
    b = a;
  }
  RootHit h = bisect(ray, t0, eps, fallback_step, false, &budget);
  return h.hit ? h : m;
}

RootHit RootSearcher::bisect(const Ray& ray, float t0, float eps, float fallback_step, bool any_hit,
                             int* budget) {
  const float march_span = kPrunedSpan * fallback_step;
  while (!stack_.empty()) {
    if ((*budget)-- <= 0) {
      // Out of budget: finish the remaining pieces, front to back, by marching.
      counters_.interval_fallbacks++;
      while (!stack_.empty()) {
        Piece p = stack_.back();
        stack_.pop_back();
        RootHit h = sign_search(ray, p.a, p.b, fallback_step, eps, any_hit);
        if (h.hit) {
          h.at_start = h.at_start && p.a == t0;
          return h;
        }
      }
      return {};
    }
    Piece p = stack_.back();
    stack_.pop_back();
    bool maybe_nan = false;
    Interval iv = field_.eval_interval(segment_box(ray, p.a, p.b), &maybe_nan);
    counters_.interval_calls++;
    if (iv.hi < 0) continue;  // no point of the piece is inside (NaN points count as outside)
    bool known = !std::isnan(iv.lo) && !std::isnan(iv.hi);
    if (known && iv.lo >= 0 && !maybe_nan) {
      // The whole piece is inside and everything before it was excluded: the surface is at
      // its start.
      return {true, p.a, p.a == t0};
    }
    if (any_hit && !p.marched && p.b - p.a <= march_span) {
      // A shadow ray only asks whether some point is inside, in any order: one march over the
      // piece settles most occluded rays without bisecting down to the tolerance. A miss of the
      // march proves nothing (a thinner feature), so the bisection goes on.
      RootHit h = sign_search(ray, p.a, p.b, fallback_step, eps, true);
      if (h.hit) return {true, h.t, h.at_start && p.a == t0};
      p.marched = true;
    }
    float mid = p.a + (p.b - p.a) * 0.5f;
    bool leaf = p.b - p.a <= eps || !(mid > p.a && mid < p.b);
    if (!leaf) {
      stack_.push_back({mid, p.b, p.marched});
      stack_.push_back({p.a, mid, p.marched});
      continue;
    }
    ts_.resize(std::max<size_t>(ts_.size(), 3));
    ts_[0] = p.a, ts_[1] = mid, ts_[2] = p.b;
    eval_params(ray, 3);
    for (int i = 0; i < 3; ++i) {
      if (fs_[i] >= 0) {
        if (i == 0) return {true, p.a, p.a == t0};
        if (any_hit) return {true, ts_[i], false};
        return {true, refine(ray, ts_[i - 1], fs_[i - 1], ts_[i], fs_[i], eps * 0.25f), false};
      }
    }
    // No sample is inside but the interval still reaches 0 at the tolerance: a feature thinner
    // than eps or a tangent touch. Report it rather than punch a hole.
    if (known && iv.hi >= 0) return {true, mid, false};
  }
  return {};
}

RootHit RootSearcher::analytic_search(const Ray& ray, float t0, float t1, bool start_outside,
                                      bool end_inside) {
  if (!(t0 <= t1)) return {};
  std::vector<double>& c = candidates_;
  c.clear();
  field_.ray_candidates(ray.o, ray.d, t0, t1, &c);
  counters_.candidate_calls++;
  counters_.candidates += c.size();
  // Sorted, distinct, strictly inside (t0, t1]: a candidate at t0 is covered by F(t0).
  std::sort(c.begin(), c.end());
  size_t n = 0;
  for (double t : c) {
    if (!(t > double(t0) && t <= double(t1))) continue;
    if (n > 0 && c[n - 1] == t) continue;
    c[n++] = t;
  }
  c.resize(n);
  // Samples: gap 0 [t0, c[0]) (unless known outside), then the midpoint of each gap
  // (c[k], c[k+1]) with c[n] = t1. F keeps its sign on each gap (every sign change is at a
  // candidate), so one sample per gap decides it. The last gap (c[n-1], t1], or [t0, t1]
  // without candidates, is known inside with end_inside (unless that contradicts
  // start_outside: then sampled).
  const bool last_known = end_inside && (n == 0 ? !start_outside : c[n - 1] < double(t1));
  if (n == 0 && last_known) return {true, t0, true};
  const size_t first = start_outside ? 0 : 1;     // index of gap 0's sample
  const size_t sampled = last_known ? n - 1 : n;  // gaps after a candidate that get a sample
  const size_t m = first + sampled;
  if (m == 0) return last_known ? RootHit{true, float(c[0]), false} : RootHit{};
  if (ts_.size() < m) ts_.resize(m);
  // Gap 0's sample at its midpoint rather than at t0 (the same side: no candidate lies in
  // between): t0 is often next to a surface (a shadow ray's biased origin, a culled slab's
  // end), where a mesh or patch leaf's side costs its own winding number, while the midpoint
  // of a long gap is usually in a region of the leaf's cell grid that has one for all its
  // points (geom::MeshSurface::inside).
  if (!start_outside) ts_[0] = float(0.5 * (double(t0) + (n > 0 ? c[0] : double(t1))));
  for (size_t k = 0; k < sampled; ++k) {
    double next = k + 1 < n ? c[k + 1] : double(t1);
    ts_[first + k] = float(0.5 * (c[k] + next));
  }
  // The first sample (t0, or the first gap) alone, then the rest: most hits are decided by
  // the first gap, and a mesh or patch leaf's sample may cost a winding number.
  eval_params(ray, 1);
  if (m > 1 && !(fs_[0] >= 0)) eval_params(ray, m - 1, 1);  // NaN counts as outside
  if (!start_outside && fs_[0] >= 0) return {true, t0, true};
  for (size_t k = 0; k < sampled; ++k) {
    if (fs_[first + k] >= 0) return {true, float(c[k]), false};
  }
  if (last_known) return {true, float(c[n - 1]), false};
  return {};
}

RootHit RootSearcher::pruned_sign_search(const Ray& ray, float t0, float t1, float step, float eps,
                                         bool any_hit) {
  if (!(t0 <= t1)) return {};
  const float span = kPrunedSpan * step;
  std::vector<Piece> stack{{t0, t1, false}};  // separate from stack_: sign_search does not use it
  while (!stack.empty()) {
    Piece p = stack.back();
    stack.pop_back();
    bool maybe_nan = false;
    Interval iv = field_.eval_interval(segment_box(ray, p.a, p.b), &maybe_nan);
    counters_.interval_calls++;
    if (iv.hi < 0) continue;
    float mid = p.a + (p.b - p.a) * 0.5f;
    if (p.b - p.a > span && mid > p.a && mid < p.b) {
      stack.push_back({mid, p.b, false});
      stack.push_back({p.a, mid, false});
      continue;
    }
    // Everything before p.a was excluded or marched without a hit.
    RootHit h = sign_search(ray, p.a, p.b, step, eps, any_hit);
    if (h.hit) {
      h.at_start = h.at_start && p.a == t0;
      return h;
    }
  }
  return {};
}

}  // namespace hfrt::render

namespace hfrt::render {

void RootSearcher::batch_clear() {
  batch_rays_.clear();
  batch_pieces_.clear();
  batch_over_.clear();
}

int RootSearcher::batch_add_ray(const BatchRay& ray) {
  BatchState st;
  static_cast<BatchRay&>(st) = ray;
  st.best = std::numeric_limits<float>::infinity();
  batch_rays_.push_back(st);
  return int(batch_rays_.size()) - 1;
}

void RootSearcher::batch_add_piece(int ray, float a, float b) {
  if (a <= b) batch_pieces_.push_back({ray, a, b, false});
}

void RootSearcher::batch_add_growing(int ray, float a, float b, float first, float growth,
                                     bool from_b) {
  if (!(a <= b)) return;
  float len = first > 0 ? first : b - a;
  if (from_b) {
    for (float hi = b; hi > a; len *= growth) {
      float lo = len < hi - a ? hi - len : a;
      if (!(lo < hi)) lo = a;
      batch_pieces_.push_back({ray, lo, hi, false});
      hi = lo;
    }
  } else {
    size_t first_piece = batch_pieces_.size();
    for (float lo = a; lo < b; len *= growth) {
      float hi = len < b - lo ? lo + len : b;
      if (!(hi > lo)) hi = b;
      batch_pieces_.push_back({ray, lo, hi, false});
      lo = hi;
    }
    if (batch_pieces_.size() == first_piece) batch_pieces_.push_back({ray, a, b, false});
  }
}

void RootSearcher::batch_hit(BatchState& r, float t, bool at_start) {
  if (r.any_hit) {
    r.done = true;
    r.best = t;
    r.result = {true, t, at_start};
    return;
  }
  if (t < r.best) {
    r.best = t;
    r.result = {true, t, at_start};
  }
}

void RootSearcher::batch_run() {
  for (BatchState& r : batch_rays_) r.result = {};
  while (!batch_pieces_.empty()) {
    // The boxes of this round: every piece of a ray still searching, in front of its best hit.
    batch_live_.clear();
    batch_boxes_.clear();
    for (const BatchPiece& p : batch_pieces_) {
      BatchState& r = batch_rays_[size_t(p.ray)];
      if (r.done || !(p.a < r.best)) continue;
      if (r.evals >= kIntervalBudget) {
        batch_over_.push_back(p);
        continue;
      }
      r.evals++;
      batch_live_.push_back(p);
      batch_boxes_.push_back(segment_box(r.ray, p.a, p.b));
    }
    const size_t n = batch_boxes_.size();
    batch_ivs_.resize(n);
    if (batch_nan_size_ < n) {
      batch_nan_size_ = std::max(n, 2 * batch_nan_size_);
      batch_nan_.reset(new bool[batch_nan_size_]);
    }
    if (n > 0) field_.eval_intervals(n, batch_boxes_.data(), batch_ivs_.data(), batch_nan_.get());
    counters_.interval_calls += n;
    // The marches of this round's shadow pieces (those that the loop below marches), together:
    // the first of each ray (a march that finds an occluder settles the ray, and the ray's
    // other pieces of the round are not marched then, so the later ones are marched by the
    // loop as it reaches them, if the ray is still searching).
    batch_march_of_.assign(n, -1);
    batch_march_req_.clear();
    ++batch_round_;
    for (size_t i = 0; i < n; ++i) {
      const BatchPiece& p = batch_live_[i];
      BatchState& r = batch_rays_[size_t(p.ray)];
      const Interval iv = batch_ivs_[i];
      if (iv.hi < 0 || !r.any_hit || p.marched || !(p.b - p.a <= kPrunedSpan * r.step)) continue;
      if (!std::isnan(iv.lo) && !std::isnan(iv.hi) && iv.lo >= 0 && !batch_nan_[i]) continue;
      if (r.march_round == batch_round_) continue;
      r.march_round = batch_round_;
      batch_march_of_[i] = int(batch_march_req_.size());
      batch_march_req_.push_back({r.ray, p.a, p.b, r.step, r.eps, true});
    }
    batch_march_hit_.resize(batch_march_req_.size());
    sign_search_batch(batch_march_req_.size(), batch_march_req_.data(), batch_march_hit_.data());
    batch_next_.clear();
    for (size_t i = 0; i < n; ++i) {
      BatchPiece p = batch_live_[i];
      BatchState& r = batch_rays_[size_t(p.ray)];
      // An earlier piece of this round may have settled the ray or found a nearer hit.
      if (r.done || !(p.a < r.best)) continue;
      const Interval iv = batch_ivs_[i];
      const bool maybe_nan = batch_nan_[i];
      if (iv.hi < 0) continue;
      const bool known = !std::isnan(iv.lo) && !std::isnan(iv.hi);
      if (known && iv.lo >= 0 && !maybe_nan) {
        batch_hit(r, p.a, p.a == r.t_start);
        continue;
      }
      if (r.any_hit && !p.marched && p.b - p.a <= kPrunedSpan * r.step) {
        const RootHit h = batch_march_of_[i] >= 0
                              ? batch_march_hit_[size_t(batch_march_of_[i])]
                              : sign_search(r.ray, p.a, p.b, r.step, r.eps, true);
        if (h.hit) {
          batch_hit(r, h.t, h.at_start && p.a == r.t_start);
          continue;
        }
        p.marched = true;
      }
      float mid = p.a + (p.b - p.a) * 0.5f;
      bool leaf = p.b - p.a <= r.eps || !(mid > p.a && mid < p.b);
      if (!leaf) {
        batch_next_.push_back({p.ray, p.a, mid, p.marched});
        batch_next_.push_back({p.ray, mid, p.b, p.marched});
        continue;
      }
      ts_.resize(std::max<size_t>(ts_.size(), 3));
      ts_[0] = p.a, ts_[1] = mid, ts_[2] = p.b;
      eval_params(r.ray, 3);
      bool found = false;
      for (int k = 0; k < 3 && !found; ++k) {
        if (fs_[k] >= 0) {
          found = true;
          if (k == 0) {
            batch_hit(r, p.a, p.a == r.t_start);
          } else if (r.any_hit) {
            batch_hit(r, ts_[k], false);
          } else {
            batch_hit(r, refine(r.ray, ts_[k - 1], fs_[k - 1], ts_[k], fs_[k], r.eps * 0.25f),
                      false);
          }
        }
      }
      // No sample inside but the interval reaches 0 at the tolerance: a feature thinner than
      // eps or a tangent touch, reported rather than punched through (as bisect() does).
      if (!found && known && iv.hi >= 0) batch_hit(r, mid, false);
    }
    batch_pieces_.swap(batch_next_);
  }
  // Rays out of budget: their remaining pieces, front to back, by marching.
  if (!batch_over_.empty()) {
    std::stable_sort(batch_over_.begin(), batch_over_.end(),
                     [](const BatchPiece& u, const BatchPiece& v) {
                       return u.ray != v.ray ? u.ray < v.ray : u.a < v.a;
                     });
    int last_ray = -1;
    for (const BatchPiece& p : batch_over_) {
      BatchState& r = batch_rays_[size_t(p.ray)];
      if (p.ray != last_ray) {
        counters_.interval_fallbacks++;
        last_ray = p.ray;
      }
      if (r.done || !(p.a < r.best)) continue;
      RootHit h = sign_search(r.ray, p.a, p.b, r.step, r.eps, r.any_hit);
      if (h.hit) batch_hit(r, h.t, h.at_start && p.a == r.t_start);
    }
    batch_over_.clear();
  }
  for (BatchState& r : batch_rays_) {
    if (!r.result.hit) r.result = r.otherwise;
  }
}

}  // namespace hfrt::render
