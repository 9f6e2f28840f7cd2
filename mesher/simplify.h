#pragma once
// Simplification of a mesher::TriMesh (`hfrt mesh --simplify ERROR`): edges are collapsed in
// order of their quadric error (Garland and Heckbert) while that error stays within a bound,
// so flat regions end with few large triangles and curved ones keep their density.
//
// The bound: a collapse is made only when the merged vertex lies within ERROR of every
// tangent plane the two vertices stand for (the planes of the original triangles around them:
// the sum of the squared distances is at most ERROR^2). The merged vertex is one of the two
// ends or their midpoint, whichever has the smaller error, so vertices on sharp edges and
// corners stay there. A collapse that would break the mesh is refused: the two ends must share
// exactly the two neighbours of their edge (the link condition: the mesh stays a closed
// 2-manifold), and no triangle around them may turn over.
//
// The order: by the error in steps of 1/1024 of the bound (ERROR^2), and within a step the
// shorter edge first, then by vertex index (deterministic). Why the steps: on a flat region
// every error is zero up to rounding, and in the order of the bare error one vertex took its
// neighbours' edges one after another, a fan of hundreds of triangles whose every further
// collapse looked at all of them: simplifying the corpus csg model at 320 cells took 893 s,
// and 3.5 s in this order (about as many triangles: 48336 before, 49718 now).
// Single-threaded.

#include <functional>

#include "mesher/mesher.h"

namespace hfrt::mesher {

/// Figures of one simplification.
struct SimplifyStats {
  size_t triangles_before = 0, triangles_after = 0;
  size_t collapses = 0;
  /// Triangles looked at (around the ends of the edges tried and collapsed): about a constant
  /// times the triangles when no vertex gathers a large fan.
  size_t triangle_visits = 0;
  double seconds = 0;
};

/// Simplifies `mesh` (a closed oriented manifold, as mesh_field returns) in place with the
/// error bound `max_error` (> 0, in model units). Colours follow the surviving vertices.
/// `progress`, when set, is called now and then from the calling thread with the candidate
/// collapses looked at so far and that number plus those still waiting (which collapses
/// add to), and last with the two equal.
void simplify_mesh(TriMesh* mesh, double max_error, SimplifyStats* stats = nullptr,
                   const std::function<void(size_t done, size_t total)>& progress = {});

}  // namespace hfrt::mesher
