#include "app/mesh_job.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <thread>

#include "app/model_field.h"
#include "app/scene_job.h"
#include "base/memory.h"
#include "base/timer.h"
#include "render/framing.h"

namespace hfrt::app {
namespace {

std::string box_text(const render::Box& b) {
  char buf[200];
  std::snprintf(buf, sizeof buf, "%g,%g,%g,%g,%g,%g", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y,
                b.hi.z);
  return buf;
}

/// "FILE:LINE:COL: error: " for a message about the object as a whole, located at its name in
/// its header (FILE alone where the location is unknown).
std::string object_error_prefix(const std::string& file, const Model& model) {
  const auto [line, col] = model.object_location();
  if (line <= 0) return file + ": error: ";
  return file + ":" + std::to_string(line) + ":" + std::to_string(col) + ": error: ";
}

/// The bytes a mesh's main arrays (vertices, triangles, cells) will likely take: ~100 per cell
/// of the longest side squared (the 512^3 blend's 623k surface cells took ~24 MB; a surface
/// of more area takes more). Only a hint for HeapPrefault.
size_t mesh_heap_estimate(const MeshJob& job) {
  double n = job.resolution;
  if (job.cell > 0) n = double(job.bbox.max_extent()) / double(job.cell);
  return size_t(std::clamp(100.0 * n * n, 0.0, 1e12));
}

}  // namespace

MeshJobResult run_mesh_job(const MeshJob& job) {
  MeshJobResult out;
  const Model& model = *job.model;
  if (model.num_inputs() < 3) {  // x[4] is time (Model::set_time); more coordinates are 0
    out.status = MeshJobStatus::kNotThreeD;
    out.error = object_error_prefix(job.file, model) + "object '" + model.object_name() + "' has " +
                std::to_string(model.num_inputs()) +
                " coordinates; hfrt mesh needs a 3-D object (x[3], or x[4] with time)\n  hint: a "
                "2-D object can "
                "be drawn with hfrt slice";
    return out;
  }
  ModelField field(model, job.file);
  // The mesher's once-per-process set-up (tables, TBB's workers, and the heap its arrays
  // will fill) beside the compile. The heap's block is taken here, on the thread that will
  // allocate the arrays (its arena), and touched on the helper.
  std::optional<HeapPrefault> heap;
  if (job.prefault_heap) heap.emplace(mesh_heap_estimate(job));
  std::thread warm_up([threads = job.threads, &heap] {
    mesher::warm_up(threads);
    if (heap) heap->touch();
  });
  PreparedCode prepared = prepare_render_code(model, /*interval=*/true, /*gradient=*/true);
  warm_up.join();
  heap.reset();  // back to malloc, its pages kept
  out.prepare_ms = prepared.ms;
  out.warnings = prepared.warnings;

  render::Box region = job.bbox;
  if (!job.bbox_given) {
    const auto t0 = Clock::now();
    render::Box extent = render::find_extent(field, job.bbox, 6);
    out.extent_ms = ms_since(t0);
    if (!extent.empty()) {
      const render::Vec3 pad =
          extent.size() * 0.02f + render::Vec3{1e-4f, 1e-4f, 1e-4f} * job.bbox.max_extent();
      extent.lo = extent.lo - pad;
      extent.hi = extent.hi + pad;
      region = intersect(extent, job.bbox);
      if (region.empty() || !(region.max_extent() > 0)) region = job.bbox;
    }
  }
  out.region = region;

  mesher::MeshOptions opt;
  opt.box = region;
  opt.resolution = job.resolution;
  opt.cell = job.cell;
  {
    int cells[3];
    double size[3];
    mesher::grid_for(opt, cells, size);
    const int most = std::max({cells[0], cells[1], cells[2]});
    if (most > kMaxMeshCells) {
      out.status = MeshJobStatus::kTooFine;
      char buf[200];
      std::snprintf(buf, sizeof buf, "%g", double(job.cell));
      out.error = std::string("hfrt mesh: --cell ") + buf + " gives " + std::to_string(most) +
                  " cells along the region's longest side (at most " +
                  std::to_string(kMaxMeshCells) + ")";
      return out;
    }
  }
  opt.threads = job.threads;
  opt.colors = job.colors;
  opt.progress = job.progress;
  out.mesh = mesher::mesh_field(field, opt, &out.stats);
  for (std::string& w : background_compile_warnings(model)) out.warnings.push_back(std::move(w));
  if (out.stats.nan_samples > 0) {
    out.warnings.push_back("hfrt: warning: F has no value at " +
                           std::to_string(out.stats.nan_samples) +
                           " grid nodes (meshed as outside)");
  }
  if (job.simplify > 0 && !out.mesh.triangles.empty()) {
    mesher::simplify_mesh(&out.mesh, job.simplify, &out.simplified, job.simplify_progress);
  }
  if (out.mesh.triangles.empty()) {
    out.status = MeshJobStatus::kNoSurface;
    out.error = object_error_prefix(job.file, model) + "object '" + model.object_name() +
                "' has no surface in the box " + box_text(region) +
                "\n  hint: the solid is where F >= 0; F < 0 at every grid node here (give a "
                "larger --bbox, or a finer --resolution for thin parts)";
  }
  return out;
}

std::string format_mesh_stats(const MeshJobResult& r, double compile_ms, double write_ms) {
  const mesher::MeshStats& s = r.stats;
  char buf[1200];
  std::snprintf(
      buf, sizeof buf,
      "stats: compile %.1f ms (+ %.1f ms interval and gradient code), extent %.1f ms\n"
      "stats: region %s, grid %dx%dx%d cells, %d threads\n"
      "stats: octree %zu interval nodes, %zu of %zu blocks (%d^3 cells) sampled, %zu surface "
      "cells, %zu crossing edges\n"
      "stats: %zu vertices (%zu sharp, %zu moved onto F = 0, %zu face splits), %zu triangles\n"
      "stats: mesh %.3f s (octree %.3f, blocks %.3f, join %.3f, faces %.3f), write %.1f ms\n"
      "stats: blocks' thread-seconds: sample %.3f, edges %.3f, vertices %.3f\n",
      compile_ms, r.prepare_ms, r.extent_ms, box_text(r.region).c_str(), s.grid[0], s.grid[1],
      s.grid[2], s.threads, s.octree_nodes, s.blocks_sampled, s.blocks_total, s.block_size,
      s.surface_cells, s.crossing_edges, r.mesh.vertices.size(), s.sharp_vertices,
      s.projected_vertices, s.split_faces, r.mesh.triangles.size(), s.seconds_total,
      s.seconds_octree, s.seconds_blocks, s.seconds_join, s.seconds_faces, write_ms,
      s.thread_seconds_sample, s.thread_seconds_edges, s.thread_seconds_vertices);
  std::string text = buf;
  text += malloc_pages_stats_line();
  if (r.simplified.triangles_before > 0) {
    std::snprintf(buf, sizeof buf,
                  "stats: simplify %zu -> %zu triangles (%zu collapses) in %.3f s\n",
                  r.simplified.triangles_before, r.simplified.triangles_after,
                  r.simplified.collapses, r.simplified.seconds);
    text += buf;
  }
  return text;
}

MeshJobResult run_scene_mesh_job(const scene::SceneDesc& sc, const MeshJob& settings) {
  MeshJobResult all;
  ModelOptions mo;
  mo.eager_f64 = false;
  mo.eager_f32 = true;
  std::vector<MeshJobResult> parts(sc.objects.size());
  bool any_colour = false;
  for (size_t i = 0; i < sc.objects.size(); ++i) {
    const scene::ObjectDesc& o = sc.objects[i];
    CompileResult compiled = compile_scene_object(sc, i, mo);
    if (!compiled.error.empty()) {
      all.status = MeshJobStatus::kEnvironment;
      all.error = compiled.error;
      return all;
    }
    if (!compiled.ok()) {
      all.status = MeshJobStatus::kSourceError;
      all.error = compiled.rendered;
      return all;
    }
    compiled.model->set_time(settings.time);
    MeshJob job = settings;
    job.model = &*compiled.model;
    job.file = o.file.empty() ? sc.path : o.file;
    job.bbox = o.bbox.value_or(render::Box{{-10, -10, -10}, {10, 10, 10}});
    job.bbox_given = false;
    parts[i] = run_mesh_job(job);
    MeshJobResult& r = parts[i];
    for (std::string& w : r.warnings) all.warnings.push_back(std::move(w));
    all.prepare_ms += r.prepare_ms;
    all.extent_ms += r.extent_ms;
    if (r.status == MeshJobStatus::kNoSurface) {
      char where[64];
      std::snprintf(where, sizeof where, ":%d:%d", o.pos.line, o.pos.column);
      all.warnings.push_back(sc.path + where +
                             ": warning: this [[object]] has no surface in its box; skipped");
      continue;
    }
    if (r.status != MeshJobStatus::kOk) return std::move(r);
    // Into the world: a uniform scale and a rotation keep the triangles' orientation.
    const render::Transform place = scene::placement(o);
    for (render::Vec3& v : r.mesh.vertices) v = place.point_to_world(v);
    all.region.extend(place.box_to_world(r.region));
    any_colour = any_colour || !r.mesh.colors.empty();
  }
  for (size_t i = 0; i < parts.size(); ++i) {
    MeshJobResult& r = parts[i];
    if (r.status != MeshJobStatus::kOk) continue;
    const uint32_t base = uint32_t(all.mesh.vertices.size());
    all.mesh.vertices.insert(all.mesh.vertices.end(), r.mesh.vertices.begin(),
                             r.mesh.vertices.end());
    for (const auto& t : r.mesh.triangles) {
      all.mesh.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    }
    if (any_colour) {
      if (r.mesh.colors.empty()) {
        const scene::ObjectDesc& o = sc.objects[i];
        const render::Vec3 c =
            o.material.empty() ? render::Material{}.color : sc.materials.at(o.material).color;
        r.mesh.colors.assign(r.mesh.vertices.size(), c);
      }
      all.mesh.colors.insert(all.mesh.colors.end(), r.mesh.colors.begin(), r.mesh.colors.end());
    }
    all.stats.seconds_total += r.stats.seconds_total;
  }
  if (all.mesh.triangles.empty()) {
    all.status = MeshJobStatus::kNoSurface;
    all.error = sc.path + ": error: no object of the scene has a surface in its box\n  hint: " +
                "check each [[object]]'s bbox";
  }
  return all;
}

}  // namespace hfrt::app
