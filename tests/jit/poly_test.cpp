// The polynomial domain (jit/poly.h) and its public face (Model::analytic_info,
// Model::ray_polynomials): classification of small models, leaf polynomials against the
// scalar values of the same IR, and F's zero crossings against the leaves' roots.
#include "jit/poly.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "hfrt/model.h"
#include "ir/builder.h"
#include "ir/scalar_ops.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

using testutil::compile;

// ---- helpers ------------------------------------------------------------------------------

/// The scalar value of IR value v at x (straight-line, pure ops only: what leaves are made of).
double value_at(const Function& fn, ValueId v, const double x[3], std::span<const double> a,
                std::unordered_map<ValueId, double>* memo) {
  auto it = memo->find(v);
  if (it != memo->end()) return it->second;
  const Inst& in = fn.insts[v];
  double r = 0;
  switch (in.op) {
    case Op::kConst:
      r = in.imm;
      break;
    case Op::kInput:
      r = in.aux < 3 ? x[in.aux] : 0.0;
      break;
    case Op::kParam:
      r = size_t(in.aux) < a.size() ? a[size_t(in.aux)] : 0.0;
      break;
    case Op::kTableLoad:
      r = fn.tables[size_t(in.aux)][size_t(value_at(fn, in.args[0], x, a, memo))];
      break;
    default: {
      EXPECT_TRUE(op_is_pure(in.op)) << "leaf uses " << op_name(in.op);
      double args[3] = {0, 0, 0};
      for (int k = 0; k < op_num_args(in.op); ++k) args[k] = value_at(fn, in.args[k], x, a, memo);
      r = apply_op(in.op, args[0], args[1], args[2]);
    }
  }
  memo->emplace(v, r);
  return r;
}

/// Sum of |c_k| |t|^k: the size of the terms, for relative tolerances.
double poly_scale(const double* c, double t) {
  double s = 0, p = 1;
  for (int k = 0; k < kPolyCoeffs; ++k, p *= std::fabs(t)) s += std::fabs(c[k]) * p;
  return s;
}

/// True when polynomial c has a root within `tol` of t: a sign change across [t-tol, t+tol]
/// or a value that vanishes to rounding at t (a tangent, double root).
bool root_near(const double* c, double t, double tol) {
  const double lo = poly_value(c, t - tol), hi = poly_value(c, t + tol), mid = poly_value(c, t);
  if ((lo <= 0 && hi >= 0) || (lo >= 0 && hi <= 0)) return true;
  return std::fabs(mid) <= 1e-9 * std::max(poly_scale(c, t), 1e-300);
}

/// Sign changes of g on [t0, t1] sampled at n+1 points, each refined by bisection.
std::vector<double> crossings(const std::function<double(double)>& g, double t0, double t1, int n) {
  std::vector<double> out;
  double prev_t = t0, prev = g(t0);
  for (int i = 1; i <= n; ++i) {
    const double t = t0 + (t1 - t0) * i / n;
    const double v = g(t);
    if (!std::isnan(v) && !std::isnan(prev) && ((prev < 0 && v >= 0) || (prev >= 0 && v < 0))) {
      double a = prev_t, b = t, fa = prev;
      for (int k = 0; k < 60 && b - a > 1e-13; ++k) {
        const double m = 0.5 * (a + b), fm = g(m);
        if (std::isnan(fm)) break;
        if ((fa < 0) == (fm < 0)) {
          a = m;
          fa = fm;
        } else {
          b = m;
        }
      }
      out.push_back(0.5 * (a + b));
    }
    prev_t = t;
    prev = v;
  }
  return out;
}

struct Ray {
  double o[3], d[3];
};

Ray random_ray(std::mt19937_64& rng, double extent) {
  std::uniform_real_distribution<double> u(-extent, extent);
  std::normal_distribution<double> g;
  Ray r;
  double n = 0;
  for (int k = 0; k < 3; ++k) {
    r.o[k] = u(rng);
    r.d[k] = g(rng);
    n += r.d[k] * r.d[k];
  }
  for (double& c : r.d) c /= std::sqrt(n);
  return r;
}

PolyAnalysis analyze(const std::string& text, Function* fn_out = nullptr) {
  auto c = compile(text);
  EXPECT_TRUE(c.ok) << c.diagnostics;
  if (!c.ok) return {};
  PolyAnalysis p = analyze_polynomial(c.fn);
  if (fn_out) *fn_out = std::move(c.fn);
  return p;
}

// ---- classification -------------------------------------------------------------------------

struct Case {
  const char* name;
  const char* text;
  bool qualifies;
  int leaves;       ///< when it qualifies
  int max_degree;   ///< when it qualifies
  const char* why;  ///< a substring of the reason when it does not
  int line, col;    ///< the reason's location when it does not (0: not checked)
};

const Case kCases[] = {
    {"sphere", "my_model(x[3], a[1]) { array c[3]; c = [0, 0, 0]; my_model = hfSphere(x, c, 1); }",
     true, 1, 2, "", 0, 0},
    {"transformed_sphere",
     "my_model(x[3], a[1]) { array c[3]; c = [0.5, 0, 0];\n"
     "  d = hfShift3D(x, 1, 2, 3); d = hfRotate3DZ(x, 0.7); d = hfScale3D(x, 2, 1, 0.5);\n"
     "  my_model = hfSphere(x, c, 1); }",
     true, 1, 2, "", 0, 0},
    {"rotated_torus",
     "my_model(x[3], a[1]) { array c[3]; c = [0, 0, 0]; d = hfRotate3DX(x, 0.6);\n"
     "  my_model = hfTorusZ(x, c, 2, 0.5); }",
     true, 1, 4, "", 0, 0},
    {"set_operations",
     "my_model(x[3], a[1]) { array c[3]; c = [0, 0, 0];\n"
     "  sp = hfSphere(x, c, 1); k = hfCylinderZ(x, c, 0.5); e = hfEllipsoid(x, c, 2, 1, 0.5);\n"
     "  my_model = (e | sp) & (x[3] + 0.2) \\ k; }",
     true, 4, 2, "", 0, 0},
    {"min_max_neg",
     "my_model(x[3], a[1]) { my_model = max(min(1 - x[1]^2 - x[2]^2 - x[3]^2, x[3]), -(x[1] - "
     "0.3)); }",
     true, 3, 2, "", 0, 0},
    {"block_minus_sphere",
     "my_model(x[3], a[1]) { array v[3], c[3]; v = [-1, -1, -1]; c = [1, 1, 1];\n"
     "  my_model = hfBlock(x, v, 2, 2, 2) \\ hfSphere(x, c, 1.2); }",
     true, 4, 2, "", 0, 0},
    {"quartic_by_hand",
     "my_model(x[3], a[1]) { my_model = 1 - x[1]^4 - x[2]^4 - x[3]^4 + 0.5*x[1]*x[2]; }", true, 1,
     4, "", 0, 0},
    {"distance_sphere", "my_model(x[3], a[1]) { my_model = 1 - sqrt(x[1]^2 + x[2]^2 + x[3]^2); }",
     true, 1, 2, "", 0, 0},
    {"if_on_constant",
     "my_model(x[3], a[1]) { k = 2;\n"
     "  if k > 1 then f = 1 - x[1]^2 - x[2]^2 - x[3]^2; else f = sin(x[1]); endif;\n"
     "  my_model = f; }",
     true, 1, 2, "", 0, 0},
    {"blend",
     "my_model(x[3], a[1]) { f1 = 1 - x[1]^2; f2 = 0.5 - x[2]^2 - x[3];\n"
     "  my_model = hfBlendUni(f1, f2, 0.5, 1.5, 2); }",
     false, 0, 0, "hfBlendUni", 2, 14},
    {"noise",
     "my_model(x[3], a[1]) { array c[3]; c = [0, 0, 0];\n"
     "  my_model = hfSphere(x, c, 1) + hfNoiseG(x, 0.1, 2, 0.5); }",
     false, 0, 0, "hfNoiseG", 2, 34},
    {"sin", "my_model(x[3], a[1]) {\n  my_model = 1 - x[1]^2 | sin(x[2]); }", false, 0, 0,
     "'sin' is not a polynomial", 2, 27},
    {"division", "my_model(x[3], a[1]) {\n  my_model = 1 / (1 + x[1]^2) - 0.5; }", false, 0, 0,
     "division by a variable", 2, 16},
    {"set_in_arithmetic",
     "my_model(x[3], a[1]) {\n  my_model = 2 + ((1 - x[1]^2) | (1 - x[2]^2)); }", false, 0, 0,
     "the result of a set operation is used in arithmetic", 2, 16},
    {"blended_csg",
     "my_model(x[3], a[1]) { array c[3], v[3]; c = [0, 0, 0]; v = [-1, -1, -1];\n"
     "  frame = hfBlock(x, v, 2, 2, 2) \\ hfSphere(x, c, 1.3); ring = hfTorusZ(x, c, 1.5, 0.3);\n"
     "  my_model = hfBlendUni(frame, ring, 0.5, 1, 1); }",
     false, 0, 0, "'hfBlendUni' is not a set operation nor a polynomial", 3, 14},
    {"degree_6", "my_model(x[3], a[1]) { my_model = 1 - x[1]^6; }", false, 0, 0, "degree 6", 0, 0},
    {"twist",
     "my_model(x[3], a[1]) { array c[3]; c = [0, 0, 0]; d = hfTwistZ(x, -1, 1, 0, 1);\n"
     "  my_model = hfSphere(x, c, 1); }",
     false, 0, 0, "hfTwistZ", 1, 55},
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.name;
}

class Classification : public ::testing::TestWithParam<Case> {};

TEST_P(Classification, QualifiesOrNamesTheConstruct) {
  const Case& c = GetParam();
  PolyAnalysis p = analyze(c.text);
  EXPECT_EQ(p.qualifies, c.qualifies) << p.reason;
  if (c.qualifies) {
    EXPECT_EQ(static_cast<int>(p.program.leaves.size()), c.leaves);
    EXPECT_EQ(p.max_degree, c.max_degree);
    EXPECT_TRUE(p.reason.empty());
  } else {
    EXPECT_NE(p.reason.find(c.why), std::string::npos) << p.reason;
    EXPECT_TRUE(p.program.leaves.empty());
    if (c.line > 0) {
      EXPECT_EQ(static_cast<int>(p.loc.line), c.line) << p.reason;
      EXPECT_EQ(static_cast<int>(p.loc.col), c.col) << p.reason;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Models, Classification, ::testing::ValuesIn(kCases),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(PolyAnalysis, CbrtIsNotAPolynomialUnlessIndependentOfX) {
  auto model = [](bool of_x) {
    Function fn;
    IrBuilder b(fn);
    ValueId x = b.input(0), y = b.input(1), z = b.input(2);
    ValueId r2 = b.add(b.add(b.sqr(x), b.sqr(y)), b.sqr(z));
    b.finish(b.sub(b.constant(1), b.unary(Op::kCbrt, of_x ? r2 : b.param(0))));
    return fn;
  };
  PolyAnalysis p = analyze_polynomial(model(true));
  EXPECT_FALSE(p.qualifies);
  EXPECT_NE(p.reason.find("'cbrt' is not a polynomial"), std::string::npos) << p.reason;
  // Of a parameter it is a constant per ray (a degree-0 polynomial).
  p = analyze_polynomial(model(false));
  EXPECT_TRUE(p.qualifies) << p.reason;
}

TEST(PolyAnalysis, SkeletonOfAUnionHasTheRFunctionNode) {
  PolyAnalysis p = analyze("my_model(x[3], a[1]) { my_model = (1 - x[1]^2) | (1 - x[2]^2); }");
  ASSERT_TRUE(p.qualifies) << p.reason;
  EXPECT_EQ(p.skeleton.size(), 1u);
  EXPECT_EQ(p.program.leaves.size(), 2u);
}

// ---- leaf polynomials against the scalar values ------------------------------------------

// The printer lists every register with its op, operands and degree, then the leaves.
TEST(PolyPrint, ListsEveryRegisterAndLeaf) {
  PolyAnalysis p =
      analyze("my_model(x[3], a[1]) { my_model = 1 - (x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }");
  ASSERT_TRUE(p.qualifies) << p.reason;
  const std::string text = print(p.program);
  size_t regs = 0, leaves = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("r", 0) == 0) ++regs;
    if (line.rfind("leaf ", 0) == 0) ++leaves;
  }
  EXPECT_EQ(regs, p.program.insts.size()) << text;
  EXPECT_EQ(leaves, p.program.leaves.size()) << text;
  EXPECT_NE(text.find("= input x[1]"), std::string::npos) << text;
  EXPECT_NE(text.find("= mul r"), std::string::npos) << text;
  EXPECT_NE(text.find("; deg 2"), std::string::npos) << text;
  EXPECT_NE(text.find("leaf 0 = r"), std::string::npos) << text;
  EXPECT_EQ(poly_op_name(PolyOp::kSelect), "select");
}

TEST(PolyInterpreter, LeafPolynomialsMatchLeafValues) {
  int checked_exact = 0, checked_surrogate = 0;
  std::mt19937_64 rng(7);
  for (const Case& c : kCases) {
    if (!c.qualifies) continue;
    Function fn;
    PolyAnalysis p = analyze(c.text, &fn);
    ASSERT_TRUE(p.qualifies) << c.name;
    PolyInterpreter interp(fn, p.program);
    const std::vector<double> a(size_t(std::max(fn.num_params, 1)), 0.0);
    std::vector<double> coeffs(p.program.leaves.size() * kPolyCoeffs);
    for (int r = 0; r < 40; ++r) {
      Ray ray = random_ray(rng, 2.0);
      interp.eval(ray.o, ray.d, a, coeffs.data());
      for (size_t i = 0; i < p.program.leaves.size(); ++i) {
        const PolyLeaf& leaf = p.program.leaves[i];
        const double* cf = &coeffs[i * kPolyCoeffs];
        for (int k = leaf.degree + 1; k < kPolyCoeffs; ++k) EXPECT_EQ(cf[k], 0.0) << c.name;
        auto leaf_value = [&](double t) {
          const double x[3] = {ray.o[0] + t * ray.d[0], ray.o[1] + t * ray.d[1],
                               ray.o[2] + t * ray.d[2]};
          std::unordered_map<ValueId, double> memo;
          return value_at(fn, leaf.value, x, a, &memo);
        };
        if (!leaf.surrogate) {
          for (int s = 0; s < 8; ++s) {
            const double t = std::uniform_real_distribution<double>(-4, 4)(rng);
            const double want = leaf_value(t);
            EXPECT_NEAR(poly_value(cf, t), want, 1e-11 * std::max(1.0, poly_scale(cf, t)))
                << c.name << " leaf " << i << " t " << t;
            ++checked_exact;
          }
        } else {
          // Same zero set: every sign change of the leaf value is a root of the surrogate.
          for (double t : crossings(leaf_value, -6, 6, 3000)) {
            EXPECT_TRUE(root_near(cf, t, 1e-9)) << c.name << " leaf " << i << " t " << t;
            ++checked_surrogate;
          }
        }
      }
    }
  }
  std::printf("[ poly ] %d leaf values and %d surrogate zeros checked\n", checked_exact,
              checked_surrogate);
  EXPECT_GT(checked_exact, 1000);
  EXPECT_GT(checked_surrogate, 20);
}

// ---- the JIT against the interpreter ---------------------------------------------------------

/// Same coefficients from PolyJit (one ray, and blocks of 4 with a tail) as from the interpreter.
int check_jit(const Function& fn, const PolyProgram& prog, std::span<const double> a, int rays,
              uint64_t seed, const std::string& name) {
  auto one = PolyJit::compile(fn, prog, 1);
  auto wide = PolyJit::compile(fn, prog, 4);
  EXPECT_TRUE(one.ok() && wide.ok()) << name;
  if (!one.ok() || !wide.ok()) return 0;
  PolyInterpreter interp(fn, prog);
  const size_t rows = prog.leaves.size() * kPolyCoeffs;
  std::mt19937_64 rng(seed);
  std::vector<Ray> rs(static_cast<size_t>(rays));
  for (Ray& r : rs) r = random_ray(rng, 3.0);
  std::vector<double> o(3 * rs.size()), d(3 * rs.size()), batch(rows * rs.size());
  for (size_t i = 0; i < rs.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      o[k * rs.size() + i] = rs[i].o[k];
      d[k * rs.size() + i] = rs[i].d[k];
    }
  }
  wide.value()->eval(int64_t(rs.size()), o.data(), d.data(), a, batch.data());
  int compared = 0;
  std::vector<double> want(rows), got(rows);
  for (size_t i = 0; i < rs.size(); ++i) {
    interp.eval(rs[i].o, rs[i].d, a, want.data());
    one.value()->eval_one(rs[i].o, rs[i].d, a, got.data());
    for (size_t r = 0; r < rows; ++r) {
      EXPECT_EQ(got[r], want[r]) << name << " ray " << i << " row " << r;
      EXPECT_EQ(batch[r * rs.size() + i], want[r])
          << name << " (4 lanes) ray " << i << " row " << r;
      ++compared;
    }
  }
  return compared;
}

TEST(PolyJit, MatchesTheInterpreter) {
  int compared = 0;
  for (const Case& c : kCases) {
    if (!c.qualifies) continue;
    Function fn;
    PolyAnalysis p = analyze(c.text, &fn);
    ASSERT_TRUE(p.qualifies) << c.name;
    const std::vector<double> a(size_t(std::max(fn.num_params, 1)), 0.5);
    compared += check_jit(fn, p.program, a, 37, 3, c.name);
  }
  // Parameters and an x-independent scalar op (sin) and a select on a parameter.
  Function fn;
  PolyAnalysis p = analyze(
      "my_model(x[3], a[2]) { r = sin(a[1]) + 2; my_model = r*r - x[1]^2 - (x[2] - a[2])^2 - "
      "x[3]^2 | x[1]; }",
      &fn);
  ASSERT_TRUE(p.qualifies) << p.reason;
  const std::vector<double> a = {0.3, -0.7};
  compared += check_jit(fn, p.program, a, 37, 4, "params");
  std::printf("[ poly ] %d JIT coefficients compared\n", compared);
  EXPECT_GT(compared, 1000);
}

// ---- F's zero crossings against the leaves' roots (public API) -----------------------------

/// Samples F along random rays; every sign change must be within 1e-6 of a root of a leaf.
/// Returns the number of crossings checked.
int check_crossings(const Model& model, int rays, double extent, double reach, int samples,
                    uint64_t seed, const std::string& name) {
  const AnalyticInfo info = model.analytic_info();
  EXPECT_TRUE(info.qualifies);
  std::vector<double> coeffs(size_t(info.num_leaves) * kPolyCoeffs);
  std::mt19937_64 rng(seed);
  int checked = 0;
  for (int r = 0; r < rays; ++r) {
    Ray ray = random_ray(rng, extent);
    model.ray_polynomials(ray.o, ray.d, coeffs.data());
    auto f = [&](double t) {
      return model.eval({ray.o[0] + t * ray.d[0], ray.o[1] + t * ray.d[1], ray.o[2] + t * ray.d[2]})
          .f;
    };
    for (double t : crossings(f, -reach, reach, samples)) {
      bool found = false;
      for (int i = 0; i < info.num_leaves && !found; ++i)
        found = root_near(&coeffs[size_t(i) * kPolyCoeffs], t, 1e-6);
      EXPECT_TRUE(found) << name << ": crossing at t=" << t << " on ray " << r
                         << " is no leaf root";
      ++checked;
    }
  }
  return checked;
}

TEST(ModelAnalytic, InfoAndReasonThroughTheApi) {
  ModelOptions mo;
  mo.backend = Backend::kInterp;
  auto blend = Model::compile(
      "my_model(x[3], a[1]) {\n  f1 = 1 - x[1]^2; f2 = 0.5 - x[2]^2 - x[3];\n  my_model = "
      "hfBlendUni(f1, f2, 0.5, 1.5, 2); }",
      mo);
  ASSERT_TRUE(blend.ok()) << blend.rendered;
  AnalyticInfo bi = blend.model->analytic_info();
  EXPECT_FALSE(bi.qualifies);
  EXPECT_NE(bi.reason.find("'hfBlendUni' is not a set operation"), std::string::npos) << bi.reason;
  EXPECT_EQ(bi.line, 3);
  EXPECT_EQ(bi.col, 14);

  auto torus = Model::compile(
      "my_model(x[3], a[1]) { array c[3]; c = [0, 0, 0]; d = hfRotate3DX(x, 0.6);\n"
      "  my_model = hfTorusZ(x, c, 2, 0.5) | hfSphere(x, c, 1); }",
      mo);
  ASSERT_TRUE(torus.ok()) << torus.rendered;
  AnalyticInfo ti = torus.model->analytic_info();
  EXPECT_TRUE(ti.qualifies) << ti.reason;
  EXPECT_EQ(ti.num_leaves, 2);
  EXPECT_EQ(ti.max_degree, 4);
}

TEST(ModelAnalytic, ParametersReachThePolynomials) {
  ModelOptions mo;
  mo.backend = Backend::kInterp;
  auto c = Model::compile(
      "my_model(x[3], a[1]) { my_model = a[1]*a[1] - x[1]^2 - x[2]^2 - x[3]^2; }", mo);
  ASSERT_TRUE(c.ok()) << c.rendered;
  c.model->set_params({2.0});
  const double o[3] = {0, 0, 0}, d[3] = {1, 0, 0};
  double coeffs[5];
  c.model->ray_polynomials(o, d, coeffs);
  EXPECT_DOUBLE_EQ(coeffs[0], 4.0);
  EXPECT_DOUBLE_EQ(coeffs[1], 0.0);
  EXPECT_DOUBLE_EQ(coeffs[2], -1.0);
}

TEST(ModelAnalytic, ZeroCrossingsAreLeafRoots) {
  int total = 0;
  for (const Case& c : kCases) {
    if (!c.qualifies) continue;
    auto compiled = Model::compile(c.text);  // the JIT: F as the renderer sees it
    ASSERT_TRUE(compiled.ok()) << compiled.rendered;
    total += check_crossings(*compiled.model, 60, 2.5, 6.0, 2000, 11, c.name);
  }
  std::printf("[ poly ] %d zero crossings of F checked against leaf roots\n", total);
  EXPECT_GT(total, 200);
}

TEST(ModelAnalytic, RayPolynomialsCost) {
  // Not a benchmark with a threshold: prints the per-ray cost of the reference interpreter
  // (the renderer calls ray_polynomials once per ray) and checks the results stay finite.
  auto c = Model::compile(kCases[3].text);
  ASSERT_TRUE(c.ok()) << c.rendered;
  const AnalyticInfo info = c.model->analytic_info();
  std::vector<double> coeffs(size_t(info.num_leaves) * kPolyCoeffs);
  std::mt19937_64 rng(1);
  const int n = 200000;
  std::vector<Ray> rays(256);
  for (Ray& r : rays) r = random_ray(rng, 2.0);
  ModelOptions mo;
  mo.backend = Backend::kInterp;
  auto ci = Model::compile(kCases[3].text, mo);
  ASSERT_TRUE(ci.ok());
  double sum = 0;
  for (const Model* m : {&*ci.model, &*c.model}) {
    m->ray_polynomials(rays[0].o, rays[0].d, coeffs.data());  // compiles the JIT
    auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) {
      m->ray_polynomials(rays[i & 255].o, rays[i & 255].d, coeffs.data());
      sum += coeffs[0];
    }
    const double ns =
        std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - t0).count() / n;
    std::printf("[ poly ] ray_polynomials (%s): %.0f ns per ray (%d leaves)\n",
                m == &*ci.model ? "interpreter" : "JIT", ns, info.num_leaves);
  }
  std::string error;
  EXPECT_TRUE(c.model->prepare_polynomial(&error)) << error;
  EXPECT_TRUE(ci.model->prepare_polynomial(&error)) << error;  // interpreter backend: no-op
  EXPECT_TRUE(c.model->stats().polynomial.compiled);
  EXPECT_FALSE(ci.model->stats().polynomial.compiled);
  EXPECT_TRUE(std::isfinite(sum));
}

TEST(ModelAnalytic, CorpusModels) {
  const std::filesystem::path root = std::filesystem::path(HFRT_CORPUS_DIR);
  std::vector<std::filesystem::path> files;
  for (const char* dir : {"models", "probes"}) {
    if (!std::filesystem::exists(root / dir)) continue;
    for (const auto& e : std::filesystem::recursive_directory_iterator(root / dir)) {
      if (e.is_regular_file() && e.path().extension() == ".hf") files.push_back(e.path());
    }
  }
  // 34 models and 63 probes (2026-12): fewer means the corpus moved or was not found.
  ASSERT_GE(files.size(), 97u) << "the corpus at " << root;
  std::sort(files.begin(), files.end());
  int qualified = 0, total = 0, crossings_checked = 0;
  for (const auto& path : files) {
    ModelOptions mo;
    mo.backend = Backend::kInterp;  // no JIT compile for the big historical files
    auto c = Model::compile_file(path.string(), mo);
    const std::string rel = std::filesystem::relative(path, root).string();
    EXPECT_TRUE(c.ok()) << rel << " does not compile:\n" << c.rendered;
    if (!c.ok()) continue;
    ++total;
    AnalyticInfo info = c.model->analytic_info();
    if (info.qualifies) {
      ++qualified;
      std::printf("[ poly ] qualifies  %-70s %d leaves, degree %d\n", rel.c_str(), info.num_leaves,
                  info.max_degree);
      if (c.model->num_inputs() >= 3 && info.num_leaves > 0 && info.num_leaves < 200) {
        crossings_checked += check_crossings(*c.model, 8, 3.0, 8.0, 800, 3, rel);
      }
    } else {
      std::printf("[ poly ] no         %-70s %s (%d:%d)\n", rel.c_str(), info.reason.c_str(),
                  info.line, info.col);
      EXPECT_FALSE(info.reason.empty()) << rel;
    }
  }
  std::printf("[ poly ] corpus: %d of %d models qualify for analytic roots; %d crossings checked\n",
              qualified, total, crossings_checked);
  // Every file classified; at least the 42 that qualify today (a change of the classification
  // that loses some is a regression), and their crossings compared.
  EXPECT_EQ(total, static_cast<int>(files.size()));
  EXPECT_GE(qualified, 42);
  EXPECT_GE(crossings_checked, 350);  // 400 today
}

}  // namespace
}  // namespace hfrt::jit
