// Tests of the GPU path (jit/nvptx.h, jit/device_math.h) that need no GPU:
//  - device_math.h's algorithms (the `double` instantiation) against glibc's double functions
//    rounded to float, within 1 ulp over wide samples, and exactly on special values;
//  - its LLVM backend (the code that goes into the PTX, compiled for the host) bit for bit
//    against the `double` instantiation;
//  - PTX for every corpus model: produced, with the entry points and parameter lists that
//    gpu/kernel_abi.h promises, no external call left, and a model that uses every lane-call op;
//  - the kernels on the host against the CPU's f32 JIT on every corpus model.
#include "jit/nvptx.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "jit/device_math.h"
#include "jit/interval.h"
#include "jit/llvm_jit.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

/// Distance in units in the last place between two floats (0 for two NaNs, a huge number for
/// a NaN against a number).
int64_t ulps(float a, float b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b) ? 0 : INT64_MAX / 2;
  auto ordered = [](float f) {
    int32_t i;
    std::memcpy(&i, &f, 4);
    return i < 0 ? int64_t(INT32_MIN) - i : int64_t(i);
  };
  return std::llabs(ordered(a) - ordered(b));
}

struct MathCase {
  Op op;
  double (*reference)(double, double);  ///< glibc, double precision
  double (*device)(double, double);     ///< device_math.h, double instantiation
  float lo, hi;                         ///< sampled range (uniform), plus log-uniform magnitudes
};

#define HFRT_UNARY(op, fn, lo, hi)                                        \
  MathCase {                                                              \
    Op::k##op, [](double a, double) -> double { return std::fn(a); },     \
        [](double a, double) -> double { return devmath::fn(a); }, lo, hi \
  }
#define HFRT_BINARY(op, fn, lo, hi)                                            \
  MathCase {                                                                   \
    Op::k##op, [](double a, double b) -> double { return std::fn(a, b); },     \
        [](double a, double b) -> double { return devmath::fn(a, b); }, lo, hi \
  }

std::vector<MathCase> math_cases() {
  // Names as in <cmath>; Exp..Cbrt of ir_ops.h (kPowHF has its own test).
  return {
      HFRT_UNARY(Exp, exp, -100.0f, 100.0f),   HFRT_UNARY(Log, log, 0.0f, 1e6f),
      HFRT_UNARY(Log10, log10, 0.0f, 1e6f),    HFRT_UNARY(Sin, sin, -1000.0f, 1000.0f),
      HFRT_UNARY(Cos, cos, -1000.0f, 1000.0f), HFRT_UNARY(Tan, tan, -100.0f, 100.0f),
      HFRT_UNARY(Asin, asin, -1.0f, 1.0f),     HFRT_UNARY(Acos, acos, -1.0f, 1.0f),
      HFRT_UNARY(Atan, atan, -1e4f, 1e4f),     HFRT_BINARY(Atan2, atan2, -100.0f, 100.0f),
      HFRT_UNARY(Sinh, sinh, -80.0f, 80.0f),   HFRT_UNARY(Cosh, cosh, -80.0f, 80.0f),
      HFRT_UNARY(Tanh, tanh, -20.0f, 20.0f),   HFRT_BINARY(Fmod, fmod, -1e4f, 1e4f),
      HFRT_BINARY(Pow, pow, -10.0f, 10.0f),    HFRT_UNARY(Cbrt, cbrt, -1e6f, 1e6f),
  };
}

/// Arguments: uniform in [lo, hi], log-uniform magnitudes of both signs within the range, and
/// the special values; for binary ops, pairs (pow: integral exponents too).
std::vector<std::pair<float, float>> samples(const MathCase& c, int n) {
  std::mt19937 rng(1234 + int(c.op));
  std::uniform_real_distribution<float> uni(c.lo, c.hi);
  std::uniform_real_distribution<float> expo(-20.0f,
                                             std::log2(std::max(std::fabs(c.lo), std::fabs(c.hi))));
  std::vector<std::pair<float, float>> out;
  auto any = [&] {
    if (rng() % 2) return uni(rng);
    float m = std::exp2(expo(rng));
    float v = (rng() % 2) ? m : -m;
    return v < c.lo ? c.lo : v > c.hi ? c.hi : v;
  };
  for (int i = 0; i < n; ++i) {
    float a = any(), b = any();
    if (c.op == Op::kPow && i % 3 == 0) b = std::round(b);
    if (c.op == Op::kPow && i % 3 == 1) a = std::fabs(a);
    out.push_back({a, b});
  }
  const float specials[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.5f, -0.5f, 2.0f, INFINITY, -INFINITY, NAN};
  for (float a : specials) {
    for (float b : specials) out.push_back({a, b});
  }
  return out;
}

TEST(DeviceMath, DoubleInstantiationIsWithinOneUlpOfGlibcRoundedToFloat) {
  for (const MathCase& c : math_cases()) {
    const bool binary = op_num_args(c.op) == 2;
    int64_t worst = 0;
    float worst_a = 0, worst_b = 0;
    int compared = 0;
    for (auto [a, b] : samples(c, 20000)) {
      const float ref = static_cast<float>(c.reference(a, binary ? b : 0.0));
      const float got = static_cast<float>(c.device(a, binary ? b : 0.0));
      const int64_t u = ulps(ref, got);
      ++compared;
      if (u > worst) worst = u, worst_a = a, worst_b = b;
    }
    EXPECT_GE(compared, 20000);
    EXPECT_LE(worst, 1) << op_name(c.op) << "(" << worst_a << (binary ? ", " : "")
                        << (binary ? std::to_string(worst_b) : "")
                        << "): " << c.device(worst_a, worst_b) << " vs "
                        << c.reference(worst_a, worst_b);
  }
}

TEST(DeviceMath, PowHFFollowsTheSinglePrecisionHelper) {
  // hfrt_jit_powhf_f32 (llvm_jit.cpp): |b| < 1e-6 -> 0, integral e -> b multiplied |e|
  // times (inverted for e < 0), else expf(e logf b).
  EXPECT_EQ(devmath::powhf_f32(1e-7, 2.0), 0.0);
  EXPECT_EQ(static_cast<float>(devmath::powhf_f32(2.0, 10.0)), 1024.0f);
  EXPECT_EQ(static_cast<float>(devmath::powhf_f32(-2.0, 3.0)), -8.0f);
  EXPECT_EQ(static_cast<float>(devmath::powhf_f32(2.0, -2.0)), 0.25f);
  EXPECT_TRUE(std::isnan(devmath::powhf_f32(-2.0, 0.5)));
  const float general = std::exp(0.5f * std::log(3.0f));
  EXPECT_LE(ulps(static_cast<float>(devmath::powhf_f32(3.0, 0.5)), general), 1);
}

TEST(DeviceMath, LlvmBackendIsBitIdenticalToTheDoubleInstantiation) {
  auto libm = HostDeviceLibm::compile();
  ASSERT_TRUE(libm.ok()) << libm.error().message;
  auto cases = math_cases();
  cases.push_back(
      {Op::kPowHF, nullptr, [](double a, double b) { return devmath::powhf_f32(a, b); }, -10, 10});
  for (const MathCase& c : cases) {
    const bool binary = op_num_args(c.op) == 2;
    int differ = 0, compared = 0;
    for (auto [a, b] : samples(c, 4000)) {
      const float want = static_cast<float>(c.device(a, binary ? b : 0.0));
      const float got = (*libm.value())(c.op, a, b);
      ++compared;
      if (ulps(want, got) != 0) {
        if (differ++ < 3)
          ADD_FAILURE() << op_name(c.op) << "(" << a << ", " << b << "): " << got << " vs " << want;
      }
    }
    EXPECT_EQ(differ, 0) << op_name(c.op);
    EXPECT_GE(compared, 4000);
  }
}

// ---------------------------------------------------------------------------------------

/// The corpus models that lower without errors and have no mesh or patch leaves.
struct CorpusModel {
  std::string path;
  testutil::Compiled c;
};
std::vector<std::string> corpus_paths() {
  std::vector<std::string> out;
  for (const std::string& p : testutil::hf_files(std::string(HFRT_CORPUS_DIR) + "/models")) {
    // The machine-generated parser stress tests (10^4 statements) cost minutes of NVPTX
    // codegen each and evaluate to NaN everywhere (corpus MANIFEST): left to the device check.
    if (p.find("historical_") != std::string::npos) continue;
    out.push_back(p);
  }
  return out;
}

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The parameter list of `.entry name(...)` in PTX text: the number of .param lines.
int entry_params(const std::string& ptx, const std::string& name) {
  size_t at = ptx.find(".entry " + std::string(name) + "(");
  if (at == std::string::npos) return -1;
  size_t end = ptx.find(')', at);
  int n = 0;
  for (size_t p = ptx.find(".param", at); p != std::string::npos && p < end;
       p = ptx.find(".param", p + 1))
    ++n;
  return n;
}

TEST(Nvptx, EveryCorpusModelBecomesPtxWithTheKernelAbi) {
  int produced = 0, unsupported = 0, lowered = 0;
  const std::vector<std::string> paths = corpus_paths();
  for (const std::string& path : paths) {
    testutil::Compiled c = testutil::compile(read(path), "", path);
    EXPECT_TRUE(c.ok) << path << " does not lower:\n" << c.diagnostics;
    if (!c.ok) continue;
    ++lowered;
    if (!device_unsupported_reason(c.fn).empty()) {
      ++unsupported;
      EXPECT_FALSE(emit_ptx(c.fn).ok()) << path;
      continue;
    }
    Result<std::string> ptx = emit_ptx(c.fn);
    ASSERT_TRUE(ptx.ok()) << path << ": " << ptx.error().message;
    const std::string& t = ptx.value();
    EXPECT_NE(t.find(".version"), std::string::npos) << path;
    EXPECT_NE(t.find(".target sm_60"), std::string::npos) << path;
    EXPECT_EQ(entry_params(t, gpu::kEvalEntry), 5) << path;
    EXPECT_EQ(entry_params(t, gpu::kRenderEntry), 3) << path;
    // Everything the kernels call is in the module: no libm on the GPU.
    EXPECT_EQ(t.find(".extern .func"), std::string::npos) << path;
    ++produced;
  }
  // 29 models besides the historical_* ones (2026-12); every one lowers, and either becomes
  // PTX or is refused for its mesh or patch leaves.
  EXPECT_GE(paths.size(), 29u);
  EXPECT_EQ(lowered, static_cast<int>(paths.size()));
  EXPECT_EQ(produced + unsupported, lowered);
  EXPECT_GE(produced, 25) << "unsupported: " << unsupported;
}

TEST(Nvptx, EveryLaneCallOpPassesTheNvptxBackEnd) {
  // One model calling every per-lane C function of ir_ops.h, plus arrays and a loop.
  const std::string text = R"(
my_model(x[3], a[1]) {
  array v[3];
  v[1] = exp(x[1]) + log(abs(x[2]) + 1) + logd(abs(x[3]) + 1) + sin(x[1]) + cos(x[2]);
  v[2] = tan(x[3]) + asin(x[1] / 100) + acos(x[2] / 100) + atan(x[3]) + atan2(x[1], x[2]);
  v[3] = sinh(x[1] / 10) + cosh(x[2] / 10) + tanh(x[3]) + mod(x[1], 3) + x[2]^3 + x[1]^0.5;
  i = 1;
  t = 0;
  while i <= 3 loop t = t + v[i]; i = i + 1; endloop;
  my_model = t;
})";
  testutil::Compiled c = testutil::compile(text);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  Result<std::string> ir = device_llvm_ir(c.fn);
  ASSERT_TRUE(ir.ok()) << ir.error().message;
  for (const char* name : {"hfrt_dev_expf", "hfrt_dev_logf", "hfrt_dev_sinf", "hfrt_dev_atan2f",
                           "hfrt_dev_fmodf", "hfrt_dev_hfrt_jit_powhf_f32"}) {
    EXPECT_NE(ir.value().find(name), std::string::npos) << name;
  }
  Result<std::string> ptx = emit_ptx(c.fn, {"sm_80", 2});
  ASSERT_TRUE(ptx.ok()) << ptx.error().message;
  EXPECT_NE(ptx.value().find(".target sm_80"), std::string::npos);
  EXPECT_EQ(ptx.value().find(".extern .func"), std::string::npos);
  // Double precision inside the math functions, single precision at the interface.
  EXPECT_NE(ptx.value().find(".f64"), std::string::npos);
}

TEST(Nvptx, EvalOnlyPtxHasThePointEvaluatorAlone) {
  testutil::Compiled c =
      testutil::compile("my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1] - x[2]*x[2]; }");
  ASSERT_TRUE(c.ok);
  PtxOptions o;
  o.eval_only = true;
  Result<std::string> ptx = emit_ptx(c.fn, o);
  ASSERT_TRUE(ptx.ok());
  EXPECT_EQ(entry_params(ptx.value(), gpu::kEvalEntry), 5);
  EXPECT_EQ(entry_params(ptx.value(), gpu::kRenderEntry), -1);
  EXPECT_EQ(entry_params(ptx.value(), gpu::kIntervalEntry), -1);
  Result<std::string> all = emit_ptx(c.fn);
  ASSERT_TRUE(all.ok());
  EXPECT_LT(ptx.value().size(), all.value().size() / 2);
}

TEST(Nvptx, MeshLeavesAreRefusedWithTheReason) {
  Function fn;
  fn.surfaces.emplace_back();
  EXPECT_NE(device_unsupported_reason(fn).find("mesh and patch leaves"), std::string::npos);
  Result<std::string> ptx = emit_ptx(fn);
  ASSERT_FALSE(ptx.ok());
  EXPECT_NE(ptx.error().message.find("not on the GPU yet"), std::string::npos);
}

TEST(HostKernels, EvalAgreesWithTheF32JitOnEveryCorpusModel) {
  int models = 0;
  int64_t points = 0;
  for (const std::string& path : corpus_paths()) {
    testutil::Compiled c = testutil::compile(read(path), "", path);
    if (!c.ok || !device_unsupported_reason(c.fn).empty()) continue;
    auto kernels = HostKernels::compile(c.fn);
    ASSERT_TRUE(kernels.ok()) << path << ": " << kernels.error().message;
    auto jit = JitFunction::compile(c.fn, Precision::kF32);
    ASSERT_TRUE(jit.ok()) << path;
    const int64_t n = 512;
    const int nin = std::max(c.fn.num_inputs, 1);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-2.0f, 2.0f);
    std::vector<float> xs(size_t(nin) * n), a(size_t(std::max(c.fn.num_params, 1)), 0.5f);
    for (float& x : xs) x = u(rng);
    std::vector<float> want(n), got(n);
    jit.value()->f32()(n, xs.data(), a.data(), want.data(), nullptr);
    kernels.value()->eval(n, xs.data(), a.data(), got.data(), nullptr);
    int bad = 0;
    for (int64_t i = 0; i < n; ++i) {
      const bool both_nan = std::isnan(want[i]) && std::isnan(got[i]);
      const bool close = std::fabs(want[i] - got[i]) <= 1e-4f * (1.0f + std::fabs(want[i])) ||
                         ulps(want[i], got[i]) <= 16;
      if (!both_nan && !close) {
        if (bad++ < 3)
          ADD_FAILURE() << path << " point " << i << ": jit " << want[i] << " device " << got[i];
      }
    }
    // A libm ulp apart can flip a comparison (a branch, a NaN domain edge) at rare points.
    EXPECT_LE(bad, 2) << path;
    ++models;
    points += n;
  }
  EXPECT_GE(models, 25);
  EXPECT_GE(points, 25 * 512);
}

TEST(HostKernels, IntervalEntryIsTheIntervalJitWhereTheModelNeedsNoHost) {
  // Prospero-like CSG of the IR's own arithmetic (no libm, no R-function nodes): the kernels
  // carry kIntervalEntry, and it computes what the CPU's interval JIT computes, bit for bit
  // (the same emitter, one lane); a model with sin has no interval entry.
  const std::string csg = R"(
my_model(x[3], a[1]) {
  sp = 9 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3];
  b = min(min(4 - abs(x[1]), 4 - abs(x[2])), 4 - abs(x[3]));
  h = sqrt(x[1]*x[1] + x[2]*x[2]) - 1.5;
  my_model = max(min(sp, b), -max(h, -10)) * (1 + a[1]);
})";
  testutil::Compiled c = testutil::compile(csg);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  ASSERT_TRUE(interval_code_is_self_contained(c.fn));
  auto kernels = HostKernels::compile(c.fn);
  ASSERT_TRUE(kernels.ok()) << kernels.error().message;
  ASSERT_TRUE(kernels.value()->has_interval());
  IntervalJit::Options io;
  io.trace = false;
  auto jit = IntervalJit::compile(c.fn, io);
  ASSERT_TRUE(jit.ok());
  const int64_t n = 1000;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-6, 6), w(0, 3);
  std::vector<double> lo(3 * n), hi(3 * n), a{0.25};
  for (int64_t i = 0; i < 3 * n; ++i) {
    lo[i] = u(rng);
    hi[i] = lo[i] + (i % 7 == 0 ? 0.0 : w(rng));
  }
  std::vector<double> want_lo(n), want_hi(n), got_lo(n), got_hi(n);
  std::vector<uint8_t> want_nan(n), got_nan(n);
  jit.value()->eval(n, lo.data(), hi.data(), a, want_lo.data(), want_hi.data(), want_nan.data());
  kernels.value()->interval(n, lo.data(), hi.data(), a.data(), got_lo.data(), got_hi.data(),
                            got_nan.data());
  int proven_empty = 0;
  for (int64_t i = 0; i < n; ++i) {
    ASSERT_EQ(got_lo[i], want_lo[i]) << i;
    ASSERT_EQ(got_hi[i], want_hi[i]) << i;
    ASSERT_EQ(got_nan[i], want_nan[i]) << i;
    proven_empty += want_hi[i] < 0;
  }
  EXPECT_GT(proven_empty, 10);  // the culling has something to cull
  Result<std::string> ptx = emit_ptx(c.fn);
  ASSERT_TRUE(ptx.ok());
  EXPECT_EQ(entry_params(ptx.value(), gpu::kIntervalEntry), 7);

  testutil::Compiled wavy = testutil::compile("my_model(x[3], a[1]) { my_model = sin(x[1]); }");
  ASSERT_TRUE(wavy.ok);
  EXPECT_FALSE(interval_code_is_self_contained(wavy.fn));
  Result<std::string> ptx2 = emit_ptx(wavy.fn);
  ASSERT_TRUE(ptx2.ok());
  EXPECT_EQ(entry_params(ptx2.value(), gpu::kIntervalEntry), -1);
}

TEST(HostKernels, CulledRenderFindsTheSameSurfaceAsThePlainMarch) {
  // The ray caster of a self-contained model culls empty ray pieces by intervals before it
  // marches; a model with sin marches everything. x -> sin(asin(x)) keeps the same surface,
  // so the two renders of the same sphere must agree pixel for pixel in coverage.
  auto render = [](const std::string& text, std::vector<float>* out) {
    testutil::Compiled c = testutil::compile(text);
    ASSERT_TRUE(c.ok) << c.diagnostics;
    auto kernels = HostKernels::compile(c.fn);
    ASSERT_TRUE(kernels.ok()) << kernels.error().message;
    gpu::RenderParams p{};
    const float eye[3] = {0, 0, 20}, fwd[3] = {0, 0, -1}, right[3] = {1, 0, 0}, up[3] = {0, 1, 0};
    std::copy(eye, eye + 3, p.eye);
    std::copy(fwd, fwd + 3, p.forward);
    std::copy(right, right + 3, p.right);
    std::copy(up, up + 3, p.up);
    p.half_w = p.half_h = 0.3f;
    p.width = p.height = 64;
    for (int k = 0; k < 3; ++k) p.box_lo[k] = -10, p.box_hi[k] = 10;
    p.step = 20.0f / 512;
    p.eps = 20e-5f;
    p.shadow_bias = 0.02f;
    p.max_steps = 1 << 26;
    p.albedo[0] = p.albedo[1] = p.albedo[2] = 0.8f;
    p.ambient = 0.12f;
    p.specular = 0.25f;
    p.shininess = 48;
    p.shadows = 1;
    p.num_lights = 1;
    p.light_kind[0] = gpu::kLightDirectional;
    p.light_v[0][1] = 1;
    p.light_v[0][2] = 1;
    p.light_radiance[0][0] = p.light_radiance[0][1] = p.light_radiance[0][2] = 1;
    std::vector<float> a{0};
    out->assign(64 * 64 * gpu::kRenderFloatsPerPixel, 0);
    kernels.value()->render(p, a.data(), out->data(), 0, 64 * 64);
  };
  std::vector<float> culled, plain;
  render("my_model(x[3], a[1]) { my_model = 16 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }", &culled);
  render(
      "my_model(x[3], a[1]) { my_model = 16 - x[1]*x[1] - x[2]*x[2] - sin(asin(x[3]/10))*x[3]*10; "
      "}",
      &plain);
  int covered = 0, differ = 0;
  for (int i = 0; i < 64 * 64; ++i) {
    const float ca = culled[size_t(i) * gpu::kRenderFloatsPerPixel + 3];
    const float cb = plain[size_t(i) * gpu::kRenderFloatsPerPixel + 3];
    covered += ca > 0.5f;
    differ += (ca > 0.5f) != (cb > 0.5f);
    if (ca > 0.5f && cb > 0.5f) {
      EXPECT_NEAR(culled[size_t(i) * gpu::kRenderFloatsPerPixel + 4],
                  plain[size_t(i) * gpu::kRenderFloatsPerPixel + 4], 1e-3f)
          << i;
    }
  }
  EXPECT_GT(covered, 1000);
  EXPECT_LE(differ, 8);  // pixels on the rim, where the two F differ in the last bits
}

}  // namespace
}  // namespace hfrt::jit
