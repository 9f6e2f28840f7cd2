// Conformance of the whole pipeline (front end, lowering, library, evaluator) with the
// original HyperFun: every probe of corpus/probes evaluates to its reference values in
// corpus/probe_values within 1e-9 relative, and to NaN where the original stopped with a
// run-time error. Run once with the reference interpreter and once with the LLVM JIT.
// Also: every corpus model compiles and evaluates without crashing.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hfrt/model.h"
#include "tests/jit/probe_values.h"

namespace hfrt {
namespace {

std::string corpus() {
  return HFRT_CORPUS_DIR;
}

std::string base_name(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

/// The documented deviation (hyperfun.md): hfrt's sign(v) is -1/0/1 where the original
/// returns 1, so math_builtins is 2 smaller where x[1] < 0 and 1 smaller where x[1] = 0.
double expected_f(const probe::ProbeValues& values, const probe::ProbePoint& p) {
  if (values.model == "math_builtins.hf") {
    const double u = p.x[0];
    return p.f + ((u > 0) - (u < 0)) - 1.0;
  }
  return p.f;
}

struct ProbeCase {
  std::string file;
  Backend backend;
};

void PrintTo(const ProbeCase& c, std::ostream* os) {
  *os << base_name(c.file) << (c.backend == Backend::kJit ? " (jit)" : " (interpreter)");
}

std::string case_name(const ::testing::TestParamInfo<ProbeCase>& info) {
  std::string name = base_name(info.param.file);
  name = name.substr(0, name.find('.'));
  const std::string prefix = "oracle_probes__";
  if (name.rfind(prefix, 0) == 0) name = name.substr(prefix.size());
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return name + (info.param.backend == Backend::kJit ? "_jit" : "_interp");
}

std::vector<ProbeCase> all_cases() {
  std::vector<ProbeCase> cases;
  for (Backend backend : {Backend::kInterp, Backend::kJit}) {
    for (const std::string& f : probe::list_probe_value_files(corpus())) {
      cases.push_back({f, backend});
    }
  }
  return cases;
}

class ProbeTest : public ::testing::TestWithParam<ProbeCase> {};

TEST_P(ProbeTest, MatchesReferenceValues) {
  probe::ProbeValues values;
  std::string error;
  ASSERT_TRUE(probe::read_probe_values(GetParam().file, &values, &error)) << error;
  ModelOptions options;
  options.object = values.selected;
  options.backend = GetParam().backend;
  auto compiled = Model::compile_file(probe::probe_model_path(corpus(), values), options);
  ASSERT_TRUE(compiled.ok()) << compiled.rendered << compiled.error;
  const Model& model = *compiled.model;
  if (GetParam().backend == Backend::kJit) {
    std::string jit_error;
    ASSERT_TRUE(model.prepare(Precision::kF64, &jit_error)) << jit_error;
    ASSERT_TRUE(model.stats().jit_f64.compiled);
  }
  int pass = 0, fail = 0;
  std::ostringstream first_failures;
  for (const probe::ProbePoint& p : values.points) {
    std::vector<double> x(p.x, p.x + 3);
    x.resize(std::max(3, values.x_size), 0.0);
    PointValue got = model.eval(x);
    bool ok = true;
    std::ostringstream why;
    if (p.runtime_error) {
      ok = std::isnan(got.f);
      if (!ok) why << "want NaN (" << p.error_message << ") got " << got.f;
    } else {
      const double want = expected_f(values, p);
      ok = probe::values_agree(want, got.f);
      if (!ok) why << "f: want " << want << " got " << got.f << " (" << got.error << ")";
      for (size_t k = 0; k < p.s.size() && ok; ++k) {
        const double gs = k < got.s.size() ? got.s[k] : std::nan("");
        if (!probe::values_agree(p.s[k], gs)) {
          ok = false;
          why << "s" << k + 1 << ": want " << p.s[k] << " got " << gs;
        }
      }
    }
    if (ok) {
      ++pass;
    } else {
      if (fail < 5) {
        first_failures.precision(17);
        first_failures << "  at (" << p.x[0] << ", " << p.x[1] << ", " << p.x[2]
                       << "): " << why.str() << "\n";
      }
      ++fail;
    }
  }
  RecordProperty("pass", pass);
  RecordProperty("fail", fail);
  EXPECT_EQ(0, fail) << values.model << ": " << pass << " points agree, " << fail
                     << " differ; first:\n"
                     << first_failures.str();
  EXPECT_GT(pass, 0);
}

INSTANTIATE_TEST_SUITE_P(Corpus, ProbeTest, ::testing::ValuesIn(all_cases()), case_name);

// --- Models ------------------------------------------------------------------------------

std::vector<std::string> all_models() {
  std::vector<std::string> out;
  const std::filesystem::path root = corpus() + "/models";
  if (!std::filesystem::exists(root)) return out;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(root)) {
    if (entry.is_regular_file() && entry.path().extension() == ".hf") {
      out.push_back(entry.path().string());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

class ModelTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ModelTest, CompilesAndEvaluatesEveryObject) {
  ModelOptions options;
  options.backend = Backend::kInterp;
  auto compiled = Model::compile_file(GetParam(), options);
  ASSERT_TRUE(compiled.ok()) << compiled.rendered << compiled.error;
  Model& model = *compiled.model;
  for (const std::string& name : model.object_names()) {
    std::string error;
    ASSERT_TRUE(model.select_object(name, &error)) << name << ": " << error;
    int evaluated = 0;
    for (double t : {-2.5, -0.3, 0.0, 0.7, 3.1}) {
      std::vector<double> x(std::max(3, model.num_inputs()), t);
      x[0] = t * 0.9 + 0.1;
      PointValue v = model.eval(x);
      // Any double (NaN included, with a run-time error) is fine: no crash, no hang.
      if (!v.ok()) {
        EXPECT_TRUE(std::isnan(v.f)) << name;
      }
      ++evaluated;
    }
    EXPECT_EQ(5, evaluated);
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, ModelTest, ::testing::ValuesIn(all_models()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string n = std::to_string(info.index) + "_" + base_name(info.param);
                           n = n.substr(0, n.rfind('.'));
                           for (char& c : n) {
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           }
                           return n;
                         });

TEST(CorpusCount, EveryProbeFileOnBothBackendsAndEveryModel) {
  // ../shared/corpus: 63 probe-value files (each on the interpreter and the JIT) and 34 models
  // (2026-12), one test each above; fewer means the corpus moved or a listing lost files.
  EXPECT_GE(all_cases().size(), 2u * 63u) << "probe values under " << corpus();
  EXPECT_GE(all_models().size(), 34u) << "models under " << corpus();
}

}  // namespace
}  // namespace hfrt
