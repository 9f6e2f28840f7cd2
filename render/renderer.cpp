#include "render/renderer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

#include "base/check.h"
#include "base/parallel.h"
#include "render/depth_cull.h"
#include "render/framing.h"
#include "render/sampling.h"
#include "render/tape_regions.h"
#include "render/tiles.h"

namespace hfrt::render {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// A range of camera depths that per-tile culling could not prove empty.
struct Span {
  float a, b;
};

/// Appends [a, b] to `spans`, merged with the last span when they touch (the culling keeps
/// its pieces front to back).
void append_span(std::vector<Span>* spans, float a, float b) {
  if (!spans->empty() && spans->back().b == a) {
    spans->back().b = b;
  } else {
    spans->push_back({a, b});
  }
}

/// One camera sample of a tile.
struct Sample {
  Ray ray;
  int pixel;  // index into the tile's pixel list
  bool hit = false;
  bool cap = false;  // hit the bbox face while entering it inside the solid
  int cap_axis = 0;
  float t = 0;
};

/// A piece [a, b] of camera sample `sample`'s ray (search_primary_pruned).
struct SamplePiece {
  uint32_t sample;
  float a, b;
};

/// Scratch memory and counters of one worker thread.
struct ThreadState {
  /// `cells`: the render's shared cell tapes, where the tile's first prunes start.
  ThreadState(const Field& field, TapeCells* cells)
      : regions(std::make_unique<TapeRegions>(field, cells)), searcher(*regions) {}
  /// The tapes pruned for the current tile's culling slabs; the searcher evaluates through it
  /// (on the heap: the searcher refers to it, and ThreadStates move).
  std::unique_ptr<TapeRegions> regions;
  RootSearcher searcher;
  std::vector<Sample> samples;
  std::vector<Span> spans;
  /// Where the tile's last span turns proven inside (F >= 0 for every ray of the tile from
  /// there to the span's end: its last culling piece was an inside one); +inf when it does not.
  float inside_from = std::numeric_limits<float>::infinity();
  std::vector<DepthPiece> stack;  // scratch of bisect_depths
  std::vector<float> hx, hy, hz, f, gx, gy, gz, attrs;
  std::vector<int> hit_index;
  /// Per camera sample / per shadow ray: its ray in the searcher's batch (-1: none).
  std::vector<int> batch_index;
  /// search_primary_pruned: per sample, its pieces still to visit (the front on top) and the
  /// pieces it marched without a hit and could not exclude (front to back); this round's
  /// pieces and their enclosures.
  std::vector<std::vector<SamplePiece>> todo, unproven;
  std::vector<SamplePiece> round;
  /// search_primary_pruned's marches: the pieces of a round, their requests and answers, and
  /// the samples whose depths are marched whole.
  std::vector<SamplePiece> to_march;
  std::vector<RootSearcher::MarchRequest> march_requests;
  std::vector<RootHit> march_hits;
  std::vector<uint32_t> short_rays;
  /// search_primary_sign: per sample the end of its range in the box and its next span, and
  /// the samples still searching.
  std::vector<float> t_exit;
  std::vector<uint32_t> next_span, searching;
  std::vector<Box> round_boxes;
  std::vector<Interval> round_ivs;
  std::unique_ptr<bool[]> round_nan;
  size_t round_nan_size = 0;
  std::vector<RootHit> marched;
  std::vector<SamplePiece> hit_piece;
  std::vector<float> t_enter;  // per sample: where its ray enters the box
  /// Per light: the ranges of t along the shadow rays of the current tile that its bundle
  /// culling could not prove empty (see TileRenderer::cull_shadow_bundle).
  std::vector<std::vector<Span>> shadow_spans;
  std::vector<float> accum;  // per pixel: r g b hits depth nx ny nz
  /// prefetch_analytic: the camera rays and segments whose candidates are traced together.
  std::vector<Vec3> pf_o, pf_d;
  std::vector<float> pf_a, pf_b;
  double cull_seconds = 0, search_seconds = 0, shade_seconds = 0;
  uint64_t primary_rays = 0, shadow_rays = 0, hits = 0;
  size_t tiles_empty = 0;
};

class TileRenderer {
 public:
  TileRenderer(const Field& field, const RenderOptions& options, Image* image)
      : field_(field),
        opt_(options),
        frame_(options.camera, options.width, options.height),
        image_(image) {
    step_ = effective_step(options);
    eps_ = effective_epsilon(options);
    use_analytic_ = options.root == RootMode::kAnalytic ||
                    (options.root == RootMode::kAuto && field.has_ray_candidates());
    use_interval_ = !use_analytic_ && (options.root == RootMode::kInterval ||
                                       (options.root == RootMode::kAuto && field.has_interval()));
    cull_ = options.tile_culling && field.has_interval();
    prune_ = cull_ && use_interval_ && options.pruned_tapes;
    lights_ = options.lights.empty() ? default_lights(frame_) : options.lights;
    frame_.depth_range(options.bbox, &t_min_, &t_max_);
    // The per-pixel world footprint at depth t is footprint_a_ + footprint_b_ * t.
    Ray r0 = frame_.ray(0, 0), r1 = frame_.ray(1, 0);
    if (frame_.orthographic()) {
      footprint_a_ = length(r1.o - r0.o);
      footprint_b_ = 0;
    } else {
      footprint_a_ = 0;
      footprint_b_ = length(r1.d - r0.d);
    }
    attrs_ = field.num_attributes() >= 3;
    shadow_bias_ = shadow_bias(options);
    // Shadow rays search only where intervals have not proven the solid absent: the render box
    // is often far larger than the solid (the default -10..10 around a gear 2.5 wide), and a
    // shadow ray leaving the solid would cross the rest of it. The octree stops at a depth
    // of 6 or where its next level would take it past kShadowBoxCells cells: on c1_gear in a
    // box of 1.6 that is depth 5 (3849 cells, ~0.5 ms; depth 6 took 2.3 ms, depth 4 gave a
    // box 30 % wider), and 512x512 renders took 99 -> 85 ms (medians of 8, --bbox 1.6).
    shadow_box_ = options.bbox;
    if (options.shadows && cull_ && !use_analytic_) {
      shadow_box_ = proven_extent(field, options.bbox, kShadowBoxDepth, kShadowBoxCells);
    }
  }

  RootMode root_used() const {
    return use_analytic_ ? RootMode::kAnalytic
                         : (use_interval_ ? RootMode::kInterval : RootMode::kSign);
  }

  void render_tile(int tx0, int ty0, int tx1, int ty1, ThreadState& ts) {
    auto t_start = Clock::now();
    ts.searcher.set_plain_bisection(!opt_.interval_march_first);
    int tw = tx1 - tx0, th = ty1 - ty0;
    size_t npix = size_t(tw) * th;
    ts.accum.assign(npix * 8, 0.0f);
    // 1. Which depths can hold the surface for any ray of this tile.
    ts.spans.clear();
    ts.inside_from = std::numeric_limits<float>::infinity();
    if (t_min_ <= t_max_) {
      if (cull_) {
        cull_tile(tx0, ty0, tx1, ty1, ts);
      } else {
        ts.spans.push_back({t_min_, t_max_});
      }
    }
    auto t_cull = Clock::now();
    ts.cull_seconds += std::chrono::duration<double>(t_cull - t_start).count();
    ts.primary_rays += npix * opt_.spp;
    if (ts.spans.empty()) {
      ts.tiles_empty++;
      write_background(tx0, ty0, tx1, ty1);
      return;
    }
    // 2. Camera samples and their root search.
    make_samples(tx0, ty0, tx1, ty1, ts);
    if (use_interval_ && opt_.interval_march_first) {
      if (opt_.interval_pruned_march) {
        search_primary_pruned(ts);
      } else {
        search_primary_batched(ts);
      }
    } else if (use_analytic_) {
      prefetch_analytic(ts);
      for (Sample& s : ts.samples) search_primary(s, ts);
      field_.clear_prefetched_ray_candidates();
    } else if (!use_interval_) {
      search_primary_sign(ts);
    } else {
      for (Sample& s : ts.samples) search_primary(s, ts);
    }
    auto t_search = Clock::now();
    ts.search_seconds += std::chrono::duration<double>(t_search - t_cull).count();
    // 3. Normals, colours, shadows; accumulate into pixels.
    shade(ts);
    resolve(tx0, ty0, tx1, ty1, ts);
    ts.shade_seconds += seconds_since(t_search);
  }

 private:
  void cull_tile(int tx0, int ty0, int tx1, int ty1, ThreadState& ts) {
    const float tile_px = float(std::max(tx1 - tx0, ty1 - ty0));
    EvalCounters& c = ts.searcher.counters();
    TapeRegions& regions = *ts.regions;
    regions.clear();
    const bool prune = prune_ && regions.enabled();
    const bool split = use_interval_ && regions.enabled();
    bisect_depths(
        t_min_, t_max_, &ts.stack,
        [&](float a, float b, int node) {
          const Box slab = frame_.slab_box(float(tx0), float(ty0), float(tx1), float(ty1), a, b);
          const Box box = intersect(slab, opt_.bbox);
          if (box.empty()) return SlabTest{.empty = true};
          // Every ray of the tile is inside the solid by the end of an inside slab, unless the
          // box clipped it (a ray of the tile passing the slab outside the box meets the
          // solid's cap later).
          const bool unclipped = opt_.bbox.contains(slab);
          // A slab much deeper than wide (the tile's first pieces) decides few of the model's
          // choices, and the VM's one-box pass on a long tape costs ~20x the interval JIT's
          // call: such slabs keep the JIT, and their children prune from the root tape.
          if (!prune || (b - a) > kPruneDepth * tile_px * (footprint_a_ + footprint_b_ * b)) {
            return interval_slab_test(field_, box, unclipped, &c.interval_calls);
          }
          // The same test on the tape pruned for the parent slab, which is pruned again for
          // this one: the tile's searches evaluate the boxes inside it on that tape.
          return pruned_slab_test(regions, node, box, unclipped, &c.interval_calls);
        },
        // Split along depth while the slab is deeper than it is wide: past that, halving the
        // depth no longer shrinks the box much.
        [&](float b) { return tile_px * (footprint_a_ + footprint_b_ * b); },
        [&](float a, float b, const SlabTest& s) {
          // For the interval search of a model that can be pruned every piece stays a span of
          // its own, so that a camera ray's pieces and proofs lie inside one culling piece's
          // box and are evaluated on its tape. Merged, 157k of c1_gear's 1.41M interval boxes
          // (512x512) crossed a piece boundary and went to the whole program; unmerged, 35k of
          // 1.32M (and the frame ~10 % faster). Models too short to prune keep merged spans
          // (unmerged, s2_csg and s3_blend were ~10 % slower); --no-prune does not change the
          // choice, so it searches the same pieces and gives the same image.
          if (split) {
            ts.spans.push_back({a, b});
          } else {
            append_span(&ts.spans, a, b);
          }
          // F >= 0 from `a` on when this piece, so far the last, was proven inside.
          ts.inside_from = s.inside ? a : std::numeric_limits<float>::infinity();
        });
  }

  /// Culling pieces deeper than this many times their width are judged by the interval JIT
  /// without pruning (see cull_tile): on c1_gear at 512x512 (no shadows) 1000 (prune every
  /// piece) took culling 0.035 thread-s, 8 0.021, 4 0.020-0.022 (slab tapes of 32 instructions on
  /// average instead of 39), 2 and 1 about the same with shorter, fewer slab tapes.
  static constexpr float kPruneDepth = 4;

  void make_samples(int tx0, int ty0, int tx1, int ty1, ThreadState& ts) {
    const int spp = opt_.spp;
    const int nx = std::max(1, int(std::floor(std::sqrt(float(spp)))));
    const int ny = (spp + nx - 1) / nx;
    ts.samples.clear();
    int tw = tx1 - tx0;
    for (int y = ty0; y < ty1; ++y) {
      for (int x = tx0; x < tx1; ++x) {
        int pixel = (y - ty0) * tw + (x - tx0);
        for (int s = 0; s < spp; ++s) {
          float fx = 0.5f, fy = 0.5f;
          if (spp > 1) {
            uint64_t seed =
                ((uint64_t(y) * uint64_t(opt_.width) + uint64_t(x)) << 16) ^ uint64_t(s);
            uint64_t h = mix64(seed ^ 0x68667274ull);
            float jx = unit_float(h), jy = unit_float(mix64(h));
            fx = (float(s % nx) + jx) / float(nx);
            fy = (float(s / nx) + jy) / float(ny);
          }
          Sample smp;
          smp.ray = frame_.ray(float(x) + fx, float(y) + fy);
          smp.pixel = pixel;
          ts.samples.push_back(smp);
        }
      }
    }
  }

  /// The range [*te, *tx] of a camera ray inside the box and the axis of the face it enters
  /// by (-1: the eye is inside the box, where the range starts); false when it misses the box.
  bool box_range(const Ray& ray, float* te, float* tx, int* axis) const {
    if (!intersect_box(ray, opt_.bbox, te, tx, axis)) return false;
    if (!frame_.orthographic() && *te < 0) {
      *te = 0;
      *axis = -1;
    }
    return true;
  }

  /// The tile's camera rays' candidates traced together, in the order search_primary asks for
  /// them (a mesh leaf traces them in packets of neighbouring pixels): the segment of each is
  /// search_primary's.
  void prefetch_analytic(ThreadState& ts) {
    ts.pf_o.clear(), ts.pf_d.clear(), ts.pf_a.clear(), ts.pf_b.clear();
    for (const Sample& s : ts.samples) {
      float te, tx;
      int axis;
      if (!box_range(s.ray, &te, &tx, &axis)) continue;
      const float a = std::max(ts.spans.front().a, te), b = std::min(ts.spans.back().b, tx);
      if (!(a <= b)) continue;
      ts.pf_o.push_back(s.ray.o), ts.pf_d.push_back(s.ray.d);
      ts.pf_a.push_back(a), ts.pf_b.push_back(b);
    }
    field_.prefetch_ray_candidates(ts.pf_o.data(), ts.pf_d.data(), ts.pf_a.data(), ts.pf_b.data(),
                                   ts.pf_o.size());
  }

  /// The analytic search, or the interval search without the march first, of one camera
  /// sample (the sign-change search of a tile's samples is search_primary_sign).
  void search_primary(Sample& s, ThreadState& ts) {
    float te, tx;
    if (!box_range(s.ray, &te, &tx, &s.cap_axis)) return;
    if (use_analytic_) {
      // One search over all spans: the candidates are exact, and the gaps between spans (proven
      // outside) cannot hold a hit, so only the first span's start matters.
      float a = std::max(ts.spans.front().a, te), b = std::min(ts.spans.back().b, tx);
      if (!(a <= b)) return;
      // A span that starts inside the box starts where a culled slab ends: every point of
      // that slab's box, this ray's point at a included, has F < 0.
      const bool start_outside = a > te && a == ts.spans.front().a;
      // Likewise the last span may end in a piece proven inside (the walk stops after one
      // that hides the rest): the gap that reaches it is inside without a sample.
      const bool end_inside = ts.inside_from < b;
      RootHit h = ts.searcher.analytic_search(s.ray, a, b, start_outside, end_inside);
      h.at_start = h.at_start && a == te;
      if (h.hit) set_hit(s, h);
      return;
    }
    HFRT_CHECK(use_interval_);
    float dlen = length(s.ray.d);
    for (const Span& span : ts.spans) {
      float a = std::max(span.a, te), b = std::min(span.b, tx);
      if (!(a <= b)) continue;
      RootHit h = ts.searcher.interval_search(s.ray, a, b, eps_ / dlen, step_ / dlen, false);
      if (!h.hit) continue;
      h.at_start = h.at_start && a == te;
      set_hit(s, h);
      return;
    }
  }

  /// The sign-change search of the tile's camera samples: each sample's spans marched in
  /// order, the tile's samples together (RootSearcher::sign_search_batch), in rounds of the
  /// next span of every sample still without a hit.
  void search_primary_sign(ThreadState& ts) {
    const size_t n = ts.samples.size();
    ts.t_enter.resize(n);
    ts.t_exit.resize(n);
    ts.next_span.assign(n, 0);
    ts.searching.clear();
    for (size_t si = 0; si < n; ++si) {
      Sample& s = ts.samples[si];
      if (box_range(s.ray, &ts.t_enter[si], &ts.t_exit[si], &s.cap_axis)) {
        ts.searching.push_back(uint32_t(si));
      }
    }
    while (!ts.searching.empty()) {
      ts.to_march.clear();
      ts.march_requests.clear();
      size_t kept = 0;
      for (const uint32_t si : ts.searching) {
        const float te = ts.t_enter[si], tx = ts.t_exit[si];
        uint32_t& j = ts.next_span[si];
        while (j < ts.spans.size() &&
               !(std::max(ts.spans[j].a, te) <= std::min(ts.spans[j].b, tx))) {
          ++j;
        }
        if (j == ts.spans.size()) continue;
        const float a = std::max(ts.spans[j].a, te), b = std::min(ts.spans[j].b, tx);
        ++j;
        const Ray& ray = ts.samples[si].ray;
        const float dlen = length(ray.d);
        ts.to_march.push_back({si, a, b});
        ts.march_requests.push_back({ray, a, b, step_ / dlen, eps_ / dlen, false});
        ts.searching[kept++] = si;
      }
      ts.searching.resize(kept);
      const size_t m = ts.march_requests.size();
      ts.march_hits.resize(m);
      ts.searcher.sign_search_batch(m, ts.march_requests.data(), ts.march_hits.data());
      kept = 0;
      for (size_t i = 0; i < m; ++i) {
        const SamplePiece& p = ts.to_march[i];
        RootHit h = ts.march_hits[i];
        if (!h.hit) {
          ts.searching[kept++] = p.sample;
          continue;
        }
        h.at_start = h.at_start && p.a == ts.t_enter[p.sample];
        set_hit(ts.samples[p.sample], h);
      }
      ts.searching.resize(kept);
    }
  }

  /// The interval search of the tile's camera samples with the march pruned: each sample's
  /// depths are bisected front to back by intervals (one piece per sample per round, the
  /// tile's samples in one batch) down to kPrunedSpan march steps; a piece proven outside is
  /// dropped, the first piece that is not is marched, and the search stops at the first
  /// march hit. The proof then covers the marched pieces in front of the hit (and all of them
  /// for a miss) and, in the hit's piece, the pieces growing away from the root
  /// (RootSearcher::batch_run, as search_primary_batched). A ray beside a silhouette marches
  /// only the pieces near the surface instead of every depth of its tile's spans.
  void search_primary_pruned(ThreadState& ts) {
    const size_t n = ts.samples.size();
    if (ts.todo.size() < n) {
      ts.todo.resize(n);
      ts.unproven.resize(n);
    }
    ts.marched.assign(n, RootHit{});
    ts.hit_piece.assign(n, SamplePiece{0, 0, 0});
    std::vector<float>& te_of = ts.t_enter;
    te_of.assign(n, 0);
    RootSearcher& rs = ts.searcher;
    // Marches the pieces in ts.to_march, at most one per sample, together: the first hit ends
    // a sample's search (what lies behind it is not searched); a piece without one waits for
    // the proof.
    auto march_all = [&] {
      const size_t m = ts.to_march.size();
      if (m == 0) return;
      ts.march_requests.resize(m);
      ts.march_hits.resize(m);
      for (size_t i = 0; i < m; ++i) {
        const SamplePiece& p = ts.to_march[i];
        const Ray& ray = ts.samples[p.sample].ray;
        const float dlen = length(ray.d);
        ts.march_requests[i] = {ray, p.a, p.b, step_ / dlen, eps_ / dlen * 0.25f, false};
      }
      rs.sign_search_batch(m, ts.march_requests.data(), ts.march_hits.data());
      for (size_t i = 0; i < m; ++i) {
        const SamplePiece& p = ts.to_march[i];
        RootHit h = ts.march_hits[i];
        if (h.hit) {
          h.at_start = h.at_start && p.a == te_of[p.sample];
          ts.marched[p.sample] = h;
          ts.hit_piece[p.sample] = p;
          ts.todo[p.sample].clear();
        } else {
          ts.unproven[p.sample].push_back(p);
        }
      }
      ts.to_march.clear();
    };
    ts.short_rays.clear();
    for (size_t si = 0; si < n; ++si) {
      ts.todo[si].clear();
      ts.unproven[si].clear();
      Sample& s = ts.samples[si];
      float te, tx;
      if (!box_range(s.ray, &te, &tx, &s.cap_axis)) continue;
      te_of[si] = te;
      float total = 0;
      for (size_t j = ts.spans.size(); j-- > 0;) {
        const float a = std::max(ts.spans[j].a, te), b = std::min(ts.spans[j].b, tx);
        if (a <= b) {
          ts.todo[si].push_back({uint32_t(si), a, b});
          total += b - a;
        }
      }
      const float step = step_ / length(s.ray.d);
      // Depths that short are marched whole, front to back: halving them would cost more
      // interval evaluations than the march samples it could save.
      if (total <= 2 * RootSearcher::kPrunedSpan * step) ts.short_rays.push_back(uint32_t(si));
    }
    // The short rays' pieces, in rounds of one piece per ray (the next in depth of each).
    for (;;) {
      size_t kept = 0;
      for (const uint32_t si : ts.short_rays) {
        if (ts.todo[si].empty()) continue;
        ts.to_march.push_back(ts.todo[si].back());
        ts.todo[si].pop_back();
        ts.short_rays[kept++] = si;
      }
      ts.short_rays.resize(kept);
      if (kept == 0) break;
      march_all();
    }
    EvalCounters& c = rs.counters();
    for (;;) {
      ts.round.clear();
      for (size_t si = 0; si < n; ++si) {
        if (ts.todo[si].empty()) continue;
        ts.round.push_back(ts.todo[si].back());
        ts.todo[si].pop_back();
      }
      const size_t m = ts.round.size();
      if (m == 0) break;
      ts.round_boxes.resize(m);
      for (size_t i = 0; i < m; ++i) {
        const SamplePiece& p = ts.round[i];
        ts.round_boxes[i] = segment_box(ts.samples[p.sample].ray, p.a, p.b);
      }
      ts.round_ivs.resize(m);
      if (ts.round_nan_size < m) {
        ts.round_nan_size = std::max(m, 2 * ts.round_nan_size);
        ts.round_nan.reset(new bool[ts.round_nan_size]);
      }
      ts.regions->eval_intervals(m, ts.round_boxes.data(), ts.round_ivs.data(), ts.round_nan.get());
      c.interval_calls += m;
      for (size_t i = 0; i < m; ++i) {
        const SamplePiece p = ts.round[i];
        const Interval iv = ts.round_ivs[i];
        if (iv.hi < 0) continue;  // no point inside (NaN points count as outside)
        const float step = step_ / length(ts.samples[p.sample].ray.d);
        const bool inside = !std::isnan(iv.lo) && iv.lo >= 0 && !ts.round_nan[i];
        const float mid = p.a + (p.b - p.a) * 0.5f;
        if (!inside && p.b - p.a > RootSearcher::kPrunedSpan * step && mid > p.a && mid < p.b) {
          ts.todo[p.sample].push_back({p.sample, mid, p.b});
          ts.todo[p.sample].push_back({p.sample, p.a, mid});
          continue;
        }
        ts.to_march.push_back(p);
      }
      // (Each sample has at most one piece in a round, so marching them after the round's
      // verdicts is what marching each at its verdict would do.)
      march_all();
    }
    rs.batch_clear();
    ts.batch_index.assign(n, -1);
    for (size_t si = 0; si < n; ++si) {
      Sample& s = ts.samples[si];
      const RootHit& h = ts.marched[si];
      if (ts.unproven[si].empty() && (!h.hit || h.at_start || h.t == ts.hit_piece[si].a)) {
        if (h.hit) set_hit(s, h);  // nothing to prove
        continue;
      }
      RootSearcher::BatchRay br = camera_batch_ray(s.ray, te_of[si]);
      br.otherwise = h;
      const int ray = rs.batch_add_ray(br);
      for (const SamplePiece& p : ts.unproven[si]) rs.batch_add_piece(ray, p.a, p.b);
      if (h.hit && !h.at_start) {
        const float a = ts.hit_piece[si].a, b = h.t - RootSearcher::kVerifyGap * br.eps;
        if (b > a) {
          rs.batch_add_growing(ray, a, b, RootSearcher::kVerifyGap * br.eps,
                               RootSearcher::kVerifyGrowth, true);
        }
      }
      ts.batch_index[si] = ray;
    }
    run_camera_batch(ts);
  }

  /// A camera ray's entry in the searcher's batch: its tolerance and march step in units of
  /// its t, its range starting at `t_start` (the box entry: a hit there is a cap).
  RootSearcher::BatchRay camera_batch_ray(const Ray& ray, float t_start) const {
    const float dlen = length(ray.d);
    RootSearcher::BatchRay br;
    br.ray = ray;
    br.t_start = t_start;
    br.eps = eps_ / dlen;
    br.step = step_ / dlen;
    return br;
  }

  /// Runs the searcher's batch of the tile's camera rays (ts.batch_index: each sample's ray
  /// in it, -1 for none) and records their hits.
  void run_camera_batch(ThreadState& ts) {
    RootSearcher& rs = ts.searcher;
    rs.batch_run();
    for (size_t si = 0; si < ts.samples.size(); ++si) {
      if (ts.batch_index[si] < 0) continue;
      const RootHit& h = rs.batch_result(ts.batch_index[si]);
      if (h.hit) set_hit(ts.samples[si], h);
    }
  }

  /// The interval search of every camera sample of the tile, batched: each ray marches to its
  /// first sample inside (RootSearcher::interval_search does the same per ray), then the
  /// pieces that must be proven empty for all rays (the spans before the one the march hit
  /// in, and in that span the pieces growing away from the root) are bisected together by
  /// RootSearcher::batch_run, so that the interval evaluator gets boxes by the hundred.
  void search_primary_batched(ThreadState& ts) {
    RootSearcher& rs = ts.searcher;
    rs.batch_clear();
    ts.batch_index.assign(ts.samples.size(), -1);
    for (size_t si = 0; si < ts.samples.size(); ++si) {
      Sample& s = ts.samples[si];
      float te, tx;
      if (!box_range(s.ray, &te, &tx, &s.cap_axis)) continue;
      RootSearcher::BatchRay br = camera_batch_ray(s.ray, te);
      const float eps = br.eps, step = br.step;
      size_t hit_span = ts.spans.size();
      for (size_t j = 0; j < ts.spans.size(); ++j) {
        float a = std::max(ts.spans[j].a, te), b = std::min(ts.spans[j].b, tx);
        if (!(a <= b)) continue;
        RootHit m = rs.sign_search(s.ray, a, b, step, eps * 0.25f, false);
        if (m.hit) {
          m.at_start = m.at_start && a == te;
          br.otherwise = m;
          hit_span = j;
          break;
        }
      }
      // What lies in front of the march's hit (or everything, when it found none).
      bool any_piece = false;
      int ray = -1;
      for (size_t j = 0; j <= hit_span && j < ts.spans.size(); ++j) {
        float a = std::max(ts.spans[j].a, te), b = std::min(ts.spans[j].b, tx);
        if (!(a <= b)) continue;
        if (j == hit_span) {
          if (br.otherwise.at_start || br.otherwise.t == a) break;
          b = br.otherwise.t - RootSearcher::kVerifyGap * eps;
          if (!(b > a)) break;
        }
        if (ray < 0) ray = rs.batch_add_ray(br);
        if (j == hit_span) {
          rs.batch_add_growing(ray, a, b, RootSearcher::kVerifyGap * eps,
                               RootSearcher::kVerifyGrowth, true);
        } else {
          rs.batch_add_piece(ray, a, b);
        }
        any_piece = true;
      }
      if (!any_piece) {
        // Nothing to prove: the march's answer stands.
        if (br.otherwise.hit) set_hit(s, br.otherwise);
        continue;
      }
      ts.batch_index[si] = ray;
    }
    run_camera_batch(ts);
  }

  /// A sample's hit; at_start (the solid already at the box entry) makes it a cap.
  static void set_hit(Sample& s, const RootHit& h) {
    s.hit = true;
    s.t = h.t;
    s.cap = h.at_start && s.cap_axis >= 0;
  }

  /// The shadow rays of a tile towards a directional light are parallel: for t in [a, b] their
  /// points lie in the box of their origins moved by [a, b] along the light. Bisects [0, the
  /// box diagonal] like cull_tile and keeps in `spans` the ranges of t whose box may hold the
  /// surface, so that the per-ray searches skip what is empty for the whole tile (far from the
  /// surface the rays leave, most of the way to the light). Used with the sign-change search
  /// only (see shade()), so the pieces are judged on the whole program.
  void cull_shadow_bundle(const Box& origins, Vec3 l, std::vector<Span>* spans, ThreadState& ts) {
    spans->clear();
    const float width = std::max(origins.max_extent(), step_);
    const float t_end = length(opt_.bbox.size()) + origins.max_extent();
    EvalCounters& c = ts.searcher.counters();
    bisect_depths(
        0.0f, t_end, &ts.stack,
        [&](float a, float b) {
          Box box = origins;
          for (int i = 0; i < 3; ++i) {
            float u = a * l[i], v = b * l[i];
            // The ray points o + t l round: pad by a few ulps of the operands, as segment_box
            // does.
            float pad = 4e-7f * (std::max(std::abs(origins.lo[i]), std::abs(origins.hi[i])) +
                                 std::max(std::abs(u), std::abs(v))) +
                        1e-30f;
            box.lo[i] += std::min(u, v) - pad;
            box.hi[i] += std::max(u, v) + pad;
          }
          box = intersect(box, shadow_box_);
          if (box.empty()) return SlabTest{.empty = true};
          // Only emptiness is asked here: pieces are split down to the bundle's width, inside
          // or not.
          return SlabTest{.empty = interval_slab_test(field_, box, false, &c.interval_calls).empty};
        },
        [&](float) { return width; },
        [&](float a, float b, const SlabTest&) { append_span(spans, a, b); });
  }

  /// The unit direction from surface point p towards `light`.
  static Vec3 light_direction(const Light& light, Vec3 p) {
    return light.kind != Light::Kind::kDirectional ? normalize(light.v - p) : normalize(light.v);
  }

  /// The shadow ray from surface point p (normal n) towards `light`, and the range [*te, *tx]
  /// of it inside the box and before the light; false when there is none (nothing occludes).
  bool shadow_ray(Vec3 p, Vec3 n, const Light& light, Ray* ray, float* te, float* tx) const {
    Vec3 o = p + n * shadow_bias_;
    Vec3 l;
    float dist = std::numeric_limits<float>::infinity();
    if (light.kind != Light::Kind::kDirectional) {
      l = light.v - o;
      dist = length(l);
      l = l / dist;
    } else {
      l = normalize(light.v);
    }
    *ray = Ray{o, l};
    if (shadow_box_.empty() || !intersect_box(*ray, shadow_box_, te, tx, nullptr)) return false;
    *te = std::max(*te, 0.0f);
    *tx = std::min(*tx, dist);
    return *te <= *tx;
  }

  /// The analytic shadow rays of the tile's n hits (as occluded() will search them, in its
  /// order: hit by hit, light by light) traced together ahead.
  void prefetch_shadows(ThreadState& ts, size_t n) {
    ts.pf_o.clear(), ts.pf_d.clear(), ts.pf_a.clear(), ts.pf_b.clear();
    for (size_t k = 0; k < n; ++k) {
      const Vec3 p{ts.hx[k], ts.hy[k], ts.hz[k]}, nrm{ts.gx[k], ts.gy[k], ts.gz[k]};
      for (const Light& light : lights_) {
        if (dot(nrm, light_direction(light, p)) <= 0) continue;
        Ray r;
        float te, tx;
        if (!shadow_ray(p, nrm, light, &r, &te, &tx)) continue;
        ts.pf_o.push_back(r.o), ts.pf_d.push_back(r.d);
        ts.pf_a.push_back(te), ts.pf_b.push_back(tx);
      }
    }
    field_.prefetch_ray_candidates(ts.pf_o.data(), ts.pf_d.data(), ts.pf_a.data(), ts.pf_b.data(),
                                   ts.pf_o.size());
  }

  bool occluded(Vec3 p, Vec3 n, const Light& light, const std::vector<Span>* spans,
                ThreadState& ts) {
    Ray r;
    float te, tx;
    if (!shadow_ray(p, n, light, &r, &te, &tx)) return false;
    ts.shadow_rays++;
    if (spans && !use_analytic_) {
      for (const Span& span : *spans) {
        float a = std::max(span.a, te), b = std::min(span.b, tx);
        if (!(a <= b)) continue;
        RootHit h = use_interval_ ? ts.searcher.interval_search(r, a, b, eps_, step_, true)
                                  : ts.searcher.pruned_sign_search(r, a, b, step_, eps_, true);
        if (h.hit) return true;
      }
      return false;
    }
    RootHit h = use_analytic_   ? ts.searcher.analytic_search(r, te, tx)
                : use_interval_ ? ts.searcher.interval_search(r, te, tx, eps_, step_, true)
                : cull_         ? ts.searcher.pruned_sign_search(r, te, tx, step_, eps_, true)
                                : ts.searcher.sign_search(r, te, tx, step_, eps_, true);
    return h.hit;
  }

  void shade(ThreadState& ts) {
    ts.hit_index.clear();
    for (size_t i = 0; i < ts.samples.size(); ++i) {
      if (ts.samples[i].hit) ts.hit_index.push_back(int(i));
    }
    size_t n = ts.hit_index.size();
    ts.hits += n;
    if (n == 0) return;
    for (auto* v : {&ts.hx, &ts.hy, &ts.hz, &ts.f, &ts.gx, &ts.gy, &ts.gz}) v->resize(n);
    for (size_t k = 0; k < n; ++k) {
      const Sample& s = ts.samples[ts.hit_index[k]];
      Vec3 p = s.ray.o + s.ray.d * s.t;
      ts.hx[k] = p.x, ts.hy[k] = p.y, ts.hz[k] = p.z;
    }
    EvalCounters& c = ts.searcher.counters();
    field_.eval_gradient(n, ts.hx.data(), ts.hy.data(), ts.hz.data(), ts.f.data(), ts.gx.data(),
                         ts.gy.data(), ts.gz.data());
    c.gradient_calls++;
    c.gradient_points += n;
    if (attrs_) {
      int k = field_.num_attributes();
      ts.attrs.resize(size_t(k) * n);
      field_.eval_attributes(n, ts.hx.data(), ts.hy.data(), ts.hz.data(), ts.attrs.data());
      c.attribute_calls++;
      c.attribute_points += n;
    }
    // Bundle culling of the shadow rays towards each directional light, for the sign-change
    // search with culling (whose shadow rays are searched one at a time). Their origins
    // p + n bias lie within bias of the hit points. The interval search's batches do without:
    // their pieces growing away from the surface prove the way to the light in a few boxes per
    // ray, and with the shadow box the bundles cost more than they saved (512x512, --bbox 1.6,
    // min of 8 renders: c1_gear 88 -> 76 ms, c2_colonnade 85 -> 73 ms, s3_blend, s2_csg,
    // s4_gyroid, s5_twist within 1-2 ms; the sign-change search's s3_blend took 72 -> 94 ms
    // without them).
    const bool bundles = opt_.shadows && cull_ && !use_analytic_ && !use_interval_;
    if (bundles) {
      Box origins{{ts.hx[0], ts.hy[0], ts.hz[0]}, {ts.hx[0], ts.hy[0], ts.hz[0]}};
      for (size_t k = 1; k < n; ++k) {
        Vec3 p{ts.hx[k], ts.hy[k], ts.hz[k]};
        origins.lo = vmin(origins.lo, p);
        origins.hi = vmax(origins.hi, p);
      }
      const float grow = shadow_bias_ * 1.001f;
      for (int i = 0; i < 3; ++i) {
        origins.lo[i] -= grow + 4e-7f * std::abs(origins.lo[i]);
        origins.hi[i] += grow + 4e-7f * std::abs(origins.hi[i]);
      }
      ts.shadow_spans.resize(lights_.size());
      for (size_t li = 0; li < lights_.size(); ++li) {
        if (lights_[li].kind == Light::Kind::kDirectional) {
          cull_shadow_bundle(origins, normalize(lights_[li].v), &ts.shadow_spans[li], ts);
        }
      }
    }
    // Shading normals, in place of the gradients.
    for (size_t k = 0; k < n; ++k) {
      const Sample& s = ts.samples[ts.hit_index[k]];
      Vec3 view = -normalize(s.ray.d);
      Vec3 nrm;
      if (s.cap) {
        nrm = Vec3{};
        nrm[s.cap_axis] = s.ray.d[s.cap_axis] > 0 ? -1.0f : 1.0f;
      } else {
        // F grows into the solid: the outward normal is -grad F.
        nrm = -Vec3{ts.gx[k], ts.gy[k], ts.gz[k]};
        float l = length(nrm);
        nrm = (l > 0 && std::isfinite(l)) ? nrm / l : view;
      }
      if (dot(nrm, view) < 0) nrm = -nrm;  // seen from behind (noisy gradients): shade both sides
      ts.gx[k] = nrm.x, ts.gy[k] = nrm.y, ts.gz[k] = nrm.z;
    }
    // With the interval search, the shadow rays of the whole tile are searched in one batch.
    const size_t nl = lights_.size();
    const bool batched = opt_.shadows && use_interval_;
    if (batched) {
      RootSearcher& rs = ts.searcher;
      rs.batch_clear();
      ts.batch_index.assign(n * nl, -1);
      for (size_t k = 0; k < n; ++k) {
        Vec3 p{ts.hx[k], ts.hy[k], ts.hz[k]}, nrm{ts.gx[k], ts.gy[k], ts.gz[k]};
        for (size_t li = 0; li < nl; ++li) {
          const Light& light = lights_[li];
          Vec3 l = light_direction(light, p);
          if (dot(nrm, l) <= 0) continue;
          RootSearcher::BatchRay br;
          float te, tx;
          if (!shadow_ray(p, nrm, light, &br.ray, &te, &tx)) continue;
          ts.shadow_rays++;
          br.t_start = te;
          br.eps = eps_;
          br.step = step_;
          br.any_hit = true;
          int ray = rs.batch_add_ray(br);
          ts.batch_index[k * nl + li] = ray;
          // Pieces growing away from the surface (one march step, then by kShadowGrowth).
          rs.batch_add_growing(ray, te, tx, step_, RootSearcher::kShadowGrowth, false);
        }
      }
      rs.batch_run();
    }
    // With the analytic search, the shadow rays' candidates of the whole tile are traced
    // together first (packets of neighbouring hits' rays for mesh leaves).
    const bool prefetched = opt_.shadows && use_analytic_;
    if (prefetched) prefetch_shadows(ts, n);
    for (size_t k = 0; k < n; ++k) {
      Sample& s = ts.samples[ts.hit_index[k]];
      Vec3 p{ts.hx[k], ts.hy[k], ts.hz[k]};
      Vec3 view = -normalize(s.ray.d);
      Vec3 nrm{ts.gx[k], ts.gy[k], ts.gz[k]};
      Vec3 albedo = opt_.albedo;
      if (attrs_) {
        Vec3 a{ts.attrs[k], ts.attrs[n + k], ts.attrs[2 * n + k]};
        if (is_finite(a)) albedo = vmin(vmax(a, Vec3{0, 0, 0}), Vec3{1, 1, 1});
      }
      Vec3 color = albedo * kAmbient;
      for (size_t li = 0; li < lights_.size(); ++li) {
        const Light& light = lights_[li];
        const std::vector<Span>* spans =
            bundles && light.kind == Light::Kind::kDirectional ? &ts.shadow_spans[li] : nullptr;
        Vec3 l = light_direction(light, p);
        float ndotl = dot(nrm, l);
        if (ndotl <= 0) continue;
        if (batched) {
          int ray = ts.batch_index[k * nl + li];
          if (ray >= 0 && ts.searcher.batch_result(ray).hit) continue;
        } else if (opt_.shadows && occluded(p, nrm, light, spans, ts)) {
          continue;
        }
        Vec3 h = normalize(l + view);
        float spec = kSpecular * std::pow(std::max(0.0f, dot(nrm, h)), kShininess);
        Vec3 radiance = light.color * light.intensity;
        color += mul(albedo, radiance) * ndotl + radiance * spec;
      }
      float* acc = &ts.accum[size_t(s.pixel) * 8];
      acc[0] += color.x, acc[1] += color.y, acc[2] += color.z;
      acc[3] += 1;
      acc[4] += s.t * length(s.ray.d);
      acc[5] += nrm.x, acc[6] += nrm.y, acc[7] += nrm.z;
    }
    if (prefetched) field_.clear_prefetched_ray_candidates();
  }

  void resolve(int tx0, int ty0, int tx1, int ty1, ThreadState& ts) {
    const float inv_spp = 1.0f / float(opt_.spp);
    int tw = tx1 - tx0;
    for (int y = ty0; y < ty1; ++y) {
      for (int x = tx0; x < tx1; ++x) {
        const float* acc = &ts.accum[size_t((y - ty0) * tw + (x - tx0)) * 8];
        size_t i = size_t(y) * opt_.width + x;
        float hits = acc[3], misses = float(opt_.spp) - hits;
        for (int c = 0; c < 3; ++c) {
          image_->rgb[3 * i + c] = (acc[c] + misses * opt_.background[c]) * inv_spp;
        }
        image_->alpha[i] = hits * inv_spp;
        if (hits > 0) {
          image_->depth[i] = acc[4] / hits;
          Vec3 nrm = normalize(Vec3{acc[5], acc[6], acc[7]});
          image_->normal[3 * i] = nrm.x;
          image_->normal[3 * i + 1] = nrm.y;
          image_->normal[3 * i + 2] = nrm.z;
        }
      }
    }
  }

  void write_background(int tx0, int ty0, int tx1, int ty1) {
    for (int y = ty0; y < ty1; ++y) {
      for (int x = tx0; x < tx1; ++x) {
        size_t i = size_t(y) * opt_.width + x;
        for (int c = 0; c < 3; ++c) image_->rgb[3 * i + c] = opt_.background[c];
      }
    }
  }

  const Field& field_;
  const RenderOptions& opt_;
  CameraFrame frame_;
  Image* image_;
  std::vector<Light> lights_;
  float step_ = 0, eps_ = 0;
  bool use_interval_ = false, use_analytic_ = false, cull_ = false, attrs_ = false;
  /// Culling registers pruned tapes (RenderOptions::pruned_tapes, the interval search).
  bool prune_ = false;
  float t_min_ = 0, t_max_ = 0;
  float footprint_a_ = 0, footprint_b_ = 0;
  float shadow_bias_ = 0;
  /// Where shadow rays are searched: the render box, or with intervals the part of it outside
  /// which they prove F < 0 (proven_extent; empty: nowhere).
  Box shadow_box_;
  static constexpr int kShadowBoxDepth = 6;
  static constexpr size_t kShadowBoxCells = 4096;
};

}  // namespace

const char* root_mode_name(RootMode mode) {
  switch (mode) {
    case RootMode::kSign:
      return "sign";
    case RootMode::kInterval:
      return "interval";
    case RootMode::kAuto:
      return "auto";
    case RootMode::kAnalytic:
      return "analytic";
  }
  return "?";
}

bool parse_root_mode(std::string_view text, RootMode* mode) {
  for (RootMode m : {RootMode::kSign, RootMode::kInterval, RootMode::kAuto, RootMode::kAnalytic}) {
    if (text == root_mode_name(m)) {
      *mode = m;
      return true;
    }
  }
  return false;
}

float effective_step(const RenderOptions& options) {
  return options.step > 0 ? options.step : options.bbox.max_extent() / 512.0f;
}

float shadow_bias(const RenderOptions& options) {
  return 1e-3f * options.bbox.max_extent();
}

float effective_epsilon(const RenderOptions& options) {
  return options.epsilon > 0 ? options.epsilon : options.bbox.max_extent() * 1e-5f;
}

std::vector<Light> default_lights(const CameraFrame& frame) {
  Vec3 f = frame.forward(), r = frame.right(), u = frame.up();
  Light key{
      Light::Kind::kDirectional, normalize(-f * 0.8f + u * 0.9f - r * 0.6f), {0.85f, 0.85f, 0.82f}};
  Light fill{
      Light::Kind::kDirectional, normalize(-f * 0.6f - u * 0.2f + r * 1.0f), {0.25f, 0.27f, 0.3f}};
  return {key, fill};
}

RenderResult render(const Field& field, const RenderOptions& options) {
  RenderResult result;
  render_into(field, options, &result);
  return result;
}

void render_into(const Field& field, const RenderOptions& options, RenderResult* out) {
  HFRT_CHECK(options.width > 0 && options.height > 0);
  HFRT_CHECK(options.spp >= 1 && options.spp <= 65536);
  HFRT_CHECK(options.tile_size >= 1);
  HFRT_CHECK(!options.bbox.empty());
  HFRT_CHECK_MSG(options.root != RootMode::kInterval || field.has_interval(),
                 "--root interval needs an interval evaluator");
  HFRT_CHECK_MSG(options.root != RootMode::kAnalytic || field.has_ray_candidates(),
                 "--root analytic needs a field with ray candidates");
  auto start = Clock::now();
  RenderResult& result = *out;
  result.stats = RenderStats{};
  result.image.resize(options.width, options.height);
  TileRenderer tiles(field, options, &result.image);

  std::mutex nan_mutex;
  size_t nan_tile = std::numeric_limits<size_t>::max();
  Vec3 nan_point;

  // The cells' tapes are made on first use, shared by the threads: a tile's first slabs prune
  // from the tape of the smallest cell holding them instead of from the whole program.
  const Box cell_bounds = intersect(options.solid_extent, options.bbox);
  TapeCells cells(field, cell_bounds.empty() ? options.bbox : cell_bounds);
  par::ThreadLocal<ThreadState> states([&] { return ThreadState(field, &cells); });
  TileLoop loop = for_each_tile(options.width, options.height, options.tile_size, options.threads,
                                options.progress, options.cancel, [&](const Tile& t) {
                                  ThreadState& st = states.local();
                                  st.searcher.reset_nan_point();
                                  tiles.render_tile(t.x0, t.y0, t.x1, t.y1, st);
                                  if (st.searcher.has_nan_point()) {
                                    // Keep the first in tile order, so the report does not depend
                                    // on scheduling.
                                    std::lock_guard<std::mutex> lock(nan_mutex);
                                    if (t.index < nan_tile) {
                                      nan_tile = t.index;
                                      nan_point = st.searcher.nan_point();
                                    }
                                  }
                                });

  RenderStats& s = result.stats;
  s.root_used = tiles.root_used();
  s.tiles = loop.tiles;
  s.threads = loop.threads;
  s.cancelled = loop.cancelled;
  states.for_each([&](ThreadState& st) {
    s.evals += st.searcher.counters();
    s.primary_rays += st.primary_rays;
    s.shadow_rays += st.shadow_rays;
    s.hits += st.hits;
    s.tiles_empty += st.tiles_empty;
    s.cull_seconds += st.cull_seconds;
    s.search_seconds += st.search_seconds;
    s.shade_seconds += st.shade_seconds;
    s.pruned_regions += st.regions->regions_made();
    s.pruned_region_length += st.regions->region_length_sum();
    s.pruned_boxes += st.regions->pruned_boxes();
    s.full_boxes += st.regions->full_boxes();
  });
  s.pruned_cells = cells.cells_made();
  s.pruned_cell_length = cells.cell_length_sum();
  if (nan_tile != std::numeric_limits<size_t>::max()) {
    s.has_nan_point = true;
    s.nan_point = nan_point;
    s.nan_explanation = field.explain_nan(nan_point);
  }
  s.seconds = seconds_since(start);
}

}  // namespace hfrt::render
