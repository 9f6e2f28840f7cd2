#include "render/poly_solve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <random>
#include <vector>

namespace hfrt::render {
namespace {

// ---------------------------------------------------------------------------------------------
// Reference: eigenvalues of the companion matrix by the shifted (Francis double-shift) QR
// iteration on an upper Hessenberg matrix (the companion matrix already is one). Independent of
// the closed forms under test.

/// Eigenvalues of the n x n upper Hessenberg matrix `a` (destroyed). Returns false when the
/// iteration does not converge.
bool hessenberg_eigenvalues(double a[4][4], int n, double* wr, double* wi) {
  double anorm = 0;
  for (int i = 0; i < n; ++i)
    for (int j = std::max(i - 1, 0); j < n; ++j) anorm += std::abs(a[i][j]);
  int nn = n - 1, l = 0;
  double t = 0;
  while (nn >= 0) {
    int its = 0;
    do {
      for (l = nn; l > 0; --l) {
        double s = std::abs(a[l - 1][l - 1]) + std::abs(a[l][l]);
        if (s == 0) s = anorm;
        if (std::abs(a[l][l - 1]) + s == s) {
          a[l][l - 1] = 0;
          break;
        }
      }
      double x = a[nn][nn];
      if (l == nn) {  // one eigenvalue deflated
        wr[nn] = x + t;
        wi[nn--] = 0;
      } else {
        double y = a[nn - 1][nn - 1], w = a[nn][nn - 1] * a[nn - 1][nn];
        if (l == nn - 1) {  // a 2x2 block deflated
          double p = 0.5 * (y - x), q = p * p + w, z = std::sqrt(std::abs(q));
          x += t;
          if (q >= 0) {
            z = p + std::copysign(z, p);
            wr[nn - 1] = wr[nn] = x + z;
            if (z != 0) wr[nn] = x - w / z;
            wi[nn - 1] = wi[nn] = 0;
          } else {
            wr[nn - 1] = wr[nn] = x + p;
            wi[nn - 1] = -(wi[nn] = z);
          }
          nn -= 2;
        } else {
          if (its == 200) return false;
          if (its > 0 && its % 10 == 0) {  // exceptional shift, varied so cycles are broken
            t += x;
            for (int i = 0; i <= nn; ++i) a[i][i] -= x;
            double s = std::abs(a[nn][nn - 1]) + std::abs(a[nn - 1][nn - 2]);
            y = x = (0.75 + 0.01 * its) * s;
            w = -0.4375 * s * s;
          }
          ++its;
          int m;
          double p = 0, q = 0, r = 0, z;
          for (m = nn - 2; m >= l; --m) {
            z = a[m][m];
            r = x - z;
            double s = y - z;
            p = (r * s - w) / a[m + 1][m] + a[m][m + 1];
            q = a[m + 1][m + 1] - z - r - s;
            r = a[m + 2][m + 1];
            s = std::abs(p) + std::abs(q) + std::abs(r);
            p /= s, q /= s, r /= s;
            if (m == l) break;
            double u = std::abs(a[m][m - 1]) * (std::abs(q) + std::abs(r));
            double v =
                std::abs(p) * (std::abs(a[m - 1][m - 1]) + std::abs(z) + std::abs(a[m + 1][m + 1]));
            if (u + v == v) break;
          }
          for (int i = m + 2; i <= nn; ++i) {
            a[i][i - 2] = 0;
            if (i != m + 2) a[i][i - 3] = 0;
          }
          for (int k = m; k <= nn - 1; ++k) {
            if (k != m) {
              p = a[k][k - 1];
              q = a[k + 1][k - 1];
              r = k + 1 != nn ? a[k + 2][k - 1] : 0;
              x = std::abs(p) + std::abs(q) + std::abs(r);
              if (x != 0) p /= x, q /= x, r /= x;
            }
            double s = std::copysign(std::sqrt(p * p + q * q + r * r), p);
            if (s != 0) {
              if (k == m) {
                if (l != m) a[k][k - 1] = -a[k][k - 1];
              } else {
                a[k][k - 1] = -s * x;
              }
              p += s;
              x = p / s, y = q / s, z = r / s;
              q /= p, r /= p;
              for (int j = k; j <= nn; ++j) {
                p = a[k][j] + q * a[k + 1][j];
                if (k + 1 != nn) {
                  p += r * a[k + 2][j];
                  a[k + 2][j] -= p * z;
                }
                a[k + 1][j] -= p * y;
                a[k][j] -= p * x;
              }
              int mmin = nn < k + 3 ? nn : k + 3;
              for (int i = l; i <= mmin; ++i) {
                p = x * a[i][k] + y * a[i][k + 1];
                if (k + 1 != nn) {
                  p += z * a[i][k + 2];
                  a[i][k + 2] -= p * r;
                }
                a[i][k + 1] -= p * q;
                a[i][k] -= p;
              }
            }
          }
        }
      }
    } while (nn >= 0 && l < nn - 1);
  }
  return true;
}

/// All complex roots of c[0] + ... + c[n] t^n (c[n] != 0) as companion-matrix eigenvalues.
std::vector<std::complex<double>> companion_roots(const double* c, int n) {
  // Scale t = s u (s a power of two) so the companion matrix is balanced.
  double bound = 0;
  for (int k = 0; k < n; ++k)
    if (c[k] != 0) bound = std::max(bound, std::pow(std::abs(c[k] / c[n]), 1.0 / (n - k)));
  int e = 0;
  if (bound > 0) std::frexp(bound, &e);
  double a[4][4] = {};
  for (int i = 1; i < n; ++i) a[i][i - 1] = 1;
  for (int i = 0; i < n; ++i) a[i][n - 1] = -c[i] / c[n] * std::ldexp(1.0, (i - n) * e);
  // Balance (Parlett-Reinsch, powers of two): companion matrices of polynomials with roots of
  // very different sizes have rows and columns of very different norms, which costs the QR
  // iteration most of the accuracy of the small eigenvalues.
  for (bool done = false; !done;) {
    done = true;
    for (int i = 0; i < n; ++i) {
      double r = 0, col = 0;
      for (int j = 0; j < n; ++j)
        if (j != i) col += std::abs(a[j][i]), r += std::abs(a[i][j]);
      if (col == 0 || r == 0) continue;
      double g = r / 2, f = 1, sum = col + r;
      while (col < g) f *= 2, col *= 4;
      g = r * 2;
      while (col > g) f /= 2, col /= 4;
      if ((col + r) / f < 0.95 * sum) {
        done = false;
        for (int j = 0; j < n; ++j) a[i][j] /= f;
        for (int j = 0; j < n; ++j) a[j][i] *= f;
      }
    }
  }
  double wr[4], wi[4];
  EXPECT_TRUE(hessenberg_eigenvalues(a, n, wr, wi));
  // The eigenvalues of clustered small roots next to a large one are only accurate to a
  // fraction of the large one; a few complex Newton steps in long double on the polynomial
  // sharpen each (they start close enough to stay on their root).
  std::vector<std::complex<double>> out;
  // Eigenvalues of a multiple root (a cluster within 1e-3 of each other) are left alone: Newton
  // converges only linearly there.
  for (int i = 0; i < n; ++i) {
    std::complex<long double> z(std::ldexp(wr[i], e), std::ldexp(wi[i], e));
    bool clustered = false;
    for (int j = 0; j < n; ++j)
      clustered |=
          j != i && std::hypot(wr[j] - wr[i], wi[j] - wi[i]) < 1e-3 * std::hypot(wr[i], wi[i]);
    for (int it = 0; it < 8 && !clustered; ++it) {
      std::complex<long double> p = c[n], dp = 0;
      for (int k = n - 1; k >= 0; --k) {
        dp = dp * z + p;
        p = p * z + (long double)c[k];
      }
      if (dp == std::complex<long double>(0)) break;
      std::complex<long double> nz = z - p / dp;
      if (!(std::abs(nz - z) < 0.5L * std::abs(z) + 1e-30L)) break;  // no jumping to a neighbour
      z = nz;
    }
    out.emplace_back(double(z.real()), double(z.imag()));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Test polynomials built from known roots.

struct Root {
  double re, im;  // im > 0: the pair re +- i im
  int multiplicity;
};

struct TestPoly {
  double c[5] = {0, 0, 0, 0, 0};
  int degree = 0;
  std::vector<Root> roots;
};

/// Multiplies out lead * prod (t - r)^m (t^2 - 2 re t + re^2 + im^2) in long double.
TestPoly expand(const std::vector<Root>& roots, double lead) {
  long double p[5] = {lead, 0, 0, 0, 0};
  int deg = 0;
  auto mul = [&](long double f0, long double f1, long double f2, int fd) {
    long double q[5] = {0, 0, 0, 0, 0};
    for (int i = 0; i <= deg; ++i) {
      q[i] += p[i] * f0;
      q[i + 1] += p[i] * f1;
      if (fd == 2) q[i + 2] += p[i] * f2;
    }
    deg += fd;
    std::copy(q, q + 5, p);
  };
  for (const Root& r : roots) {
    for (int k = 0; k < r.multiplicity; ++k) {
      if (r.im > 0)
        mul((long double)r.re * r.re + (long double)r.im * r.im, -2.0L * r.re, 1, 2);
      else
        mul(-(long double)r.re, 1, 0, 1);
    }
  }
  TestPoly out;
  out.degree = deg;
  out.roots = roots;
  for (int i = 0; i <= 4; ++i) out.c[i] = double(p[i]);
  return out;
}

/// Root shapes per degree: each entry lists multiplicities of real roots (1..3) and 'c' for a
/// complex pair (written as 0).
const std::vector<std::vector<int>> kShapes[5] = {
    {},
    {},
    {{1, 1}, {2}, {0}},
    {{1, 1, 1}, {2, 1}, {3}, {1, 0}},
    {{1, 1, 1, 1}, {2, 1, 1}, {2, 2}, {3, 1}, {1, 1, 0}, {2, 0}, {0, 0}},
};

/// A random polynomial of the given degree. Exact family: every root (and every complex part)
/// is an integer in [1, 1023] times a shared power of two, so the coefficients (products of at
/// most four 10-bit integers) are exact in double and the roots are known exactly; magnitudes
/// 2^-10 .. 1023 (1e-3 .. 1e3). Distinct roots differ by at least 1% of their size, complex
/// parts are at least 1% of the modulus (closer than that they are numerically real).
TestPoly random_exact(std::mt19937_64& rng, int degree) {
  const auto& shapes = kShapes[degree];
  const auto& shape = shapes[std::uniform_int_distribution<size_t>(0, shapes.size() - 1)(rng)];
  int e = std::uniform_int_distribution<int>(-10, 0)(rng);
  double unit = std::ldexp(1.0, e);
  std::uniform_int_distribution<int> mant(1, 1023);
  std::uniform_int_distribution<int> sign(0, 1);
  for (;;) {
    std::vector<Root> roots;
    for (int m : shape) {
      if (m == 0) {
        double re = (sign(rng) ? -1 : 1) * (mant(rng) - 1) * unit;
        double im = mant(rng) * unit;
        roots.push_back({re, im, 1});
      } else {
        roots.push_back({(sign(rng) ? -1 : 1) * mant(rng) * unit, 0, m});
      }
    }
    bool ok = true;
    for (size_t i = 0; i < roots.size() && ok; ++i) {
      const Root& a = roots[i];
      if (a.im > 0 && a.im < 0.01 * std::hypot(a.re, a.im)) ok = false;
      for (size_t j = 0; j < i && ok; ++j) {
        const Root& b = roots[j];
        double d = std::hypot(a.re - b.re, a.im - b.im);
        if (d < 0.01 * std::max(std::hypot(a.re, a.im), std::hypot(b.re, b.im))) ok = false;
      }
    }
    if (!ok) continue;
    // Leading coefficient: a power of two, +-, keeps the coefficients exact.
    double lead =
        std::ldexp(sign(rng) ? -1.0 : 1.0, std::uniform_int_distribution<int>(-8, 8)(rng));
    return expand(roots, lead);
  }
}

/// A random polynomial with simple real roots and complex pairs of arbitrary double values
/// spread over 1e-3 .. 1e3 within one polynomial (coefficients rounded: roots known to the
/// conditioning of the rounded polynomial, which the separation keeps small).
TestPoly random_spread(std::mt19937_64& rng, int degree) {
  std::uniform_real_distribution<double> expo(-3, 3);
  std::uniform_int_distribution<int> sign(0, 1);
  auto magnitude = [&] { return (sign(rng) ? -1 : 1) * std::pow(10.0, expo(rng)); };
  for (;;) {
    std::vector<Root> roots;
    int left = degree;
    while (left > 0) {
      if (left >= 2 && sign(rng) && sign(rng)) {
        double re = magnitude(), im = std::abs(magnitude());
        roots.push_back({re, im, 1});
        left -= 2;
      } else {
        roots.push_back({magnitude(), 0, 1});
        left -= 1;
      }
    }
    bool ok = true;
    for (size_t i = 0; i < roots.size() && ok; ++i) {
      const Root& a = roots[i];
      if (a.im > 0 && a.im < 0.05 * std::hypot(a.re, a.im)) ok = false;
      for (size_t j = 0; j < i && ok; ++j) {
        const Root& b = roots[j];
        double d = std::hypot(a.re - b.re, a.im - b.im);
        if (d < 0.05 * std::max(std::hypot(a.re, a.im), std::hypot(b.re, b.im))) ok = false;
      }
    }
    if (!ok) continue;
    return expand(roots, magnitude());
  }
}

/// Checks the solver on `p`; returns the number of real roots checked.
int check(const TestPoly& p, const char* family) {
  double got[4] = {0, 0, 0, 0};
  int n = solve_polynomial(p.c, got);
  std::vector<Root> real;
  for (const Root& r : p.roots)
    if (r.im == 0) real.push_back(r);
  std::sort(real.begin(), real.end(), [](const Root& a, const Root& b) { return a.re < b.re; });
  auto describe = [&] {
    std::string s = std::string(family) + " degree " + std::to_string(p.degree) + " coeffs";
    for (int i = 0; i <= 4; ++i) s += " " + std::to_string(p.c[i]);
    s += " roots";
    for (const Root& r : p.roots)
      s += " (" + std::to_string(r.re) + "," + std::to_string(r.im) + ")^" +
           std::to_string(r.multiplicity);
    s += " got";
    for (int i = 0; i < n; ++i) s += " " + std::to_string(got[i]);
    return s;
  };
  // No spurious and no missing roots: exactly one per distinct real root, ascending.
  EXPECT_EQ(n, int(real.size())) << describe();
  if (n != int(real.size())) return 0;
  for (int i = 0; i < n; ++i) {
    double tol = real[i].multiplicity == 1 ? 1e-10 : 1e-5;
    EXPECT_LE(std::abs(got[i] - real[i].re), tol * std::abs(real[i].re))
        << "root " << i << " multiplicity " << real[i].multiplicity << ": " << describe();
  }
  // Cross-check against the companion matrix: every simple real root has a real eigenvalue
  // next to it, and every eigenvalue that is clearly real is one of the returned roots.
  // The QR iteration is backward stable: its eigenvalues carry an absolute error of about
  // eps times the largest root, amplified for clustered small roots; the tolerance allows for it
  // (it still tells a wrong or missing root).
  std::vector<std::complex<double>> eig = companion_roots(p.c, p.degree);
  double scale = 0;
  for (auto z : eig) scale = std::max(scale, std::abs(z));
  for (int i = 0; i < n; ++i) {
    if (real[i].multiplicity != 1) continue;
    double best = INFINITY;
    for (auto z : eig) best = std::min(best, std::abs(z - std::complex<double>(got[i], 0)));
    EXPECT_LE(best, 1e-6 * std::abs(got[i]) + 1e-7 * scale) << "companion mismatch: " << describe();
  }
  for (auto z : eig) {
    if (std::abs(z.imag()) > 1e-9 * scale) continue;
    // Eigenvalues of a multiple root scatter by eps^(1/m); those were checked against the
    // known roots above. Only isolated eigenvalues are compared.
    int near = 0;
    for (auto w : eig) near += std::abs(w - z) < 1e-2 * std::abs(z) + 1e-8 * scale;
    if (near > 1) continue;
    double best = INFINITY;
    for (int i = 0; i < n; ++i) best = std::min(best, std::abs(got[i] - z.real()));
    EXPECT_LE(best, 1e-3 * std::abs(z) + 1e-8 * scale)
        << "eigenvalue " << z.real() << " missing: " << describe();
  }
  return n;
}

TEST(PolySolve, RandomPolynomialsFromKnownRoots) {
  std::mt19937_64 rng(20261123);
  int polys = 0, roots = 0;
  for (int degree = 2; degree <= 4; ++degree) {
    for (int i = 0; i < 25000; ++i) {
      roots += check(random_exact(rng, degree), "exact");
      ++polys;
    }
    for (int i = 0; i < 10000; ++i) {
      roots += check(random_spread(rng, degree), "spread");
      ++polys;
    }
    if (::testing::Test::HasFailure()) break;
  }
  EXPECT_GE(polys, 100000);
  EXPECT_GT(roots, 150000);
}

TEST(PolySolve, VanishingLeadingCoefficientsDropTheDegree) {
  double r[4];
  // 0 t^4 + 0 t^3 + (t - 1)(t - 2): a quadratic.
  double c1[5] = {2, -3, 1, 0, 0};
  ASSERT_EQ(solve_polynomial(c1, r), 2);
  EXPECT_DOUBLE_EQ(r[0], 1);
  EXPECT_DOUBLE_EQ(r[1], 2);
  // A leading term at rounding level relative to the others (a ray parallel to a plane).
  double c2[5] = {-0.5, 1, 0, 1e-19, -1e-18};
  ASSERT_EQ(solve_polynomial(c2, r), 1);
  EXPECT_DOUBLE_EQ(r[0], 0.5);
  // Constant and zero polynomials have no isolated roots.
  double c3[5] = {1, 0, 0, 0, 0}, c4[5] = {0, 0, 0, 0, 0};
  EXPECT_EQ(solve_polynomial(c3, r), 0);
  EXPECT_EQ(solve_polynomial(c4, r), 0);
  // NaN coefficients: no roots rather than garbage.
  double c5[5] = {NAN, 1, 1, 0, 0};
  EXPECT_EQ(solve_polynomial(c5, r), 0);
}

TEST(PolySolve, MultipleRootsAtZeroAndTangentTorusRay) {
  double r[4];
  double c1[5] = {0, 0, 0, 0, 3};  // 3 t^4
  ASSERT_EQ(solve_polynomial(c1, r), 1);
  EXPECT_EQ(r[0], 0);
  // Torus R = 2, r0 = 1 around z, ray along x at height z = 1 (tangent to the tube's top):
  // (t^2 + 4 - 1 + 1)^2 - 16 t^2 = (t^2 - 4)^2: double roots at -2 and 2.
  double c2[5] = {16, 0, -8, 0, 1};
  ASSERT_EQ(solve_polynomial(c2, r), 2);
  EXPECT_NEAR(r[0], -2, 1e-7);
  EXPECT_NEAR(r[1], 2, 1e-7);
}

}  // namespace
}  // namespace hfrt::render
