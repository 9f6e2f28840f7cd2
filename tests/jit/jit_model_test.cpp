// The public embedding API (hfrt/model.h): compile, diagnostics, objects, parameters,
// single points and batches in both precisions and both backends, threads.

#include <gtest/gtest.h>

#include <cmath>
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

}  // namespace
}  // namespace hfrt
