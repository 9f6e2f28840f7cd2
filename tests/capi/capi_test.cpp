// Tests of the C API (capi/include/hfrt/hfrt.h): values against closed forms and the C++ API,
// every error path (bad source, missing file, wrong array sizes, null pointers, bad options)
// as a status with a located message, the per-thread last error, thread safety on one handle,
// and rendering into a caller's buffer (coverage against the disk's area).

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "hfrt/hfrt.h"
#include "hfrt/model.h"

namespace {

// F = a1^2 - |x|^2 (a ball of radius a1), s[1] = x1 + 2 x2.
const char* kBall = R"(my_model(x[3], a[1], s[1])
{
  s[1] = x[1] + 2 * x[2];
  my_model = a[1] * a[1] - x[1] * x[1] - x[2] * x[2] - x[3] * x[3];
}
)";

double ball(double r, double x, double y, double z) {
  return r * r - x * x - y * y - z * z;
}

struct ModelPtr {
  hfrt_model* m = nullptr;
  ~ModelPtr() { hfrt_model_free(m); }
};

hfrt_model* compile_ball(double radius) {
  hfrt_compile_options opt;
  hfrt_compile_options_init(&opt);
  opt.params = &radius;
  opt.num_params = 1;
  hfrt_model* m = nullptr;
  EXPECT_EQ(hfrt_model_compile_source(kBall, "ball.hf", &opt, &m), HFRT_OK)
      << hfrt_last_error_message();
  return m;
}

std::string last_function() {
  return hfrt_last_error_function();
}

TEST(CApi, VersionMatchesHeader) {
  char expect[64];
  std::snprintf(expect, sizeof expect, "%d.%d.%d", HFRT_VERSION_MAJOR, HFRT_VERSION_MINOR,
                HFRT_VERSION_PATCH);
  EXPECT_STREQ(hfrt_version(), expect);
  EXPECT_STREQ(hfrt_status_name(HFRT_ERROR_COMPILE), "HFRT_ERROR_COMPILE");
}

TEST(CApi, InfoAndEvalF64MatchClosedFormAndCppApi) {
  ModelPtr p{compile_ball(1.5)};
  ASSERT_NE(p.m, nullptr);
  int32_t k = -1, na = -1, ns = -1;
  ASSERT_EQ(hfrt_model_info(p.m, &k, &na, &ns), HFRT_OK);
  EXPECT_EQ(k, 3);
  EXPECT_EQ(na, 1);
  EXPECT_EQ(ns, 1);
  EXPECT_STREQ(hfrt_model_object_name(p.m), "my_model");

  // Any n, including ones that are not a multiple of the SIMD width.
  for (int64_t n : {1, 7, 1000, 1029}) {
    std::vector<double> xs(3 * n), f(n), s(n);
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> u(-2, 2);
    for (double& v : xs) v = u(rng);
    ASSERT_EQ(hfrt_model_eval_f64(p.m, n, xs.data(), 3 * n, f.data(), n, s.data(), n), HFRT_OK);
    auto cpp = hfrt::Model::compile(kBall, {}, "ball.hf");
    ASSERT_TRUE(cpp.ok());
    cpp.model->set_params({1.5});
    for (int64_t i = 0; i < n; ++i) {
      double x = xs[i], y = xs[n + i], z = xs[2 * n + i];
      EXPECT_NEAR(f[i], ball(1.5, x, y, z), 1e-12);
      EXPECT_NEAR(s[i], x + 2 * y, 1e-12);
      hfrt::PointValue v = cpp.model->eval({x, y, z});
      EXPECT_EQ(f[i], v.f) << "C API and C++ API differ at point " << i;
    }
  }
}

TEST(CApi, EvalF32AndNullAttributes) {
  ModelPtr p{compile_ball(1.0)};
  std::vector<float> xs = {0.5f, 0.0f, 2.0f, 0.0f, 0.5f, 0.0f, 0.0f, 0.0f, 0.0f};  // 3 points
  std::vector<float> f(3);
  ASSERT_EQ(hfrt_model_eval_f32(p.m, 3, xs.data(), 9, f.data(), 3, nullptr, 0), HFRT_OK);
  EXPECT_NEAR(f[0], 0.75f, 1e-6);
  EXPECT_NEAR(f[1], 0.75f, 1e-6);
  EXPECT_NEAR(f[2], -3.0f, 1e-6);
  // n = 0 is a no-op, with or without buffers.
  EXPECT_EQ(hfrt_model_eval_f32(p.m, 0, nullptr, 0, nullptr, 0, nullptr, 0), HFRT_OK);
}

TEST(CApi, GradientIsTheClosedForm) {
  ModelPtr p{compile_ball(1.0)};
  std::vector<double> xs = {0.5, -1.0, 0.25, 2.0, 0.0, -3.0};  // 2 points: (0.5, .25, 0) ...
  std::vector<double> out(8);
  ASSERT_EQ(hfrt_model_gradient_f64(p.m, 2, xs.data(), 6, out.data(), 8), HFRT_OK);
  for (int i = 0; i < 2; ++i) {
    double x = xs[i], y = xs[2 + i], z = xs[4 + i];
    EXPECT_NEAR(out[i], ball(1.0, x, y, z), 1e-12);
    EXPECT_NEAR(out[2 + i], -2 * x, 1e-12);
    EXPECT_NEAR(out[4 + i], -2 * y, 1e-12);
    EXPECT_NEAR(out[6 + i], -2 * z, 1e-12);
  }
}

TEST(CApi, IntervalsEncloseSampledValues) {
  ModelPtr p{compile_ball(1.0)};
  const int64_t n = 16;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2, 2), w(0, 1);
  std::vector<double> lo(3 * n), hi(3 * n), olo(n), ohi(n);
  std::vector<uint8_t> nan(n);
  for (int64_t j = 0; j < 3 * n; ++j) {
    lo[j] = u(rng);
    hi[j] = lo[j] + w(rng);
  }
  ASSERT_EQ(hfrt_model_eval_interval(p.m, n, lo.data(), hi.data(), 3 * n, olo.data(), ohi.data(),
                                     nan.data(), n),
            HFRT_OK);
  for (int64_t i = 0; i < n; ++i) {
    EXPECT_EQ(nan[i], 0);
    for (int t = 0; t < 50; ++t) {
      double c[3];
      for (int k = 0; k < 3; ++k) c[k] = lo[k * n + i] + w(rng) * (hi[k * n + i] - lo[k * n + i]);
      double v = ball(1.0, c[0], c[1], c[2]);
      EXPECT_LE(olo[i], v);
      EXPECT_GE(ohi[i], v);
    }
  }
  // out_maybe_nan may be NULL.
  EXPECT_EQ(hfrt_model_eval_interval(p.m, n, lo.data(), hi.data(), 3 * n, olo.data(), ohi.data(),
                                     nullptr, n),
            HFRT_OK);
}

TEST(CApi, SetParamsWithoutRecompiling) {
  ModelPtr p{compile_ball(1.0)};
  double xs[3] = {0.5, 0, 0}, f = 0;
  ASSERT_EQ(hfrt_model_eval_f64(p.m, 1, xs, 3, &f, 1, nullptr, 0), HFRT_OK);
  EXPECT_EQ(f, 0.75);
  double a = 2;
  ASSERT_EQ(hfrt_model_set_params(p.m, &a, 1), HFRT_OK);
  ASSERT_EQ(hfrt_model_eval_f64(p.m, 1, xs, 3, &f, 1, nullptr, 0), HFRT_OK);
  EXPECT_EQ(f, 3.75);
  ASSERT_EQ(hfrt_model_set_params(p.m, nullptr, 0), HFRT_OK);  // all zeros
  ASSERT_EQ(hfrt_model_eval_f64(p.m, 1, xs, 3, &f, 1, nullptr, 0), HFRT_OK);
  EXPECT_EQ(f, -0.25);
}

TEST(CApi, CompileErrorIsLocated) {
  const char* bad = "my_model(x[3], a[1])\n{\n  my_model = 1 - * x[1];\n}\n";
  hfrt_model* m = reinterpret_cast<hfrt_model*>(0x1);
  EXPECT_EQ(hfrt_model_compile_source(bad, "bad.hf", nullptr, &m), HFRT_ERROR_COMPILE);
  EXPECT_EQ(m, nullptr);
  EXPECT_EQ(hfrt_last_error_status(), HFRT_ERROR_COMPILE);
  const char* file = nullptr;
  int32_t line = 0, col = 0;
  hfrt_last_error_location(&file, &line, &col);
  EXPECT_STREQ(file, "bad.hf");
  EXPECT_EQ(line, 3);
  EXPECT_EQ(col, 18);
  std::string msg = hfrt_last_error_message();
  EXPECT_NE(msg.find("bad.hf:3:18: error:"), std::string::npos) << msg;
  EXPECT_EQ(last_function(), "hfrt_model_compile_source");
  ASSERT_GE(hfrt_last_error_diagnostic_count(), 1);
  hfrt_diagnostic d;
  ASSERT_EQ(hfrt_last_error_diagnostic(0, &d), HFRT_OK);
  EXPECT_EQ(d.severity, HFRT_SEVERITY_ERROR);
  EXPECT_STREQ(d.file, "bad.hf");
  EXPECT_EQ(d.line, 3);
  EXPECT_EQ(d.column, 18);
  EXPECT_GT(std::string(d.message).size(), 0u);
  // Out of range: a status, and the diagnostics stay readable.
  EXPECT_EQ(hfrt_last_error_diagnostic(99, &d), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_last_error_diagnostic(-1, &d), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_last_error_diagnostic(0, nullptr), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_GE(hfrt_last_error_diagnostic_count(), 1);
}

TEST(CApi, MissingFileIsAnIoError) {
  hfrt_model* m = nullptr;
  const char* path = "/nonexistent/dir/model.hf";
  EXPECT_EQ(hfrt_model_compile_file(path, nullptr, &m), HFRT_ERROR_IO);
  EXPECT_EQ(m, nullptr);
  std::string msg = hfrt_last_error_message();
  EXPECT_NE(msg.find(path), std::string::npos) << msg;
  const char* file = nullptr;
  hfrt_last_error_location(&file, nullptr, nullptr);
  EXPECT_STREQ(file, path);
  EXPECT_EQ(hfrt_last_error_diagnostic_count(), 0);
}

TEST(CApi, CompileFileAndItsErrorsCarryThePath) {
  const std::string path = ::testing::TempDir() + "capi_bad.hf";
  std::ofstream(path) << "my_model(x[3], a[1])\n{\n  my_model = undefined_var;\n}\n";
  hfrt_model* m = nullptr;
  EXPECT_EQ(hfrt_model_compile_file(path.c_str(), nullptr, &m), HFRT_ERROR_COMPILE);
  const char* file = nullptr;
  int32_t line = 0, col = 0;
  hfrt_last_error_location(&file, &line, &col);
  EXPECT_EQ(std::string(file), path);
  EXPECT_EQ(line, 3);
  EXPECT_EQ(col, 14);
  std::ofstream(path) << kBall;
  ASSERT_EQ(hfrt_model_compile_file(path.c_str(), nullptr, &m), HFRT_OK);
  hfrt_model_free(m);
}

TEST(CApi, NoSuchObject) {
  hfrt_compile_options opt;
  hfrt_compile_options_init(&opt);
  opt.object = "nope";
  hfrt_model* m = nullptr;
  EXPECT_EQ(hfrt_model_compile_source(kBall, "ball.hf", &opt, &m), HFRT_ERROR_NO_OBJECT);
  EXPECT_NE(std::string(hfrt_last_error_message()).find("nope"), std::string::npos)
      << hfrt_last_error_message();
}

TEST(CApi, NullPointersAreStatuses) {
  hfrt_model* m = nullptr;
  EXPECT_EQ(hfrt_model_compile_source(kBall, nullptr, nullptr, nullptr),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()), "hfrt_model_compile_source: out is NULL");
  const char* file = nullptr;
  hfrt_last_error_location(&file, nullptr, nullptr);
  EXPECT_STREQ(file, "hfrt_model_compile_source");
  EXPECT_EQ(hfrt_model_compile_source(nullptr, nullptr, nullptr, &m), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_model_compile_file(nullptr, nullptr, &m), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()), "hfrt_model_compile_file: path is NULL");
  double x[3] = {0, 0, 0}, f = 0;
  EXPECT_EQ(hfrt_model_eval_f64(nullptr, 1, x, 3, &f, 1, nullptr, 0), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()), "hfrt_model_eval_f64: model is NULL");
  EXPECT_EQ(hfrt_model_info(nullptr, nullptr, nullptr, nullptr), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_model_set_params(nullptr, nullptr, 0), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_render_model(nullptr, nullptr, nullptr, 0), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_STREQ(hfrt_model_object_name(nullptr), "");
  EXPECT_EQ(hfrt_model_diagnostic_count(nullptr), 0);
  hfrt_model_free(nullptr);  // a no-op

  ModelPtr p{compile_ball(1.0)};
  EXPECT_EQ(hfrt_model_eval_f64(p.m, 1, nullptr, 3, &f, 1, nullptr, 0),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()), "hfrt_model_eval_f64: xs is NULL");
  EXPECT_EQ(hfrt_model_eval_f64(p.m, 1, x, 3, nullptr, 1, nullptr, 0), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()), "hfrt_model_eval_f64: out_f is NULL");
  EXPECT_EQ(hfrt_model_gradient_f64(p.m, 1, x, 3, nullptr, 4), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_model_eval_interval(p.m, 1, x, nullptr, 3, &f, &f, nullptr, 1),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()), "hfrt_model_eval_interval: hi is NULL");
  double a = 1;
  EXPECT_EQ(hfrt_model_set_params(p.m, nullptr, 1), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_model_set_params(p.m, &a, -1), HFRT_ERROR_INVALID_ARGUMENT);
  hfrt_diagnostic d;
  EXPECT_EQ(hfrt_model_diagnostic(p.m, 0, nullptr), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_model_diagnostic(p.m, 0, &d), HFRT_ERROR_INVALID_ARGUMENT);  // no warnings
}

TEST(CApi, WrongArraySizesAreStatuses) {
  ModelPtr p{compile_ball(1.0)};
  std::vector<double> xs(6), f(2), s(2), g(8);
  EXPECT_EQ(hfrt_model_eval_f64(p.m, 2, xs.data(), 5, f.data(), 2, nullptr, 0),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_eval_f64: xs has 5 elements, 3 x 2 = 6 are needed");
  EXPECT_EQ(hfrt_model_eval_f64(p.m, 2, xs.data(), 6, f.data(), 1, nullptr, 0),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_eval_f64: out_f has 1 elements, 1 x 2 = 2 are needed");
  EXPECT_EQ(hfrt_model_eval_f64(p.m, 2, xs.data(), 6, f.data(), 2, s.data(), 1),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_eval_f64: out_s has 1 elements, 1 x 2 = 2 are needed");
  EXPECT_EQ(hfrt_model_eval_f64(p.m, -1, xs.data(), 6, f.data(), 2, nullptr, 0),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()), "hfrt_model_eval_f64: n is negative");
  // n so large that n * k overflows: a status, not a wrap-around.
  EXPECT_EQ(hfrt_model_eval_f64(p.m, INT64_MAX / 2, xs.data(), 6, f.data(), 2, nullptr, 0),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_model_gradient_f64(p.m, 2, xs.data(), 6, g.data(), 7),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_gradient_f64: out has 7 elements, 4 x 2 = 8 are needed");
  std::vector<float> xf(6), ff(2);
  EXPECT_EQ(hfrt_model_eval_f32(p.m, 2, xf.data(), 3, ff.data(), 2, nullptr, 0),
            HFRT_ERROR_INVALID_ARGUMENT);
  // Boxes: too short, and lo > hi (or NaN).
  std::vector<double> lo(6, 0.0), hi(6, 1.0), olo(2), ohi(2);
  EXPECT_EQ(
      hfrt_model_eval_interval(p.m, 2, lo.data(), hi.data(), 4, olo.data(), ohi.data(), nullptr, 2),
      HFRT_ERROR_INVALID_ARGUMENT);
  lo[3] = 2.0;  // box 1, coordinate 2
  EXPECT_EQ(
      hfrt_model_eval_interval(p.m, 2, lo.data(), hi.data(), 6, olo.data(), ohi.data(), nullptr, 2),
      HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_eval_interval: box 1, coordinate 2: lo = 2.000000 is not <= hi = 1.000000");
  lo[3] = NAN;
  EXPECT_EQ(
      hfrt_model_eval_interval(p.m, 2, lo.data(), hi.data(), 6, olo.data(), ohi.data(), nullptr, 2),
      HFRT_ERROR_INVALID_ARGUMENT);
  // Parameters: more than a[] holds.
  double a[2] = {1, 2};
  EXPECT_EQ(hfrt_model_set_params(p.m, a, 2), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_set_params: 2 values for the object 'my_model', which has a[1]");
}

TEST(CApi, BadOptionsAreStatuses) {
  hfrt_compile_options opt;
  hfrt_compile_options_init(&opt);
  hfrt_model* m = nullptr;
  opt.struct_size = 0;
  EXPECT_EQ(hfrt_model_compile_source(kBall, nullptr, &opt, &m), HFRT_ERROR_INVALID_ARGUMENT);
  hfrt_compile_options_init(&opt);
  opt.precision = static_cast<hfrt_precision>(7);
  EXPECT_EQ(hfrt_model_compile_source(kBall, nullptr, &opt, &m), HFRT_ERROR_INVALID_ARGUMENT);
  hfrt_compile_options_init(&opt);
  opt.num_params = 2;
  EXPECT_EQ(hfrt_model_compile_source(kBall, nullptr, &opt, &m), HFRT_ERROR_INVALID_ARGUMENT);
  double a[2] = {1, 2};
  opt.params = a;
  EXPECT_EQ(hfrt_model_compile_source(kBall, nullptr, &opt, &m), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_compile_source: options->num_params = 2 but the object 'my_model' has "
            "a[1]");
  EXPECT_EQ(m, nullptr);
  // The interpreter backend gives the same values.
  hfrt_compile_options_init(&opt);
  opt.backend = HFRT_BACKEND_INTERP;
  opt.params = a;
  opt.num_params = 1;
  ASSERT_EQ(hfrt_model_compile_source(kBall, nullptr, &opt, &m), HFRT_OK);
  double x[3] = {0.5, 0.25, 0}, f = 0;
  EXPECT_EQ(hfrt_model_eval_f64(m, 1, x, 3, &f, 1, nullptr, 0), HFRT_OK);
  EXPECT_EQ(f, ball(1, 0.5, 0.25, 0));
  hfrt_model_free(m);
}

TEST(CApi, LastErrorIsPerThread) {
  hfrt_model* m = nullptr;
  EXPECT_EQ(hfrt_model_compile_file("/nonexistent.hf", nullptr, &m), HFRT_ERROR_IO);
  std::string other;
  hfrt_status other_status = HFRT_ERROR_INTERNAL;
  std::thread t([&] {
    other_status = hfrt_last_error_status();
    other = hfrt_last_error_message();
  });
  t.join();
  EXPECT_EQ(other_status, HFRT_OK);
  EXPECT_EQ(other, "");
  EXPECT_EQ(hfrt_last_error_status(), HFRT_ERROR_IO);
}

TEST(CApi, ConcurrentEvalAndSetParamsOnOneHandle) {
  ModelPtr p{compile_ball(1.0)};
  const int64_t n = 4096;
  std::vector<double> xs(3 * n);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double& v : xs) v = u(rng);
  std::atomic<bool> stop{false};
  std::atomic<int> bad{0}, calls{0};
  std::vector<std::thread> workers;
  for (int t = 0; t < 4; ++t) {
    workers.emplace_back([&] {
      std::vector<double> f(n);
      while (!stop) {
        if (hfrt_model_eval_f64(p.m, n, xs.data(), 3 * n, f.data(), n, nullptr, 0) != HFRT_OK) {
          ++bad;
          continue;
        }
        // One call sees one parameter value: radius 1 or 2 for every point.
        const double r = f[0] == ball(1, xs[0], xs[n], xs[2 * n]) ? 1 : 2;
        for (int64_t i = 0; i < n; ++i) {
          if (std::abs(f[i] - ball(r, xs[i], xs[n + i], xs[2 * n + i])) > 1e-12) {
            ++bad;
            break;
          }
        }
        ++calls;
      }
    });
  }
  for (int i = 0; i < 50; ++i) {
    double a = i % 2 ? 1.0 : 2.0;
    ASSERT_EQ(hfrt_model_set_params(p.m, &a, 1), HFRT_OK);
    std::this_thread::yield();
  }
  while (calls < 20) std::this_thread::yield();
  stop = true;
  for (auto& w : workers) w.join();
  EXPECT_EQ(bad, 0);
}

TEST(CApi, RenderCoversTheDiskOfTheBall) {
  ModelPtr p{compile_ball(1.0)};
  hfrt_render_options ro;
  hfrt_render_options_init(&ro);
  const int w = 64, h = 64;
  ro.width = w;
  ro.height = h;
  ro.has_eye = ro.has_look_at = 1;
  ro.eye[2] = 10;  // looking down -z at the origin
  ro.ortho_width = 4;
  ro.bbox[0] = ro.bbox[1] = ro.bbox[2] = -2;
  ro.bbox[3] = ro.bbox[4] = ro.bbox[5] = 2;
  ro.spp = 4;
  std::vector<float> rgba(4 * w * h, -1.0f);
  ASSERT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), int64_t(rgba.size())), HFRT_OK)
      << hfrt_last_error_message();
  double coverage = 0;
  for (int i = 0; i < w * h; ++i) coverage += rgba[4 * i + 3];
  // The disk of radius 1 in a 4 x 4 view: pi / 16 of the image.
  EXPECT_NEAR(coverage / (w * h), M_PI / 16, 0.01);
  // A corner pixel is background: its colour and alpha 0.
  EXPECT_EQ(rgba[3], 0.0f);
  EXPECT_NEAR(rgba[0], ro.background[0], 1e-6);
  EXPECT_NEAR(rgba[2], ro.background[2], 1e-6);
  // The centre pixel is lit solid.
  const int c = 4 * (h / 2 * w + w / 2);
  EXPECT_EQ(rgba[c + 3], 1.0f);
}

// Time (issue 24): hfrt_model_set_time moves a model whose x[4] is time, in renders.
TEST(CApi, SetTimeMovesTheRenderedModel) {
  hfrt_model* raw = nullptr;
  ASSERT_EQ(hfrt_model_compile_source(
                "m(x[4], a[1]) { m = 1 - (x[1] - (-2 + 4 * x[4]))^2 - x[2]^2 - x[3]^2; }",
                "moving.hf", nullptr, &raw),
            HFRT_OK)
      << hfrt_last_error_message();
  ModelPtr p{raw};
  hfrt_render_options ro;
  hfrt_render_options_init(&ro);
  const int w = 64, h = 16;
  ro.width = w;
  ro.height = h;
  ro.has_eye = ro.has_look_at = 1;
  ro.eye[2] = 10;
  ro.ortho_width = 8;
  ro.bbox[0] = -4, ro.bbox[1] = -2, ro.bbox[2] = -2;
  ro.bbox[3] = 4, ro.bbox[4] = 2, ro.bbox[5] = 2;
  for (double t : {0.0, 0.75}) {
    ASSERT_EQ(hfrt_model_set_time(p.m, t), HFRT_OK);
    std::vector<float> rgba(4 * w * h);
    ASSERT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), int64_t(rgba.size())), HFRT_OK)
        << hfrt_last_error_message();
    double sum = 0, n = 0;
    for (int x = 0; x < w; ++x) {
      const float a = rgba[4 * (8 * w + x) + 3];
      sum += a * ((x + 0.5) / 8 - 4);
      n += a;
    }
    EXPECT_NEAR(sum / n, -2 + 4 * t, 0.07) << t;
  }
  EXPECT_EQ(hfrt_model_set_time(p.m, NAN), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(last_function(), "hfrt_model_set_time");
  EXPECT_EQ(hfrt_model_set_time(nullptr, 0), HFRT_ERROR_INVALID_ARGUMENT);
}

TEST(CApi, RenderErrorsAreStatuses) {
  ModelPtr p{compile_ball(1.0)};
  hfrt_render_options ro;
  hfrt_render_options_init(&ro);
  ro.width = ro.height = 8;
  std::vector<float> rgba(4 * 8 * 8);
  EXPECT_EQ(hfrt_render_model(p.m, &ro, nullptr, 256), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), 255), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_render_model: rgba has 255 floats, a 8x8 image needs 256");
  ro.width = 0;
  EXPECT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), 256), HFRT_ERROR_INVALID_ARGUMENT);
  ro.width = 8;
  ro.spp = 0;
  EXPECT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), 256), HFRT_ERROR_INVALID_ARGUMENT);
  ro.spp = 1;
  ro.bbox[0] = 20;  // min above max
  EXPECT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), 256), HFRT_ERROR_INVALID_ARGUMENT);
  ro.bbox[0] = -10;
  ro.root = static_cast<hfrt_root_search>(9);
  EXPECT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), 256), HFRT_ERROR_INVALID_ARGUMENT);
  ro.root = HFRT_ROOT_AUTO;
  ro.struct_size = 4;
  EXPECT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), 256), HFRT_ERROR_INVALID_ARGUMENT);
  hfrt_render_options_init(&ro);
  ro.width = ro.height = 8;
  // A degenerate camera: the eye at the look-at point.
  ro.has_eye = ro.has_look_at = 1;
  EXPECT_EQ(hfrt_render_model(p.m, &ro, rgba.data(), 256), HFRT_ERROR_RENDER);
  EXPECT_EQ(last_function(), "hfrt_render_model");
}

TEST(CApi, AnalyticRootOnANonPolynomialModelIsLocated) {
  const char* src = "my_model(x[3], a[1])\n{\n  my_model = 1 - sin(x[1]) - x[2]*x[2];\n}\n";
  hfrt_model* m = nullptr;
  ASSERT_EQ(hfrt_model_compile_source(src, "sin.hf", nullptr, &m), HFRT_OK);
  hfrt_render_options ro;
  hfrt_render_options_init(&ro);
  ro.width = ro.height = 8;
  ro.root = HFRT_ROOT_ANALYTIC;
  std::vector<float> rgba(256);
  EXPECT_EQ(hfrt_render_model(m, &ro, rgba.data(), 256), HFRT_ERROR_RENDER);
  std::string msg = hfrt_last_error_message();
  EXPECT_NE(msg.find("sin.hf:3:"), std::string::npos) << msg;
  hfrt_model_free(m);
}

}  // namespace

namespace {

/// Writes `text` to a file of the temporary folder and returns its path.
std::string temp_file(const std::string& name, const std::string& text) {
  std::string path = ::testing::TempDir() + "hfrt_capi_" + std::to_string(::getpid()) + "_" + name;
  std::ofstream(path) << text;
  return path;
}

}  // namespace

// A scene file through the C API: an emitting ball (ambient 1, no diffuse or highlight) of a
// known colour, seen orthographically: the centre pixel has exactly that colour, a corner the
// scene's background.
TEST(CApi, RenderSceneFile) {
  std::string ball = temp_file("ball.hf",
                               "my_model(x[3], a[1]) { my_model = 1 - sqrt(x[1]*x[1] + "
                               "x[2]*x[2] + x[3]*x[3]); }\n");
  std::string scene =
      temp_file("s.toml",
                "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\northo = 4\n"
                "[render]\nbackground = [0, 0, 1]\n"
                "[material.lamp]\ncolor = [0.25, 0.5, 0.75]\nambient = 1\ndiffuse = 0\n"
                "specular = 0\n[[object]]\nfile = \"" +
                    ball + "\"\nbbox = [-2, -2, -2, 2, 2, 2]\nmaterial = \"lamp\"\n");
  const int w = 16, h = 16;
  std::vector<float> rgba(4 * w * h, -1.0f);
  ASSERT_EQ(hfrt_render_scene_file(scene.c_str(), w, h, 2, rgba.data(), int64_t(rgba.size())),
            HFRT_OK)
      << hfrt_last_error_message();
  const int c = 4 * (h / 2 * w + w / 2);
  EXPECT_FLOAT_EQ(rgba[c], 0.25f);
  EXPECT_FLOAT_EQ(rgba[c + 1], 0.5f);
  EXPECT_FLOAT_EQ(rgba[c + 2], 0.75f);
  EXPECT_EQ(rgba[c + 3], 1.0f);
  EXPECT_EQ(rgba[2], 1.0f);  // the corner sees the background
  EXPECT_EQ(rgba[3], 0.0f);
  // Errors: a located scene error, NULL pointers, a small buffer.
  std::string bad = temp_file("bad.toml", "[render]\nspp = 0\n");
  EXPECT_EQ(hfrt_render_scene_file(bad.c_str(), w, h, 0, rgba.data(), int64_t(rgba.size())),
            HFRT_ERROR_RENDER);
  EXPECT_NE(std::string(hfrt_last_error_message()).find(bad + ":2:7: error: "), std::string::npos)
      << hfrt_last_error_message();
  EXPECT_EQ(hfrt_render_scene_file(nullptr, w, h, 0, rgba.data(), 4), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_render_scene_file(scene.c_str(), w, h, 0, nullptr, 4),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(hfrt_render_scene_file(scene.c_str(), w, h, 0, rgba.data(), 5),
            HFRT_ERROR_INVALID_ARGUMENT);
  std::remove(ball.c_str());
  std::remove(scene.c_str());
  std::remove(bad.c_str());
}

namespace limits_test {

const char* kEndless =
    "my_model(x[3], a[1])\n{\n  i = 0;\n  while x[1] > 0 loop i = i + 1; endloop;\n"
    "  my_model = i;\n}\n";

TEST(CApi, LimitsAreOptionsWithTheirDefaults) {
  hfrt_compile_options opt;
  hfrt_compile_options_init(&opt);
  EXPECT_EQ(opt.max_loop_iterations, 1000000);
  EXPECT_EQ(opt.max_array_size, 8192);
  EXPECT_EQ(opt.max_mesh_bytes, int64_t{256} << 20);
  EXPECT_EQ(opt.max_exact_curves, 64);
  // max_exact_curves came after the others: out of range, an error; beyond an older caller's
  // struct_size, not read (the default).
  opt.max_exact_curves = 0;
  hfrt_model* bad = nullptr;
  EXPECT_EQ(hfrt_model_compile_source(kEndless, "endless.hf", &opt, &bad),
            HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(std::string(hfrt_last_error_message()).find("max_exact_curves must be at least 1"),
            std::string::npos)
      << hfrt_last_error_message();
  opt.struct_size = uint32_t(offsetof(hfrt_compile_options, max_exact_curves));
  ASSERT_EQ(hfrt_model_compile_source(kEndless, "endless.hf", &opt, &bad), HFRT_OK)
      << hfrt_last_error_message();
  hfrt_model_free(bad);
  hfrt_compile_options_init(&opt);
  opt.max_loop_iterations = 10;
  hfrt_model* m = nullptr;
  ASSERT_EQ(hfrt_model_compile_source(kEndless, "endless.hf", &opt, &m), HFRT_OK)
      << hfrt_last_error_message();
  double xs[3] = {1, 0, 0}, f = 0;
  ASSERT_EQ(hfrt_model_eval_f64(m, 1, xs, 3, &f, 1, nullptr, 0), HFRT_OK);
  EXPECT_TRUE(std::isnan(f));
  xs[0] = -1;
  ASSERT_EQ(hfrt_model_eval_f64(m, 1, xs, 3, &f, 1, nullptr, 0), HFRT_OK);
  EXPECT_EQ(f, 0);
  hfrt_model_free(m);

  // A located compile error for an array over the limit.
  hfrt_compile_options_init(&opt);
  opt.max_array_size = 2;
  m = nullptr;
  EXPECT_EQ(hfrt_model_compile_source("m(x[3], a[1]) { m = 1; }", "arr.hf", &opt, &m),
            HFRT_ERROR_COMPILE);
  const char* file = nullptr;
  int32_t line = 0, col = 0;
  hfrt_last_error_location(&file, &line, &col);
  EXPECT_EQ(line, 1);
  EXPECT_EQ(col, 5);
  EXPECT_NE(std::string(hfrt_last_error_message()).find("array size 3 is more than the limit of 2"),
            std::string::npos)
      << hfrt_last_error_message();
}

TEST(CApi, BadLimitsAndOldOptionStructs) {
  hfrt_compile_options opt;
  hfrt_compile_options_init(&opt);
  opt.max_slots = 0;
  hfrt_model* m = nullptr;
  EXPECT_EQ(hfrt_model_compile_source(kBall, nullptr, &opt, &m), HFRT_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(std::string(hfrt_last_error_message()),
            "hfrt_model_compile_source: options->max_slots must be at least 1 (got 0)");
  // A caller built against the first header (no limits) gets the defaults.
  hfrt_compile_options_init(&opt);
  opt.struct_size = offsetof(hfrt_compile_options, max_loop_iterations);
  opt.max_slots = 0;  // beyond its struct: not read
  ASSERT_EQ(hfrt_model_compile_source(kBall, nullptr, &opt, &m), HFRT_OK)
      << hfrt_last_error_message();
  hfrt_model_free(m);
}

}  // namespace limits_test
