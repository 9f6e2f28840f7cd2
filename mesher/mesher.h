#pragma once
// The mesher: a watertight triangle mesh of the surface F = 0 of a field (render::Field, the
// same view of a model the renderer has), by dual contouring on the finest level of an
// interval-pruned octree.
//
// The algorithm (docs/meshing.md):
//  1. The box is cut into a uniform grid of cells (resolution cells along its longest side),
//     padded by one cell on every side so that the grid's outer nodes are outside the solid.
//     The solid is capped at the box: the mesher contours Fc = min(F, d), d the signed distance
//     to the box's faces (positive inside), as the renderer caps the solid at its box.
//  2. An octree over blocks of 4^3 cells, subdivided level by level where the interval of Fc
//     over the node contains 0 (batched Field::eval_intervals); blocks proven empty or full
//     are dropped, so the work grows with the area of the surface, not the volume of the box.
//  3. The blocks left are meshed in runs of 16, each run from its own data (steps 3-4): F is
//     sampled at every node of its blocks in one evaluation call; a cell whose corners
//     disagree (inside: F >= 0; NaN counts as outside) is a surface cell.
//     Its crossing edges are grouped into patches as marching cubes would connect them
//     (on a face with four crossings the inside corners are separated, a rule that only looks
//     at the face, so both cells sharing it agree): one vertex per patch.
//  4. Each crossing edge's zero is found by a false-position step whose value and exact
//     gradient (the normal) come from one evaluation (enough on a plane: |F| below 1e-5 of
//     its change along the edge), and
//     on a smooth edge by one Newton step along the edge with that gradient (a kink of
//     min/max takes two more false-position steps instead); the patch vertex minimises the quadric
//     error of those tangent planes (truncated pseudo-inverse around the mass point), clamped to
//     its cell, so that sharp edges and corners of CSG are reproduced. A vertex that is then not on
//     F = 0 (a smooth region) is moved onto it by Newton steps: the point a step reaches is
//     checked by F alone, and a flat patch's first step goes along its mean edge normal and
//     slope, so that a smooth vertex usually costs two values of F and no gradient.
//  5. Every crossing edge gives one quad over the four patches around it, oriented so that
//     its normal points out of the solid, split into two triangles along the better diagonal.
//     Where two cells' patches would be joined by two distinct face segments (an edge of the
//     dual mesh used twice), a vertex on that face splits one of them.
// The result is a closed, oriented 2-manifold whenever the surface is closed inside the box
// (always, thanks to the cap), with each edge shared by exactly two triangles.
//
// Blocks whose cells a crossing edge needs but the octree pruned (interval and point values
// disagreeing) are meshed too, round after round (the closure).
//
// Parallel with TBB over octree nodes, runs of blocks and blocks; all results are written to
// slots fixed by position in block order, so the mesh does not depend on the thread count.

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "base/box.h"
#include "base/memory.h"
#include "base/vec.h"
#include "render/field.h"

namespace hfrt::mesher {

/// Triangles as three vertex indices each; resize() leaves new ones unset (the mesher writes
/// every one, from several threads).
using TriangleList =
    std::vector<std::array<uint32_t, 3>, DefaultInitAllocator<std::array<uint32_t, 3>>>;

/// A triangle mesh: shared vertices, counter-clockwise triangles seen from outside (the normal
/// (b - a) x (c - a) points out of the solid). `colors` is empty or one RGB in [0, 1] per
/// vertex (s[1..3] of the model).
struct TriMesh {
  std::vector<Vec3> vertices;
  TriangleList triangles;
  std::vector<Vec3> colors;
};

/// What to mesh and how finely.
struct MeshOptions {
  /// The region meshed; the solid is capped at it. Must be non-empty with positive extent.
  Box box;
  /// Cells along the longest side of the box (>= 1), used when `cell` is 0.
  int resolution = 128;
  /// The edge length of a cell; 0 = box.max_extent() / resolution. The cells are the box
  /// divided evenly, so their edges are at most this long.
  float cell = 0;
  /// Worker threads; 0 = all cores.
  int threads = 0;
  /// Per-vertex colours from s[1..3] when the field has at least 3 attributes.
  bool colors = true;
  /// Called now and then with the work done out of a total (blocks meshed, then the faces);
  /// from the calling thread only.
  std::function<void(size_t done, size_t total)> progress;
};

/// Figures for `--stats`.
struct MeshStats {
  int grid[3] = {0, 0, 0};        ///< cells per axis (without the padding)
  size_t octree_nodes = 0;        ///< interval evaluations
  int block_size = 0;             ///< cells per side of a block (the octree leaves)
  size_t blocks_sampled = 0;      ///< blocks whose nodes were sampled
  size_t blocks_total = 0;        ///< blocks of the padded grid
  size_t surface_cells = 0;       ///< cells with a sign change
  size_t crossing_edges = 0;      ///< grid edges with a sign change (= quads)
  size_t sharp_vertices = 0;      ///< vertices left on an edge or corner (QEF rank >= 2)
  size_t projected_vertices = 0;  ///< vertices moved onto F = 0 by Newton steps
  size_t split_faces = 0;         ///< face vertices added to keep the mesh manifold
  size_t closure_cells = 0;       ///< surface cells in blocks the octree had pruned (interval
                                  ///< and point evaluators disagreeing at a node; normally 0)
  size_t nan_samples = 0;         ///< grid nodes where F has no value
  /// Wall time of the steps: the octree; the blocks (sampling, edges and vertices, fused
  /// run by run); the join of the runs (with closure rounds and face vertices); the faces.
  double seconds_octree = 0, seconds_blocks = 0, seconds_join = 0, seconds_faces = 0,
         seconds_total = 0;
  /// Thread-seconds inside the blocks' runs, summed over threads: sampling and surface
  /// cells, the crossing edges' zeros and normals, the vertices' placement.
  double thread_seconds_sample = 0, thread_seconds_edges = 0, thread_seconds_vertices = 0;
  int threads = 0;
};

/// The mesh of the surface of `field`'s solid (F >= 0) inside `options.box`, capped at the box.
/// Empty (no triangles) when there is no surface in the box. Never fails for a valid field;
/// broken options (empty box, resolution < 1) are invariant violations (HFRT_CHECK): callers
/// validate user input first.
TriMesh mesh_field(const render::Field& field, const MeshOptions& options,
                   MeshStats* stats = nullptr);

/// Sets up what the first mesh_field of a process pays once: the cube case tables and the
/// thread pool for `threads` workers (0: all cores). Optional and thread-safe: app/mesh_job
/// runs it on a thread of its own while the model's code compiles, so that the mesher's own
/// time is meshing (the 512^3 blend's "mesh" figure included ~1 ms of tables and ~2.5 ms of
/// TBB start-up).
void warm_up(int threads);

/// The grid `mesh_field` uses for `options`: cells per axis (without padding) and the cell
/// size per axis. Exposed so that callers can report or bound it before meshing.
void grid_for(const MeshOptions& options, int cells[3], double size[3]);

}  // namespace hfrt::mesher
