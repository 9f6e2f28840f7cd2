// The `--root auto` policy (root_choice.h).
#include "render/root_choice.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>

#include "base/timer.h"

namespace hfrt::render {
namespace {

/// Above this many interval evaluations per primary ray (probe average, the search the render
/// runs: march first, then the batched proof), the interval root search costs clearly more
/// than the sign-change march, and `auto` takes the march. Measured at 512x512 on 2 cores: the
/// FRep-Designer-Bench models need 7-9 per ray (interval search 1.0-1.7x the march's time),
/// the default example 38 (0.65 s against 0.33 s for the march), blend.hf 213 (29 s against
/// 0.6 s: hfBlendUni's displacement term keeps its enclosures loose near the surface).
constexpr double kAutoMaxIntervalEvalsPerRay = 24;
constexpr int kAutoProbeSize = 24;  ///< the probe image's larger side, in pixels

/// The field seen by the probe render: counts interval evaluations and, past the budget,
/// answers "empty" to every further one, so that a model with loose enclosures costs the probe
/// no more than the budget (the probe's image is thrown away).
class ProbeField final : public Field {
 public:
  ProbeField(const Field& field, uint64_t budget) : field_(field), budget_(budget) {}
  void eval(size_t n, const float* x, const float* y, const float* z, float* out_f) const override {
    field_.eval(n, x, y, z, out_f);
  }
  bool has_interval() const override { return true; }
  Interval eval_interval(const Box& box, bool* maybe_nan) const override {
    if (calls_.fetch_add(1, std::memory_order_relaxed) >= budget_) {
      *maybe_nan = false;
      return {-1, -1};
    }
    return field_.eval_interval(box, maybe_nan);
  }
  /// The renderer's batches go to the field as batches (the same counts and answers as box by
  /// box: the boxes past the budget are empty): one box at a time, the probe of a
  /// 993-instruction model took ~95 ms on the tape VM's one-box pass.
  void eval_intervals(size_t n, const Box* boxes, Interval* out, bool* maybe_nan) const override {
    const uint64_t first = calls_.fetch_add(n, std::memory_order_relaxed);
    const size_t within = first >= budget_ ? 0 : size_t(std::min<uint64_t>(n, budget_ - first));
    if (within > 0) field_.eval_intervals(within, boxes, out, maybe_nan);
    for (size_t i = within; i < n; ++i) {
      maybe_nan[i] = false;
      out[i] = {-1, -1};
    }
  }
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f, float* dx,
                     float* dy, float* dz) const override {
    field_.eval_gradient(n, x, y, z, f, dx, dy, dz);
  }
  uint64_t calls() const { return calls_.load(); }

 private:
  const Field& field_;
  uint64_t budget_;
  mutable std::atomic<uint64_t> calls_{0};
};

/// A probe render with the interval search: whether its evaluations stayed within
/// kAutoMaxIntervalEvalsPerRay per ray, and how many it made per ray.
struct IntervalProbe {
  bool tight = false;
  double per_ray = 0;
  int width = 0, height = 0;
};

IntervalProbe probe_intervals(const Field& field, const RenderOptions& opt) {
  RenderOptions probe = opt;
  const float scale = float(kAutoProbeSize) / float(std::max(opt.width, opt.height));
  if (scale < 1) {
    probe.width = std::max(1, int(std::lround(float(opt.width) * scale)));
    probe.height = std::max(1, int(std::lround(float(opt.height) * scale)));
  }
  probe.spp = 1;
  probe.shadows = false;
  probe.root = RootMode::kInterval;
  probe.interval_march_first = true;  // the search the render runs (batched, march first)
  // ... but marching every depth: kAutoMaxIntervalEvalsPerRay was set by that search's counts
  // (the pruned march spends 2-3 more interval evaluations per ray to save point samples).
  probe.interval_pruned_march = false;
  probe.progress = nullptr;
  probe.threads = opt.threads;
  const uint64_t rays = uint64_t(probe.width) * uint64_t(probe.height);
  const uint64_t budget = uint64_t(kAutoMaxIntervalEvalsPerRay * double(rays)) + 1;
  ProbeField counted(field, budget);
  render(counted, probe);
  IntervalProbe r;
  r.tight = counted.calls() <= budget;
  r.per_ray = double(counted.calls()) / double(std::max<uint64_t>(rays, 1));
  r.width = probe.width;
  r.height = probe.height;
  return r;
}

/// The interval-or-march probe of settle_root(). Returns the reason, for the user.
std::string probe_auto_root(const Field& field, RenderOptions* opt) {
  const IntervalProbe p = probe_intervals(field, *opt);
  char buf[220];
  if (!p.tight) {
    std::snprintf(buf, sizeof buf,
                  "loose interval enclosures, over %.0f interval evaluations per ray in a %dx%d "
                  "probe; --root interval forces the interval search",
                  kAutoMaxIntervalEvalsPerRay, p.width, p.height);
    opt->root = RootMode::kSign;
    opt->tile_culling = false;
    return buf;
  }
  std::snprintf(buf, sizeof buf, "interval evaluator, %.0f evaluations per ray in a %dx%d probe",
                p.per_ray, p.width, p.height);
  opt->root = RootMode::kInterval;
  return buf;
}

}  // namespace

RootDecision choose_root(const Field& field, RenderOptions* opt, const AnalyticRootInfo& analytic) {
  RootDecision d;
  if (opt->root != RootMode::kAuto) return d;
  if (field.has_ray_candidates()) {
    // Exact roots, no step: every leaf is a polynomial of degree <= 4 on a ray.
    d.why = analytic.description.empty() ? "analytic: polynomial leaves" : analytic.description;
    opt->root = RootMode::kAnalytic;
    // Many leaves: every ray solves them all, and tight enclosures make the interval search
    // cheaper (kAutoProbeAnalyticLeaves). Loose ones (quartics, R-function blends) keep the
    // exact roots.
    if (analytic.num_leaves >= kAutoProbeAnalyticLeaves && analytic.num_surface_leaves == 0 &&
        field.has_interval()) {
      const auto t0 = Clock::now();
      const IntervalProbe p = probe_intervals(field, *opt);
      d.probed = true;
      d.probe_ms = ms_since(t0);
      char buf[200];
      if (p.tight) {
        std::snprintf(buf, sizeof buf,
                      "interval evaluator, %.0f evaluations per ray in a %dx%d probe, cheaper "
                      "than solving %d polynomial leaves per ray; --root analytic forces exact "
                      "roots",
                      p.per_ray, p.width, p.height, analytic.num_leaves);
        d.why = buf;
        opt->root = RootMode::kInterval;
      } else {
        std::snprintf(buf, sizeof buf, "; loose interval enclosures in a %dx%d probe", p.width,
                      p.height);
        d.why += buf;
      }
    }
    return d;
  }
  d.analytic_fallback = analytic.not_qualified;
  if (!field.has_interval()) {
    d.why = "the interval evaluator of this model is the interpreter, too slow per ray";
    opt->root = RootMode::kSign;
    return d;
  }
  const auto t0 = Clock::now();
  d.why = probe_auto_root(field, opt);
  d.probed = true;
  d.probe_ms = ms_since(t0);
  return d;
}

}  // namespace hfrt::render
