#pragma once
// The one axis-aligned box of hfrt (BVH bounds in geom/, render and framing boxes in render/).

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/vec.h"

namespace hfrt {

/// An axis-aligned closed box of points. The default box is empty (lo = +inf, hi = -inf) so that
/// extend() needs no special first case.
struct Box {
  Vec3 lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
          std::numeric_limits<float>::infinity()};
  Vec3 hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
          -std::numeric_limits<float>::infinity()};

  constexpr Box() = default;
  constexpr Box(Vec3 lo_, Vec3 hi_) : lo(lo_), hi(hi_) {}

  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
  void extend(Vec3 p) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
  void extend(const Box& b) {
    lo = vmin(lo, b.lo);
    hi = vmax(hi, b.hi);
  }
  Vec3 center() const { return (lo + hi) * 0.5f; }
  Vec3 diagonal() const { return hi - lo; }
  Vec3 size() const { return hi - lo; }
  float max_extent() const {
    Vec3 s = size();
    return std::max(s.x, std::max(s.y, s.z));
  }
  /// Closed: points on the faces are inside.
  bool contains(Vec3 p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
  /// Whether box b lies in this one (closed; an empty b is contained).
  bool contains(const Box& b) const { return b.empty() || (contains(b.lo) && contains(b.hi)); }
  /// Half the surface area (the SAH only needs ratios); 0 for an empty box.
  float half_area() const {
    if (empty()) return 0;
    Vec3 d = diagonal();
    return d.x * d.y + d.y * d.z + d.z * d.x;
  }
  int max_axis() const {
    Vec3 d = diagonal();
    return d.x >= d.y && d.x >= d.z ? 0 : (d.y >= d.z ? 1 : 2);
  }
  /// Squared distance from `p` to the box (0 inside).
  float distance2(Vec3 p) const {
    float dx = std::max({lo.x - p.x, 0.0f, p.x - hi.x});
    float dy = std::max({lo.y - p.y, 0.0f, p.y - hi.y});
    float dz = std::max({lo.z - p.z, 0.0f, p.z - hi.z});
    return dx * dx + dy * dy + dz * dz;
  }
  /// Squared distance between two boxes (0 when they overlap or touch).
  float distance2(const Box& b) const {
    float dx = std::max({lo.x - b.hi.x, 0.0f, b.lo.x - hi.x});
    float dy = std::max({lo.y - b.hi.y, 0.0f, b.lo.y - hi.y});
    float dz = std::max({lo.z - b.hi.z, 0.0f, b.lo.z - hi.z});
    return dx * dx + dy * dy + dz * dz;
  }
  /// Squared distance from `p` to the farthest point of the box.
  float max_distance2(Vec3 p) const {
    float dx = std::max(std::abs(p.x - lo.x), std::abs(p.x - hi.x));
    float dy = std::max(std::abs(p.y - lo.y), std::abs(p.y - hi.y));
    float dz = std::max(std::abs(p.z - lo.z), std::abs(p.z - hi.z));
    return dx * dx + dy * dy + dz * dz;
  }
};

/// Intersection of two boxes (empty() when they do not overlap).
inline Box intersect(const Box& a, const Box& b) {
  return {vmax(a.lo, b.lo), vmin(a.hi, b.hi)};
}

}  // namespace hfrt
