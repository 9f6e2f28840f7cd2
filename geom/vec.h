#pragma once
// Small single-precision vector maths for geom/ (meshes, BVHs, Bézier patches). geom/ sits
// below jit/ and render/ in the dependency order, so it has its own tiny Vec3 rather than
// borrowing render/vec.h; the two are member-wise identical and convert trivially.

#include <algorithm>
#include <cmath>
#include <limits>

namespace hfrt::geom {

/// A 3-vector (point or direction).
struct Vec3 {
  float x = 0, y = 0, z = 0;

  constexpr Vec3() = default;
  constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}

  constexpr float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

constexpr Vec3 operator+(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
constexpr Vec3 operator-(Vec3 a, Vec3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
constexpr Vec3 operator-(Vec3 a) {
  return {-a.x, -a.y, -a.z};
}
constexpr Vec3 operator*(Vec3 a, float s) {
  return {a.x * s, a.y * s, a.z * s};
}
constexpr Vec3 operator*(float s, Vec3 a) {
  return a * s;
}
constexpr Vec3 operator/(Vec3 a, float s) {
  return {a.x / s, a.y / s, a.z / s};
}
inline Vec3& operator+=(Vec3& a, Vec3 b) {
  return a = a + b;
}

constexpr float dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
constexpr Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(Vec3 a) {
  return std::sqrt(dot(a, a));
}
inline float length2(Vec3 a) {
  return dot(a, a);
}
/// Unit vector along `a`; `a` unchanged when it has no direction (zero or NaN length).
inline Vec3 normalize(Vec3 a) {
  float l = length(a);
  return (l > 0 && std::isfinite(l)) ? a / l : a;
}
inline bool is_finite(Vec3 a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}
inline Vec3 vmin(Vec3 a, Vec3 b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
inline Vec3 vmax(Vec3 a, Vec3 b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}

/// An axis-aligned box; the default box is empty (lo = +inf, hi = -inf) so that extend()
/// needs no special first case.
struct Bounds3 {
  Vec3 lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
          std::numeric_limits<float>::infinity()};
  Vec3 hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
          -std::numeric_limits<float>::infinity()};

  constexpr Bounds3() = default;
  constexpr Bounds3(Vec3 lo_, Vec3 hi_) : lo(lo_), hi(hi_) {}

  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
  void extend(Vec3 p) {
    lo = vmin(lo, p);
    hi = vmax(hi, p);
  }
  void extend(const Bounds3& b) {
    lo = vmin(lo, b.lo);
    hi = vmax(hi, b.hi);
  }
  Vec3 center() const { return (lo + hi) * 0.5f; }
  Vec3 diagonal() const { return hi - lo; }
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
  float distance2(const Bounds3& b) const {
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

/// A ray org + t dir. `dir` need not be unit length: t is measured in units of |dir|.
struct Ray {
  Vec3 org, dir;
};

}  // namespace hfrt::geom
