// The public embedding API (hfrt/model.h): compile, diagnostics, objects, parameters,
// single points and batches in both precisions and both backends, threads; the interval and
// gradient domains (soundness on sampled points, central differences, engines, laziness).

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <thread>

#include "hfrt/model.h"

namespace hfrt {
namespace {

const char* kTwoObjects =
    "my_model(x[3], a[2], s[1])\n"
    "{\n"
    "  r2 = x[1]*x[1] + x[2]*x[2] + x[3]*x[3];\n"
    "  s[1] = r2;\n"
    "  my_model = a[1] - r2 / a[2];\n"
    "}\n"
    "slab(x[3], a[1])\n"
    "{\n"
    "  slab = 1 - abs(x[3]);\n"
    "}\n";

double sphere(double x, double y, double z, double a1, double a2) {
  return a1 - (x * x + y * y + z * z) / a2;
}

TEST(JitModelTest, CompileErrorsAreStructuredDiagnostics) {
  CompileResult r = Model::compile("my_model(x[3], a[1]) { my_model = x[1] + ; }", {}, "bad.hf");
  ASSERT_FALSE(r.ok());
  ASSERT_FALSE(r.diagnostics.empty());
  EXPECT_EQ(r.diagnostics[0].severity, SourceDiagnostic::Severity::kError);
  EXPECT_EQ(r.diagnostics[0].file, "bad.hf");
  EXPECT_EQ(r.diagnostics[0].line, 1);
  EXPECT_GT(r.diagnostics[0].col, 30);
  EXPECT_NE(r.rendered.find("bad.hf:1:"), std::string::npos) << r.rendered;
  EXPECT_EQ(r.error, "");
  CompileResult missing = Model::compile_file("/nonexistent/model.hf");
  EXPECT_FALSE(missing.ok());
  EXPECT_NE(missing.error, "");
}

TEST(JitModelTest, BothBackendsAndPrecisionsAgree) {
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    ModelOptions mo;
    mo.backend = backend;
    CompileResult r = Model::compile(kTwoObjects, mo);
    ASSERT_TRUE(r.ok()) << r.rendered << r.error;
    Model& m = *r.model;
    EXPECT_EQ(m.object_name(), "my_model");
    EXPECT_EQ(m.num_inputs(), 3);
    EXPECT_EQ(m.num_params(), 2);
    EXPECT_EQ(m.num_attributes(), 1);
    m.set_params({2.0, 4.0});
    PointValue v = m.eval({0.5, -1.0, 0.25});
    EXPECT_TRUE(v.ok());
    EXPECT_DOUBLE_EQ(v.f, sphere(0.5, -1.0, 0.25, 2, 4));
    ASSERT_EQ(v.s.size(), 1u);
    EXPECT_DOUBLE_EQ(v.s[0], 0.25 + 1 + 0.0625);

    const int n = 37;  // not a multiple of the lane count
    std::vector<double> xs(3 * n), f(n), s(n);
    std::vector<float> xs32(3 * n), f32(n);
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k) xs[k * n + i] = xs32[k * n + i] = 0.1f * (i - 18) * (k + 1);
    }
    m.eval_batch(n, xs.data(), f.data(), s.data());
    m.eval_batch(n, xs32.data(), f32.data());
    for (int i = 0; i < n; ++i) {
      double want = sphere(xs[i], xs[n + i], xs[2 * n + i], 2, 4);
      EXPECT_DOUBLE_EQ(f[i], want) << i;
      EXPECT_NEAR(f32[i], want, 1e-5 * (1 + std::fabs(want))) << i;
      const double x = xs[i], y = xs[n + i], z = xs[2 * n + i];
      EXPECT_DOUBLE_EQ(s[i], x * x + y * y + z * z) << i;
    }
  }
}

/// `calls` atan2 of different arguments, summed, and `arith` more multiply-adds.
std::string atan2_sum(int calls, int arith = 0) {
  std::string text = "m(x[3], a[1]) { t = 0; u = 0;";
  for (int i = 0; i < calls; ++i) {
    text +=
        " t = t + atan2(x[1] + " + std::to_string(i) + ", x[2] - " + std::to_string(2 * i) + ");";
  }
  for (int i = 0; i < arith; ++i) text += " u = u * 0.5 + x[1];";
  return text + " m = 1 - 0.01 * t - 1e-9 * u; }";
}

/// The JIT's values of `text` equal the interpreter's (f64 bit for bit, f32 closely); returns
/// the JIT model's stats.
ModelStats expect_jit_equals_interpreter(const std::string& text) {
  CompileResult jit = Model::compile(text);
  EXPECT_TRUE(jit.ok()) << jit.rendered;
  ModelOptions interp_options;
  interp_options.backend = Backend::kInterp;
  CompileResult interp = Model::compile(text, interp_options);
  EXPECT_TRUE(interp.ok()) << interp.rendered;
  if (!jit.ok() || !interp.ok()) return {};
  const int n = 37;
  std::vector<double> xs(3 * n), f(n), want(n);
  std::vector<float> xs32(3 * n), f32(n);
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) xs[k * n + i] = xs32[k * n + i] = 0.3f * (i - 18) * (k + 1);
  }
  jit.model->eval_batch(n, xs.data(), f.data());
  jit.model->eval_batch(n, xs32.data(), f32.data());
  interp.model->eval_batch(n, xs.data(), want.data());
  for (int i = 0; i < n; ++i) {
    EXPECT_DOUBLE_EQ(f[i], want[i]) << i;
    EXPECT_NEAR(f32[i], want[i], 1e-4 * (1 + std::fabs(want[i]))) << i;
  }
  // Gradients: f, df/dx, df/dy, df/dz per point.
  std::vector<double> g(4 * n), want_g(4 * n);
  jit.model->eval_gradient_batch(n, xs.data(), g.data());
  interp.model->eval_gradient_batch(n, xs.data(), want_g.data());
  for (int i = 0; i < 4 * n; ++i) {
    if (std::isnan(want_g[i])) {
      EXPECT_TRUE(std::isnan(g[i])) << i;  // atan2(0, 0)'s derivative
    } else {
      EXPECT_NEAR(g[i], want_g[i], 1e-12 * (1 + std::fabs(want_g[i]))) << i;
    }
  }
  return jit.model->stats();
}

TEST(JitModelTest, CallHeavyCodeTakesOneLaneAndFastCodeGeneration) {
  // 160 atan2: 1280 calls at 8 f64 lanes, more than jit::kCallHeavyLaneCalls (1000), and
  // most of the instructions: one lane, 160 calls, under jit::kFastCodegenCalls (500): the
  // optimising code generator.
  ModelStats st = expect_jit_equals_interpreter(atan2_sum(160));
  EXPECT_EQ(st.jit_f64.lanes, 1);
  EXPECT_EQ(st.jit_f32.lanes, 1);
  EXPECT_EQ(st.gradient_f64.lanes, 1);
  EXPECT_EQ(st.jit_f64.llvm_calls, 160u);
  EXPECT_FALSE(st.jit_f64.fast_codegen);
  // 600 atan2: more than 500 calls at one lane: fast code generation too.
  st = expect_jit_equals_interpreter(atan2_sum(600));
  EXPECT_EQ(st.jit_f64.lanes, 1);
  EXPECT_GT(st.jit_f64.llvm_calls, 500u);
  EXPECT_TRUE(st.jit_f64.fast_codegen);
  EXPECT_TRUE(st.jit_f32.fast_codegen);
  // A few calls: the host's lanes.
  st = expect_jit_equals_interpreter(atan2_sum(3));
  EXPECT_GT(st.jit_f64.lanes, 1);
  EXPECT_GT(st.jit_f32.lanes, 1);
  EXPECT_GT(st.gradient_f64.lanes, 1);
  EXPECT_FALSE(st.jit_f64.fast_codegen);
  // 160 calls among 4000 multiply-adds (< 1/16 of the instructions): the host's lanes.
  st = expect_jit_equals_interpreter(atan2_sum(160, 4000));
  EXPECT_GT(st.jit_f64.lanes, 1);
  EXPECT_GT(st.jit_f32.lanes, 1);
}

TEST(JitModelTest, RuntimeErrorsGiveNanAndTheMessage) {
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    ModelOptions mo;
    mo.backend = backend;
    CompileResult r = Model::compile(kTwoObjects, mo);
    ASSERT_TRUE(r.ok());
    r.model->set_params({1.0, 0.0});  // divides by a[2] = 0
    PointValue v = r.model->eval({1, 2, 3});
    EXPECT_TRUE(std::isnan(v.f));
    EXPECT_EQ(v.error, "Division by zero");
    EXPECT_EQ(v.error_line, 5);
    double xs[3] = {1, 2, 3}, f = 0, s = 0;
    r.model->eval_batch(1, xs, &f, &s);
    EXPECT_TRUE(std::isnan(f));
    EXPECT_TRUE(std::isnan(s));
  }
}

TEST(JitModelTest, SelectObjectRecompiles) {
  ModelOptions mo;
  mo.object = "SLAB";  // case-insensitive, as the language
  CompileResult r = Model::compile(kTwoObjects, mo);
  ASSERT_TRUE(r.ok()) << r.rendered;
  Model& m = *r.model;
  EXPECT_EQ(m.object_name(), "slab");
  EXPECT_EQ(m.object_location(), (std::pair<int, int>{7, 1}));  // its name in its header
  EXPECT_EQ(m.object_names(), (std::vector<std::string>{"my_model", "slab"}));
  EXPECT_DOUBLE_EQ(m.eval({0, 0, 0.25}).f, 0.75);
  EXPECT_NE(m.ir_text().find("abs"), std::string::npos) << m.ir_text();
  std::string err;
  EXPECT_FALSE(m.select_object("nope", &err));
  EXPECT_NE(err, "");
  EXPECT_EQ(m.object_name(), "slab");
  for (int k = 0; k < 5; ++k) {  // recompiling repeatedly frees the old code
    ASSERT_TRUE(m.select_object(k % 2 ? "slab" : "my_model", &err)) << err;
  }
  EXPECT_EQ(m.object_name(), "my_model");
  EXPECT_EQ(m.object_location(), (std::pair<int, int>{1, 1}));
  m.set_params({1.0, 1.0});
  EXPECT_DOUBLE_EQ(m.eval({0.5, 0, 0}).f, 0.75);
  EXPECT_NE(m.llvm_ir(Precision::kF64).find("define"), std::string::npos);
  EXPECT_TRUE(m.stats().jit_f64.compiled);
}

TEST(JitModelTest, ManyThreadsEvaluateAtOnce) {
  CompileResult r = Model::compile(kTwoObjects);
  ASSERT_TRUE(r.ok());
  const Model& m = *r.model;  // f32 code is compiled lazily by whichever thread comes first
  std::vector<std::thread> threads;
  std::vector<int> bad(8, 0);
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      const int n = 1000;
      std::vector<float> xs(3 * n), f(n);
      for (int rep = 0; rep < 20; ++rep) {
        for (int i = 0; i < n; ++i) xs[i] = xs[n + i] = xs[2 * n + i] = 0.001f * (i + t);
        m.eval_batch(n, xs.data(), f.data());
        for (int i = 0; i < n; ++i) {
          double want = sphere(xs[i], xs[i], xs[i], 0, 1);
          bad[t] += std::fabs(f[i] - want) > 1e-5;
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 8; ++t) EXPECT_EQ(bad[t], 0) << t;
}

// --- Interval and gradient domains -----------------------------------------------------------

const char* kSphereModel =
    "my_model(x[3], a[1]) {\n"
    "  array c[3];\n"
    "  c = [0.5, -1, 0];\n"
    "  my_model = hfSphere(x, c, a[1]);\n"
    "}\n";

const char* kTorusModel =
    "my_model(x[3], a[1]) {\n"
    "  array c[3];\n"
    "  c = [0, 0, 1];\n"
    "  my_model = hfTorusZ(x, c, 3, 1);\n"
    "}\n";

/// Blends, a division and a square root: loose enclosures, NaN possible (sqrt of x[1]).
const char* kRoughModel =
    "my_model(x[3], a[1]) {\n"
    "  array c[3];\n"
    "  c = [0, 0, 0];\n"
    "  b = hfBlendUni(hfSphere(x, c, 2), x[3] - 0.5, 1, 1, 1);\n"
    "  my_model = b + sqrt(x[1]) / (1 + x[2] * x[2]);\n"
    "}\n";

Model compile_or_die(const char* source, Backend backend, std::vector<double> params = {3.0}) {
  ModelOptions mo;
  mo.backend = backend;
  CompileResult r = Model::compile(source, mo);
  EXPECT_TRUE(r.ok()) << r.rendered << r.error;
  Model m = std::move(*r.model);
  m.set_params(std::move(params));
  return m;
}

TEST(JitModelTest, IntervalContainsSampledPoints) {
  for (const char* source : {kSphereModel, kTorusModel, kRoughModel}) {
    for (Backend backend : {Backend::kJit, Backend::kInterp}) {
      Model m = compile_or_die(source, backend);
      std::mt19937_64 rng(7);
      std::uniform_real_distribution<double> u(-4, 4), w(0, 1);
      int nan_boxes = 0;
      for (int b = 0; b < 200; ++b) {
        double lo[3], hi[3];
        const double width = std::pow(10.0, -3 + 3.5 * w(rng));
        for (int k = 0; k < 3; ++k) {
          lo[k] = u(rng);
          hi[k] = lo[k] + width * w(rng);
        }
        IntervalValue iv = m.eval_interval(lo, hi);
        ASSERT_LE(iv.lo, iv.hi);
        nan_boxes += iv.maybe_nan;
        for (int s = 0; s < 40; ++s) {
          double p[3];
          for (int k = 0; k < 3; ++k) {
            // Corners first, then random points inside.
            p[k] = s < 8 ? ((s >> k) & 1 ? hi[k] : lo[k]) : lo[k] + (hi[k] - lo[k]) * w(rng);
          }
          double f = m.eval(std::span<const double>(p, 3)).f;
          ASSERT_TRUE(iv.contains(f)) << "F = " << f << " outside [" << iv.lo << ", " << iv.hi
                                      << "]" << (iv.maybe_nan ? " nan" : "") << " at (" << p[0]
                                      << ", " << p[1] << ", " << p[2] << ")";
        }
      }
      if (source == kRoughModel) {
        EXPECT_GT(nan_boxes, 0);  // boxes with x[1] < 0 may have no value
      } else {
        EXPECT_EQ(nan_boxes, 0);
      }
    }
  }
}

TEST(JitModelTest, IntervalOfAKnownBoxIsTight) {
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    Model m = compile_or_die(kSphereModel, backend, {2.0});
    // hfSphere = r^2 - |x - c|^2; over [0.5, 1.5] x [-1, 0] x [0, 1]: [4 - 3, 4 - 0].
    IntervalValue iv = m.eval_interval({0.5, -1, 0}, {1.5, 0, 1});
    EXPECT_NEAR(iv.lo, 1.0, 1e-9);
    EXPECT_NEAR(iv.hi, 4.0, 1e-9);
    EXPECT_LE(iv.lo, 1.0);
    EXPECT_GE(iv.hi, 4.0);
    EXPECT_FALSE(iv.maybe_nan);
    // A degenerate box is (about) the point value.
    IntervalValue pt = m.eval_interval({1, 1, 1}, {1, 1, 1});
    double f = m.eval({1, 1, 1}).f;
    EXPECT_TRUE(pt.contains(f));
    EXPECT_LT(pt.hi - pt.lo, 1e-12);
  }
}

TEST(JitModelTest, IntervalBatchMatchesSingleBoxesOnBothBackends) {
  Model jit = compile_or_die(kRoughModel, Backend::kJit);
  Model interp = compile_or_die(kRoughModel, Backend::kInterp);
  EXPECT_EQ(jit.interval_engine(), DomainEngine::kJit);
  EXPECT_EQ(interp.interval_engine(), DomainEngine::kInterp);
  const int n = 23;
  std::vector<double> lo(3 * n), hi(3 * n);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-3, 3), w(0, 0.7);
  for (int i = 0; i < 3 * n; ++i) {
    lo[i] = u(rng);
    hi[i] = lo[i] + w(rng);
  }
  for (const Model* m : {&jit, &interp}) {
    std::vector<double> rlo(n), rhi(n);
    std::vector<uint8_t> rnan(n);
    m->eval_interval_batch(n, lo.data(), hi.data(), rlo.data(), rhi.data(), rnan.data());
    for (int i = 0; i < n; ++i) {
      double blo[3] = {lo[i], lo[n + i], lo[2 * n + i]}, bhi[3] = {hi[i], hi[n + i], hi[2 * n + i]};
      IntervalValue one = jit.eval_interval(blo, bhi);
      // The interval JIT and interpreter implement the same op extensions: same bounds.
      EXPECT_EQ(rlo[i], one.lo) << i;
      EXPECT_EQ(rhi[i], one.hi) << i;
      EXPECT_EQ(rnan[i] != 0, one.maybe_nan) << i;
    }
  }
}

TEST(JitModelTest, IntervalTraceTellsWhichOperandDecides) {
  const char* source = "my_model(x[3], a[1]) { my_model = max(x[1], x[2]); }";
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    Model m = compile_or_die(source, backend);
    std::vector<uint8_t> choices;
    auto count = [&](uint8_t bits) { return std::count(choices.begin(), choices.end(), bits); };
    m.eval_interval(std::vector<double>{2, 0, 0}, std::vector<double>{3, 1, 0}, &choices);
    EXPECT_EQ(choices.size(), static_cast<size_t>(m.stats().ir_insts));
    EXPECT_EQ(count(1), 1);  // x[1] >= 2 > x[2]: only the left operand
    EXPECT_EQ(count(2) + count(3), 0);
    m.eval_interval(std::vector<double>{0, 2, 0}, std::vector<double>{1, 3, 0}, &choices);
    EXPECT_EQ(count(2), 1);
    EXPECT_EQ(count(1) + count(3), 0);
    m.eval_interval(std::vector<double>{0, 0, 0}, std::vector<double>{2, 2, 0}, &choices);
    EXPECT_EQ(count(3), 1);
    // The batch ORs over its boxes.
    double lo[2 * 3] = {2, 0, 0, 2, 0, 0}, hi[2 * 3] = {3, 1, 1, 3, 0, 0};
    double rlo[2], rhi[2];
    uint8_t rnan[2];
    choices.assign(choices.size(), 0xff);  // overwritten, not OR-ed into
    m.eval_interval_batch(2, lo, hi, rlo, rhi, rnan, choices.data());
    EXPECT_EQ(count(3), 1);
    EXPECT_EQ(count(0xff), 0);
  }
}

/// Central differences of the f64 scalar evaluator.
void central_differences(const Model& m, const double p[3], double h, double out[3]) {
  for (int k = 0; k < 3; ++k) {
    double a[3] = {p[0], p[1], p[2]}, b[3] = {p[0], p[1], p[2]};
    a[k] += h;
    b[k] -= h;
    out[k] = (m.eval(std::span<const double>(a, 3)).f - m.eval(std::span<const double>(b, 3)).f) /
             (2 * h);
  }
}

TEST(JitModelTest, GradientMatchesCentralDifferences) {
  for (const char* source : {kSphereModel, kTorusModel}) {
    for (Backend backend : {Backend::kJit, Backend::kInterp}) {
      Model m = compile_or_die(source, backend);
      std::mt19937_64 rng(11);
      std::uniform_real_distribution<double> u(-4, 4);
      const int n = 50;
      std::vector<double> xs(3 * n), g(4 * n);
      std::vector<float> xs32(3 * n), g32(4 * n);
      for (int i = 0; i < n; ++i) {
        for (int k = 0; k < 3; ++k) xs32[k * n + i] = static_cast<float>(xs[k * n + i] = u(rng));
      }
      m.eval_gradient_batch(n, xs.data(), g.data());
      m.eval_gradient_batch(n, xs32.data(), g32.data());
      for (int i = 0; i < n; ++i) {
        const double p[3] = {xs[i], xs[n + i], xs[2 * n + i]};
        GradientValue gv = m.eval_gradient(std::span<const double>(p, 3));
        double fd[3];
        central_differences(m, p, 1e-5, fd);
        EXPECT_DOUBLE_EQ(gv.f, m.eval(std::span<const double>(p, 3)).f) << i;
        EXPECT_DOUBLE_EQ(g[i], gv.f) << i;
        for (int k = 0; k < 3; ++k) {
          EXPECT_NEAR(gv.d[k], fd[k], 1e-6 * (1 + std::fabs(fd[k]))) << "point " << i << " d" << k;
          EXPECT_DOUBLE_EQ(g[(k + 1) * n + i], gv.d[k]) << i;
          EXPECT_NEAR(g32[(k + 1) * n + i], gv.d[k], 1e-4 * (1 + std::fabs(gv.d[k]))) << i;
        }
      }
    }
  }
}

TEST(JitModelTest, GradientOfASphereIsExact) {
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    Model m = compile_or_die(kSphereModel, backend, {2.0});
    // F = 4 - (x-0.5)^2 - (y+1)^2 - z^2: grad = -2 (x - 0.5, y + 1, z).
    GradientValue g = m.eval_gradient({1.5, 1, -2});
    EXPECT_DOUBLE_EQ(g.f, 4 - 1 - 4 - 4);
    EXPECT_DOUBLE_EQ(g.d[0], -2);
    EXPECT_DOUBLE_EQ(g.d[1], -4);
    EXPECT_DOUBLE_EQ(g.d[2], 4);
  }
}

TEST(JitModelTest, GradientOfAPointWithoutValueIsNan) {
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    Model m = compile_or_die("my_model(x[3], a[1]) { my_model = 1 / x[1]; }", backend);
    GradientValue g = m.eval_gradient({0, 1, 1});
    EXPECT_TRUE(std::isnan(g.f));
    for (double d : g.d) EXPECT_TRUE(std::isnan(d));
    GradientValue ok = m.eval_gradient({2, 1, 1});
    EXPECT_DOUBLE_EQ(ok.f, 0.5);
    EXPECT_DOUBLE_EQ(ok.d[0], -0.25);
  }
}

// Found by `make fuzz` (the differential target, fuzz/seeds/differential/gradient_kinks_cancel):
// where a subexpression is not differentiable the gradient domain gives the formal derivative
// of the branch taken (sqrt at 0 with a zero inner derivative contributes 0), even where the
// kinks cancel and F itself is flat. At (1, 0, 0): v3 = -min(-x3, x3 + x2) takes x3 + x2 and
// sits on its kink, and (x3 + v3) & 0 is the R-intersection at its non-smooth origin, so
// d/dx2 = -(d(x3 + v3) + 0) = 1 while F = 0 on both sides. Both backends agree on that value,
// and one step away on either side the gradient is 0 (the fuzzer now skips such points).
TEST(JitModelTest, GradientAtCancellingKinksIsTheFormalDerivative) {
  const char* kModel =
      "my_model(x[3], a[1]) {\n"
      "  v3 = (-min((-x[3]), (x[3] + x[2])));\n"
      "  my_model = (-min(((x[3] + v3) & min(x[3], x[1])), x[1]));\n"
      "}\n";
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    Model m = compile_or_die(kModel, backend);
    GradientValue g = m.eval_gradient({1, 0, 0});
    EXPECT_EQ(g.f, 0.0);
    EXPECT_EQ(g.d[1], 1.0);
    for (double x2 : {1e-6, -1e-6}) {
      EXPECT_EQ(m.eval({1, x2, 0}).f, 0.0) << x2;
      EXPECT_EQ(m.eval_gradient({1, x2, 0}).d[1], 0.0) << x2;
    }
  }
}

TEST(JitModelTest, DomainJitsCompileLazily) {
  CompileResult r = Model::compile(kTorusModel);
  ASSERT_TRUE(r.ok());
  const Model& m = *r.model;
  EXPECT_FALSE(m.stats().interval.compiled);
  EXPECT_FALSE(m.stats().gradient_f64.compiled);
  m.eval_interval({0, 0, 0}, {1, 1, 1});
  EXPECT_TRUE(m.stats().interval.compiled);
  EXPECT_GT(m.stats().interval.compile_ms, 0);
  EXPECT_FALSE(m.stats().gradient_f64.compiled);
  EXPECT_TRUE(m.prepare_gradient(Precision::kF32));
  EXPECT_TRUE(m.stats().gradient_f32.compiled);
  EXPECT_FALSE(m.stats().gradient_f64.compiled);
}

TEST(JitModelTest, HeavyObjectsUseTheDomainInterpreters) {
  // A sum of 1200 distinct terms (no common subexpressions): about 2400 IR instructions,
  // over the default threshold of 2000.
  std::string source = "my_model(x[3], a[1]) { t = 1;";
  double sum = 0, sum_x1 = 0;
  for (int i = 0; i < 1200; ++i) {
    const double c = 0.001 + 1e-6 * i;
    char term[64];
    std::snprintf(term, sizeof term, " t = t - %.17g * x[%d];", c, i % 3 + 1);
    source += term;
    sum += c;
    if (i % 3 == 0) sum_x1 += c;
  }
  source += " my_model = t; }";
  ModelOptions mo;
  mo.eager_f64 = false;  // the scalar JIT is not needed here
  CompileResult heavy = Model::compile(source, mo);
  ASSERT_TRUE(heavy.ok()) << heavy.rendered;
  EXPECT_GT(heavy.model->stats().domain_jit_weight, 2000);
  // Straight-line code: the tape VM stands in for the interval and gradient JITs (exact
  // arithmetic only: the gradient pass has a form for it).
  EXPECT_EQ(heavy.model->interval_engine(), DomainEngine::kTapeVm);
  EXPECT_EQ(heavy.model->gradient_engine(), DomainEngine::kTapeVm);
  IntervalValue iv = heavy.model->eval_interval({1, 1, 1}, {2, 2, 2});
  EXPECT_NEAR(iv.lo, 1 - 2 * sum, 1e-9);
  EXPECT_NEAR(iv.hi, 1 - sum, 1e-9);
  EXPECT_NEAR(heavy.model->eval_gradient({1, 1, 1}).d[0], -sum_x1, 1e-12);
  EXPECT_FALSE(heavy.model->stats().interval.compiled);

  // The thresholds are options: 0 forces the interpreters (the tape VM for intervals of
  // straight-line code), -1 the JIT.
  mo.interval_jit_max_insts = 0;
  mo.gradient_jit_max_insts = 0;
  CompileResult forced = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(forced.ok());
  EXPECT_EQ(forced.model->interval_engine(), DomainEngine::kTapeVm);
  EXPECT_EQ(forced.model->gradient_engine(Precision::kF32), DomainEngine::kTapeVm);
  mo.interval_jit_max_insts = -1;
  CompileResult jit = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(jit.ok());
  EXPECT_EQ(jit.model->interval_engine(), DomainEngine::kJit);
  // Both engines give the same enclosure.
  IntervalValue a = forced.model->eval_interval({0.5, 1, 0}, {2, 3, 1.5});
  IntervalValue b = jit.model->eval_interval({0.5, 1, 0}, {2, 3, 1.5});
  EXPECT_EQ(a.lo, b.lo);
  EXPECT_EQ(a.hi, b.hi);
}

/// n boxes around kTorusModel's torus (radii 3 and 1, centre (0, 0, 1)), structure of arrays
/// over x, y, z: lower corners `step` apart from -4.5 in a scrambled order per axis, sizes 0
/// (a few points among them) to 0.8.
void torus_boxes(int64_t n, double step, std::vector<double>* lo, std::vector<double>* hi) {
  lo->assign(size_t(3 * n), 0.0);
  hi->assign(size_t(3 * n), 0.0);
  for (int64_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      (*lo)[k * n + i] = -4.5 + step * double((i * (7 + 5 * k)) % n);
      (*hi)[k * n + i] = (*lo)[k * n + i] + 0.05 * double(i % 17);
    }
  }
}

TEST(JitModelTest, TapeVmEngineEqualsTheJitInBatchesFromManyThreads) {
  // interval_jit_max_insts = 0 puts the torus on the tape VM (eval_interval_batch: its
  // batched pass, kLanes boxes at a time); the interval JIT is the reference, box for box.
  ModelOptions mo;
  mo.interval_jit_max_insts = 0;
  CompileResult tape = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(tape.ok());
  ASSERT_EQ(tape.model->interval_engine(), DomainEngine::kTapeVm);
  const Model jit = compile_or_die(kTorusModel, Backend::kJit);
  ASSERT_EQ(jit.interval_engine(), DomainEngine::kJit);
  constexpr int64_t kN = 300;  // several passes of the VM's lanes, the last one partial
  std::vector<double> lo, hi;
  torus_boxes(kN, 0.03, &lo, &hi);
  std::vector<double> ref_lo(kN), ref_hi(kN);
  std::vector<uint8_t> ref_nan(kN);
  jit.eval_interval_batch(kN, lo.data(), hi.data(), ref_lo.data(), ref_hi.data(), ref_nan.data());
  std::vector<std::thread> threads;
  std::vector<int> bad(4, 0), straddling(4, 0);
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      std::vector<double> out_lo(kN), out_hi(kN);
      std::vector<uint8_t> out_nan(kN);
      for (int round = 0; round < 20; ++round) {
        tape.model->eval_interval_batch(kN, lo.data(), hi.data(), out_lo.data(), out_hi.data(),
                                        out_nan.data());
        for (int64_t i = 0; i < kN; ++i) {
          bad[t] += out_lo[i] != ref_lo[i] || out_hi[i] != ref_hi[i] || out_nan[i] != ref_nan[i];
          straddling[t] += round == 0 && out_lo[i] <= 0 && out_hi[i] >= 0;
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) {
    EXPECT_EQ(bad[t], 0) << "thread " << t;
    EXPECT_GT(straddling[t], 0);  // some boxes hold the surface, some do not
    EXPECT_LT(straddling[t], kN);
  }
}

/// Interval ends: the same bits up to the sign of zero (what the interval JIT and the
/// interpreter promise: tests/jit/interval_jit_test.cpp).
bool same_end(double a, double b) {
  return a == b || (std::isnan(a) && std::isnan(b));
}

TEST(JitModelTest, BackgroundIntervalCompileGivesTheJitsBitsFromTheStart) {
  // Model::start_interval_compile: the interval JIT compiles on a thread of its own while
  // the tape VM (batches, single boxes) and the interpreter (a trace of choices) answer.
  // Every answer, before, during and after the compile, from several threads, equals the
  // JIT's of a model compiled the usual way, bit for bit; so does the trace.
  ModelOptions mo;
  mo.eager_f64 = false;
  mo.background_interval_min_insts = 0;  // the torus is small: the threshold off
  CompileResult bg = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(bg.ok()) << bg.rendered;
  const Model ref = compile_or_die(kTorusModel, Backend::kJit);
  ASSERT_TRUE(ref.prepare_interval());
  ASSERT_TRUE(bg.model->start_interval_compile());
  EXPECT_TRUE(bg.model->start_interval_compile());  // started once; says so again
  EXPECT_EQ(bg.model->interval_engine(), DomainEngine::kJit);
  EXPECT_TRUE(bg.model->stats().interval.background);

  constexpr int64_t kN = 100;
  std::vector<double> lo, hi;
  torus_boxes(kN, 0.09, &lo, &hi);
  std::vector<double> ref_lo(kN), ref_hi(kN);
  std::vector<uint8_t> ref_nan(kN), ref_trace;
  ref.eval_interval_batch(kN, lo.data(), hi.data(), ref_lo.data(), ref_hi.data(), ref_nan.data());
  const double tlo[3] = {2.5, -0.5, 0.5}, thi[3] = {3.5, 0.5, 1.5};
  const IntervalValue ref_one = ref.eval_interval(tlo, thi, &ref_trace);
  std::vector<std::thread> threads;
  std::vector<int> bad(3, 0), before(3, 0);
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      std::vector<double> out_lo(kN), out_hi(kN);
      std::vector<uint8_t> out_nan(kN), trace;
      for (int round = 0; round < 200; ++round) {
        before[t] += !bg.model->stats().interval.compiled;
        bg.model->eval_interval_batch(kN, lo.data(), hi.data(), out_lo.data(), out_hi.data(),
                                      out_nan.data());
        for (int64_t i = 0; i < kN; ++i) {
          bad[t] += !(same_end(out_lo[i], ref_lo[i]) && same_end(out_hi[i], ref_hi[i]) &&
                      out_nan[i] == ref_nan[i]);
        }
        const IntervalValue one = bg.model->eval_interval(tlo, thi, round % 2 ? &trace : nullptr);
        bad[t] += !(same_end(one.lo, ref_one.lo) && same_end(one.hi, ref_one.hi));
        if (round % 2) bad[t] += trace != ref_trace;
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 3; ++t) EXPECT_EQ(bad[t], 0) << "thread " << t;
  std::printf("background interval compile: %d, %d, %d of 200 rounds began before it was ready\n",
              before[0], before[1], before[2]);
  // prepare_interval waits for the compile; then the JIT answers.
  std::string error;
  EXPECT_TRUE(bg.model->prepare_interval(&error)) << error;
  const ModelStats st = bg.model->stats();
  EXPECT_TRUE(st.interval.compiled);
  EXPECT_TRUE(st.interval.background);
  EXPECT_GT(st.interval.compile_ms, 0);
  EXPECT_EQ(bg.model->interval_engine(), DomainEngine::kJit);
}

TEST(JitModelTest, BackgroundIntervalCompileOnlyForLargeStraightLineObjects) {
  ModelOptions mo;
  mo.eager_f64 = false;
  // The default threshold: the torus compiles its intervals the usual way.
  CompileResult small = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(small.ok());
  EXPECT_FALSE(small.model->start_interval_compile());
  EXPECT_FALSE(small.model->stats().interval.background);
  // Control flow has no tape form: the interpreter would answer meanwhile, ~15x the VM's cost.
  mo.background_interval_min_insts = 0;
  CompileResult branchy = Model::compile(
      "my_model(x[3], a[1]) {\n  r = 1;\n  if (x[1] > 0) then\n    r = 1 - x[1];\n  else\n"
      "    r = 1 + x[2];\n  endif;\n  my_model = r;\n}\n",
      mo);
  ASSERT_TRUE(branchy.ok()) << branchy.rendered;
  EXPECT_FALSE(branchy.model->start_interval_compile());
  // A compiled JIT is not compiled again; the interpreter backend has none.
  CompileResult done = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(done.ok());
  ASSERT_TRUE(done.model->prepare_interval());
  EXPECT_FALSE(done.model->start_interval_compile());
  mo.backend = Backend::kInterp;
  CompileResult interp = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(interp.ok());
  EXPECT_FALSE(interp.model->start_interval_compile());
  // A model destroyed while its compile runs waits for it (no crash, no leak under ASan).
  mo.backend = Backend::kJit;
  for (int i = 0; i < 3; ++i) {
    CompileResult gone = Model::compile(kTorusModel, mo);
    ASSERT_TRUE(gone.ok());
    EXPECT_TRUE(gone.model->start_interval_compile());
  }
}

TEST(JitModelTest, BackgroundGradientCompileGivesTheJitsBitsFromTheStart) {
  // Model::start_gradient_compile: the f32 gradient JIT compiles on a thread of its own while
  // the tape VM's gradient pass answers. Every answer, before, during and after the compile,
  // from several threads, equals the JIT's of a model compiled the usual way, bit for bit.
  ModelOptions mo;
  mo.eager_f64 = false;
  mo.background_gradient_min_insts = 0;  // the torus is small: the threshold off
  CompileResult bg = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(bg.ok()) << bg.rendered;
  const Model ref = compile_or_die(kTorusModel, Backend::kJit);
  ASSERT_TRUE(ref.prepare_gradient(Precision::kF32));
  ASSERT_TRUE(bg.model->start_gradient_compile(Precision::kF32));
  EXPECT_TRUE(bg.model->start_gradient_compile(Precision::kF32));  // once; says so again
  EXPECT_EQ(bg.model->gradient_engine(Precision::kF32), DomainEngine::kJit);
  EXPECT_TRUE(bg.model->stats().gradient_f32.background);
  EXPECT_FALSE(bg.model->stats().gradient_f64.background);

  constexpr int64_t kN = 100;
  std::vector<float> xs(3 * kN);
  for (int64_t i = 0; i < kN; ++i) {
    for (int k = 0; k < 3; ++k) xs[k * kN + i] = -4.5f + 0.09f * float((i * (7 + 5 * k)) % kN);
  }
  std::vector<float> want(4 * kN);
  ref.eval_gradient_batch(kN, xs.data(), want.data());
  std::vector<std::thread> threads;
  std::vector<int> bad(3, 0), before(3, 0);
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      std::vector<float> got(4 * kN);
      for (int round = 0; round < 200; ++round) {
        before[t] += !bg.model->stats().gradient_f32.compiled;
        bg.model->eval_gradient_batch(kN, xs.data(), got.data());
        for (int64_t i = 0; i < 4 * kN; ++i) {
          bad[t] += std::memcmp(&got[i], &want[i], sizeof(float)) != 0;
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 3; ++t) EXPECT_EQ(bad[t], 0) << "thread " << t;
  std::printf("background gradient compile: %d, %d, %d of 200 rounds began before it was ready\n",
              before[0], before[1], before[2]);
  std::string error;
  EXPECT_TRUE(bg.model->prepare_gradient(Precision::kF32, &error)) << error;
  EXPECT_TRUE(bg.model->stats().gradient_f32.compiled);
  EXPECT_EQ(bg.model->gradient_engine(Precision::kF32), DomainEngine::kJit);
  std::vector<float> after(4 * kN);
  bg.model->eval_gradient_batch(kN, xs.data(), after.data());
  EXPECT_EQ(std::memcmp(after.data(), want.data(), after.size() * sizeof(float)), 0);

  // The default threshold: the torus compiles its gradients the usual way.
  mo.background_gradient_min_insts = ModelOptions().background_gradient_min_insts;
  CompileResult small = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(small.ok());
  EXPECT_FALSE(small.model->start_gradient_compile(Precision::kF32));
  // A libm op has no gradient form in the VM (its lane calls need not round as the JIT's
  // code): the JIT is waited for, as before.
  mo.background_gradient_min_insts = 0;
  CompileResult trig = Model::compile("my_model(x[3], a[1]) { my_model = sin(x[1]) - x[2]; }", mo);
  ASSERT_TRUE(trig.ok()) << trig.rendered;
  EXPECT_FALSE(trig.model->start_gradient_compile(Precision::kF32));
  EXPECT_EQ(trig.model->gradient_engine(Precision::kF32), DomainEngine::kJit);
  // The interpreter backend has no JIT to compile.
  mo.backend = Backend::kInterp;
  CompileResult interp = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(interp.ok());
  EXPECT_FALSE(interp.model->start_gradient_compile(Precision::kF32));
  EXPECT_EQ(interp.model->gradient_engine(Precision::kF32), DomainEngine::kInterp);
  // A model destroyed while its compile runs waits for it.
  mo.backend = Backend::kJit;
  for (int i = 0; i < 3; ++i) {
    CompileResult gone = Model::compile(kTorusModel, mo);
    ASSERT_TRUE(gone.ok());
    EXPECT_TRUE(gone.model->start_gradient_compile(Precision::kF32));
  }
}

TEST(JitModelTest, BackgroundPointCompileGivesTheJitsBitsFromTheStart) {
  // ModelOptions::background_point_min_insts: compile() with eager_f32 starts the f32 JIT on
  // a thread of its own for an object of exact arithmetic, the tape VM's float pass answering
  // meanwhile. Every answer, before, during and after, from several threads, in batches of
  // one to many points, equals the JIT's of a model compiled the usual way, bit for bit.
  ModelOptions mo;
  mo.eager_f64 = false;
  mo.eager_f32 = true;
  mo.background_point_min_insts = 0;  // the torus is small: the threshold off
  CompileResult bg = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(bg.ok()) << bg.rendered;
  EXPECT_TRUE(bg.model->stats().jit_f32.background);
  EXPECT_TRUE(bg.model->start_point_compile());  // started by compile(); says so
  mo.background_point_min_insts = -1;
  CompileResult ref = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(ref.ok());
  EXPECT_TRUE(ref.model->stats().jit_f32.compiled);
  EXPECT_FALSE(ref.model->stats().jit_f32.background);

  constexpr int64_t kN = 100;
  std::vector<float> xs(3 * kN);
  for (int64_t i = 0; i < kN; ++i) {
    for (int k = 0; k < 3; ++k) xs[k * kN + i] = -4.5f + 0.09f * float((i * (7 + 5 * k)) % kN);
  }
  std::vector<float> want(kN);
  ref.model->eval_batch(kN, xs.data(), want.data());
  std::vector<std::thread> threads;
  std::vector<int> bad(3, 0), before(3, 0);
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&, t] {
      std::vector<float> got(kN), one(3);
      for (int round = 0; round < 200; ++round) {
        before[t] += !bg.model->stats().jit_f32.compiled;
        bg.model->eval_batch(kN, xs.data(), got.data());
        bad[t] += std::memcmp(got.data(), want.data(), sizeof(float) * kN) != 0;
        // A call of one point (the narrow pass): point `round % kN`.
        const int64_t i = round % kN;
        const float p[3] = {xs[i], xs[kN + i], xs[2 * kN + i]};
        bg.model->eval_batch(1, p, one.data());
        bad[t] += std::memcmp(&one[0], &want[i], sizeof(float)) != 0;
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 3; ++t) EXPECT_EQ(bad[t], 0) << "thread " << t;
  std::printf("background point compile: %d, %d, %d of 200 rounds began before it was ready\n",
              before[0], before[1], before[2]);
  std::string error;
  EXPECT_TRUE(bg.model->prepare(Precision::kF32, &error)) << error;  // waits for it
  EXPECT_TRUE(bg.model->stats().jit_f32.compiled);
  std::vector<float> after(kN);
  bg.model->eval_batch(kN, xs.data(), after.data());
  EXPECT_EQ(std::memcmp(after.data(), want.data(), sizeof(float) * kN), 0);

  // Not for a libm op (its lane calls need not round as the JIT's code), nor for a small
  // object at the default threshold, nor with the interpreter backend: compiled as usual.
  mo.background_point_min_insts = 0;
  CompileResult trig = Model::compile("my_model(x[3], a[1]) { my_model = sin(x[1]) - x[2]; }", mo);
  ASSERT_TRUE(trig.ok()) << trig.rendered;
  EXPECT_FALSE(trig.model->stats().jit_f32.background);
  EXPECT_TRUE(trig.model->stats().jit_f32.compiled);
  mo.background_point_min_insts = ModelOptions().background_point_min_insts;
  CompileResult small = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(small.ok());
  EXPECT_FALSE(small.model->stats().jit_f32.background);
  EXPECT_FALSE(small.model->start_point_compile());
  mo.background_point_min_insts = 0;
  mo.backend = Backend::kInterp;
  CompileResult interp = Model::compile(kTorusModel, mo);
  ASSERT_TRUE(interp.ok());
  EXPECT_FALSE(interp.model->start_point_compile());
  // A model destroyed while its compile runs waits for it.
  mo.backend = Backend::kJit;
  for (int i = 0; i < 3; ++i) {
    CompileResult gone = Model::compile(kTorusModel, mo);
    ASSERT_TRUE(gone.ok());
    EXPECT_TRUE(gone.model->stats().jit_f32.background);
  }
}

TEST(JitModelTest, ManyThreadsEvaluateDomainsAtOnce) {
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    // `m` compiles its domain code lazily, under contention; `ref`, a second model of the
    // same source, gives the expected values.
    const Model m = compile_or_die(kTorusModel, backend);
    const Model ref = compile_or_die(kTorusModel, backend);
    std::vector<std::thread> threads;
    std::vector<int> bad(6, 0);
    for (int t = 0; t < 6; ++t) {
      threads.emplace_back([&, t] {
        for (int i = 0; i < 300; ++i) {
          double lo[3] = {0.01 * i - 2, 0.5 - 0.01 * t, 0}, hi[3] = {lo[0] + 0.3, lo[1] + 0.2, 1.5};
          IntervalValue a = m.eval_interval(lo, hi), b = ref.eval_interval(lo, hi);
          bad[t] += a.lo != b.lo || a.hi != b.hi || a.maybe_nan != b.maybe_nan;
          GradientValue g = m.eval_gradient(std::span<const double>(lo, 3));
          GradientValue h = ref.eval_gradient(std::span<const double>(lo, 3));
          bad[t] += g.f != h.f || g.d[0] != h.d[0] || g.d[1] != h.d[1] || g.d[2] != h.d[2];
        }
      });
    }
    for (auto& th : threads) th.join();
    for (int t = 0; t < 6; ++t) EXPECT_EQ(bad[t], 0) << t;
  }
}

}  // namespace
}  // namespace hfrt

namespace hfrt {
// ---- limits on hostile input (docs/limits.md) ------------------------------------------------

namespace limits_test {

// x[1] > 0: a loop that never ends; else no loop at all.
const char* kEndless =
    "my_model(x[3], a[1])\n"
    "{\n"
    "  i = 0;\n"
    "  while x[1] > 0 loop i = i + 1; endloop;\n"
    "  my_model = i - x[2];\n"
    "}\n";

// An endless loop gives NaN and the located LoopLimit error in every engine of every domain,
// quickly (the default limit, 10^6 iterations per point); points without the loop keep values.
TEST(JitModelTest, EndlessLoopIsNaNInEveryDomainAndEngine) {
  for (Backend backend : {Backend::kJit, Backend::kInterp}) {
    ModelOptions mo;
    mo.backend = backend;
    mo.eager_f32 = true;
    mo.interval_jit_max_insts = -1;  // the domain JITs, whatever the size
    mo.gradient_jit_max_insts = -1;
    CompileResult r = Model::compile(kEndless, mo, "endless.hf");
    ASSERT_TRUE(r.ok()) << r.rendered;
    const Model& m = *r.model;
    const DomainEngine engine =
        backend == Backend::kJit ? DomainEngine::kJit : DomainEngine::kInterp;
    ASSERT_EQ(m.interval_engine(), engine);
    ASSERT_EQ(m.gradient_engine(Precision::kF64), engine);
    ASSERT_EQ(m.gradient_engine(Precision::kF32), engine);

    PointValue v = m.eval({1, 0, 0});
    EXPECT_TRUE(std::isnan(v.f));
    EXPECT_EQ(v.error, "Loop iteration limit exceeded");
    EXPECT_EQ(v.error_line, 4);
    EXPECT_EQ(v.error_col, 3);
    EXPECT_EQ(m.eval({-1, 2, 0}).f, -2);

    const double xs64[6] = {1, -1, 0, 2, 0, 0};  // points (1, 0, 0) and (-1, 2, 0)
    double f64[2];
    m.eval_batch(2, xs64, f64);
    EXPECT_TRUE(std::isnan(f64[0]));
    EXPECT_EQ(f64[1], -2);
    const float xs32[6] = {1, -1, 0, 2, 0, 0};
    float f32[2];
    m.eval_batch(2, xs32, f32);
    EXPECT_TRUE(std::isnan(f32[0]));
    EXPECT_EQ(f32[1], -2);

    // Sound: a box with points that loop forever may have no value.
    IntervalValue iv = m.eval_interval({0.5, 0, 0}, {1, 1, 1});
    EXPECT_TRUE(iv.maybe_nan);
    EXPECT_TRUE(iv.contains(std::nan("")));
    IntervalValue mixed = m.eval_interval({-1, 0, 0}, {1, 1, 1});
    EXPECT_TRUE(mixed.maybe_nan);
    EXPECT_TRUE(mixed.contains(-1));
    IntervalValue none = m.eval_interval({-2, 0, 0}, {-1, 1, 1});
    EXPECT_FALSE(none.maybe_nan);

    GradientValue g = m.eval_gradient({1, 0, 0});
    EXPECT_TRUE(std::isnan(g.f));
    EXPECT_TRUE(std::isnan(g.d[0]));
    float gout[8];
    m.eval_gradient_batch(2, xs32, gout);
    EXPECT_TRUE(std::isnan(gout[0]));
    EXPECT_EQ(gout[1], -2);
    EXPECT_EQ(gout[2 * 2 + 1], -1);  // dF/dx[2] of the second point
  }
}

TEST(JitModelTest, LoopLimitIsAnOptionAndAtTheLimitStillWorks) {
  const char* counted =
      "my_model(x[3], a[1]) { i = 0; while i < x[1] loop i = i + 1; endloop; my_model = i; }";
  ModelOptions mo;
  mo.eager_f32 = true;
  mo.limits.max_loop_iterations = 50;
  CompileResult r = Model::compile(counted, mo);
  ASSERT_TRUE(r.ok()) << r.rendered;
  EXPECT_EQ(r.model->eval({50, 0, 0}).f, 50);
  EXPECT_EQ(r.model->eval({51, 0, 0}).error, "Loop iteration limit exceeded");
  const float xs[2] = {50, 51};
  float f[2];
  r.model->eval_batch(2, xs, f);
  EXPECT_EQ(f[0], 50);
  EXPECT_TRUE(std::isnan(f[1]));
  // The largest limit: single precision still counts every iteration.
  mo.limits.max_loop_iterations = 1 << 24;
  CompileResult big = Model::compile(counted, mo);
  ASSERT_TRUE(big.ok()) << big.rendered;
  EXPECT_EQ(big.model->eval({1000, 0, 0}).f, 1000);
}

TEST(JitModelTest, InvalidLimitsAreAnErrorWithoutAModel) {
  ModelOptions mo;
  mo.limits.max_loop_iterations = 0;
  CompileResult r = Model::compile("m(x[3], a[1]) { m = 1; }", mo);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.error, "ModelLimits::max_loop_iterations must be from 1 to 16777216 (got 0)");
  mo.limits = {};
  mo.limits.max_slots = -1;
  EXPECT_EQ(Model::compile("m(x[3], a[1]) { m = 1; }", mo).error,
            "ModelLimits::max_slots must be at least 1 (got -1)");
  EXPECT_EQ(check_model_limits(ModelLimits{}), "");
}

TEST(JitModelTest, ArrayAndSourceLimitsAreOptions) {
  const char* arrays = "m(x[3], a[1]) { array v[100]; v[1] = x[1]; m = v[1]; }";
  ModelOptions mo;
  EXPECT_TRUE(Model::compile(arrays, mo).ok());
  mo.limits.max_array_size = 99;
  CompileResult r = Model::compile(arrays, mo, "arrays.hf");
  ASSERT_FALSE(r.ok());
  ASSERT_FALSE(r.diagnostics.empty());
  EXPECT_EQ(r.diagnostics[0].message, "array size 100 is more than the limit of 99 elements");
  EXPECT_EQ(r.diagnostics[0].line, 1);
  EXPECT_EQ(r.diagnostics[0].col, 25);

  // A source file over the limit, and an endless one, are refused without reading them whole.
  const std::string path =
      ::testing::TempDir() + "hfrt_limits_source_" + std::to_string(::getpid()) + ".hf";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  std::fputs(arrays, f);
  std::fclose(f);
  ModelOptions small;
  EXPECT_TRUE(Model::compile_file(path, small).ok());
  small.limits.max_source_bytes = 10;
  CompileResult big = Model::compile_file(path, small);
  EXPECT_FALSE(big.ok());
  EXPECT_EQ(big.error.rfind(path + ": is " + std::to_string(std::strlen(arrays)) +
                                " bytes, more than the limit of 10 bytes (raise the limit with "
                                "--max-source-bytes N",
                            0),
            0u)
      << big.error;
  std::remove(path.c_str());
  small.limits.max_source_bytes = 1 << 20;
  CompileResult zero = Model::compile_file("/dev/zero", small);
  EXPECT_EQ(zero.error.rfind("/dev/zero: is more than the limit of 1048576 bytes", 0), 0u)
      << zero.error;
}

}  // namespace limits_test

}  // namespace hfrt
