#include "render/tracer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>

#include "base/check.h"
#include "base/parallel.h"
#include "render/depth_cull.h"
#include "render/sampling.h"
#include "render/texture.h"
#include "render/tiles.h"

namespace hfrt::render {

float fresnel_dielectric(float cos_i, float n1, float n2) {
  cos_i = std::clamp(cos_i, 0.0f, 1.0f);
  float eta = n1 / n2;
  float sin2_t = eta * eta * (1 - cos_i * cos_i);
  if (sin2_t >= 1) return 1;
  float cos_t = std::sqrt(1 - sin2_t);
  float rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
  float rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
  return 0.5f * (rs * rs + rp * rp);
}

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

/// -F: the solid's complement (F <= 0), for rays that start inside a solid and look for where
/// they leave it. Its intervals are the negated intervals and its ray candidates are F's.
class NegatedField final : public Field {
 public:
  explicit NegatedField(const Field& f) : f_(f) {}
  void eval(size_t n, const float* x, const float* y, const float* z, float* out) const override {
    f_.eval(n, x, y, z, out);
    for (size_t i = 0; i < n; ++i) out[i] = -out[i];
  }
  bool has_interval() const override { return f_.has_interval(); }
  Interval eval_interval(const Box& box, bool* maybe_nan) const override {
    Interval iv = f_.eval_interval(box, maybe_nan);
    return {-iv.hi, -iv.lo};
  }
  void eval_intervals(size_t n, const Box* boxes, Interval* out, bool* maybe_nan) const override {
    f_.eval_intervals(n, boxes, out, maybe_nan);
    for (size_t i = 0; i < n; ++i) out[i] = {-out[i].hi, -out[i].lo};
  }
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f, float* dx,
                     float* dy, float* dz) const override {
    f_.eval_gradient(n, x, y, z, f, dx, dy, dz);
    for (size_t i = 0; i < n; ++i) f[i] = -f[i], dx[i] = -dx[i], dy[i] = -dy[i], dz[i] = -dz[i];
  }
  bool has_ray_candidates() const override { return f_.has_ray_candidates(); }
  void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const override {
    f_.ray_candidates(o, d, t0, t1, out);
  }

 private:
  const Field& f_;
};

/// The root search an object gets: its own, or for kAuto analytic when the field lists ray
/// candidates, else interval when it has intervals, else sign.
RootMode resolved_root(const SceneObject& o) {
  if (o.root != RootMode::kAuto) return o.root;
  return o.field->has_ray_candidates()
             ? RootMode::kAnalytic
             : (o.field->has_interval() ? RootMode::kInterval : RootMode::kSign);
}

/// What the tracer knows of one object for the whole trace.
struct ObjectInfo {
  const SceneObject* object;
  std::unique_ptr<NegatedField> negated;
  const Material* material;
  RootMode mode;      // kSign, kInterval or kAnalytic
  float step, eps;    // object units
  float bias;         // world units: how far secondary rays start off the surface
  bool transmits;     // shadow rays pass through (attenuated)
  bool colour_attrs;  // the field computes s[1..3]
};

/// A ray of the wavefront, in world space with a unit direction.
struct PathRay {
  Vec3 o, d;
  Vec3 weight;           // what its radiance counts in its sample
  int sample;            // index into the batch's samples
  int pixel_sample = 0;  // which of the pixel's spp samples it serves (light strata share them)
  int depth;             // 0: camera ray
  int medium;            // the object whose solid it travels in, -1: none
  uint64_t seed;         // for glossy and light sampling
  /// Distance from the surface point it leaves to its origin (it starts a little off the
  /// surface, along its own direction): counted in the absorption of its medium.
  float pre = 0;
};

/// The origin of a ray leaving surface point p in direction d (nf: the normal on d's side):
/// `bias` away from the tangent plane, moved along d itself so that the ray stays on the exact
/// line of reflection or refraction; *pre gets the distance moved.
Vec3 leave_surface(Vec3 p, Vec3 d, Vec3 nf, float bias, float* pre) {
  *pre = bias / std::max(std::abs(dot(d, nf)), 0.05f);
  return p + d * *pre;
}

/// A ray's nearest hit.
struct Hit {
  int object = -1;
  float t = std::numeric_limits<float>::infinity();
  int cap_axis = -1;  // >= 0: the box face (object space) is the surface
  bool cap_exit = false;
  Vec3 p_object;  // hit point in object space
};

/// One search request against one object (object-space ray).
struct Query {
  Ray ray;
  float a = 0, b = 0;  // range to search
  float te = 0;        // where the ray enters the box (at_start at a == te is a cap)
  int enter_axis = -1, exit_axis = -1;
  float box_exit = 0;
  int ray_index = 0;
};

/// The range of a ray in a box with the axes of the faces it enters and leaves by.
bool box_span(const Ray& ray, const Box& box, float* te, float* tx, int* enter, int* exit_axis) {
  float t0 = -std::numeric_limits<float>::infinity(), t1 = std::numeric_limits<float>::infinity();
  int a0 = -1, a1 = -1;
  for (int i = 0; i < 3; ++i) {
    float o = ray.o[i], d = ray.d[i];
    if (d == 0) {
      if (o < box.lo[i] || o > box.hi[i]) return false;
      continue;
    }
    float inv = 1.0f / d;
    float a = (box.lo[i] - o) * inv, b = (box.hi[i] - o) * inv;
    if (a > b) std::swap(a, b);
    if (a > t0) t0 = a, a0 = i;
    if (b < t1) t1 = b, a1 = i;
  }
  if (!(t0 <= t1)) return false;
  *te = t0, *tx = t1, *enter = a0, *exit_axis = a1;
  return true;
}

struct ThreadState {
  std::vector<std::unique_ptr<RootSearcher>> searchers, negated;
  std::vector<Query> queries;
  std::vector<RootHit> found;
  std::vector<int> batch_index;
  std::vector<float> px, py, pz, f, gx, gy, gz, attrs;
  std::vector<DepthPiece> depth_stack;  // scratch of bisect_depths
  double search_seconds = 0, shade_seconds = 0;
  uint64_t camera_rays = 0, secondary_rays = 0, shadow_rays = 0, hits = 0, refined = 0;
};

class SceneTracer {
 public:
  SceneTracer(const std::vector<SceneObject>& objects, const std::vector<Material>& materials,
              const TraceOptions& options, Image* image)
      : opt_(options), frame_(options.camera, options.width, options.height), image_(image) {
    for (const SceneObject& o : objects) {
      HFRT_CHECK(o.field != nullptr);
      HFRT_CHECK(!o.bbox.empty());
      HFRT_CHECK(o.material >= 0 && size_t(o.material) < materials.size());
      ObjectInfo info;
      info.object = &o;
      info.negated = std::make_unique<NegatedField>(*o.field);
      info.material = &materials[size_t(o.material)];
      const RootMode m = resolved_root(o);
      HFRT_CHECK(m != RootMode::kInterval || o.field->has_interval());
      HFRT_CHECK(m != RootMode::kAnalytic || o.field->has_ray_candidates());
      info.mode = m;
      float ext = o.bbox.max_extent();
      info.step = o.step > 0 ? o.step : ext / 512.0f;
      info.eps = o.epsilon > 0 ? o.epsilon : ext * 1e-5f;
      info.bias = 1e-3f * ext * o.transform.scale();
      info.transmits = info.material->transmit > 0;
      info.colour_attrs = o.field->num_attributes() >= 3;
      objects_.push_back(std::move(info));
    }
    lights_ = options.lights.empty() ? default_lights(frame_) : options.lights;
    Vec3 view = options.camera.look_at - options.camera.eye;
    focus_ = options.focus_distance > 0 ? options.focus_distance : length(view);
    Ray r0 = frame_.ray(0, 0), r1 = frame_.ray(1, 0);
    if (frame_.orthographic()) {
      footprint_a_ = length(r1.o - r0.o);
    } else {
      footprint_b_ = length(r1.d - r0.d);
    }
  }

  ThreadState make_state() const {
    ThreadState ts;
    for (const ObjectInfo& o : objects_) {
      ts.searchers.push_back(std::make_unique<RootSearcher>(*o.object->field));
      ts.negated.push_back(std::make_unique<RootSearcher>(*o.negated));
    }
    return ts;
  }

  void trace_tile(int tx0, int ty0, int tx1, int ty1, ThreadState& ts) {
    const int tw = tx1 - tx0, th = ty1 - ty0;
    const size_t npix = size_t(tw) * th;
    pix_.assign(npix, PixelAccum{});
    cull_tile(tx0, ty0, tx1, ty1, ts);
    const bool subset = opt_.sample_count > 0;
    const int begin = subset ? opt_.sample_begin : 0;
    const int first = subset          ? begin + opt_.sample_count
                      : opt_.adaptive ? std::min(opt_.spp, TraceOptions::kAdaptiveFirst)
                                      : opt_.spp;
    std::vector<std::pair<int, int>> list;  // (pixel, sample index)
    list.reserve(npix * size_t(first - begin));
    for (size_t p = 0; p < npix; ++p)
      for (int s = begin; s < first; ++s) list.push_back({int(p), s});
    trace_samples(list, tx0, ty0, tw, ts);
    if (!subset && first < opt_.spp) {
      list.clear();
      for (size_t p = 0; p < npix; ++p) {
        const PixelAccum& a = pix_[p];
        float spread = std::max({a.hi.x - a.lo.x, a.hi.y - a.lo.y, a.hi.z - a.lo.z});
        if (spread <= opt_.adaptive_threshold) continue;
        ts.refined++;
        for (int s = first; s < opt_.spp; ++s) list.push_back({int(p), s});
      }
      if (!list.empty()) trace_samples(list, tx0, ty0, tw, ts);
    }
    for (int y = ty0; y < ty1; ++y) {
      for (int x = tx0; x < tx1; ++x) {
        const PixelAccum& a = pix_[size_t((y - ty0) * tw + (x - tx0))];
        size_t i = size_t(y) * opt_.width + x;
        float inv = 1.0f / float(a.samples);
        image_->rgb[3 * i] = a.rgb.x * inv;
        image_->rgb[3 * i + 1] = a.rgb.y * inv;
        image_->rgb[3 * i + 2] = a.rgb.z * inv;
        image_->alpha[i] = a.hits * inv;
        if (a.hits > 0) {
          image_->depth[i] = a.depth / a.hits;
          Vec3 n = normalize(a.normal);
          image_->normal[3 * i] = n.x;
          image_->normal[3 * i + 1] = n.y;
          image_->normal[3 * i + 2] = n.z;
        }
      }
    }
  }

 private:
  struct PixelAccum {
    Vec3 rgb{0, 0, 0};
    Vec3 lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
            std::numeric_limits<float>::infinity()};
    Vec3 hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
            -std::numeric_limits<float>::infinity()};
    int samples = 0;
    float hits = 0, depth = 0;
    Vec3 normal{0, 0, 0};
  };

  /// The stratum of sample s of spp: a fixed permutation, so that the first samples of an
  /// adaptive pixel are spread over the pixel rather than filling its first rows.
  static int stratum(int s, int spp) {
    if (spp <= 2) return s;
    int k = std::max(1, int(float(spp) * 0.618034f));
    while (std::gcd(k, spp) != 1) ++k;
    return int((int64_t(s) * k) % spp);
  }

  PathRay camera_ray(int x, int y, int s, int sample_index) const {
    const int spp = opt_.spp;
    const int nx = std::max(1, int(std::floor(std::sqrt(float(spp)))));
    const int ny = (spp + nx - 1) / nx;
    float fx = 0.5f, fy = 0.5f;
    uint64_t seed = ((uint64_t(y) * uint64_t(opt_.width) + uint64_t(x)) << 16) ^ uint64_t(s);
    uint64_t h = mix64(seed ^ 0x68667274ull);
    if (spp > 1) {
      int st = stratum(s, spp);
      float jx = unit_float(h), jy = unit_float(mix64(h));
      fx = (float(st % nx) + jx) / float(nx);
      fy = (float(st / nx) + jy) / float(ny);
    }
    Ray r = frame_.ray(float(x) + fx, float(y) + fy);
    PathRay pr;
    pr.o = r.o;
    if (opt_.aperture > 0) {
      // Thin lens: the point of the pinhole ray at depth focus_ stays sharp; the origin moves
      // over the lens disk (stratified like the pixel, decorrelated from it).
      Vec3 focus = r.o + r.d * focus_;  // r.d has unit depth along the view (camera.h)
      uint64_t hl = mix64(h ^ 0x6c656e73ull);
      float lu = unit_float(hl), lv = unit_float(mix64(hl));
      if (spp > 1) {
        int st = stratum((s * 7 + 3) % spp, spp);
        lu = (float(st % nx) + lu) / float(nx);
        lv = (float(st / nx) + lv) / float(ny);
      }
      float dx, dy;
      concentric_disk(lu, lv, &dx, &dy);
      pr.o = r.o + (frame_.right() * dx + frame_.up() * dy) * opt_.aperture;
      pr.d = normalize(focus - pr.o);
    } else {
      pr.d = normalize(r.d);
    }
    pr.weight = {1, 1, 1};
    pr.sample = sample_index;
    pr.depth = 0;
    pr.medium = -1;
    pr.seed = mix64(h ^ 0x74726163ull);
    pr.pixel_sample = s;
    return pr;
  }

  /// Searches object k for the rays of ts.queries (negated: for where they leave its solid);
  /// answers into ts.found, one per query.
  void search(size_t k, bool negated, bool any_hit, ThreadState& ts) {
    const ObjectInfo& obj = objects_[k];
    RootSearcher& rs = negated ? *ts.negated[k] : *ts.searchers[k];
    const float s = obj.object->transform.scale();
    const float eps = obj.eps * s, step = obj.step * s;  // in units of t (|d_object| = 1 / s)
    ts.found.assign(ts.queries.size(), RootHit{});
    switch (obj.mode) {
      case RootMode::kAnalytic:
        for (size_t i = 0; i < ts.queries.size(); ++i) {
          const Query& q = ts.queries[i];
          ts.found[i] = rs.analytic_search(q.ray, q.a, q.b);
        }
        return;
      case RootMode::kSign:
      case RootMode::kAuto:
        for (size_t i = 0; i < ts.queries.size(); ++i) {
          const Query& q = ts.queries[i];
          ts.found[i] = obj.object->field->has_interval()
                            ? rs.pruned_sign_search(q.ray, q.a, q.b, step, eps, any_hit)
                            : rs.sign_search(q.ray, q.a, q.b, step, eps, any_hit);
        }
        return;
      case RootMode::kInterval:
        break;
    }
    // The batched interval search, as the renderer's camera rays: march to the first sample
    // inside, then prove what lies before it in one batch; shadow rays bisect pieces growing
    // away from their origin.
    rs.batch_clear();
    ts.batch_index.assign(ts.queries.size(), -1);
    for (size_t i = 0; i < ts.queries.size(); ++i) {
      const Query& q = ts.queries[i];
      RootSearcher::BatchRay br;
      br.ray = q.ray;
      br.t_start = q.a;
      br.eps = eps;
      br.step = step;
      br.any_hit = any_hit;
      if (any_hit) {
        int ray = rs.batch_add_ray(br);
        rs.batch_add_growing(ray, q.a, q.b, step, RootSearcher::kShadowGrowth, false);
        ts.batch_index[i] = ray;
        continue;
      }
      RootHit m = rs.sign_search(q.ray, q.a, q.b, step, eps * 0.25f, false);
      float b = q.b;
      if (m.hit) {
        br.otherwise = m;
        if (m.at_start || m.t == q.a) {
          ts.found[i] = m;
          continue;
        }
        b = m.t - RootSearcher::kVerifyGap * eps;
        if (!(b > q.a)) {
          ts.found[i] = m;
          continue;
        }
      }
      int ray = rs.batch_add_ray(br);
      if (m.hit) {
        rs.batch_add_growing(ray, q.a, b, RootSearcher::kVerifyGap * eps,
                             RootSearcher::kVerifyGrowth, true);
      } else {
        rs.batch_add_piece(ray, q.a, b);
      }
      ts.batch_index[i] = ray;
    }
    rs.batch_run();
    for (size_t i = 0; i < ts.queries.size(); ++i) {
      if (ts.batch_index[i] >= 0) ts.found[i] = rs.batch_result(ts.batch_index[i]);
    }
  }

  /// t along a unit camera ray per unit of camera depth (render/camera.h: depth is measured
  /// along the view direction from the eye, or from the eye plane for orthographic cameras).
  float camera_depth_to_t(Vec3 d) const {
    return frame_.orthographic() ? 1.0f : 1.0f / std::max(dot(d, frame_.forward()), 1e-6f);
  }

  /// Per object, the range of camera depths [first, second] where the tile's rays may meet its
  /// solid (first > second: none), by interval bisection of the tile's frustum as the first-hit
  /// renderer culls (renderer.cpp, cull_tile), each slab's world box taken into object space.
  /// Pinhole cameras only: a lens moves the rays' origins (culled_ is false; ranges are all).
  void cull_tile(int tx0, int ty0, int tx1, int ty1, ThreadState& ts) {
    tile_span_.assign(objects_.size(), {0.0f, std::numeric_limits<float>::infinity()});
    culled_ = opt_.aperture <= 0;
    if (!culled_) return;
    const float tile_px = float(std::max(tx1 - tx0, ty1 - ty0));
    for (size_t k = 0; k < objects_.size(); ++k) {
      const SceneObject& obj = *objects_[k].object;
      const Field& field = *obj.field;
      const Box world = obj.transform.box_to_world(obj.bbox);
      float t_min, t_max;
      frame_.depth_range(world, &t_min, &t_max);
      float lo = std::numeric_limits<float>::infinity(), hi = -lo;
      if (!field.has_interval()) {
        if (t_min <= t_max) lo = t_min, hi = t_max;
        tile_span_[k] = {lo, hi};
        continue;
      }
      if (t_min <= t_max) {
        EvalCounters& c = ts.searchers[k]->counters();
        bisect_depths(
            t_min, t_max, &ts.depth_stack,
            [&](float a, float b) {
              const Box slab =
                  frame_.slab_box(float(tx0), float(ty0), float(tx1), float(ty1), a, b);
              const Box wb = intersect(slab, world);
              if (wb.empty()) return SlabTest{.empty = true};
              Box ob;
              for (int corner = 0; corner < 8; ++corner) {
                ob.extend(obj.transform.point_to_object({(corner & 1) ? wb.hi.x : wb.lo.x,
                                                         (corner & 2) ? wb.hi.y : wb.lo.y,
                                                         (corner & 4) ? wb.hi.z : wb.lo.z}));
              }
              // Rounding of the transform: pad by a few ulps of the box.
              const float pad = 1e-6f * obj.bbox.max_extent();
              const Box padded{ob.lo - Vec3{pad, pad, pad}, ob.hi + Vec3{pad, pad, pad}};
              ob = intersect(padded, obj.bbox);
              if (ob.empty()) return SlabTest{.empty = true};
              // Every ray of the tile is inside by the end of an inside slab, unless a box
              // clipped it (a ray passing the slab outside the box meets the object's cap
              // later).
              return interval_slab_test(
                  field, ob, world.contains(slab) && obj.bbox.contains(padded), &c.interval_calls);
            },
            [&](float b) { return tile_px * (footprint_a_ + footprint_b_ * b); },
            [&](float a, float b, const SlabTest&) {
              lo = std::min(lo, a);
              hi = std::max(hi, b);
            });
      }
      tile_span_[k] = {lo, hi};
    }
  }

  /// Object-space query of a world ray against object k over world parameters [0, t_max];
  /// false when the ray misses the box there.
  bool make_query(size_t k, Vec3 o, Vec3 d, float t_max, Query* q) const {
    const SceneObject& obj = *objects_[k].object;
    q->ray = Ray{obj.transform.point_to_object(o), obj.transform.direction_to_object(d)};
    float te, tx;
    if (!box_span(q->ray, obj.bbox, &te, &tx, &q->enter_axis, &q->exit_axis)) return false;
    q->te = te;
    q->box_exit = tx;
    q->a = std::max(te, 0.0f);
    q->b = std::min(tx, t_max);
    return q->a <= q->b;
  }

  /// The nearest hit of every ray.
  void find_hits(const std::vector<PathRay>& rays, bool camera, std::vector<Hit>* hits,
                 ThreadState& ts) {
    hits->assign(rays.size(), Hit{});
    for (size_t k = 0; k < objects_.size(); ++k) {
      // Camera rays of a tile that culling proved empty of this object skip it.
      if (camera && tile_span_[k].first > tile_span_[k].second) continue;
      for (int pass = 0; pass < 2; ++pass) {
        const bool inside = pass == 1;  // rays travelling in this object's solid
        ts.queries.clear();
        for (size_t i = 0; i < rays.size(); ++i) {
          if ((rays[i].medium == int(k)) != inside) continue;
          Query q;
          if (!make_query(k, rays[i].o, rays[i].d, (*hits)[i].t, &q)) continue;
          if (camera && culled_) {
            // The tile's span of camera depths, as distances along this ray.
            const float to_t = camera_depth_to_t(rays[i].d);
            const float a = tile_span_[k].first * to_t, b = tile_span_[k].second * to_t;
            if (a > q.a) q.a = a;  // not at the box entry any more: no cap at q.a
            q.b = std::min(q.b, b);
            if (!(q.a <= q.b)) continue;
          }
          q.ray_index = int(i);
          ts.queries.push_back(q);
        }
        if (ts.queries.empty()) continue;
        search(k, inside, false, ts);
        for (size_t j = 0; j < ts.queries.size(); ++j) {
          const Query& q = ts.queries[j];
          const RootHit& h = ts.found[j];
          Hit& best = (*hits)[size_t(q.ray_index)];
          Hit cand;
          cand.object = int(k);
          if (h.hit) {
            cand.t = h.t;
            if (!inside && h.at_start && q.a == q.te) cand.cap_axis = q.enter_axis;
          } else if (inside && q.box_exit <= q.b) {
            // Inside the solid up to the box: it leaves through the cap.
            cand.t = q.box_exit;
            cand.cap_axis = q.exit_axis;
            cand.cap_exit = true;
          } else {
            continue;
          }
          if (!(cand.t < best.t)) continue;
          cand.p_object = q.ray.o + q.ray.d * cand.t;
          best = cand;
        }
      }
    }
  }

  /// The fraction of light (per channel) that reaches along each shadow ray: 0 behind an opaque
  /// object, attenuated by colour, transmit weight and Beer-Lambert absorption through
  /// transmitting ones.
  void shadow_transmittance(const std::vector<Ray>& rays, const std::vector<float>& dist,
                            std::vector<Vec3>* trans, ThreadState& ts) {
    trans->assign(rays.size(), Vec3{1, 1, 1});
    ts.shadow_rays += rays.size();
    // Opaque objects first, all shadow rays of the batch together (any hit).
    for (size_t k = 0; k < objects_.size(); ++k) {
      if (objects_[k].transmits) continue;
      ts.queries.clear();
      for (size_t i = 0; i < rays.size(); ++i) {
        if ((*trans)[i].x == 0 && (*trans)[i].y == 0 && (*trans)[i].z == 0) continue;
        Query q;
        if (!make_query(k, rays[i].o, rays[i].d, dist[i], &q)) continue;
        q.ray_index = int(i);
        ts.queries.push_back(q);
      }
      if (ts.queries.empty()) continue;
      search(k, false, true, ts);
      for (size_t j = 0; j < ts.queries.size(); ++j) {
        if (ts.found[j].hit) (*trans)[size_t(ts.queries[j].ray_index)] = Vec3{0, 0, 0};
      }
    }
    // Transmitting objects: every crossing of the solid (entry, then exit by -F), a few per ray.
    for (size_t k = 0; k < objects_.size(); ++k) {
      const ObjectInfo& obj = objects_[k];
      if (!obj.transmits) continue;
      const Material& m = *obj.material;
      for (size_t i = 0; i < rays.size(); ++i) {
        Vec3& tr = (*trans)[i];
        float t = 0;
        for (int crossing = 0; crossing < 8; ++crossing) {
          if (tr.x == 0 && tr.y == 0 && tr.z == 0) break;
          Query q;
          if (!make_query(k, rays[i].o + rays[i].d * t, rays[i].d, dist[i] - t, &q)) break;
          ts.queries.assign(1, q);
          search(k, false, false, ts);
          if (!ts.found[0].hit) break;
          float t_in = ts.found[0].t;
          Query qo;
          const float gap = obj.bias;
          if (!make_query(k, rays[i].o + rays[i].d * (t + t_in + gap), rays[i].d,
                          std::numeric_limits<float>::infinity(), &qo)) {
            break;
          }
          ts.queries.assign(1, qo);
          search(k, true, false, ts);
          float t_out = ts.found[0].hit ? ts.found[0].t : qo.box_exit;
          float chord = gap + t_out;
          tr = mul(tr, m.color) * m.transmit;
          for (int c = 0; c < 3; ++c) tr[c] *= std::exp(-m.absorb[c] * chord);
          t += t_in + chord + gap;
          if (t >= dist[i]) break;
        }
      }
    }
  }

  /// A direction near `ideal` for a glossy surface of `roughness` (0: `ideal` itself), on the
  /// side of the surface that `side` points to.
  static Vec3 glossy(Vec3 ideal, float roughness, Vec3 side, uint64_t seed) {
    if (roughness <= 0) return ideal;
    for (int attempt = 0; attempt < 4; ++attempt) {
      uint64_t h = mix64(seed + uint64_t(attempt) * 0x9e37ull);
      float u = unit_float(h), v = unit_float(mix64(h)), w = unit_float(mix64(h ^ 0x55ull));
      // A uniform point of the unit ball.
      float z = 2 * u - 1, phi = 2 * float(M_PI) * v, r = std::cbrt(w);
      float s = std::sqrt(std::max(0.0f, 1 - z * z));
      Vec3 jitter{r * s * std::cos(phi), r * s * std::sin(phi), r * z};
      Vec3 d = normalize(ideal + jitter * roughness);
      if (dot(d, side) > 0) return d;
    }
    return ideal;
  }

  void trace_samples(const std::vector<std::pair<int, int>>& list, int tx0, int ty0, int tw,
                     ThreadState& ts) {
    std::vector<Vec3> radiance(list.size(), Vec3{0, 0, 0});
    std::vector<PathRay> cur, next;
    cur.reserve(list.size());
    for (size_t i = 0; i < list.size(); ++i) {
      int p = list[i].first;
      cur.push_back(camera_ray(tx0 + p % tw, ty0 + p / tw, list[i].second, int(i)));
    }
    ts.camera_rays += cur.size();
    std::vector<Hit> hits;
    std::vector<Vec3> normal, colour;
    std::vector<Ray> shadow;
    std::vector<float> shadow_dist;
    std::vector<Vec3> shadow_trans;
    struct ShadowUse {
      int hit;
      Vec3 contribution;  // the light's unshadowed contribution through this shadow ray
    };
    std::vector<ShadowUse> uses;
    for (int depth = 0; !cur.empty(); ++depth) {
      auto t0 = Clock::now();
      find_hits(cur, depth == 0, &hits, ts);
      auto t1 = Clock::now();
      double shadow_s = 0;
      ts.search_seconds += std::chrono::duration<double>(t1 - t0).count();
      // Normals (world, outward) and colours of the hits, one batch per object.
      normal.assign(cur.size(), Vec3{0, 0, 0});
      colour.assign(cur.size(), Vec3{0, 0, 0});
      for (size_t k = 0; k < objects_.size(); ++k) {
        const ObjectInfo& obj = objects_[k];
        std::vector<int> idx;
        for (size_t i = 0; i < cur.size(); ++i)
          if (hits[i].object == int(k)) idx.push_back(int(i));
        if (idx.empty()) continue;
        size_t n = idx.size();
        for (auto* v : {&ts.px, &ts.py, &ts.pz, &ts.f, &ts.gx, &ts.gy, &ts.gz}) v->resize(n);
        for (size_t j = 0; j < n; ++j) {
          Vec3 p = hits[size_t(idx[j])].p_object;
          ts.px[j] = p.x, ts.py[j] = p.y, ts.pz[j] = p.z;
        }
        obj.object->field->eval_gradient(n, ts.px.data(), ts.py.data(), ts.pz.data(), ts.f.data(),
                                         ts.gx.data(), ts.gy.data(), ts.gz.data());
        EvalCounters& c = ts.searchers[k]->counters();
        c.gradient_calls++;
        c.gradient_points += n;
        if (obj.colour_attrs) {
          c.attribute_calls++;
          c.attribute_points += n;
          int na = obj.object->field->num_attributes();
          ts.attrs.resize(size_t(na) * n);
          obj.object->field->eval_attributes(n, ts.px.data(), ts.py.data(), ts.pz.data(),
                                             ts.attrs.data());
        }
        for (size_t j = 0; j < n; ++j) {
          const size_t i = size_t(idx[j]);
          const Hit& h = hits[i];
          Vec3 d_obj = obj.object->transform.direction_to_object(cur[i].d);
          Vec3 nrm;
          if (h.cap_axis >= 0) {
            nrm = Vec3{0, 0, 0};
            bool positive = h.cap_exit ? d_obj[h.cap_axis] > 0 : d_obj[h.cap_axis] < 0;
            nrm[h.cap_axis] = positive ? 1.0f : -1.0f;
          } else {
            nrm = -Vec3{ts.gx[j], ts.gy[j], ts.gz[j]};
            float l = length(nrm);
            nrm = (l > 0 && std::isfinite(l)) ? nrm / l : -normalize(d_obj);
          }
          normal[i] = normalize(obj.object->transform.normal_to_world(nrm));
          Vec3 c = obj.material->color;
          if (obj.material->texture_image) {
            c = texture_colour(*obj.material->texture_image, obj.material->mapping, h.p_object,
                               nrm);
          }
          if (obj.colour_attrs) {
            Vec3 a{ts.attrs[j], ts.attrs[n + j], ts.attrs[2 * n + j]};
            if (is_finite(a)) c = vmin(vmax(a, Vec3{0, 0, 0}), Vec3{1, 1, 1});
          }
          colour[i] = c;
        }
      }
      // Misses see the background; hits lose what their medium absorbed on the way.
      for (size_t i = 0; i < cur.size(); ++i) {
        PathRay& r = cur[i];
        if (hits[i].object < 0) {
          radiance[size_t(r.sample)] += mul(r.weight, opt_.background);
          continue;
        }
        ts.hits++;
        if (r.medium >= 0) {
          const Vec3& a = objects_[size_t(r.medium)].material->absorb;
          for (int c = 0; c < 3; ++c) r.weight[c] *= std::exp(-a[c] * (hits[i].t + r.pre));
        }
        if (depth == 0) {
          PixelAccum& acc = pix_[size_t(list[size_t(r.sample)].first)];
          Vec3 nf = dot(normal[i], r.d) > 0 ? -normal[i] : normal[i];
          acc.hits += 1;
          acc.depth += hits[i].t;
          acc.normal += nf;
        }
      }
      // Local lighting at hits from outside a solid: ambient, and per light its shadow rays.
      shadow.clear();
      shadow_dist.clear();
      uses.clear();
      for (size_t i = 0; i < cur.size(); ++i) {
        const Hit& h = hits[i];
        if (h.object < 0) continue;
        const PathRay& r = cur[i];
        if (r.medium == h.object) continue;  // leaving a solid: lights are outside
        const ObjectInfo& obj = objects_[size_t(h.object)];
        const Material& m = *obj.material;
        Vec3 nf = dot(normal[i], r.d) > 0 ? -normal[i] : normal[i];
        Vec3 p = r.o + r.d * h.t;
        radiance[size_t(r.sample)] += mul(r.weight, colour[i] * m.ambient);
        if (m.diffuse <= 0 && m.specular <= 0) continue;
        Vec3 view = -r.d;
        for (size_t li = 0; li < lights_.size(); ++li) {
          const Light& light = lights_[li];
          Vec3 radiance_l = light.color * light.intensity;
          // A sphere light's `samples` strata are shared by the pixel's spp samples: each
          // camera sample takes ceil(samples / spp) of them (its own, interleaved), so that a
          // pixel gets `samples` shadow rays per light in all, however many samples it has.
          const int strata = light.kind == Light::Kind::kSphere ? std::max(1, light.samples) : 1;
          const int ns = light.kind == Light::Kind::kSphere
                             ? std::max(1, (strata + opt_.spp - 1) / opt_.spp)
                             : 1;
          Vec3 to_c = light.kind == Light::Kind::kDirectional ? normalize(light.v) : light.v - p;
          Vec3 w = normalize(to_c);
          Vec3 u =
              normalize(std::abs(w.x) > 0.5f ? cross(w, Vec3{0, 1, 0}) : cross(w, Vec3{1, 0, 0}));
          Vec3 v = cross(w, u);
          // nx * ny <= strata cells; strata past them (when strata is not a product) are
          // sampled without stratification, so that no part of the disk is favoured.
          const int nx = std::max(1, int(std::floor(std::sqrt(float(strata)))));
          const int ny = strata / nx;
          for (int s = 0; s < ns; ++s) {
            Vec3 target = light.v;
            if (light.kind == Light::Kind::kSphere) {
              // A stratified point of the light's disk as seen from p (its silhouette).
              // Permuted, so that the first samples of an adaptive pixel spread over the disk.
              const int st = stratum((r.pixel_sample + s * opt_.spp) % strata, strata);
              uint64_t hs = mix64(r.seed ^ (uint64_t(li) << 40) ^ (uint64_t(st) << 20) ^ 0x6c74ull);
              float a = unit_float(hs), b = unit_float(mix64(hs));
              if (st < nx * ny) {
                a = (float(st % nx) + a) / float(nx);
                b = (float(st / nx) + b) / float(ny);
              }
              float dx, dy;
              concentric_disk(a, std::min(b, 0.99999994f), &dx, &dy);
              target = light.v + (u * dx + v * dy) * light.radius;
            }
            Vec3 l;
            float dist = std::numeric_limits<float>::infinity();
            if (light.kind == Light::Kind::kDirectional) {
              l = w;
            } else {
              l = target - p;
              dist = length(l);
              l = l / dist;
            }
            float ndotl = dot(nf, l);
            if (ndotl <= 0) continue;
            Vec3 hv = normalize(l + view);
            float spec = m.specular * std::pow(std::max(0.0f, dot(nf, hv)), m.shininess);
            Vec3 contrib = (mul(colour[i], radiance_l) * (m.diffuse * ndotl) + radiance_l * spec) *
                           (1.0f / float(ns));
            contrib = mul(contrib, r.weight);
            if (!opt_.shadows) {
              radiance[size_t(r.sample)] += contrib;
              continue;
            }
            Vec3 o = p + nf * obj.bias;
            shadow.push_back(Ray{o, l});
            shadow_dist.push_back(dist);
            uses.push_back({int(i), contrib});
          }
        }
      }
      if (!shadow.empty()) {
        auto ts0 = Clock::now();
        shadow_transmittance(shadow, shadow_dist, &shadow_trans, ts);
        shadow_s = seconds_since(ts0);
        ts.search_seconds += shadow_s;
        for (size_t j = 0; j < shadow.size(); ++j) {
          const PathRay& r = cur[size_t(uses[j].hit)];
          radiance[size_t(r.sample)] += mul(uses[j].contribution, shadow_trans[j]);
        }
      }
      // The next generation: mirror reflection and refraction.
      next.clear();
      if (depth < opt_.max_depth) {
        for (size_t i = 0; i < cur.size(); ++i) {
          const Hit& h = hits[i];
          if (h.object < 0) continue;
          const PathRay& r = cur[i];
          const ObjectInfo& obj = objects_[size_t(h.object)];
          const Material& m = *obj.material;
          if (m.reflect <= 0 && m.transmit <= 0) continue;
          const bool entering = r.medium != h.object;
          Vec3 nf = entering ? normal[i] : -normal[i];  // against the incoming ray
          float cos_i = -dot(r.d, nf);
          if (cos_i < 0) {  // a noisy normal: face the ray
            nf = -nf;
            cos_i = -cos_i;
          }
          const float n1 = entering ? 1.0f : m.ior, n2 = entering ? m.ior : 1.0f;
          const float eta = n1 / n2;
          const float sin2_t = eta * eta * std::max(0.0f, 1 - cos_i * cos_i);
          const bool tir = sin2_t >= 1;
          float wr = m.reflect, wt = m.transmit;
          if (tir) {
            wr += wt;
            wt = 0;
          } else if (m.fresnel) {
            float fr = fresnel_dielectric(cos_i, n1, n2);
            wr += wt * fr;
            wt *= 1 - fr;
          }
          Vec3 p = r.o + r.d * h.t;
          if (wr > 0) {
            Vec3 w = r.weight * wr;
            if (std::max({w.x, w.y, w.z}) > 1e-4f) {
              Vec3 ideal = normalize(r.d + nf * (2 * cos_i));
              PathRay c;
              c.d = glossy(ideal, m.roughness, nf, mix64(r.seed ^ 0x7265666cull));
              c.o = leave_surface(p, c.d, nf, obj.bias, &c.pre);
              c.weight = w;
              c.sample = r.sample;
              c.depth = depth + 1;
              c.medium = r.medium;
              c.seed = mix64(r.seed ^ 0x52ull);
              c.pixel_sample = r.pixel_sample;
              next.push_back(c);
            }
          }
          if (wt > 0) {
            Vec3 w = r.weight * wt;
            if (entering) w = mul(w, colour[i]);  // filtered once, where light enters
            if (std::max({w.x, w.y, w.z}) > 1e-4f) {
              float cos_t = std::sqrt(1 - sin2_t);
              Vec3 ideal = normalize(r.d * eta + nf * (eta * cos_i - cos_t));
              PathRay c;
              c.d = glossy(ideal, m.roughness, -nf, mix64(r.seed ^ 0x74726e73ull));
              c.o = leave_surface(p, c.d, -nf, obj.bias, &c.pre);
              c.weight = w;
              c.sample = r.sample;
              c.depth = depth + 1;
              c.medium = entering ? h.object : -1;
              c.seed = mix64(r.seed ^ 0x54ull);
              c.pixel_sample = r.pixel_sample;
              next.push_back(c);
            }
          }
        }
      }
      ts.secondary_rays += next.size();
      ts.shade_seconds += seconds_since(t1) - shadow_s;
      std::swap(cur, next);
    }
    for (size_t i = 0; i < list.size(); ++i) {
      PixelAccum& a = pix_[size_t(list[i].first)];
      const Vec3& c = radiance[i];
      a.rgb += c;
      a.lo = vmin(a.lo, c);
      a.hi = vmax(a.hi, c);
      a.samples++;
    }
  }

  const TraceOptions& opt_;
  CameraFrame frame_;
  Image* image_;
  std::vector<ObjectInfo> objects_;
  std::vector<Light> lights_;
  float focus_ = 1;
  /// Per pixel of the tile being traced. thread_local through ThreadState would also do; one
  /// tracer per tile task is simpler: see trace_into().
  std::vector<PixelAccum> pix_;
  /// cull_tile()'s answer for the current tile (camera depths, per object).
  std::vector<std::pair<float, float>> tile_span_;
  bool culled_ = false;
  float footprint_a_ = 0, footprint_b_ = 0;  // pixel width in the world at camera depth t
};

}  // namespace

void trace_into(const std::vector<SceneObject>& objects, const std::vector<Material>& materials,
                const TraceOptions& options, TraceResult* out) {
  HFRT_CHECK(options.width > 0 && options.height > 0);
  HFRT_CHECK(options.spp >= 1 && options.spp <= 65536);
  HFRT_CHECK(options.tile_size >= 1);
  HFRT_CHECK(options.max_depth >= 0);
  HFRT_CHECK(options.sample_count >= 0 && options.sample_begin >= 0 &&
             options.sample_begin + options.sample_count <= options.spp);
  auto start = Clock::now();
  out->stats = TraceStats{};
  if (out->image.width != options.width || out->image.height != options.height || !options.tiles)
    out->image.resize(options.width, options.height);
  Image* image = &out->image;

  struct Worker {
    std::unique_ptr<SceneTracer> tracer;
    ThreadState state;
  };
  par::ThreadLocal<Worker> workers([&] {
    Worker w;
    w.tracer = std::make_unique<SceneTracer>(objects, materials, options, image);
    w.state = w.tracer->make_state();
    return w;
  });
  TileLoop loop = for_each_tile(
      options.width, options.height, options.tile_size, options.threads, options.progress,
      options.cancel,
      [&](const Tile& t) {
        Worker& w = workers.local();
        w.tracer->trace_tile(t.x0, t.y0, t.x1, t.y1, w.state);
      },
      options.tiles);

  TraceStats& s = out->stats;
  s.tiles = loop.tiles;
  s.threads = loop.threads;
  s.cancelled = loop.cancelled;
  for (const SceneObject& o : objects) s.root_used.push_back(resolved_root(o));
  workers.for_each([&](Worker& w) {
    for (auto& rs : w.state.searchers) s.evals += rs->counters();
    for (auto& rs : w.state.negated) s.evals += rs->counters();
    s.camera_rays += w.state.camera_rays;
    s.secondary_rays += w.state.secondary_rays;
    s.shadow_rays += w.state.shadow_rays;
    s.hits += w.state.hits;
    s.refined_pixels += w.state.refined;
    s.search_seconds += w.state.search_seconds;
    s.shade_seconds += w.state.shade_seconds;
  });
  s.seconds = seconds_since(start);
}

void TraceStats::add(const TraceStats& o) {
  seconds += o.seconds;
  threads = o.threads;
  tiles = o.tiles;
  camera_rays += o.camera_rays;
  secondary_rays += o.secondary_rays;
  shadow_rays += o.shadow_rays;
  hits += o.hits;
  refined_pixels += o.refined_pixels;
  root_used = o.root_used;
  evals += o.evals;
  search_seconds += o.search_seconds;
  shade_seconds += o.shade_seconds;
  cancelled = cancelled || o.cancelled;
}

TraceResult trace(const std::vector<SceneObject>& objects, const std::vector<Material>& materials,
                  const TraceOptions& options) {
  TraceResult r;
  trace_into(objects, materials, options, &r);
  return r;
}

}  // namespace hfrt::render
