// Unit tests of the library's IR, built directly with IrBuilder and run by the reference
// interpreter (no front end): formulas against independent C++ evaluations of library.md,
// in-place writes, loops, the SARDF quartic, Perlin tables and the size warnings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "ir/builder.h"
#include "stdlib/lib_util.h"
#include "tests/stdlib/lib_harness.h"

namespace hfrt::stdlib {
namespace {

using lang::LibraryFn;
using testing::LibHarness;

constexpr double kFail = -1111111111111.0;

::testing::AssertionResult near_rel(double want, double got, double rel = 1e-12) {
  if (std::isnan(want) && std::isnan(got)) return ::testing::AssertionSuccess();
  if (std::abs(got - want) <= rel * std::max(1.0, std::abs(want))) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "want " << want << " got " << got;
}

// --- Algebraic primitives --------------------------------------------------------------

TEST(Primitives, SphereMatchesFormula) {
  LibHarness h;
  auto x = h.point();
  auto c = h.array({0.5, -1, 2});
  h.finish(h.call(LibraryFn::kSphere, {x, c, h.real(2.5)}));
  for (auto p : {std::vector<double>{0, 0, 0}, {1, 2, 3}, {-2, 0.25, 1}}) {
    const double d1 = p[0] - 0.5, d2 = p[1] + 1, d3 = p[2] - 2;
    EXPECT_TRUE(near_rel(2.5 * 2.5 - d1 * d1 - d2 * d2 - d3 * d3, h.eval(p).value));
  }
}

TEST(Primitives, EllipsoidFailureValueForTinySemiAxis) {
  LibHarness h;
  auto x = h.point();
  auto c = h.array({0, 0, 0});
  // b comes from x[2]: the check happens at run time.
  h.finish(h.call(LibraryFn::kEllipsoid, {x, c, h.real(2), h.real_from_input(1), h.real(1)}));
  EXPECT_EQ(kFail, h.eval({0.3, 1e-7, 0}).value);
  // b = 0.5 at this point: 1 - (0.3/2)^2 - (0.5/0.5)^2 - 0.
  EXPECT_TRUE(near_rel(1 - (0.3 / 2) * (0.3 / 2) - 1.0, h.eval({0.3, 0.5, 0}).value));
}

TEST(Primitives, TorusAxes) {
  for (auto fn : {LibraryFn::kTorusX, LibraryFn::kTorusY, LibraryFn::kTorusZ}) {
    LibHarness h;
    auto x = h.point();
    auto c = h.array({0.1, 0.2, 0.3});
    h.finish(h.call(fn, {x, c, h.real(2), h.real(0.5)}));
    const std::vector<double> p = {1.2, -0.7, 0.4};
    const double d[3] = {p[0] - 0.1, p[1] - 0.2, p[2] - 0.3};
    const int axis = fn == LibraryFn::kTorusX ? 0 : fn == LibraryFn::kTorusY ? 1 : 2;
    double rho2 = 0;
    for (int k = 0; k < 3; ++k) rho2 += k == axis ? 0 : d[k] * d[k];
    const double want = 0.25 - d[0] * d[0] - d[1] * d[1] - d[2] * d[2] - 4 + 4 * std::sqrt(rho2);
    EXPECT_TRUE(near_rel(want, h.eval(p).value)) << lang::library_fn_name(fn);
  }
}

TEST(Primitives, BlockIsRFunctionIntersectionAndChecksEdges) {
  LibHarness h;
  auto x = h.point();
  auto v = h.array({-1, -1, -1});
  h.finish(h.call(LibraryFn::kBlock, {x, v, h.real(2), h.real(2), h.real_from_input(2)}));
  // dz = x[3] < 0: failure value.
  EXPECT_EQ(kFail, h.eval({0, 0, -0.5}).value);
  const double z = 0.5;
  const double p1 = (0 + 1) * (-1 + 2 - 0), p2 = p1, p3 = (z + 1) * (-1 + z - z);
  const double g = p1 + p2 - std::sqrt(p1 * p1 + p2 * p2);
  EXPECT_TRUE(near_rel(g + p3 - std::sqrt(g * g + p3 * p3), h.eval({0, 0, z}).value));
}

TEST(Primitives, MetaballCases) {
  LibHarness h;
  auto x = h.point();
  auto x0 = h.array({0, 3, 0});
  auto y0 = h.array({0, 0, 0});
  auto z0 = h.array({0, 0, 0});
  auto b = h.array({2, 1, 5});
  auto d = h.array({3, 1, -1});  // the third blob has d <= 0: no contribution
  h.finish(h.call(LibraryFn::kMetaball, {x, x0, y0, z0, b, d, h.real(0.1)}));
  auto contribution = [](double r, double bb, double dd) {
    if (dd <= 0) return 0.0;
    const double q = r / dd;
    if (r <= dd / 3) return bb * (1 - 3 * q * q);
    if (r < dd) return 1.5 * bb * (1 - q) * (1 - q);
    return 0.0;
  };
  for (double px : {0.5, 1.5, 2.5, 2.9}) {
    const double want = contribution(std::abs(px), 2, 3) + contribution(std::abs(px - 3), 1, 1) +
                        contribution(std::abs(px), 5, -1) - 0.1;
    EXPECT_TRUE(near_rel(want, h.eval({px, 0, 0}).value)) << px;
  }
}

// --- Transformations -------------------------------------------------------------------

TEST(Transforms, RotateMovesThePointInPlace) {
  LibHarness h;
  auto x = h.point();
  auto r = h.call(LibraryFn::kRotate3DZ, {x, h.real(0.3)});
  h.finish(r, {x});
  auto res = h.eval({1, 2, 3});
  EXPECT_EQ(1.0, res.value);
  ASSERT_EQ(3u, res.s.size());
  EXPECT_TRUE(near_rel(1 * std::cos(0.3) + 2 * std::sin(0.3), res.s[0]));
  EXPECT_TRUE(near_rel(-1 * std::sin(0.3) + 2 * std::cos(0.3), res.s[1]));
  EXPECT_EQ(3.0, res.s[2]);
}

TEST(Transforms, TaperScaleOneBelowEps) {
  LibHarness h;
  auto x = h.point();
  h.finish(h.call(LibraryFn::kTaperZ, {x, h.real(0), h.real(1), h.real(0), h.real(2)}), {x});
  // z = 0 gives scale s1 = 0 -> replaced by 1; z = 0.5 gives scale 1 as well.
  auto res = h.eval({3, 4, 0});
  EXPECT_EQ(3.0, res.s[0]);
  EXPECT_EQ(4.0, res.s[1]);
  res = h.eval({3, 4, 0.25});
  EXPECT_TRUE(near_rel(3 / 0.5, res.s[0]));
  res = h.eval({3, 4, 5});  // above z2: s2
  EXPECT_TRUE(near_rel(1.5, res.s[0]));
}

TEST(Transforms, SpaceMapCubicOnlyInsideTheSupport) {
  LibHarness h;
  auto x = h.point();
  auto src = h.array({0, 0, 0});
  auto dst = h.array({1, 0, 0});
  auto b = h.array({1, 1, 1});
  h.finish(h.call(LibraryFn::kSpaceMapCubic, {x, src, dst, b}), {x});
  // At the destination q = 0, rho = 0, w = 1: the point moves by -delta.
  auto res = h.eval({1, 0, 0});
  EXPECT_EQ(0.0, res.s[0]);
  // Far away nothing moves.
  res = h.eval({10, 0, 0});
  EXPECT_EQ(10.0, res.s[0]);
}

// --- Attribute functions ---------------------------------------------------------------

TEST(Attributes, LookUpTableBelowFirstEntryGivesLastSet) {
  LibHarness h;
  auto out = h.array({-1, -1});
  auto col = h.array({1, 2, 3, 4, 5, 6});
  auto map = h.array({0, 1, 2});
  h.finish(h.call(LibraryFn::kALookUpTable, {h.real_from_input(0), out, col, map}), {out});
  EXPECT_EQ(std::vector<double>({5, 6}), h.eval({-0.5, 0, 0}).s);
  EXPECT_EQ(std::vector<double>({1, 2}), h.eval({0.5, 0, 0}).s);
  EXPECT_EQ(std::vector<double>({3, 4}), h.eval({1.5, 0, 0}).s);
  EXPECT_EQ(std::vector<double>({5, 6}), h.eval({2.5, 0, 0}).s);
}

TEST(Attributes, HsvToRgbWrapsTheHueWithLoops) {
  LibHarness h;
  auto hsv = h.array({0, 1, 1});
  auto rgb = h.array({0, 0, 0});
  // hue from x[1] so that the loops run at evaluation time.
  auto& b = h.builder();
  b.store(hsv.base_slot, b.input(0));
  h.finish(h.call(LibraryFn::kAHSVToRGB, {hsv, rgb}), {rgb});
  auto want = [](double hue) {
    while (hue < 0) hue += 360;
    while (hue > 360) hue -= 360;
    double c[3];
    if (hue < 120)
      c[0] = (120 - hue) / 60, c[1] = hue / 60, c[2] = 0;
    else if (hue < 240)
      c[0] = 0, c[1] = (240 - hue) / 60, c[2] = (hue - 120) / 60;
    else
      c[0] = (hue - 240) / 60, c[1] = 0, c[2] = (360 - hue) / 60;
    std::vector<double> out;
    for (double v : c) out.push_back(std::min(v, 1.0));
    return out;
  };
  for (double hue : {-1000.5, -30.0, 45.0, 400.0, 1234.5}) {
    auto got = h.eval({hue, 0, 0}).s;
    auto w = want(hue);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(near_rel(w[k], got[k])) << hue << " " << k;
  }
}

TEST(Attributes, SawtoothLoopAgreesWithUnrolledSum) {
  LibHarness h;
  auto& b = h.builder();
  // n = 7 as a constant and n = x[1] (7 at run time).
  auto unrolled =
      h.call(LibraryFn::kSawtooth, {h.real_from_input(1), h.real(7), h.real(1.5), h.real(0.8)});
  auto looped = h.call(LibraryFn::kSawtooth,
                       {h.real_from_input(1), h.real_from_input(0), h.real(1.5), h.real(0.8)});
  h.finish(b.binary(ir::Op::kSub, unrolled, looped));
  EXPECT_EQ(0.0, h.eval({7, 0.37, 0}).value);
  EXPECT_EQ(0.0, h.eval({7, -1.2, 0}).value);
}

// --- Distance ----------------------------------------------------------------------------

TEST(Distance, DEllipsoidOfASphereIsTheEuclideanDistance) {
  LibHarness h;
  auto x = h.point();
  auto c = h.array({0, 0, 0});
  h.finish(h.call(LibraryFn::kDEllipsoid, {x, c, h.real(2), h.real(2), h.real(2)}));
  EXPECT_TRUE(near_rel(2 - std::sqrt(1 + 4 + 9.0), h.eval({1, 2, 3}).value, 1e-9));
  // Inside, Newton stops at |s| < 1e-6 (the original's criterion): about 1e-6 accurate.
  EXPECT_TRUE(near_rel(2 - 0.5, h.eval({0.5, 0, 0}).value, 1e-5));
}

TEST(Distance, DEllipsoidClosestPointLiesOnTheSurface) {
  LibHarness h;
  auto x = h.point();
  auto c = h.array({0, 0, 0});
  h.finish(h.call(LibraryFn::kDEllipsoid, {x, c, h.real(3), h.real(1), h.real(2)}));
  // Along the x axis the closest point is (3, 0, 0).
  EXPECT_TRUE(near_rel(-(5 - 3.0), h.eval({5, 0, 0}).value, 1e-9));
  // Inside near the shortest semi-axis: the closest point is (0, 1, 0).
  EXPECT_TRUE(near_rel(0.5, h.eval({0, 0.5, 0}).value, 1e-5));
}

// --- SARDF ---------------------------------------------------------------------------------

/// All real roots of a monic quartic by sign changes on a fine grid + bisection (an
/// independent root finder).
std::vector<double> quartic_roots(double a3, double a2, double a1, double a0) {
  auto p = [&](double m) { return (((m + a3) * m + a2) * m + a1) * m + a0; };
  std::vector<double> roots;
  const double lo = -50, hi = 50, step = 1e-3;
  for (double m = lo; m < hi; m += step) {
    double l = m, r = m + step;
    if (p(l) == 0) roots.push_back(l);
    if ((p(l) < 0) != (p(r) < 0) && p(r) != 0) {
      for (int i = 0; i < 200; ++i) {
        const double mid = 0.5 * (l + r);
        ((p(l) < 0) == (p(mid) < 0) ? l : r) = mid;
      }
      roots.push_back(0.5 * (l + r));
    }
  }
  std::sort(roots.rbegin(), roots.rend());
  return roots;
}

TEST(Sardf, DUniCornerUsesSecondLargestQuarticRoot) {
  LibHarness h;
  const double r = 1;
  h.finish(h.call(LibraryFn::kDUni,
                  {h.real_from_input(0), h.real_from_input(1), h.real(r), h.real(0.5)}));
  for (auto xy : {std::pair{-0.3, -0.4}, {-0.5, -0.45}, {-0.2, -0.25}}) {
    const double x = xy.first, y = xy.second;
    // Inside the rounded region (rule 5, first case)?
    ASSERT_TRUE(x <= -y * y / (4 * r) && y <= -x * x / (4 * r));
    auto roots =
        quartic_roots(-4 * std::sqrt(r), -4 * r, -4 * std::sqrt(r) * (x + y), -(x * x + y * y));
    ASSERT_EQ(4u, roots.size());
    const double mu = roots[1];
    EXPECT_TRUE(near_rel(-mu * mu, h.eval({x, y, 0}).value, 1e-10)) << x << " " << y;
  }
}

TEST(Sardf, DIntRules) {
  LibHarness h;
  h.finish(h.call(LibraryFn::kDInt,
                  {h.real_from_input(0), h.real_from_input(1), h.real(1), h.real(0.5)}));
  EXPECT_EQ(-0.5, h.eval({-0.5, 2, 0}).value);    // x < 0 < y -> x
  EXPECT_EQ(-0.7, h.eval({3, -0.7, 0}).value);    // y < 0 < x -> y
  EXPECT_EQ(0.0, h.eval({1e-8, 1e-8, 0}).value);  // both tiny
  EXPECT_EQ(0.0, h.eval({5, 1e-8, 0}).value);     // |y| tiny, x > 0
  // Quadrant I, rounded region: +mu^2 with the second largest root.
  const double x = 0.4, y = 0.5;
  auto roots = quartic_roots(-4, -4, 4 * (x + y), -(x * x + y * y));
  ASSERT_EQ(4u, roots.size());
  EXPECT_TRUE(near_rel(roots[1] * roots[1], h.eval({x, y, 0}).value, 1e-10));
}

// --- Perlin tables -------------------------------------------------------------------------

TEST(Perlin, GlibcRandStream) {
  detail::GlibcRand rng;
  EXPECT_EQ(1804289383, rng.next());
  EXPECT_EQ(846930886, rng.next());
  EXPECT_EQ(1681692777, rng.next());
}

TEST(Perlin, TablesArePermutationsAndUnitGradients) {
  detail::GlibcRand rng;
  std::vector<double> perm, grad;
  detail::build_perlin_tables(rng, &perm, &grad);
  ASSERT_EQ(514u, perm.size());
  ASSERT_EQ(3u * 514u, grad.size());
  std::set<double> seen(perm.begin(), perm.begin() + 256);
  EXPECT_EQ(256u, seen.size());
  EXPECT_EQ(0.0, *seen.begin());
  EXPECT_EQ(255.0, *seen.rbegin());
  for (int i = 0; i < 258; ++i) EXPECT_EQ(perm[i], perm[256 + i]);
  for (int i = 0; i < 514; ++i) {
    const double n2 = grad[3 * i] * grad[3 * i] + grad[3 * i + 1] * grad[3 * i + 1] +
                      grad[3 * i + 2] * grad[3 * i + 2];
    EXPECT_NEAR(1.0, n2, 1e-12);
  }
}

TEST(Perlin, NoisePIsZeroAtIntegerPointsAndTablesFollowCallOrder) {
  LibHarness h;
  auto x = h.point();
  auto t = h.call(LibraryFn::kATurbulence, {x, h.real(1)});
  auto n = h.call(LibraryFn::kANoiseP, {x});
  (void)t;
  h.finish(n);
  EXPECT_EQ(0, h.state().perlin_block_turbulence);
  EXPECT_EQ(1, h.state().perlin_block_noisep);
  EXPECT_EQ(2u, h.function().tables.size());
  EXPECT_EQ(0.0, h.eval({1, 2, 3}).value);
  EXPECT_EQ(0.0, h.eval({-4, 0, 7}).value);
  const double v = h.eval({0.3, 0.6, 0.2}).value;
  EXPECT_TRUE(v > -1.5 && v < 1.5 && v != 0);
}

// --- Warnings ----------------------------------------------------------------------------

lang::SourceRange range_at(uint32_t offset, uint32_t length) {
  lang::SourceRange r;
  r.begin.offset = offset;
  r.begin.line = 1;
  r.begin.col = offset + 1;
  r.length = length;
  return r;
}

TEST(Warnings, PointArraySizeGivesFailureValueAndLocatedWarning) {
  LibHarness h("s = hfSphere(xx, c, 1);");
  auto x = h.point(4, range_at(13, 2));
  auto c = h.array({0, 0, 0});
  h.finish(h.call(LibraryFn::kSphere, {x, c, h.real(1)}, range_at(4, 18)));
  EXPECT_EQ(kFail, h.eval({0, 0, 0, 0}).value);
  ASSERT_EQ(1u, h.diags().diagnostics().size());
  const auto& d = h.diags().diagnostics()[0];
  EXPECT_EQ(lang::Severity::kWarning, d.severity);
  EXPECT_EQ(13u, d.range.begin.offset);
  EXPECT_EQ(2u, d.range.length);
  EXPECT_EQ(
      "hfSphere: the point array 'xx' has 4 elements, not 3; the call returns the failure "
      "value -1111111111111.0",
      d.message);
}

TEST(Warnings, ConeAndCylinderHaveTheirOwnFailureValues) {
  LibHarness h;
  auto x = h.point(2);
  auto c = h.array({0, 0, 0});
  auto u = h.array({0, 0, 1});
  auto& b = h.builder();
  auto cone = h.call(LibraryFn::kDConeX, {x, c, h.real(1)});
  auto cyl = h.call(LibraryFn::kDCylinder, {x, c, u, h.real(1)});
  h.finish(b.binary(ir::Op::kAdd, b.binary(ir::Op::kMul, cone, b.constant(0)), cyl));
  EXPECT_EQ(-11111111111.1, h.eval({0, 0}).value);
  ASSERT_EQ(2u, h.diags().diagnostics().size());
  EXPECT_NE(std::string::npos, h.diags().diagnostics()[0].message.find("-11111111111.0"));
  EXPECT_NE(std::string::npos, h.diags().diagnostics()[1].message.find("-11111111111.1"));
}

TEST(Warnings, HfRReturnsFailureValueWithWarning) {
  LibHarness h;
  auto x = h.point();
  h.finish(h.call(LibraryFn::kR, {x, h.real(1)}, range_at(0, 10)));
  EXPECT_EQ(kFail, h.eval({1, 2, 3}).value);
  ASSERT_EQ(1u, h.diags().diagnostics().size());
  EXPECT_EQ("hfR needs the R package build of HyperFun; it returns the failure value here",
            h.diags().diagnostics()[0].message);
  EXPECT_EQ(10u, h.diags().diagnostics()[0].range.length);
}

TEST(Warnings, ShortArrayReadsNaNAndWarns) {
  LibHarness h;
  auto x = h.point();
  auto v = h.array({0, 0, 0, 1, 1});  // 2 points need 6 elements
  auto s = h.array({1, 1});
  h.finish(h.call(LibraryFn::kConvPoint, {x, v, s, h.real(0)}));
  EXPECT_TRUE(std::isnan(h.eval({0, 0, 0}).value));
  ASSERT_EQ(1u, h.diags().diagnostics().size());
  EXPECT_NE(std::string::npos, h.diags().diagnostics()[0].message.find("reads 6"));
}

TEST(Warnings, CracklesWritePastTheEndIsDropped) {
  LibHarness h;
  auto x = h.point();
  auto out = h.array({0.5, 0.5, 0.5});
  auto col = h.array({1, 0, 0, 0, 1, 0});          // size(map) + 1 = 4 > 3... 6 elements: fine
  auto map = h.array({0, 0.5, 1.01, 2, 3, 4, 5});  // n = 7: col[8] is past the end
  h.finish(h.call(LibraryFn::kACrackles, {x, out, h.real(1.3), col, map}));
  h.eval({0.1, 0.2, 0.3});
  bool found = false;
  for (const auto& d : h.diags().diagnostics()) {
    found = found || d.message.find("past its end") != std::string::npos;
  }
  EXPECT_TRUE(found);
}

TEST(ConvLine, ZeroLengthSegmentIsNaN) {
  LibHarness h;
  auto x = h.point();
  auto b = h.array({1, 1, 1});
  auto e = h.array({1, 1, 1});
  auto s = h.array({1});
  h.finish(h.call(LibraryFn::kConvLine, {x, b, e, s, h.real(0.1)}));
  EXPECT_TRUE(std::isnan(h.eval({0, 0, 0}).value));
}

}  // namespace
}  // namespace hfrt::stdlib
