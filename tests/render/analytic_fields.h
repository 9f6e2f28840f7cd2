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

  mutable std::atomic<long> interval_calls{0};

 private:
  bool intervals_ = true;
};

/// F = r - |p - c|: a ball.
class SphereField : public AnalyticField {
 public:
  SphereField(Vec3 c, double r) : c_(c), r_(r) {}
  double value(double x, double y, double z) const override {
    return r_ - std::sqrt((x - c_.x) * (x - c_.x) + (y - c_.y) * (y - c_.y) + (z - c_.z) * (z - c_.z));
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

 private:
  Vec3 c_;
  double r_;
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

 private:
  std::vector<Ball> balls_;
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
      s[i] = right ? 1.0f : 0.0f;           // s[1] red
      s[n + i] = 0.0f;                      // s[2] green
      s[2 * n + i] = right ? 0.0f : 1.0f;   // s[3] blue
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
