// Tapes and their VMs (jit/tape.h, jit/tape_vm.h) on every corpus model and prospero:
//  - the full tape in the f64 point VM equals the reference interpreter bit for bit;
//  - over random boxes, two levels deep: the pruned tape in the f64 point VM equals the full
//    tape bit for bit at every sampled point of its box (the interval domain is sound for
//    f64, so a decided choice is the choice at every point); in the f32 VM it equals the
//    full tape's f32 value except where f32 rounding contradicts the f64 enclosure (counted,
//    and required to be rare and within rounding); the pruned interval encloses the full
//    f64 values; tapes never grow and do shrink somewhere;
//  - the f32 VM on the full tape agrees with the f32 JIT (Model::eval_batch);
//  - the gradient pass equals the gradient JIT bit for bit (f64 and f32) where it has a form.
// Counts are asserted, so the test cannot pass with nothing checked.

#include "jit/tape.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "base/file.h"
#include "base/result.h"
#include "hfrt/model.h"
#include "jit/interpreter.h"
#include "jit/interval.h"
#include "jit/lower.h"
#include "jit/tape_vm.h"
#include "lang/frontend.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {

using namespace ::hfrt::ir;
namespace {

namespace fs = std::filesystem;

using testutil::lower_file;

std::vector<std::string> corpus_files() {
  std::vector<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(HFRT_CORPUS_DIR "/models")) {
    if (e.is_regular_file() && e.path().extension() == ".hf") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  files.push_back((fs::path(HFRT_CORPUS_DIR) / "bench" / "prospero.hf").string());
  return files;
}

template <typename T>
bool same_bits(T a, T b) {
  if (a != a) return b != b;
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

struct Totals {
  int files = 0, supported = 0;
  int64_t points = 0, boxes = 0, pruned_shorter = 0, f32_mismatches = 0;
  size_t min_child = SIZE_MAX;
};

/// Points of a box, structure of arrays (3 coordinates).
template <typename T>
struct Points {
  std::vector<T> c[3];
  std::span<const T* const> inputs() {
    ptr[0] = c[0].data(), ptr[1] = c[1].data(), ptr[2] = c[2].data();
    return {ptr, 3};
  }
  const T* ptr[3];
};

void check_box(const Tape& full, const Tape& parent, const Interval box[3], std::mt19937& rng,
               TapeVm& vm, Tape* child, Totals* t, const std::string& file, int depth) {
  vm.eval_interval(parent, {box, 3});
  if (vm.prune_last(parent, child)) {
    ASSERT_LE(child->length(), parent.length()) << file;
  } else {
    *child = parent;  // nothing decided: the parent is the box's tape
  }
  t->boxes++;
  if (child->length() < full.length()) t->pruned_shorter++;
  t->min_child = std::min(t->min_child, child->length());
  // The pruned interval over the box.
  TapeVm vm2;
  const Interval enclosure = vm2.eval_interval(*child, {box, 3});

  constexpr size_t kN = 100;  // two passes of the lanes, the second partial
  Points<double> pd;
  Points<float> pf;
  for (int k = 0; k < 3; ++k) {
    std::uniform_real_distribution<double> u(box[k].lo, box[k].hi);
    pd.c[k].resize(kN);
    pf.c[k].resize(kN);
    for (size_t i = 0; i < kN; ++i) {
      // Points as floats (exact in double), corners included.
      float v = static_cast<float>(i < 8 ? ((i >> k) & 1 ? box[k].hi : box[k].lo) : u(rng));
      v = std::clamp(v, static_cast<float>(box[k].lo), static_cast<float>(box[k].hi));
      if (v < box[k].lo) v = std::nextafter(v, INFINITY);
      if (v > box[k].hi) v = std::nextafter(v, -INFINITY);
      pf.c[k][i] = v;
      pd.c[k][i] = v;
    }
  }
  std::vector<double> full_d(kN), pruned_d(kN);
  std::vector<float> full_f(kN), pruned_f(kN);
  vm.eval<double>(full, kN, pd.inputs(), full_d.data());
  vm.eval<double>(*child, kN, pd.inputs(), pruned_d.data());
  vm.eval<float>(full, kN, pf.inputs(), full_f.data());
  vm.eval<float>(*child, kN, pf.inputs(), pruned_f.data());
  for (size_t i = 0; i < kN; ++i) {
    if (pd.c[0][i] < box[0].lo || pd.c[0][i] > box[0].hi) continue;
    t->points++;
    ASSERT_TRUE(same_bits(full_d[i], pruned_d[i]))
        << file << " depth " << depth << " at (" << pd.c[0][i] << ", " << pd.c[1][i] << ", "
        << pd.c[2][i] << "): full " << full_d[i] << " pruned " << pruned_d[i];
    ASSERT_TRUE(enclosure.contains(full_d[i])) << file << " pruned interval [" << enclosure.lo
                                               << ", " << enclosure.hi << "] misses " << full_d[i];
    if (!same_bits(full_f[i], pruned_f[i])) {
      t->f32_mismatches++;
      // Only a rounding-level disagreement is allowed (see tape.h).
      ASSERT_NEAR(full_f[i], pruned_f[i], 1e-4 * (1 + std::fabs(full_f[i]))) << file;
    }
  }
  if (depth < 2) {
    // A random quarter (in x and y) of the box, on the child.
    Interval sub[3] = {box[0], box[1], box[2]};
    for (int k = 0; k < 2; ++k) {
      const double mid = 0.5 * (box[k].lo + box[k].hi);
      if (rng() & 1) {
        sub[k].lo = mid;
      } else {
        sub[k].hi = mid;
      }
    }
    Tape grandchild;
    check_box(full, *child, sub, rng, vm, &grandchild, t, file, depth + 1);
  }
}

TEST(TapeTest, PrunedEqualsFullOnCorpus) {
  Totals t;
  std::mt19937 rng(2025);
  for (const std::string& file : corpus_files()) {
    std::optional<Function> fn = lower_file(file);
    if (!fn) continue;
    t.files++;
    std::string why;
    std::unique_ptr<Tape> tape = Tape::build(*fn, {}, &why);
    if (!tape) continue;
    t.supported++;
    SCOPED_TRACE(file);
    // The full tape against the reference interpreter, in double, bit for bit.
    Interpreter interp(*fn);
    TapeVm vm;
    std::uniform_real_distribution<double> u(-3.5, 3.5);
    {
      Points<double> p;
      constexpr size_t kN = 70;
      for (auto& c : p.c) {
        c.resize(kN);
        for (double& v : c) v = u(rng);
      }
      std::vector<double> out(kN);
      vm.eval<double>(*tape, kN, p.inputs(), out.data());
      for (size_t i = 0; i < kN; ++i) {
        const double x[3] = {p.c[0][i], p.c[1][i], p.c[2][i]};
        ASSERT_TRUE(same_bits(interp.eval(x, {}).value, out[i])) << file;
      }
    }
    for (int b = 0; b < 24; ++b) {
      Interval box[3];
      const double w = std::pow(10.0, std::uniform_real_distribution<double>(-2.5, 0.5)(rng));
      for (int k = 0; k < 3; ++k) {
        const double lo = u(rng);
        box[k] = {lo, lo + w * (k == 2 ? 0.5 : 1.0), false};
      }
      Tape child;
      check_box(*tape, *tape, box, rng, vm, &child, &t, file, 1);
      if (HasFatalFailure()) return;
    }
  }
  std::printf(
      "tape test: %d files, %d with a tape, %lld boxes (%lld pruned shorter, shortest %zu), "
      "%lld points, %lld f32 rounding disagreements\n",
      t.files, t.supported, (long long)t.boxes, (long long)t.pruned_shorter, t.min_child,
      (long long)t.points, (long long)t.f32_mismatches);
  EXPECT_GE(t.files, 30);
  EXPECT_GE(t.supported, 10);
  EXPECT_GE(t.points, 100000);
  EXPECT_GE(t.pruned_shorter, t.boxes / 4);
  EXPECT_LE(t.f32_mismatches, t.points / 10000);
}

// TapeVm::eval_intervals (kLanes boxes per pass, the ops as vector code) against
// eval_interval (one box, interval_detail / apply_interval per instruction): the same bits on
// every corpus model with a tape, over boxes of every size, points, boxes reaching to the
// overflow threshold and to infinity (inf - inf, 0 * inf, x / [0, 0], sqrt of negatives, the
// comparisons and checks), in passes that end part-way through the lanes. And the tape VM
// against the interval interpreter (what it replaces for large objects: IntervalEngine).
TEST(TapeTest, BatchedIntervalsEqualOneBoxAtATime) {
  std::mt19937 rng(7);
  int models = 0;
  int64_t boxes = 0, nan_boxes = 0, infinite = 0, interp_same = 0, interp_boxes = 0;
  for (const std::string& file : corpus_files()) {
    std::optional<Function> fn = lower_file(file);
    if (!fn) continue;
    std::unique_ptr<Tape> tape = Tape::build(*fn, {});
    if (!tape) continue;
    models++;
    SCOPED_TRACE(file);
    constexpr size_t kN = 2 * TapeVm::kLanes + 37;
    std::vector<double> lo[3], hi[3];
    std::uniform_real_distribution<double> u(-4, 4), e(-6, 3);
    for (int k = 0; k < 3; ++k) {
      lo[k].resize(kN);
      hi[k].resize(kN);
      for (size_t i = 0; i < kN; ++i) {
        double a = u(rng), w = std::pow(10.0, e(rng));
        switch (i % 9) {
          case 0:
            w = 0;
            break;  // a point
          case 1:
            a = -w / 2;
            break;  // straddles 0
          case 2:
            a = 0, w = 0;
            break;  // the point 0
          case 3:
            a = -1e300, w = 2e300;
            break;  // near overflow
          case 4:
            a = -INFINITY, w = INFINITY;
            break;
          case 5:
            a = 0;
            break;  // starts at 0
          default:
            break;
        }
        lo[k][i] = a;
        hi[k][i] = std::isinf(a) ? INFINITY : a + w;
      }
    }
    const double* in_lo[3] = {lo[0].data(), lo[1].data(), lo[2].data()};
    const double* in_hi[3] = {hi[0].data(), hi[1].data(), hi[2].data()};
    std::vector<double> out_lo(kN), out_hi(kN);
    std::vector<uint8_t> out_nan(kN);
    TapeVm batched, single;
    batched.eval_intervals(*tape, kN, in_lo, in_hi, out_lo.data(), out_hi.data(), out_nan.data());
    IntervalInterpreter interp(*fn);
    for (size_t i = 0; i < kN; ++i) {
      const Interval box[3] = {
          {lo[0][i], hi[0][i], false}, {lo[1][i], hi[1][i], false}, {lo[2][i], hi[2][i], false}};
      const Interval one = single.eval_interval(*tape, {box, 3});
      ASSERT_TRUE(same_bits(one.lo, out_lo[i]) && same_bits(one.hi, out_hi[i]) &&
                  one.maybe_nan == (out_nan[i] != 0))
          << "box " << i << ": one at a time [" << one.lo << ", " << one.hi << "] nan "
          << one.maybe_nan << ", batched [" << out_lo[i] << ", " << out_hi[i] << "] nan "
          << int(out_nan[i]);
      boxes++;
      nan_boxes += one.maybe_nan;
      infinite += std::isinf(one.lo) || std::isinf(one.hi);
      const std::vector<Interval> b(box, box + 3);
      const Interval r = interp.eval(b, {}, nullptr);
      interp_boxes++;
      interp_same +=
          same_bits(r.lo, one.lo) && same_bits(r.hi, one.hi) && r.maybe_nan == one.maybe_nan;
    }
  }
  std::printf(
      "batched intervals: %d models, %lld boxes (%lld may be NaN, %lld with an infinite "
      "end); tape VM = interval interpreter on %lld of %lld\n",
      models, (long long)boxes, (long long)nan_boxes, (long long)infinite, (long long)interp_same,
      (long long)interp_boxes);
  EXPECT_GE(models, 10);
  EXPECT_GT(nan_boxes, 0);
  EXPECT_GT(infinite, 0);
  EXPECT_GT(boxes - nan_boxes, boxes / 4);
  // The tape VM replaces the interpreter for large objects (IntervalEngine): the same bits.
  EXPECT_EQ(interp_same, interp_boxes);
}

TEST(TapeTest, F32VmAgreesWithF32Jit) {
  int compared = 0, exact = 0, exact_models = 0;
  for (const std::string& file : corpus_files()) {
    ModelOptions mo;  // only the f32 code is compared
    mo.eager_f64 = false;
    mo.eager_f32 = true;
    mo.background_point_min_insts = -1;  // the JIT is the reference: compiled now
    auto compiled = Model::compile_file(file, mo);
    if (!compiled.ok()) continue;
    const Model& model = *compiled.model;
    std::shared_ptr<const Tape> tape = model.tape();
    if (!tape) continue;
    constexpr size_t kN = 200;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-3.5f, 3.5f);
    const int dims = std::max(model.num_inputs(), 1);
    std::vector<float> xs(size_t(dims) * kN, 0.0f), jit(kN), vmout(kN);
    for (int k = 0; k < std::min(dims, 3); ++k) {
      for (size_t i = 0; i < kN; ++i) xs[k * kN + i] = u(rng);
    }
    model.eval_batch(int64_t(kN), xs.data(), jit.data());
    std::vector<const float*> in;
    for (int k = 0; k < dims; ++k) in.push_back(xs.data() + k * kN);
    TapeVm vm;
    vm.eval<float>(*tape, kN, in, vmout.data());
    // An exact tape (TapeVm::is_exact) gives the JIT's bits at every point: what lets the
    // scalar engine answer with the VM while the f32 JIT compiles in the background.
    const bool exact_tape = TapeVm::is_exact(*tape);
    exact_models += exact_tape;
    for (size_t i = 0; i < kN; ++i) {
      compared++;
      if (same_bits(jit[i], vmout[i])) {
        exact++;
        continue;
      }
      ASSERT_FALSE(exact_tape) << file << " point " << i << ": JIT " << jit[i] << " VM "
                               << vmout[i];
      // libm calls per lane may differ from a vectorised form by rounding.
      ASSERT_NEAR(jit[i], vmout[i], 1e-4 * (1 + std::fabs(jit[i]))) << file;
    }
    // Calls of a few points take the narrow pass (TapeVm::kNarrowLanes): the same values.
    for (size_t n : {size_t(1), size_t(3), TapeVm::kNarrowLanes}) {
      std::vector<float> few(n);
      vm.eval<float>(*tape, n, in, few.data());  // the first n points (a prefix of each input)
      for (size_t i = 0; i < n; ++i) {
        ASSERT_TRUE(same_bits(few[i], vmout[i])) << file << " n " << n << " point " << i;
      }
    }
  }
  std::printf("tape f32 VM vs f32 JIT: %d values, %d bit for bit (%d exact tapes: all)\n", compared,
              exact, exact_models);
  EXPECT_GE(compared, 2000);
  EXPECT_GE(exact, compared * 9 / 10);
  EXPECT_GE(exact_models, 10);
}

/// The gradient JIT of a precision at n points (Model::eval_gradient_batch), against the tape
/// VM's gradient pass (TapeVm::eval_gradient) on the model's tape: the same bits in all four
/// components, NaN where a check fires. Returns the points compared.
template <typename T>
int64_t compare_gradients(const Model& model, const Tape& tape, std::mt19937& rng,
                          const std::string& what) {
  constexpr size_t kN = 150;  // three passes of the lanes, the last one partial
  const int dims = std::max(model.num_inputs(), 1);
  std::uniform_real_distribution<double> u(-3.5, 3.5);
  std::vector<T> xs(size_t(dims) * kN, T(0));
  for (int k = 0; k < std::min(dims, 3); ++k) {
    for (size_t i = 0; i < kN; ++i) {
      // A few points on the coordinate planes and at integers (ties of min/max, |x|, x = 0).
      const double v = i % 10 == 0 ? 0.0 : i % 10 == 1 ? std::round(u(rng)) : u(rng);
      xs[k * kN + i] = static_cast<T>(v);
    }
  }
  std::vector<T> jit(4 * kN), vm_out(4 * kN);
  model.eval_gradient_batch(int64_t(kN), xs.data(), jit.data());
  std::vector<const T*> in;
  for (int k = 0; k < model.num_inputs(); ++k) in.push_back(xs.data() + k * kN);
  TapeVm vm;
  vm.eval_gradient<T>(tape, kN, in, vm_out.data());
  for (size_t c = 0; c < 4; ++c) {
    for (size_t i = 0; i < kN; ++i) {
      EXPECT_TRUE(same_bits(jit[c * kN + i], vm_out[c * kN + i]))
          << what << " component " << c << " point " << i << ": JIT " << jit[c * kN + i] << " VM "
          << vm_out[c * kN + i];
      if (!same_bits(jit[c * kN + i], vm_out[c * kN + i])) return 0;
    }
  }
  return int64_t(kN);
}

TEST(TapeTest, GradientPassEqualsTheGradientJitOnCorpus) {
  // Every corpus model whose tape has a gradient form (exact arithmetic only): the tape VM's
  // gradient pass gives the gradient JIT's bits, f64 and f32 (what lets GradientEngine answer
  // with it while the JIT compiles in the background without changing a render or a mesh).
  int models = 0, skipped = 0;
  int64_t points = 0;
  for (const std::string& file : corpus_files()) {
    if (file.find("prospero") != std::string::npos) continue;  // its gradient JIT: minutes
    ModelOptions mo;
    mo.eager_f64 = false;
    mo.gradient_jit_max_insts = -1;  // the JIT whatever the size: it is the reference
    mo.background_gradient_min_insts = -1;
    auto compiled = Model::compile_file(file, mo);
    if (!compiled.ok()) continue;
    const Model& model = *compiled.model;
    std::shared_ptr<const Tape> tape = model.tape();
    if (!tape) continue;
    if (!TapeVm::is_exact(*tape)) {
      skipped++;
      continue;
    }
    ASSERT_EQ(model.gradient_engine(hfrt::Precision::kF32), DomainEngine::kJit) << file;
    std::mt19937 rng(11);
    const int64_t d = compare_gradients<double>(model, *tape, rng, file + " f64");
    const int64_t f = compare_gradients<float>(model, *tape, rng, file + " f32");
    ASSERT_GT(d, 0) << file;
    ASSERT_GT(f, 0) << file;
    points += d + f;
    models++;
  }
  std::printf(
      "gradient pass vs gradient JIT: %d models, %lld points bit for bit (%d tapes with "
      "libm ops left to the JIT)\n",
      models, static_cast<long long>(points), skipped);
  EXPECT_GE(models, 10);
}

TEST(TapeTest, GradientPassChecksAndNaN) {
  // A check that fires (sqrt of a negative value) makes all four components NaN at that point
  // only, in the VM as in the JIT; min/max ties and |x| at 0 follow the JIT's choices.
  auto compiled = Model::compile(
      "m(x[3], a[1]) { r = sqrt(x[1]) + abs(x[2]) * min(x[1], x[3]) / (1 + x[3]*x[3]);"
      " m = max(r, x[2] - 4) - floor(x[1]); }");
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  std::shared_ptr<const Tape> tape = compiled.model->tape();
  ASSERT_NE(tape, nullptr);
  ASSERT_TRUE(TapeVm::is_exact(*tape));
  const float xs[9] = {-1, 0, 2, 0, 0, -3, 1, 0, 2};  // (-1,0,1), (0,0,0), (2,-3,2)
  float vm_out[12], jit[12];
  compiled.model->eval_gradient_batch(3, xs, jit);
  const float* in[3] = {xs, xs + 3, xs + 6};
  TapeVm vm;
  vm.eval_gradient<float>(*tape, 3, in, vm_out);
  for (int c = 0; c < 4; ++c) {
    EXPECT_TRUE(std::isnan(vm_out[c * 3])) << c;
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(same_bits(jit[c * 3 + i], vm_out[c * 3 + i])) << c;
  }
  // At (2, -3, 2): r = sqrt(2) + 3 * 2 / 5, d/dx1 = 1 / (2 sqrt(2)), d/dx2 = -(2 / 5).
  EXPECT_NEAR(vm_out[1 * 3 + 2], 0.5f / std::sqrt(2.0f), 1e-6);
  EXPECT_NEAR(vm_out[2 * 3 + 2], -0.4f, 1e-6);
  // libm ops have no gradient form: left to the JIT.
  auto with_sin = Model::compile("m(x[3], a[1]) { m = sin(x[1]) - x[2]; }");
  ASSERT_TRUE(with_sin.ok());
  EXPECT_FALSE(TapeVm::is_exact(*with_sin.model->tape()));
}

TEST(TapeTest, UnsupportedFunctionsSayWhy) {
  auto compiled = Model::compile(
      "m(x[3], a[1]) { r = 0; if (x[1] > 0) then r = 1; else r = -1; endif; m = r; }");
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  std::string why;
  EXPECT_EQ(compiled.model->tape(&why), nullptr);
  EXPECT_NE(why.find("control flow"), std::string::npos) << why;
}

TEST(TapeTest, PruningDropsDecidedMinMaxAndReusesRegisters) {
  // Two spheres far apart: over a box around the first, the union's max keeps one operand.
  auto compiled = Model::compile(
      "m(x[3], a[1]) { s1 = 1 - (x[1]-5)^2 - x[2]^2 - x[3]^2;"
      " s2 = 1 - (x[1]+5)^2 - x[2]^2 - x[3]^2; m = max(s1, s2); }");
  ASSERT_TRUE(compiled.ok()) << compiled.rendered;
  std::shared_ptr<const Tape> tape = compiled.model->tape();
  ASSERT_NE(tape, nullptr);
  // (`^2` lowers with a select of its own: count relative to the full tape.)
  ASSERT_GE(tape->num_choices(), 1u);
  TapeVm vm;
  const Interval box[3] = {{4, 6, false}, {-1, 1, false}, {-1, 1, false}};
  vm.eval_interval(*tape, box);
  Tape child;
  ASSERT_TRUE(vm.prune_last(*tape, &child));
  EXPECT_LT(child.num_choices(), tape->num_choices());
  EXPECT_LT(child.length(), tape->length());
  EXPECT_LT(child.num_regs(), child.length());
  const double x[3] = {5.5, 0.25, 0.5};
  const double* in[3] = {&x[0], &x[1], &x[2]};
  double full = 0, pruned = 0;
  vm.eval<double>(*tape, 1, in, &full);
  vm.eval<double>(child, 1, in, &pruned);
  EXPECT_EQ(full, pruned);
  EXPECT_EQ(full, 1 - 0.25 - 0.0625 - 0.25);
}

}  // namespace
}  // namespace hfrt::jit
