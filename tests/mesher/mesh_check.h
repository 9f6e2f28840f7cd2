#pragma once
// Checks of a triangle mesh that do not trust the mesher: closed (every edge used by exactly
// two triangles), consistently oriented (the two uses run in opposite directions), manifold at
// the vertices (the triangles around a vertex form one fan), no degenerate index triples; and
// the enclosed volume and area, by the divergence theorem.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/vec.h"

namespace hfrt::mesher::testing {

/// "" when the mesh is a closed, oriented 2-manifold; otherwise the first problem found.
inline std::string check_closed_manifold(const std::vector<Vec3>& vertices,
                                         std::span<const std::array<uint32_t, 3>> triangles) {
  if (triangles.empty()) return "no triangles";
  std::unordered_map<uint64_t, int> directed;
  directed.reserve(triangles.size() * 4);
  auto key = [](uint32_t a, uint32_t b) { return (uint64_t(a) << 32) | b; };
  for (size_t t = 0; t < triangles.size(); ++t) {
    const auto& tri = triangles[t];
    for (int i = 0; i < 3; ++i) {
      if (tri[i] >= vertices.size()) return "triangle " + std::to_string(t) + ": bad index";
      if (tri[i] == tri[(i + 1) % 3]) return "triangle " + std::to_string(t) + ": repeated vertex";
      if (++directed[key(tri[i], tri[(i + 1) % 3])] > 1) {
        return "edge " + std::to_string(tri[i]) + "-" + std::to_string(tri[(i + 1) % 3]) +
               " used twice in the same direction (non-manifold or inconsistently oriented)";
      }
    }
  }
  for (const auto& [k, n] : directed) {
    const uint32_t a = uint32_t(k >> 32), b = uint32_t(k);
    if (!directed.count(key(b, a))) {
      return "edge " + std::to_string(a) + "-" + std::to_string(b) + " has one triangle (a hole)";
    }
  }
  // Vertex manifoldness: around each vertex, the edges opposite to it (b -> c for a triangle
  // a b c) chain into a single cycle.
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> fans(vertices.size());
  for (const auto& tri : triangles)
    for (int i = 0; i < 3; ++i) fans[tri[i]].push_back({tri[(i + 1) % 3], tri[(i + 2) % 3]});
  for (size_t v = 0; v < vertices.size(); ++v) {
    const auto& f = fans[v];
    if (f.empty()) continue;  // unused vertex: harmless
    std::unordered_map<uint32_t, uint32_t> next;
    for (const auto& [b, c] : f) next[b] = c;
    uint32_t start = f[0].first, cur = start;
    size_t steps = 0;
    do {
      auto it = next.find(cur);
      if (it == next.end()) return "vertex " + std::to_string(v) + ": open fan";
      cur = it->second;
      ++steps;
    } while (cur != start && steps <= f.size());
    if (steps != f.size()) {
      return "vertex " + std::to_string(v) + ": " + std::to_string(f.size()) +
             " triangles in more than one fan (non-manifold vertex)";
    }
  }
  return "";
}

/// The signed volume enclosed (positive when the triangles face outward).
inline double mesh_volume(const std::vector<Vec3>& v,
                          std::span<const std::array<uint32_t, 3>> triangles) {
  double vol = 0;
  for (const auto& t : triangles) {
    const Vec3 a = v[t[0]], b = v[t[1]], c = v[t[2]];
    vol += (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) -
            double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
            double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) /
           6.0;
  }
  return vol;
}

inline double mesh_area(const std::vector<Vec3>& v,
                        std::span<const std::array<uint32_t, 3>> triangles) {
  double area = 0;
  for (const auto& t : triangles)
    area += 0.5 * double(length(cross(v[t[1]] - v[t[0]], v[t[2]] - v[t[0]])));
  return area;
}

/// Distance from p to the triangle abc (Ericson, Real-Time Collision Detection, 5.1.5).
inline double point_triangle_distance(Vec3 p, Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const float d1 = dot(ab, ap), d2 = dot(ac, ap);
  auto dist = [&](Vec3 q) { return double(length(p - q)); };
  if (d1 <= 0 && d2 <= 0) return dist(a);
  const Vec3 bp = p - b;
  const float d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return dist(b);
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return dist(a + ab * (d1 / (d1 - d3)));
  const Vec3 cp = p - c;
  const float d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dist(c);
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return dist(a + ac * (d2 / (d2 - d6)));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return dist(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
  const float denom = 1.0f / (va + vb + vc);
  return dist(a + ab * (vb * denom) + ac * (vc * denom));
}

/// Distance from p to the nearest triangle of the mesh (brute force).
inline double point_mesh_distance(Vec3 p, const std::vector<Vec3>& v,
                                  std::span<const std::array<uint32_t, 3>> triangles) {
  double best = 1e30;
  for (const auto& t : triangles)
    best = std::min(best, point_triangle_distance(p, v[t[0]], v[t[1]], v[t[2]]));
  return best;
}

}  // namespace hfrt::mesher::testing
