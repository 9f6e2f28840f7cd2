// Numbers as hidden parameters (ir::hoist_constants, ModelOptions::hoist_constants): which
// constants move, the structure key that decides code sharing, and the same values as without
// it in every domain (points f64/f32, intervals, gradients, ray polynomials) on the corpus.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "base/file.h"
#include "base/result.h"
#include "hfrt/model.h"
#include "ir/hoist_constants.h"
#include "ir/ir.h"
#include "ir/structure_key.h"
#include "ir/uniform_values.h"
#include "ir/verify.h"
#include "jit/interval.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

namespace fs = std::filesystem;

TEST(HoistConstants, OnlyNumbersThatFeedArithmeticBecomeParameters) {
  auto c = testutil::compile(
      "my_model(x[3], a[1]) {\n"
      "  k = 0.25;\n"
      "  e = abs(x[1])^2.5;\n"
      "  w = 0;\n"
      "  if (x[2] > 0.5) then w = x[3] * 3; endif;\n"
      "  my_model = k - e * 7 + w + a[1];\n"
      "}\n");
  ASSERT_TRUE(c.ok) << c.diagnostics;
  Function fn = c.fn;
  const int user = fn.num_params;
  std::vector<double> values = hoist_constants(&fn);
  EXPECT_EQ(verify(fn), "");
  // 0.25 (a variable's value), 7 and 3 (factors) move; the exponent 2.5 and the compared 0.5
  // stay constants (the polynomial analysis and the conditions read them).
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_EQ(sorted, (std::vector<double>{0.25, 3, 7}));
  EXPECT_EQ(fn.num_params, user + 3);
  EXPECT_EQ(fn.hoisted_params_from, user);
  bool two = false, half = false;
  for (const Inst& in : fn.insts) {
    if (in.op == Op::kConst) {
      two = two || in.imm == 2.5;
      half = half || in.imm == 0.5;
    }
  }
  EXPECT_TRUE(two);
  EXPECT_TRUE(half);
  // The parameters carry the values: the interpreter gives what the original gives.
  Interpreter plain(c.fn), hoisted(fn);
  for (double x2 : {0.0, 1.0}) {
    std::vector<double> x{1.5, x2, -2}, a{0.125}, ah = a;
    ah.insert(ah.end(), values.begin(), values.end());
    EXPECT_EQ(plain.eval(x, a).value, hoisted.eval(x, ah).value);
  }
}

TEST(HoistConstants, TheKeyIgnoresTheNumbersButNotTheStructure) {
  auto key = [](const std::string& body) {
    auto c = testutil::compile("my_model(x[3], a[1]) {\n" + body + "\n}\n");
    EXPECT_TRUE(c.ok) << c.diagnostics;
    Function fn = c.fn;
    hoist_constants(&fn);
    return structure_key(fn);
  };
  const std::string base = key("  r = 0.7;\n  my_model = r - sqrt(x[1]*x[1] + x[2]*x[2]);");
  EXPECT_TRUE(base == key("  r = 0.93;\n  my_model = r - sqrt(x[1]*x[1] + x[2]*x[2]);"));
  // Another operation, another exponent, another line: different code or error locations.
  EXPECT_TRUE(base != key("  r = 0.7;\n  my_model = r + sqrt(x[1]*x[1] + x[2]*x[2]);"));
  EXPECT_TRUE(base != key("  r = 0.7;\n  my_model = r - sqrt(x[1]^2 + x[2]*x[2]);"));
  EXPECT_TRUE(base != key("  r = 0.7;\n\n  my_model = r - sqrt(x[1]*x[1] + x[2]*x[2]);"));
  // Two numbers that are equal share one constant: making them differ changes the structure.
  EXPECT_TRUE(key("  my_model = 2 * x[1] + 2 * x[2];") != key("  my_model = 2 * x[1] + 3 * x[2];"));
}

bool same_bits(double u, double v) {
  return std::memcmp(&u, &v, sizeof u) == 0 || (std::isnan(u) && std::isnan(v));
}
bool same_bits(float u, float v) {
  return std::memcmp(&u, &v, sizeof u) == 0 || (std::isnan(u) && std::isnan(v));
}

/// Compares a model compiled with hoisted numbers against the plain one on points, boxes,
/// gradients and rays; returns the number of differences (reported for the first few).
int compare_models(const std::string& path, Backend backend) {
  Result<std::string> text = read_file(path);
  EXPECT_TRUE(text.ok()) << path;
  if (!text.ok()) return 1;
  ModelOptions plain_options, hoist_options;
  plain_options.backend = hoist_options.backend = backend;
  plain_options.eager_f64 = hoist_options.eager_f64 = false;
  hoist_options.hoist_constants = true;
  CompileResult plain = Model::compile(text.value(), plain_options, path);
  CompileResult hoisted = Model::compile(text.value(), hoist_options, path);
  // Every corpus model compiles: a failure here is a failure, not a model left out.
  EXPECT_TRUE(plain.ok()) << path << ":\n" << plain.rendered;
  EXPECT_TRUE(hoisted.ok()) << path << ":\n" << hoisted.rendered;
  if (!plain.ok() || !hoisted.ok()) return 1;
  const Model& p = *plain.model;
  const Model& h = *hoisted.model;
  EXPECT_EQ(p.num_params(), h.num_params()) << path;
  EXPECT_EQ(p.analytic_info().qualifies, h.analytic_info().qualifies) << path;
  const int dims = p.num_inputs();
  const int n = 64;
  std::mt19937_64 rng(std::hash<std::string>{}(fs::path(path).filename().string()));
  std::uniform_real_distribution<double> u(-3, 3);
  std::vector<double> xs(size_t(dims) * n, 0.0), lo(xs.size()), hi(xs.size());
  for (size_t i = 0; i < xs.size(); ++i) {
    xs[i] = u(rng);
    double w = std::abs(u(rng)) * 0.2;
    lo[i] = xs[i] - w;
    hi[i] = xs[i] + w;
  }
  std::vector<float> xf(xs.begin(), xs.end());
  int diffs = 0;
  auto report = [&](const char* what, int i) {
    if (diffs++ < 3) ADD_FAILURE() << path << ": " << what << " differs at sample " << i;
  };
  std::vector<double> fp(n), fh(n);
  p.eval_batch(n, xs.data(), fp.data());
  h.eval_batch(n, xs.data(), fh.data());
  for (int i = 0; i < n; ++i) {
    if (!same_bits(fp[i], fh[i])) report("f64 value", i);
  }
  std::vector<float> gp(4 * n), gh(4 * n), vp(n), vh(n);
  p.eval_batch(n, xf.data(), vp.data());
  h.eval_batch(n, xf.data(), vh.data());
  for (int i = 0; i < n; ++i) {
    if (!same_bits(vp[i], vh[i])) report("f32 value", i);
  }
  p.eval_gradient_batch(n, xf.data(), gp.data());
  h.eval_gradient_batch(n, xf.data(), gh.data());
  for (int i = 0; i < 4 * n; ++i) {
    if (!same_bits(gp[i], gh[i])) report("f32 gradient", i % n);
  }
  std::vector<double> plo(n), phi(n), hlo(n), hhi(n);
  std::vector<uint8_t> pnan(n), hnan(n);
  p.eval_interval_batch(n, lo.data(), hi.data(), plo.data(), phi.data(), pnan.data());
  h.eval_interval_batch(n, lo.data(), hi.data(), hlo.data(), hhi.data(), hnan.data());
  for (int i = 0; i < n; ++i) {
    if (!same_bits(plo[i], hlo[i]) || !same_bits(phi[i], hhi[i]) || pnan[i] != hnan[i]) {
      report("interval", i);
    }
  }
  if (p.analytic_info().qualifies && h.analytic_info().qualifies) {
    const int leaves = p.analytic_info().num_leaves;
    std::vector<double> cp(size_t(leaves) * 5), ch(cp.size());
    const double o[3] = {0.3, -2.5, 4}, d[3] = {-0.1, 0.6, -0.8};
    p.ray_polynomials(o, d, cp.data());
    h.ray_polynomials(o, d, ch.data());
    for (size_t i = 0; i < cp.size(); ++i) {
      if (!same_bits(cp[i], ch[i])) report("ray polynomial", int(i));
    }
  }
  return diffs;
}

TEST(HoistConstants, CorpusModelsGiveTheSameBitsWithTheInterpreters) {
  int files = 0, diffs = 0;
  for (const std::string& path : testutil::hf_files(HFRT_CORPUS_DIR "/models")) {
    diffs += compare_models(path, Backend::kInterp);
    ++files;
  }
  EXPECT_GE(files, 34);  // the corpus's 34 models (2026-12)
  EXPECT_EQ(diffs, 0);
}

TEST(HoistConstants, BenchModelsGiveTheSameBitsWithTheJit) {
  // The REPL benchmark's models and their neighbours (each costs two compiles of every
  // domain): blends, CSG, a gyroid (trigonometry), a twist, a gear of 255 instructions.
  int checked = 0, diffs = 0;
  for (const std::string& path :
       testutil::hf_files(HFRT_CORPUS_DIR "/models/github/alexander-penev__FRep-Designer-Bench")) {
    if (path.find("historical") != std::string::npos) continue;
    diffs += compare_models(path, Backend::kJit);
    ++checked;
  }
  EXPECT_GE(checked, 7);
  EXPECT_EQ(diffs, 0);
}

TEST(HoistConstants, OutlinedIntervalCodeReadsTheHoistedNumbersToo) {
  // Objects above IntervalJit::Options::inline_limit call one helper per op with operands in
  // their homes (hoisted parameters get homes there): the same intervals as the interpreter.
  for (const char* name : {"s3_blend.hf", "c1_gear.hf"}) {
    const std::string path = std::string(HFRT_CORPUS_DIR) +
                             "/models/github/alexander-penev__FRep-Designer-Bench/" + name;
    Result<std::string> text = read_file(path);
    ASSERT_TRUE(text.ok()) << path;
    auto c = testutil::compile(text.value());
    ASSERT_TRUE(c.ok) << c.diagnostics;
    Function fn = c.fn;
    const int user = fn.num_params;
    std::vector<double> hoisted = hoist_constants(&fn);
    ASSERT_FALSE(hoisted.empty());
    std::vector<double> a(size_t(fn.num_params), 0.0);
    std::copy(hoisted.begin(), hoisted.end(), a.begin() + user);
    for (int limit : {0, 1 << 20}) {
      IntervalJit::Options options;
      options.inline_limit = limit;
      auto jit = IntervalJit::compile(fn, options);
      ASSERT_TRUE(jit.ok()) << jit.error().message;
      IntervalInterpreter ii(fn);
      std::mt19937_64 rng(9);
      std::uniform_real_distribution<double> u(-1.5, 1.5);
      for (int i = 0; i < 50; ++i) {
        std::vector<Interval> box;
        for (int k = 0; k < 3; ++k) {
          double lo = u(rng), w = std::abs(u(rng)) * 0.3;
          box.push_back(Interval::of(lo, lo + w));
        }
        Interval want = ii.eval(box, a), got = jit.value()->eval_one(box, a);
        EXPECT_TRUE(same_bits(want.lo, got.lo) && same_bits(want.hi, got.hi) &&
                    want.maybe_nan == got.maybe_nan)
            << name << " inline_limit " << limit << " box " << i;
      }
    }
  }
}

TEST(HoistConstants, AnEditedNumberSharesTheCodeAndGivesItsOwnValues) {
  ModelOptions o;
  o.hoist_constants = true;
  auto src = [](double r) {
    return "my_model(x[3], a[1]) { my_model = " + std::to_string(r) +
           " - sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3]) + a[1]; }\n";
  };
  // (Not 1: a number equal to a constant that the lowering itself uses shares that constant,
  // and the structure differs from the edited one's.)
  CompileResult one = Model::compile(src(1.25), o, "one.hf");
  CompileResult two = Model::compile(src(2.5), o, "two.hf");
  CompileResult other =
      Model::compile("my_model(x[3], a[1]) { my_model = 1 - abs(x[1]) + a[1]; }\n", o, "other.hf");
  ASSERT_TRUE(one.ok() && two.ok() && other.ok());
  ASSERT_TRUE(one.model->prepare(hfrt::Precision::kF64));
  EXPECT_TRUE(one.model->code_key() == two.model->code_key());
  EXPECT_FALSE(other.model->share_code(*one.model));
  ASSERT_TRUE(two.model->share_code(*one.model));
  EXPECT_EQ(two.model->num_params(), 1);
  two.model->set_params({0.25});
  EXPECT_DOUBLE_EQ(two.model->eval({1, 0, 0}).f, 2.5 - 1 + 0.25);
  EXPECT_DOUBLE_EQ(one.model->eval({1, 0, 0}).f, 0.25);
  IntervalValue iv = two.model->eval_interval({0, 0, 0}, {0, 0, 0});
  EXPECT_LE(iv.lo, 2.75);
  EXPECT_GE(iv.hi, 2.75);
}

}  // namespace
}  // namespace hfrt::jit

namespace hfrt::jit {
namespace {

/// uniform_values of the model's instructions that compute `op`, in order.
std::vector<int> uniform_of(const std::string& body, Op op) {
  auto c = testutil::compile("my_model(x[3], a[1]) {\n" + body + "\n}\n");
  EXPECT_TRUE(c.ok) << c.diagnostics;
  std::vector<uint8_t> u = uniform_values(c.fn);
  std::vector<int> out;
  for (size_t i = 0; i < c.fn.insts.size(); ++i) {
    if (c.fn.insts[i].op == op) out.push_back(u[i]);
  }
  return out;
}

TEST(UniformValues, ALoopOverAConstantCountIsTheSameOnEveryLane) {
  // blend.hf's shape: the angle, its sine and the mod of the counter are uniform; the
  // distance to x is not.
  EXPECT_EQ(uniform_of("  acc = 0; i = 0;\n"
                       "  while i < 6 loop\n"
                       "    acc = acc + sin(i * 1.047) * x[1];\n"
                       "    if mod(i, 2) = 0 then acc = acc + cos(i); endif;\n"
                       "    i = i + 1;\n"
                       "  endloop;\n"
                       "  my_model = acc;",
                       Op::kSin),
            std::vector<int>{1});
  std::vector<int> two = uniform_of("  my_model = sin(x[1]) + sin(a[1]);", Op::kSin);
  std::sort(two.begin(), two.end());
  EXPECT_EQ(two, (std::vector<int>{0, 1}));
  // The cosine under the uniform `if` and the mod of the counter are uniform too.
  EXPECT_EQ(uniform_of("  acc = 0; i = 0;\n"
                       "  while i < 6 loop\n"
                       "    if mod(i, 2) = 0 then acc = acc + cos(i) * x[2]; endif;\n"
                       "    i = i + 1;\n"
                       "  endloop;\n"
                       "  my_model = acc;",
                       Op::kCos),
            std::vector<int>{1});
}

TEST(UniformValues, TheJitComputingThemOnceGivesTheInterpretersBits) {
  // examples/blend.hf: six spheres placed by sin and cos of a loop counter, radii chosen by
  // mod(i, 2). The JIT calls those once per block; values must stay the interpreter's.
  Result<std::string> text = read_file(HFRT_SOURCE_DIR "/examples/blend.hf");
  ASSERT_TRUE(text.ok());
  ModelOptions jit_options, interp_options;
  interp_options.backend = Backend::kInterp;
  CompileResult jit = Model::compile(text.value(), jit_options, "blend.hf");
  CompileResult interp = Model::compile(text.value(), interp_options, "blend.hf");
  ASSERT_TRUE(jit.ok() && interp.ok());
  const int n = 203;  // not a multiple of any lane count: a padded block too
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-8, 8);
  std::vector<double> xs(3 * n), fj(n), fi(n);
  for (double& v : xs) v = u(rng);
  jit.model->eval_batch(n, xs.data(), fj.data());
  interp.model->eval_batch(n, xs.data(), fi.data());
  int inside = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_TRUE(same_bits(fj[i], fi[i])) << i << ": " << fj[i] << " vs " << fi[i];
    inside += fi[i] >= 0;
  }
  EXPECT_GT(inside, 0);
}

TEST(UniformValues, VariablesSetWhereLanesDivergeAreNot) {
  // Stored under a condition on x: lanes differ afterwards.
  EXPECT_EQ(uniform_of("  t = 1;\n"
                       "  if x[1] > 0 then t = 2; endif;\n"
                       "  my_model = sin(t) - x[2];",
                       Op::kSin),
            std::vector<int>{0});
  // A loop whose test depends on x: lanes leave at different iterations.
  EXPECT_EQ(uniform_of("  i = 0;\n"
                       "  while i < x[1] loop i = i + 1; endloop;\n"
                       "  my_model = sin(i);",
                       Op::kSin),
            std::vector<int>{0});
  // An array element chosen by x.
  EXPECT_EQ(uniform_of("  array v[2];\n"
                       "  v = [1, 2];\n"
                       "  j = 1;\n"
                       "  if x[1] > 0 then j = 2; endif;\n"
                       "  v[j] = 5;\n"
                       "  my_model = sin(v[1]) - x[3];",
                       Op::kSin),
            std::vector<int>{0});
}

}  // namespace
}  // namespace hfrt::jit

namespace hfrt::jit {
namespace {

TEST(RFunctionIntervals, MonotoneEnclosuresAreSoundTightAndTheSameInTheJit) {
  // Union, intersection and subtraction of quadrics, nested; the operands are dead before the
  // R-function node in the op order (their JIT homes must live on until it).
  const char* bodies[] = {
      "  my_model = (1 - x[1]*x[1]) | (1 - x[2]*x[2]);",
      "  my_model = (4 - x[1]*x[1] - x[2]*x[2]) & (x[3] + 0.5);",
      "  b = 1 - x[1]*x[1] - x[3]*x[3];\n  my_model = ((2 - x[2]*x[2]) \\ b) | (x[1] - 1.5);",
  };
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-4, 4), w(0, 3);
  for (const char* body : bodies) {
    auto c = testutil::compile(std::string("my_model(x[3], a[1]) {\n") + body + "\n}\n");
    ASSERT_TRUE(c.ok) << c.diagnostics;
    IntervalInterpreter ii(c.fn);
    Interpreter point(c.fn);
    std::vector<std::unique_ptr<IntervalJit>> jits;
    for (int limit : {0, 1 << 20}) {
      IntervalJit::Options o;
      o.inline_limit = limit;
      auto j = IntervalJit::compile(c.fn, o);
      ASSERT_TRUE(j.ok()) << j.error().message;
      jits.push_back(std::move(j.value()));
    }
    std::vector<double> a{0};
    int excluded = 0;
    for (int i = 0; i < 300; ++i) {
      std::vector<Interval> box;
      for (int k = 0; k < 3; ++k) {
        double lo = u(rng);
        box.push_back(Interval::of(lo, lo + w(rng) * (i % 3 == 0 ? 0.01 : 1)));
      }
      Interval r = ii.eval(box, a);
      for (const auto& j : jits) {
        Interval got = j->eval_one(box, a);
        EXPECT_TRUE(same_bits(r.lo, got.lo) && same_bits(r.hi, got.hi) &&
                    r.maybe_nan == got.maybe_nan)
            << body << " box " << i;
      }
      for (int s = 0; s < 20; ++s) {
        std::vector<double> p;
        for (const Interval& b : box)
          p.push_back(b.lo + (b.hi - b.lo) *
                                 (s % 4 == 0 ? s % 8 / 4
                                             : std::uniform_real_distribution<double>(0, 1)(rng)));
        double v = point.eval(p, a).value;
        EXPECT_TRUE(r.contains(v))
            << body << " box " << i << ": " << v << " not in [" << r.lo << ", " << r.hi << "]";
      }
      excluded += r.hi < 0 || r.lo > 0;
    }
    EXPECT_GT(excluded, 50) << body;
  }
  // Far outside both quadrics: op by op the enclosure of the union reaches 0 (f1 and f2 each
  // occur twice); by monotonicity it is [R(-8, -8), R(-3, -3)], entirely below 0.
  auto c = testutil::compile(std::string("my_model(x[3], a[1]) {\n") + bodies[0] + "\n}\n");
  IntervalInterpreter ii(c.fn);
  std::vector<Interval> box{Interval::of(2, 3), Interval::of(2, 3), Interval::of(0, 0)};
  Interval r = ii.eval(box, std::vector<double>{0});
  EXPECT_NEAR(r.lo, -16 + std::sqrt(128.0), 1e-9);
  EXPECT_NEAR(r.hi, -6 + std::sqrt(18.0), 1e-9);
}

}  // namespace
}  // namespace hfrt::jit
