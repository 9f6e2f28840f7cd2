// The interval and gradient interpreters end to end on the corpus: every probe (at least
// one per library function and built-in) and every model under models/ is parsed, checked
// and lowered; then
//  - intervals: over seeded random boxes in [-3.5,3.5]^3 (the probes' grid) of several
//    widths, every sampled point's value from the reference interpreter lies in the box's
//    interval, or is NaN with maybe_nan set;
//  - gradients: the value equals the interpreter's, and the partial derivatives agree with
//    central differences (relative 1e-6) where F is smooth around the point.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "base/file.h"
#include "base/result.h"
#include "jit/gradient.h"
#include "jit/interpreter.h"
#include "jit/interval.h"
#include "jit/lower.h"
#include "lang/frontend.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

namespace fs = std::filesystem;

using testutil::lower_file;

std::string str(const Interval& iv) {
  std::ostringstream os;
  os.precision(17);
  os << "[" << iv.lo << ", " << iv.hi << (iv.maybe_nan ? "] nan" : "]");
  return os.str();
}

struct Totals {
  int files = 0;
  int compiled = 0;
  int64_t points = 0;
  int64_t derivatives = 0;
  int64_t boxes = 0;
  int64_t tight_boxes = 0;  ///< finite, no NaN, narrower than 1e-3 for boxes of width <= 1e-6
  int64_t small_boxes = 0;
  int failures = 0;
};

void check_intervals(const std::string& path, const Function& fn, Totals* t) {
  Interpreter interp(fn);
  IntervalInterpreter ii(fn);
  std::mt19937_64 rng(std::hash<std::string>{}(fs::path(path).filename().string()));
  std::uniform_real_distribution<double> u(0, 1);
  const double widths[] = {1e-6, 0.01, 0.3, 1.5, 7};
  std::vector<double> a(std::max(fn.num_params, 1), 0.0);
  for (int bi = 0; bi < 40; ++bi) {
    std::vector<Interval> box(fn.num_inputs, Interval{0, 0, false});
    for (int k = 0; k < std::min(fn.num_inputs, 3); ++k) {
      double w = widths[(bi + k) % 5] * u(rng);
      double c = -3.5 + 7 * u(rng);
      box[k] = {c - w / 2, c + w / 2, false};
    }
    Interval r = ii.eval(box, a);
    ++t->boxes;
    for (int si = 0; si < 16; ++si) {
      std::vector<double> p(fn.num_inputs, 0.0);
      for (int k = 0; k < std::min(fn.num_inputs, 3); ++k) {
        double s = si < 2 ? si : u(rng);
        p[k] = std::min(box[k].hi, box[k].lo + (box[k].hi - box[k].lo) * s);
      }
      double v = interp.eval(p, a).value;
      ++t->points;
      if (!r.contains(v) && t->failures++ < 10) {
        ADD_FAILURE() << path << ": F(" << p[0] << ", " << p[1] << ", " << p[2] << ") = " << v
                      << " not in " << str(r);
      }
    }
  }
}

/// Tightness: tiny boxes around random points must give narrow finite intervals where F is
/// finite and defined nearby (an evaluator returning [-inf, inf] everywhere is sound too).
void check_tightness(const Function& fn, Totals* t) {
  Interpreter interp(fn);
  IntervalInterpreter ii(fn);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-3.5, 3.5);
  std::vector<double> a(std::max(fn.num_params, 1), 0.0);
  for (int bi = 0; bi < 10; ++bi) {
    std::vector<double> p(fn.num_inputs, 0.0);
    std::vector<Interval> box(fn.num_inputs, Interval{0, 0, false});
    for (int k = 0; k < std::min(fn.num_inputs, 3); ++k) {
      p[k] = u(rng);
      box[k] = {p[k] - 1e-9, p[k] + 1e-9, false};
    }
    double v = interp.eval(p, a).value;
    if (!std::isfinite(v)) continue;
    ++t->small_boxes;
    Interval r = ii.eval(box, a);
    if (!r.maybe_nan && r.hi - r.lo < 1e-3 * std::max(1.0, std::fabs(v))) ++t->tight_boxes;
  }
}

void check_gradients(const std::string& path, const Function& fn, Totals* t) {
  Interpreter interp(fn);
  GradientInterpreter gi(fn);
  std::mt19937_64 rng(7 + std::hash<std::string>{}(fs::path(path).filename().string()));
  std::uniform_real_distribution<double> u(-3.5, 3.5);
  std::vector<double> a(std::max(fn.num_params, 1), 0.0);
  for (int pi = 0; pi < 30; ++pi) {
    std::vector<double> p(fn.num_inputs, 0.0);
    for (int k = 0; k < std::min(fn.num_inputs, 3); ++k) p[k] = u(rng);
    Dual g = gi.eval(p, a);
    double f0 = interp.eval(p, a).value;
    if (!((g.v != g.v && f0 != f0) || g.v == f0)) {
      if (t->failures++ < 10) ADD_FAILURE() << path << ": gradient value " << g.v << " vs " << f0;
      continue;
    }
    if (!std::isfinite(f0)) continue;
    for (int k = 0; k < std::min(fn.num_inputs, 3); ++k) {
      double h = 1e-5 * std::max(1.0, std::fabs(p[k]));
      std::vector<double> q = p;
      q[k] = p[k] + h;
      double fp = interp.eval(q, a).value;
      q[k] = p[k] - h;
      double fm = interp.eval(q, a).value;
      if (!std::isfinite(fp) || !std::isfinite(fm)) continue;
      double central = (fp - fm) / (2 * h);
      double scale = std::max(1.0, std::fabs(central));
      if (std::fabs((fp - f0) / h - (f0 - fm) / h) > 1e-3 * scale) continue;  // not smooth here
      ++t->derivatives;
      if (!(std::fabs(g.d[k] - central) <= 1e-6 * scale + 1e-9 * std::fabs(f0)) &&
          t->failures++ < 10) {
        ADD_FAILURE() << path << " at (" << p[0] << ", " << p[1] << ", " << p[2] << "): d/dx"
                      << k + 1 << " = " << g.d[k] << ", central difference " << central;
      }
    }
  }
}

/// Runs the interval or the gradient checks over every file of `dir`: at least `min_files`
/// files, every one lowered (a file that does not is a failure, not a skip), and for the
/// gradients at least `min_derivatives` partial derivatives compared with central differences.
void run_corpus(const std::string& dir, bool intervals, int min_files, int64_t min_derivatives) {
  Totals t;
  for (const std::string& path : testutil::hf_files(dir)) {
    ++t.files;
    std::optional<Function> fn = lower_file(path);
    EXPECT_TRUE(fn.has_value()) << path << " does not compile or lower";
    if (!fn) continue;
    ++t.compiled;
    if (intervals) {
      check_intervals(path, *fn, &t);
      check_tightness(*fn, &t);
    } else
      check_gradients(path, *fn, &t);
  }
  std::printf("%s: %d files, %d lowered, %lld points, %lld derivatives compared\n", dir.c_str(),
              t.files, t.compiled, static_cast<long long>(t.points),
              static_cast<long long>(t.derivatives));
  EXPECT_GE(t.files, min_files) << "the corpus at " << dir << " moved or shrank";
  EXPECT_EQ(t.compiled, t.files) << "every file lowers";
  if (intervals) {
    // 40 boxes of 16 points per file.
    EXPECT_EQ(t.points, int64_t(t.compiled) * 40 * 16);
    std::printf("  tiny boxes (2e-9) around finite points: %lld of %lld give a narrow interval\n",
                static_cast<long long>(t.tight_boxes), static_cast<long long>(t.small_boxes));
    EXPECT_GE(t.tight_boxes, t.small_boxes * 3 / 4) << "intervals are uselessly wide";
  } else {
    // 30 points x 3 axes per file, less the points where F is not finite or not smooth.
    EXPECT_GE(t.derivatives, min_derivatives) << "too few derivatives compared";
  }
}

// 63 probes and 34 models (2026-12). Derivatives compared today: 5663 on the probes, 2580 on
// the models; the minimums leave room for libm differences that move a point across a kink.
TEST(IntervalCorpusTest, ProbesContainEverySampledPoint) {
  run_corpus(HFRT_CORPUS_DIR "/probes", true, 63, 0);
}
TEST(IntervalCorpusTest, ModelsContainEverySampledPoint) {
  run_corpus(HFRT_CORPUS_DIR "/models", true, 34, 0);
}
TEST(GradientCorpusTest, ProbesMatchCentralDifferences) {
  run_corpus(HFRT_CORPUS_DIR "/probes", false, 63, 5000);
}
TEST(GradientCorpusTest, ModelsMatchCentralDifferences) {
  run_corpus(HFRT_CORPUS_DIR "/models", false, 34, 2300);
}

// The interval JIT on prospero (8k instructions: the outlined code shape) gives the
// interpreter's intervals and trace, and compiles (the regression this guards: minutes).
TEST(IntervalCorpusTest, ProsperoJitSameAsInterpreter) {
  std::optional<Function> fn = lower_file(HFRT_CORPUS_DIR "/bench/prospero.hf");
  ASSERT_TRUE(fn.has_value());
  ASSERT_GT(static_cast<int64_t>(fn->insts.size()), IntervalJit::Options{}.inline_limit);
  auto jit = IntervalJit::compile(*fn);
  ASSERT_TRUE(jit.ok()) << jit.error().message;
  IntervalInterpreter ii(*fn);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> a(std::max(fn->num_params, 1), 0.0);
  int failures = 0;
  for (int bi = 0; bi < 24; ++bi) {
    std::vector<Interval> box(fn->num_inputs, Interval{0, 0, false});
    const double w = bi % 3 == 0 ? 1.0 : bi % 3 == 1 ? 0.05 : 0.0;
    for (int k = 0; k < std::min(fn->num_inputs, 2); ++k) {
      const double c = u(rng);
      box[k] = {c - w / 2, c + w / 2, false};
    }
    std::vector<uint8_t> cj, ci;
    Interval got = jit.value()->eval_one(box, a, &cj);
    Interval ref = ii.eval(box, a, &ci);
    if (!(got == ref) && failures++ < 5) {
      ADD_FAILURE() << "box " << bi << ": JIT " << str(got) << ", interpreter " << str(ref);
    }
    if (cj != ci && failures++ < 5) ADD_FAILURE() << "box " << bi << ": traces differ";
  }
  EXPECT_EQ(failures, 0);
}

}  // namespace
}  // namespace hfrt::jit
