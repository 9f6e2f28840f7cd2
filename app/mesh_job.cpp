#include "app/mesh_job.h"

#include <algorithm>
#include <cstdio>

#include "app/model_field.h"
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

}  // namespace

MeshJobResult run_mesh_job(const MeshJob& job) {
  MeshJobResult out;
  const Model& model = *job.model;
  if (model.num_inputs() != 3) {
    out.status = MeshJobStatus::kNotThreeD;
    out.error = job.file + ": error: object '" + model.object_name() + "' has " +
                std::to_string(model.num_inputs()) +
                " coordinates; hfrt mesh needs a 3-D object (x[3])\n  hint: a 2-D object can "
                "be drawn with hfrt slice";
    return out;
  }
  ModelField field(model, job.file);
  PreparedCode prepared = prepare_render_code(model, /*interval=*/true, /*gradient=*/true);
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
  if (out.stats.nan_samples > 0) {
    out.warnings.push_back("hfrt: warning: F has no value at " +
                           std::to_string(out.stats.nan_samples) +
                           " grid nodes (meshed as outside)");
  }
  if (job.simplify > 0 && !out.mesh.triangles.empty()) {
    mesher::simplify_mesh(&out.mesh, job.simplify, &out.simplified);
  }
  if (out.mesh.triangles.empty()) {
    out.status = MeshJobStatus::kNoSurface;
    out.error = job.file + ": error: object '" + model.object_name() +
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
      "stats: mesh %.3f s (octree %.3f, sample %.3f, edges %.3f, vertices %.3f, faces %.3f), "
      "write %.1f ms\n",
      compile_ms, r.prepare_ms, r.extent_ms, box_text(r.region).c_str(), s.grid[0], s.grid[1],
      s.grid[2], s.threads, s.octree_nodes, s.blocks_sampled, s.blocks_total, s.block_size,
      s.surface_cells, s.crossing_edges, r.mesh.vertices.size(), s.sharp_vertices,
      s.projected_vertices, s.split_faces, r.mesh.triangles.size(), s.seconds_total,
      s.seconds_octree, s.seconds_sample, s.seconds_edges, s.seconds_vertices, s.seconds_faces,
      write_ms);
  std::string text = buf;
  if (r.simplified.triangles_before > 0) {
    std::snprintf(buf, sizeof buf,
                  "stats: simplify %zu -> %zu triangles (%zu collapses) in %.3f s\n",
                  r.simplified.triangles_before, r.simplified.triangles_after,
                  r.simplified.collapses, r.simplified.seconds);
    text += buf;
  }
  return text;
}

}  // namespace hfrt::app
