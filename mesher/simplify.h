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
// 2-manifold), and no triangle around them may turn over. Deterministic (ties broken by
// vertex index); single-threaded.

#include <functional>

#include "mesher/mesher.h"

namespace hfrt::mesher {

/// Figures of one simplification.
struct SimplifyStats {
  size_t triangles_before = 0, triangles_after = 0;
  size_t collapses = 0;
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
