#pragma once
// Analytic Fields for renderer tests and benchmarks: exact values, gradients and sound,
// tight intervals, so that render results can be checked against closed-form answers.
// Header-only; shared by tests/render/ and bench/render_bench.cpp.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "render/field.h"
#include "render/poly_solve.h"

namespace hfrt::render::testing {

/// Widens [lo, hi] computed in double outward by a little, then rounds outward to float.
inline Interval widen(double lo, double hi) {
  double pad = 1e-6 * std::max(std::abs(lo), std::abs(hi)) + 1e-12;
  return {std::nextafter(float(lo - pad), -std::numeric_limits<float>::infinity()),
          std::nextafter(float(hi + pad), std::numeric_limits<float>::infinity())};
}

/// [min, max] of |p - c| over the box (exact, in double).
inline void distance_range(const Box& b, Vec3 c, double* dmin, double* dmax) {
  double near2 = 0, far2 = 0;
  for (int i = 0; i < 3; ++i) {
    double lo = double(b.lo[i]) - c[i], hi = double(b.hi[i]) - c[i];
    double n = lo > 0 ? lo : (hi < 0 ? -hi : 0.0);
    double f = std::max(std::abs(lo), std::abs(hi));
    near2 += n * n;
    far2 += f * f;
  }
  *dmin = std::sqrt(near2);
  *dmax = std::sqrt(far2);
}

/// Appends the real roots in [t0, t1] of c[0] + c[1] t + ... + c[4] t^4 to `out` (the closed-form
/// leaf candidates of the analytic root search).
inline void push_roots(const double c[5], float t0, float t1, std::vector<double>* out) {
  double r[4];
  int n = solve_polynomial(c, r);
  for (int i = 0; i < n; ++i)
    if (r[i] >= t0 && r[i] <= t1) out->push_back(r[i]);
}

/// Coefficients of |q(t)|^2 - k for q(t) = q0 + t d (in double): c0 + c1 t + c2 t^2.
inline void sphere_poly(const double q0[3], const double d[3], double k, double c[5]) {
  c[0] = q0[0] * q0[0] + q0[1] * q0[1] + q0[2] * q0[2] - k;
  c[1] = 2 * (q0[0] * d[0] + q0[1] * d[1] + q0[2] * d[2]);
  c[2] = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  c[3] = c[4] = 0;
}

/// Candidates of a ball (or sphere surface) of radius r about `center` on the ray o + t d.
inline void sphere_candidates(Vec3 center, double r, Vec3 o, Vec3 d, float t0, float t1,
                              std::vector<double>* out) {
  double q0[3] = {double(o.x) - center.x, double(o.y) - center.y, double(o.z) - center.z};
  double dd[3] = {d.x, d.y, d.z};
  double c[5];
  sphere_poly(q0, dd, r * r, c);
  push_roots(c, t0, t1, out);
}

/// Candidates of the torus about the axis `u` (unit) through `center`: the roots of
/// (|q|^2 + R^2 - r^2)^2 - 4 R^2 rho^2, rho the distance of q to the axis.
inline void torus_candidates(const double center[3], const double u[3], double R, double r, Vec3 o,
                             Vec3 d, float t0, float t1, std::vector<double>* out) {
  double q0[3] = {double(o.x) - center[0], double(o.y) - center[1], double(o.z) - center[2]};
  double dd[3] = {d.x, d.y, d.z};
  double a[5], b[5];
  sphere_poly(q0, dd, r * r - R * R, a);  // |q|^2 + R^2 - r^2
  double qu = q0[0] * u[0] + q0[1] * u[1] + q0[2] * u[2];
  double du = dd[0] * u[0] + dd[1] * u[1] + dd[2] * u[2];
  sphere_poly(q0, dd, 0, b);  // rho^2 = |q|^2 - (q.u)^2
  b[0] -= qu * qu;
  b[1] -= 2 * qu * du;
  b[2] -= du * du;
  double c[5] = {a[0] * a[0] - 4 * R * R * b[0], 2 * a[0] * a[1] - 4 * R * R * b[1],
                 a[1] * a[1] + 2 * a[0] * a[2] - 4 * R * R * b[2], 2 * a[1] * a[2], a[2] * a[2]};
  push_roots(c, t0, t1, out);
}

/// Base: counts calls (to check that culling skips work) and computes the gradient by
/// a per-point virtual, which is fine for tests.
class AnalyticField : public Field {
 public:
  /// F and its gradient at one point, in double.
  virtual double value(double x, double y, double z) const = 0;
  virtual Vec3 gradient(double x, double y, double z) const = 0;
  virtual Interval interval(const Box& box) const = 0;

  void eval(size_t n, const float* x, const float* y, const float* z, float* out) const override {
    for (size_t i = 0; i < n; ++i) out[i] = float(value(x[i], y[i], z[i]));
  }
  bool has_interval() const override { return intervals_; }
  Interval eval_interval(const Box& box, bool* maybe_nan) const override {
    *maybe_nan = false;
    interval_calls.fetch_add(1, std::memory_order_relaxed);
    return interval(box);
  }
  void eval_intervals(size_t n, const Box* boxes, Interval* out, bool* maybe_nan) const override {
    interval_batches.fetch_add(1, std::memory_order_relaxed);
    Field::eval_intervals(n, boxes, out, maybe_nan);
  }
  void eval_gradient(size_t n, const float* x, const float* y, const float* z, float* f, float* dx,
                     float* dy, float* dz) const override {
    for (size_t i = 0; i < n; ++i) {
      f[i] = float(value(x[i], y[i], z[i]));
      Vec3 g = gradient(x[i], y[i], z[i]);
      dx[i] = g.x, dy[i] = g.y, dz[i] = g.z;
    }
  }
  /// Pretend there is no interval evaluator (to test the sign-change path and fallbacks).
  void set_has_interval(bool on) { intervals_ = on; }

  /// eval_interval() calls (boxes), and eval_intervals() calls (batches of them).
  mutable std::atomic<long> interval_calls{0};
  mutable std::atomic<long> interval_batches{0};

 private:
  bool intervals_ = true;
};

/// F = r - |p - c|: a ball.
class SphereField : public AnalyticField {
 public:
  SphereField(Vec3 c, double r) : c_(c), r_(r) {}
  double value(double x, double y, double z) const override {
    return r_ -
           std::sqrt((x - c_.x) * (x - c_.x) + (y - c_.y) * (y - c_.y) + (z - c_.z) * (z - c_.z));
  }
  Vec3 gradient(double x, double y, double z) const override {
    Vec3 d{float(x - c_.x), float(y - c_.y), float(z - c_.z)};
    return -normalize(d);
  }
  Interval interval(const Box& b) const override {
    double dmin, dmax;
    distance_range(b, c_, &dmin, &dmax);
    return widen(r_ - dmax, r_ - dmin);
  }
  bool has_ray_candidates() const override { return candidates_; }
  void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const override {
    sphere_candidates(c_, r_, o, d, t0, t1, out);
  }
  /// Pretend there are no ray candidates (the field then renders by interval or sign).
  void set_has_ray_candidates(bool on) { candidates_ = on; }

 private:
  Vec3 c_;
  double r_;
  bool candidates_ = true;
};

/// A spherical shell: the ball of radius r minus the ball of radius r - thickness.
/// F = min(r - |p|, |p| - (r - thickness)).
class ShellField : public AnalyticField {
 public:
  ShellField(double r, double thickness) : r_(r), ri_(r - thickness) {}
  double value(double x, double y, double z) const override {
    double d = std::sqrt(x * x + y * y + z * z);
    return std::min(r_ - d, d - ri_);
  }
  Vec3 gradient(double x, double y, double z) const override {
    double d = std::sqrt(x * x + y * y + z * z);
    Vec3 radial = normalize(Vec3{float(x), float(y), float(z)});
    return (r_ - d < d - ri_) ? -radial : radial;
  }
  Interval interval(const Box& b) const override {
    double dmin, dmax;
    distance_range(b, {0, 0, 0}, &dmin, &dmax);
    return widen(std::min(r_ - dmax, dmin - ri_), std::min(r_ - dmin, dmax - ri_));
  }
  bool has_ray_candidates() const override { return true; }
  void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const override {
    sphere_candidates({0, 0, 0}, r_, o, d, t0, t1, out);
    sphere_candidates({0, 0, 0}, ri_, o, d, t0, t1, out);
  }

 private:
  double r_, ri_;
};

/// A torus around the y axis: F = r - sqrt((sqrt(x^2 + z^2) - R)^2 + y^2).
class TorusField : public AnalyticField {
 public:
  TorusField(double major, double minor) : R_(major), r_(minor) {}
  double value(double x, double y, double z) const override {
    double q = std::sqrt(x * x + z * z) - R_;
    return r_ - std::sqrt(q * q + y * y);
  }
  Vec3 gradient(double x, double y, double z) const override {
    double rho = std::sqrt(x * x + z * z);
    double q = rho - R_;
    double len = std::sqrt(q * q + y * y);
    if (rho == 0 || len == 0) return {0, 0, 0};
    return {float(-q / len * x / rho), float(-y / len), float(-q / len * z / rho)};
  }
  Interval interval(const Box& b) const override {
    // rho = distance to the y axis over the box's xz rectangle.
    auto axis_range = [](double lo, double hi, double* n, double* f) {
      *n = lo > 0 ? lo : (hi < 0 ? -hi : 0.0);
      *f = std::max(std::abs(lo), std::abs(hi));
    };
    double nx, fx, nz, fz, ny, fy;
    axis_range(b.lo.x, b.hi.x, &nx, &fx);
    axis_range(b.lo.z, b.hi.z, &nz, &fz);
    axis_range(b.lo.y, b.hi.y, &ny, &fy);
    double rho_lo = std::sqrt(nx * nx + nz * nz), rho_hi = std::sqrt(fx * fx + fz * fz);
    double q_lo = rho_lo - R_, q_hi = rho_hi - R_;
    double q2_lo = (q_lo <= 0 && q_hi >= 0) ? 0.0 : std::min(q_lo * q_lo, q_hi * q_hi);
    double q2_hi = std::max(q_lo * q_lo, q_hi * q_hi);
    return widen(r_ - std::sqrt(q2_hi + fy * fy), r_ - std::sqrt(q2_lo + ny * ny));
  }
  bool has_ray_candidates() const override { return true; }
  void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const override {
    const double center[3] = {0, 0, 0}, axis[3] = {0, 1, 0};
    torus_candidates(center, axis, R_, r_, o, d, t0, t1, out);
  }

 private:
  double R_, r_;
};

/// Union (max) of balls: F = max_i (r_i - |p - c_i|). Many primitives for benchmarks.
class BallsField : public AnalyticField {
 public:
  struct Ball {
    Vec3 c;
    double r;
  };
  explicit BallsField(std::vector<Ball> balls) : balls_(std::move(balls)) {}
  double value(double x, double y, double z) const override {
    double f = -std::numeric_limits<double>::infinity();
    for (const Ball& b : balls_) {
      f = std::max(f, b.r - std::sqrt((x - b.c.x) * (x - b.c.x) + (y - b.c.y) * (y - b.c.y) +
                                      (z - b.c.z) * (z - b.c.z)));
    }
    return f;
  }
  Vec3 gradient(double x, double y, double z) const override {
    double best = -std::numeric_limits<double>::infinity();
    Vec3 g;
    for (const Ball& b : balls_) {
      Vec3 d{float(x - b.c.x), float(y - b.c.y), float(z - b.c.z)};
      double f = b.r - length(d);
      if (f > best) best = f, g = -normalize(d);
    }
    return g;
  }
  Interval interval(const Box& box) const override {
    double lo = -std::numeric_limits<double>::infinity(), hi = lo;
    for (const Ball& b : balls_) {
      double dmin, dmax;
      distance_range(box, b.c, &dmin, &dmax);
      lo = std::max(lo, b.r - dmax);
      hi = std::max(hi, b.r - dmin);
    }
    return widen(lo, hi);
  }
  bool has_ray_candidates() const override { return true; }
  void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const override {
    for (const Ball& b : balls_) sphere_candidates(b.c, b.r, o, d, t0, t1, out);
  }

 private:
  std::vector<Ball> balls_;
};

/// A solid of quadric, plane and torus leaves in disjunctive form: the union (max) of parts,
/// each the intersection (min) of leaves or complements of leaves (a difference). Every leaf's
/// F is a 1-Lipschitz distance bound (r - |q| for a ball, r - distance to the axis for a
/// cylinder, the signed distance for a half-space, r - sqrt((rho - R)^2 + h^2) for a torus), so
/// F is 1-Lipschitz too: that gives sound intervals (F(centre) +- half the diagonal) and lets a
/// test find exact first hits by sphere tracing, independently of the polynomial solvers.
/// Candidates are the real roots of each leaf's polynomial with the same zero set.
class CsgField : public AnalyticField {
 public:
  struct Leaf {
    enum class Kind { kBall, kCylinder, kHalfSpace, kTorus };
    Kind kind;
    double c[3];              ///< centre / a point on the axis / a point on the plane
    double u[3];              ///< unit axis (cylinder, torus) or outward unit normal (half-space)
    double R = 0, r = 0;      ///< torus radii; r: ball or cylinder radius
    bool complement = false;  ///< use -F (subtract the leaf)
  };
  using Part = std::vector<Leaf>;

  explicit CsgField(std::vector<Part> parts) : parts_(std::move(parts)) {}

  static Leaf ball(const double c[3], double r) {
    Leaf l{Leaf::Kind::kBall, {c[0], c[1], c[2]}, {0, 0, 1}};
    l.r = r;
    return l;
  }
  static Leaf cylinder(const double c[3], const double u[3], double r) {
    Leaf l{Leaf::Kind::kCylinder, {c[0], c[1], c[2]}, {u[0], u[1], u[2]}};
    normalize3(l.u);
    l.r = r;
    return l;
  }
  static Leaf half_space(const double c[3], const double n[3]) {
    Leaf l{Leaf::Kind::kHalfSpace, {c[0], c[1], c[2]}, {n[0], n[1], n[2]}};
    normalize3(l.u);
    return l;
  }
  static Leaf torus(const double c[3], const double u[3], double R, double r) {
    Leaf l{Leaf::Kind::kTorus, {c[0], c[1], c[2]}, {u[0], u[1], u[2]}};
    normalize3(l.u);
    l.R = R;
    l.r = r;
    return l;
  }
  static Leaf subtract(Leaf l) {
    l.complement = !l.complement;
    return l;
  }
  /// The six half-spaces of an axis-aligned box.
  static Part box(const double lo[3], const double hi[3]) {
    Part p;
    for (int i = 0; i < 3; ++i) {
      double n[3] = {0, 0, 0};
      n[i] = -1;
      p.push_back(half_space(lo, n));
      n[i] = 1;
      p.push_back(half_space(hi, n));
    }
    return p;
  }

  static double leaf_value(const Leaf& l, double x, double y, double z) {
    double q[3] = {x - l.c[0], y - l.c[1], z - l.c[2]};
    double qu = q[0] * l.u[0] + q[1] * l.u[1] + q[2] * l.u[2];
    double q2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
    double rho = std::sqrt(std::max(0.0, q2 - qu * qu));
    double f = 0;
    switch (l.kind) {
      case Leaf::Kind::kBall:
        f = l.r - std::sqrt(q2);
        break;
      case Leaf::Kind::kCylinder:
        f = l.r - rho;
        break;
      case Leaf::Kind::kHalfSpace:
        f = -qu;
        break;
      case Leaf::Kind::kTorus:
        f = l.r - std::hypot(rho - l.R, qu);
        break;
    }
    return l.complement ? -f : f;
  }

  double value(double x, double y, double z) const override {
    double f = -std::numeric_limits<double>::infinity();
    for (const Part& p : parts_) {
      double g = std::numeric_limits<double>::infinity();
      for (const Leaf& l : p) g = std::min(g, leaf_value(l, x, y, z));
      f = std::max(f, g);
    }
    return f;
  }
  Vec3 gradient(double x, double y, double z) const override {
    const double h = 1e-6;
    return {float((value(x + h, y, z) - value(x - h, y, z)) / (2 * h)),
            float((value(x, y + h, z) - value(x, y - h, z)) / (2 * h)),
            float((value(x, y, z + h) - value(x, y, z - h)) / (2 * h))};
  }
  Interval interval(const Box& b) const override {
    Vec3 c = b.center(), s = b.size();
    double f = value(c.x, c.y, c.z);
    double half_diag = 0.5 * std::sqrt(double(s.x) * s.x + double(s.y) * s.y + double(s.z) * s.z);
    return widen(f - half_diag, f + half_diag);
  }
  bool has_ray_candidates() const override { return true; }
  void ray_candidates(Vec3 o, Vec3 d, float t0, float t1, std::vector<double>* out) const override {
    for (const Part& p : parts_) {
      for (const Leaf& l : p) {
        double q0[3] = {double(o.x) - l.c[0], double(o.y) - l.c[1], double(o.z) - l.c[2]};
        double dd[3] = {d.x, d.y, d.z};
        double qu = q0[0] * l.u[0] + q0[1] * l.u[1] + q0[2] * l.u[2];
        double du = dd[0] * l.u[0] + dd[1] * l.u[1] + dd[2] * l.u[2];
        double c[5] = {0, 0, 0, 0, 0};
        switch (l.kind) {
          case Leaf::Kind::kBall:
            sphere_poly(q0, dd, l.r * l.r, c);
            break;
          case Leaf::Kind::kCylinder:
            sphere_poly(q0, dd, l.r * l.r, c);
            c[0] -= qu * qu;
            c[1] -= 2 * qu * du;
            c[2] -= du * du;
            break;
          case Leaf::Kind::kHalfSpace:
            c[0] = qu;
            c[1] = du;
            break;
          case Leaf::Kind::kTorus:
            torus_candidates(l.c, l.u, l.R, l.r, o, d, t0, t1, out);
            continue;
        }
        push_roots(c, t0, t1, out);
      }
    }
  }

 private:
  static void normalize3(double v[3]) {
    double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; ++i) v[i] /= l;
  }
  std::vector<Part> parts_;
};

/// A ball with colour attributes s[1..3] = a colour that depends on the point (red on +x, blue
/// on -x), to check that the renderer uses them.
class ColouredSphereField : public SphereField {
 public:
  using SphereField::SphereField;
  int num_attributes() const override { return 3; }
  void eval_attributes(size_t n, const float* x, const float*, const float*,
                       float* s) const override {
    for (size_t i = 0; i < n; ++i) {
      bool right = x[i] > 0;
      s[i] = right ? 1.0f : 0.0f;          // s[1] red
      s[n + i] = 0.0f;                     // s[2] green
      s[2 * n + i] = right ? 0.0f : 1.0f;  // s[3] blue
    }
  }
};

/// A ball whose F has no value (NaN) where x > 0, like sqrt of a negative in a model.
class HalfNanSphereField : public SphereField {
 public:
  using SphereField::SphereField;
  double value(double x, double y, double z) const override {
    return x > 0 ? std::numeric_limits<double>::quiet_NaN() : SphereField::value(x, y, z);
  }
  Interval eval_interval(const Box& box, bool* maybe_nan) const override {
    Interval iv = SphereField::eval_interval(box, maybe_nan);
    *maybe_nan = box.hi.x > 0;
    return iv;
  }
  std::string explain_nan(Vec3 p) const override { return "sqrt of a negative (test)"; }
};

}  // namespace hfrt::render::testing
