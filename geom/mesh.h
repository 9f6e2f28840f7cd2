#pragma once
// TriangleMesh: an indexed triangle mesh as loaded from a file (OFF, OBJ, PLY, STL through
// Assimp) or built from inline arrays (hfTriangles(x, V, T)). Loading validates everything a
// later stage would otherwise trip over, so the accelerators (geom/mesh_accel.h) can assume
// finite coordinates and in-range indices. Bad input is an environment failure: a Result whose
// message names the file and, for text formats, the line ("model.off:7: ...").

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "base/limits.h"
#include "base/result.h"
#include "geom/vec.h"

namespace hfrt::geom {

/// An indexed triangle mesh. Invariants after a successful load: at least one triangle, all
/// coordinates finite, all indices < vertices.size(), no degenerate (zero-area) triangles.
struct TriangleMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;  ///< zero-based vertex indices
  /// Zero-area triangles (repeated index or collinear corners) dropped while loading: they
  /// cannot be hit by a ray nor change the winding number, so they are skipped and counted.
  size_t degenerate_skipped = 0;
  /// Where the mesh came from ("armadillo.off", "inline"), for messages and --stats.
  std::string source;

  Box bounds() const;
  Vec3 corner(size_t tri, int k) const { return vertices[triangles[tri][k]]; }
};

/// Reads a mesh with Assimp (OFF, OBJ, PLY, STL; polygons are triangulated, identical
/// vertices joined). Text OFF and OBJ files are first checked line by line so that a malformed
/// number, a non-finite coordinate or an out-of-range index is reported with its line, which
/// Assimp does not do (it silently clamps or drops some of them). Fails on: a missing or
/// unreadable file, a malformed file, a mesh with no (non-degenerate) triangle; and, before
/// reading, on what is not a regular file (a device such as /dev/zero, a pipe) and on a file
/// of more than limits.max_mesh_bytes bytes; after reading, on more than
/// limits.max_mesh_triangles triangles or vertices (the Error's hint names the limit).
Result<TriangleMesh> load_mesh(const std::string& path, const Limits& limits = {});

/// A text OFF file's mesh (the reader behind load_mesh for .off): every malformed number,
/// non-finite coordinate, out-of-range index or missing line is an Error located at its
/// line; polygons become fans. A body of at least `parallel_min_bytes` is parsed in parallel
/// chunks of whole lines (the same mesh and the same first error as one pass; a 1M-triangle
/// file's parse was a third of its load and build).
inline constexpr size_t kOffParallelBytes = size_t(4) << 20;
Result<TriangleMesh> parse_off(const std::string& path, const std::string& text,
                               const Limits& limits = {},
                               size_t parallel_min_bytes = kOffParallelBytes);

/// The error of a file that read_file_limited refused: its own when it names the path
/// ("PATH: is ..."), else "PATH: cannot read: ...".
Error file_error(const std::string& path, const Error& read_error);

/// Builds a mesh from inline arrays as hfTriangles(x, V, T) passes them: `v` holds 3
/// coordinates per vertex, `t` three ONE-based vertex indices per triangle (stored as reals,
/// like hfConvMesh; each must be an integer in 1..#vertices). `what` names the source in
/// messages. Fails on a length that is not a multiple of 3, a bad index, a non-finite
/// coordinate, or no triangle left.
Result<TriangleMesh> mesh_from_arrays(std::span<const double> v, std::span<const double> t,
                                      const std::string& what = "inline mesh");

/// Validates and cleans a mesh built in memory (finite coordinates, in-range indices, drops
/// degenerate triangles and counts them). Used by both loaders and by tessellated patches.
/// `tags`, when not null, holds one value per triangle and is filtered in step with them.
Result<TriangleMesh> finish_mesh(TriangleMesh mesh, std::vector<uint64_t>* tags = nullptr);

}  // namespace hfrt::geom
