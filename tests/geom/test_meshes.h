#pragma once
// Meshes for geom tests: the corpus armadillo (loaded once) and a generated closed mesh with
// integer coordinates, so rays along the axes pass EXACTLY through its vertices and edges.

#include <gtest/gtest.h>

#include <random>
#include <string>

#include "geom/mesh.h"
#include "geom/mesh_surface.h"

namespace hfrt::geom::testing {

inline std::string armadillo_path() {
  return std::string(HFRT_CORPUS_DIR) + "/meshes/armadillo.off";
}

/// The armadillo as loaded by load_mesh (aborts the test binary if the corpus is missing).
inline const TriangleMesh& armadillo() {
  static const TriangleMesh mesh = [] {
    Result<TriangleMesh> m = load_mesh(armadillo_path());
    HFRT_CHECK_MSG(m.ok(), m.error().message);
    return std::move(m).value();
  }();
  return mesh;
}

inline const MeshSurface& armadillo_surface() {
  static const std::unique_ptr<MeshSurface> s = MeshSurface::build(armadillo());
  return *s;
}

/// A closed, outward-oriented "height-field box": the top is z = h(i, j) (integers 4 or 5, so
/// its slope is at most sqrt(2) and steeper rays always cross it, never graze it) over
/// the n x n integer grid [0, n]^2, the bottom is z = 0, and four side walls close it. Every
/// quad is split along its (i,j)-(i+1,j+1) diagonal. All coordinates are small integers, so
/// edge midpoints are exactly representable.
inline TriangleMesh heightfield_box(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> height(4, 5);
  TriangleMesh m;
  m.source = "heightfield box";
  auto top = [&](int i, int j) { return static_cast<uint32_t>(j * (n + 1) + i); };
  const uint32_t nb = static_cast<uint32_t>((n + 1) * (n + 1));
  auto bot = [&](int i, int j) { return nb + static_cast<uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.push_back({float(i), float(j), float(height(rng))});
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.push_back({float(i), float(j), 0.0f});
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      // Top faces up (counter-clockwise seen from +z), bottom faces down.
      m.triangles.push_back({top(i, j), top(i + 1, j), top(i + 1, j + 1)});
      m.triangles.push_back({top(i, j), top(i + 1, j + 1), top(i, j + 1)});
      m.triangles.push_back({bot(i, j), bot(i + 1, j + 1), bot(i + 1, j)});
      m.triangles.push_back({bot(i, j), bot(i, j + 1), bot(i + 1, j + 1)});
    }
  // Side walls: along each boundary edge (a -> b, counter-clockwise around the box seen from
  // +z), the quad top(a), top(b), bot(b), bot(a) faces outward when wound a, bot a, bot b, ...
  auto wall = [&](uint32_t ta, uint32_t tb, uint32_t ba, uint32_t bb) {
    m.triangles.push_back({ta, ba, bb});
    m.triangles.push_back({ta, bb, tb});
  };
  for (int i = 0; i < n; ++i) {
    wall(top(i, 0), top(i + 1, 0), bot(i, 0), bot(i + 1, 0));  // y = 0, normal -y
    wall(top(n, i), top(n, i + 1), bot(n, i), bot(n, i + 1));  // x = n, normal +x
    wall(top(i + 1, n), top(i, n), bot(i + 1, n), bot(i, n));  // y = n, normal +y
    wall(top(0, i + 1), top(0, i), bot(0, i + 1), bot(0, i));  // x = 0, normal -x
  }
  Result<TriangleMesh> r = finish_mesh(std::move(m));
  HFRT_CHECK_MSG(r.ok(), r.error().message);
  return std::move(r).value();
}

/// A point uniformly distributed in box b.
inline Vec3 random_point(std::mt19937& rng, const Box& b) {
  std::uniform_real_distribution<float> u(0, 1);
  return {b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
          b.lo.z + u(rng) * (b.hi.z - b.lo.z)};
}

/// A uniformly distributed unit direction.
inline Vec3 random_direction(std::mt19937& rng) {
  std::normal_distribution<float> g;
  Vec3 d;
  do d = {g(rng), g(rng), g(rng)};
  while (length(d) < 1e-3f);
  return normalize(d);
}

inline Box grown(const Box& b, float f) {
  const Vec3 pad = b.diagonal() * f;
  return {b.lo - pad, b.hi + pad};
}

}  // namespace hfrt::geom::testing
