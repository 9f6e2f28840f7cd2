// One render of a compiled model (render_job.h).
#include "app/render_job.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "base/memory.h"
#include "base/timer.h"
#include "lang/diagnostics.h"
#include "lang/source.h"

namespace hfrt::app {

const render::Field& render_field(const Model& model, const ModelField& model_field,
                                  const WithoutIntervals& sampled, render::RootMode root,
                                  bool pruned_tapes) {
  // Without the interval JIT (models above ModelOptions::interval_jit_max_insts, or the
  // interpreter backend) intervals over the whole program are too slow for the renderer's
  // many calls: such models are framed by sampling and rendered by the sign-change march,
  // unless the user asks for --root interval. (The tape VM that evaluates such a model's
  // intervals when it is straight-line code is ~15x the interpreter, but a 7000-instruction
  // prospero box still costs ~20-100 us: its 256x256 render with --root sign took 2.5 s with
  // the sampled field and 13.4 s with intervals, shadow rays culled by intervals.)
  const bool fast_intervals = model.interval_engine() == DomainEngine::kJit;
  if (root == render::RootMode::kInterval || fast_intervals) return model_field;
  // With tapes pruned per tile slab (render/tape_regions.h) the tape VM's intervals are
  // cheap where it matters: prospero (6903 instructions) at 256x256 took 4.0 s sampled (auto:
  // analytic over 1882 quadric leaves) and takes 2.0 s by the pruned interval search.
  if (pruned_tapes && root == render::RootMode::kAuto &&
      model.interval_engine() == DomainEngine::kTapeVm) {
    return model_field;
  }
  return sampled;
}

bool frame_camera(const render::Field& field, const render::CameraRequest& camera,
                  render::RenderOptions* opt, FramingInfo* info, std::string* err,
                  const render::Box* known_extent) {
  const auto t0 = Clock::now();
  info->framed = !camera.eye || !camera.look_at;
  info->extent_by_interval = false;
  info->extent = opt->bbox;
  if (info->framed) {
    if (known_extent) {
      info->extent = *known_extent;
    } else {
      // Sampling costs (2^depth + 1)^3 point evaluations: a coarser grid keeps slow models usable.
      info->extent = render::find_extent(field, opt->bbox, field.has_interval() ? 6 : 5,
                                         &info->extent_by_interval);
    }
  }
  opt->camera =
      render::resolve_camera(camera, info->extent, float(opt->width) / float(opt->height));
  if (info->framed) opt->solid_extent = info->extent;
  info->ms = ms_since(t0);
  render::Vec3 view = opt->camera.look_at - opt->camera.eye;
  if (length(view) == 0) {
    *err = "--eye and --look-at are the same point";
    return false;
  }
  if (length(cross(normalize(view), normalize(opt->camera.up))) < 1e-6f) {
    *err = "--up is parallel to the view direction; give another --up";
    return false;
  }
  return true;
}

render::RootDecision settle_root(const render::Field& field, render::RenderOptions* opt,
                                 const AnalyticInfo* analytic, const std::string& file) {
  render::AnalyticRootInfo info;
  if (analytic && analytic->qualifies) {
    info.num_leaves = analytic->num_leaves;
    info.num_surface_leaves = analytic->num_surface_leaves;
    char buf[160];
    if (analytic->num_surface_leaves > 0) {
      std::snprintf(buf, sizeof buf,
                    "analytic: %d polynomial leaves of degree <= %d, %d mesh/patch leaves",
                    analytic->num_leaves, analytic->max_degree, analytic->num_surface_leaves);
    } else {
      std::snprintf(buf, sizeof buf, "analytic: %d polynomial leaves of degree <= %d",
                    analytic->num_leaves, analytic->max_degree);
    }
    info.description = buf;
  }
  if (analytic && !analytic->qualifies) {
    info.not_qualified =
        analytic->reason.empty() ? "not a set operation of polynomial leaves" : analytic->reason;
    if (analytic->line > 0) {
      info.not_qualified += " at " + file + ":" + std::to_string(analytic->line) + ":" +
                            std::to_string(analytic->col);
    }
  }
  return render::choose_root(field, opt, info);
}

std::string analytic_root_diagnostic(const AnalyticInfo& analytic, const std::string& file) {
  if (analytic.qualifies) return "";
  lang::Diagnostic diag;
  diag.severity = lang::Severity::kError;
  diag.message = "--root analytic: the model is not a set operation of polynomial leaves: " +
                 (analytic.reason.empty() ? std::string("unsupported construct") : analytic.reason);
  diag.hint =
      "the analytic search needs min/max/|/&/\\ over polynomials of degree <= 4 in x "
      "(quadrics, tori, planes, blocks, moved by shifts, rotations and scales); use "
      "--root auto, interval or sign for this model";
  std::string text;
  if (analytic.line > 0) {
    std::ifstream in(file, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
    diag.range.begin.line = uint32_t(analytic.line);
    diag.range.begin.col = uint32_t(std::max(analytic.col, 1));
  }
  lang::SourceFile source(file, std::move(text));
  return lang::render_diagnostic(source, diag, /*color=*/false);
}

std::string format_render_stats(const RenderReport& r) {
  const render::RenderStats& st = r.stats;
  const render::EvalCounters& e = st.evals;
  std::string out;
  char buf[512];
  double mrays = double(st.primary_rays + st.shadow_rays) / std::max(st.seconds, 1e-9) * 1e-6;
  std::snprintf(buf, sizeof buf,
                "stats: compile %.1f ms (+ %.1f ms interval and gradient code: %s)\n", r.compile_ms,
                r.prepare_ms, r.engines.c_str());
  out += buf;
  char probe[64] = "";
  if (r.auto_root) std::snprintf(probe, sizeof probe, ", auto probe %.1f ms", r.root.probe_ms);
  std::snprintf(buf, sizeof buf, "stats: framing %.1f ms%s%s, render %.3f s on %d threads\n",
                r.framing.ms,
                r.framing.framed ? (r.framing.extent_by_interval ? " (intervals)" : " (sampling)")
                                 : " (camera given)",
                probe, st.seconds, st.threads);
  out += buf;
  std::snprintf(buf, sizeof buf,
                "stats: %llu primary + %llu shadow rays, %.2f Mrays/s, %llu hits\n",
                (unsigned long long)st.primary_rays, (unsigned long long)st.shadow_rays, mrays,
                (unsigned long long)st.hits);
  out += buf;
  std::snprintf(buf, sizeof buf,
                "stats: evaluator calls: point %llu (%llu points), interval %llu, gradient %llu "
                "(%llu points), attributes %llu; %llu interval searches finished by marching\n",
                (unsigned long long)e.eval_calls, (unsigned long long)e.eval_points,
                (unsigned long long)e.interval_calls, (unsigned long long)e.gradient_calls,
                (unsigned long long)e.gradient_points, (unsigned long long)e.attribute_calls,
                (unsigned long long)e.interval_fallbacks);
  out += buf;
  std::string tiles =
      r.culled ? std::to_string(st.tiles_empty) + " empty by intervals" : "no interval culling";
  std::snprintf(buf, sizeof buf,
                "stats: tiles %zu (%s); thread time: culling %.3f s, root search %.3f s, "
                "shading %.3f s\n",
                st.tiles, tiles.c_str(), st.cull_seconds, st.search_seconds, st.shade_seconds);
  out += buf;
  if (st.pruned_regions > 0) {
    std::snprintf(buf, sizeof buf,
                  "stats: pruned tapes: %llu slab tapes of %.1f instructions on average; "
                  "interval boxes on them %llu, on the whole program %llu\n",
                  (unsigned long long)st.pruned_regions,
                  double(st.pruned_region_length) / double(st.pruned_regions),
                  (unsigned long long)st.pruned_boxes, (unsigned long long)st.full_boxes);
    out += buf;
  }
  if (st.pruned_cells > 0) {
    std::snprintf(buf, sizeof buf, "stats: cell tapes: %llu of %.1f instructions on average\n",
                  (unsigned long long)st.pruned_cells,
                  double(st.pruned_cell_length) / double(st.pruned_cells));
    out += buf;
  }
  if (st.root_used == render::RootMode::kAnalytic) {
    std::snprintf(buf, sizeof buf, "stats: analytic candidates: %llu calls, %.2f per call\n",
                  (unsigned long long)e.candidate_calls,
                  double(e.candidates) / double(std::max<uint64_t>(e.candidate_calls, 1)));
    out += buf;
  }
  out += malloc_pages_stats_line();
  out += std::string("root: ") + render::root_mode_name(st.root_used) + "\n";
  if (!r.root.analytic_fallback.empty()) {
    out += "root fallback: not analytic: " + r.root.analytic_fallback + "\n";
  }
  return out;
}

RenderJobResult run_render_job(const RenderJob& job, render::RenderResult* out) {
  RenderJobResult r;
  const Model& model = *job.model;
  ModelField model_field(model, job.file);
  const PreparedCode prepared = prepare_render_code(model);
  r.warnings = prepared.warnings;
  r.report.prepare_ms = prepared.ms;
  WithoutIntervals sampled(model_field);
  render::RenderOptions opt = job.setup.options;
  const render::Field& field =
      render_field(model, model_field, sampled, opt.root, opt.pruned_tapes && opt.tile_culling);
  // --root analytic on a model that does not qualify is an error in the model's source (like a
  // compile error), not a usage error.
  if (opt.root == render::RootMode::kAnalytic) {
    std::string diag = analytic_root_diagnostic(model_field.analytic_info(), job.file);
    if (!diag.empty()) {
      r.status = RenderJobStatus::kSourceError;
      r.error = std::move(diag);
      return r;
    }
  }
  const bool reuse = job.view && job.view->has_interval == field.has_interval() &&
                     job.view->ray_candidates == field.has_ray_candidates();
  if (!frame_camera(field, job.setup.camera, &opt, &r.report.framing, &r.error,
                    reuse ? &job.view->extent : nullptr)) {
    r.status = RenderJobStatus::kUsageError;
    return r;
  }
  r.report.auto_root = opt.root == render::RootMode::kAuto;
  if (reuse) {
    opt.root = job.view->root;
    opt.tile_culling = job.view->tile_culling;
    r.report.root.why = job.view->why;
  } else {
    r.report.root = settle_root(field, &opt, &model_field.analytic_info(), job.file);
  }
  r.view = RenderView{r.report.framing.extent,    field.has_interval(),
                      field.has_ray_candidates(), opt.root,
                      opt.tile_culling,           r.report.root.why};
  // The analytic search samples only F's sign: mesh and patch leaves then cost a winding
  // number instead of a distance query, closed meshes not even that.
  model_field.prepare_render(opt.root);
  // The interval search evaluates each tile's boxes on tapes pruned for its culling slabs
  // (render/tape_regions.h), when the object is straight-line code. The tape is prepared with
  // --no-prune too: whether a model can be pruned also decides how the tiles' depth pieces
  // are searched (render/renderer.cpp, cull_tile), and --no-prune must give the same image.
  if (opt.root == render::RootMode::kInterval && opt.tile_culling && &field == &model_field) {
    model_field.prepare_tapes();
  }
  if (opt.root == render::RootMode::kAnalytic) {
    for (std::string& w : open_surface_warnings(model, job.file))
      r.warnings.push_back(std::move(w));
  }
  if (job.on_coarse && opt.width >= 64 && opt.height >= 8) {
    render::RenderOptions coarse = opt;
    coarse.width = std::max(1, opt.width / 8);
    coarse.height = std::max(1, opt.height / 8);
    coarse.spp = 1;
    coarse.shadows = false;
    coarse.progress = nullptr;
    render::RenderResult preview = render::render(field, coarse);
    if (preview.stats.cancelled) {
      r.status = RenderJobStatus::kCancelled;
      return r;
    }
    job.on_coarse(preview.image);
  }
  const auto t_render = Clock::now();
  render::render_into(field, opt, out);
  r.render_ms = ms_since(t_render);
  if (out->stats.cancelled) r.status = RenderJobStatus::kCancelled;
  r.report.engines = describe_domain_engines(model);
  for (std::string& w : background_compile_warnings(model)) r.warnings.push_back(std::move(w));
  r.report.culled = opt.tile_culling && field.has_interval();
  r.report.stats = out->stats;
  r.options = opt;
  return r;
}

}  // namespace hfrt::app
