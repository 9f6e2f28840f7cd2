// Conformance of the LLVM JIT (f64) through the public API: on every corpus probe it must
// agree with the original HyperFun's reference values (1e-9 relative; NaN where the original
// reports a run-time error) and with the reference interpreter; on every corpus model it
// must agree with the interpreter on a grid.
//
// Every corpus file must lower: each is first compiled in a forked child, so that an abort
// (HFRT_CHECK) in the lowering fails that file's test with the reason instead of ending the
// whole run; a file that does not compile or aborts is a failure, never a skip. The number of
// files compared is asserted, so that a corpus that moved or shrank cannot pass by comparing
// nothing.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "hfrt/model.h"
#include "tests/jit/probe_values.h"

namespace hfrt {
namespace {

namespace fs = std::filesystem;

/// True when compiling `path` (front end + lowering + interpreter set-up) finishes in a
/// child process; false when it crashes or aborts there.
bool compiles_in_child(const std::string& path, const std::string& object) {
  std::fflush(nullptr);
  pid_t pid = fork();
  if (pid == 0) {
    // Child: no JIT (forking after LLVM started threads is fine as long as we only lower).
    ModelOptions mo;
    mo.object = object;
    mo.backend = Backend::kInterp;
    int fd = open("/dev/null", 1);
    if (fd >= 0) dup2(fd, 2);
    CompileResult r = Model::compile_file(path, mo);
    _exit(r.ok() ? 0 : 3);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

bool same(double a, double b, double rel) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (a == b) return true;
  return std::fabs(a - b) <= rel * std::max({1.0, std::fabs(a), std::fabs(b)});
}

// --- Probes with reference values --------------------------------------------------------

std::vector<std::string> probe_files() {
  return probe::list_probe_value_files(HFRT_CORPUS_DIR);
}

std::string test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string s = fs::path(info.param).stem().string();
  for (char& c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return s;
}

class ProbeConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(ProbeConformance, JitAgreesWithOriginalAndInterpreter) {
  probe::ProbeValues ref;
  std::string err;
  ASSERT_TRUE(probe::read_probe_values(GetParam(), &ref, &err)) << err;
  const std::string model_path = probe::probe_model_path(HFRT_CORPUS_DIR, ref);
  ASSERT_TRUE(compiles_in_child(model_path, ref.selected))
      << model_path << " does not compile, or aborts in the lowering (see `hfrt ir` on it)";
  ModelOptions mo;
  mo.object = ref.selected;
  CompileResult jit = Model::compile_file(model_path, mo);
  ASSERT_TRUE(jit.ok()) << jit.error << jit.rendered;
  mo.backend = Backend::kInterp;
  CompileResult interp = Model::compile_file(model_path, mo);
  ASSERT_TRUE(interp.ok()) << interp.rendered;

  const size_t n = ref.points.size();
  ASSERT_GT(n, 0u) << GetParam() << " has no probe points";
  const int nx = jit.model->num_inputs();
  const int ns = jit.model->num_attributes();
  std::vector<double> xs(static_cast<size_t>(nx) * n, 0.0), f(n), s(static_cast<size_t>(ns) * n);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < nx && k < 3; ++k) xs[k * n + i] = ref.points[i].x[k];
  }
  jit.model->eval_batch(static_cast<int64_t>(n), xs.data(), f.data(), s.data());

  int failures = 0;
  for (size_t i = 0; i < n && failures < 5; ++i) {
    const probe::ProbePoint& p = ref.points[i];
    std::vector<double> x(static_cast<size_t>(nx), 0.0);
    for (int k = 0; k < nx && k < 3; ++k) x[k] = p.x[k];
    PointValue iv = interp.model->eval(x);
    std::ostringstream where;
    where.precision(17);
    where << model_path << " at (" << p.x[0] << ", " << p.x[1] << ", " << p.x[2] << "): ";
    if (p.runtime_error) {
      EXPECT_TRUE(std::isnan(f[i]))
          << where.str() << "original: " << p.error_message << ", jit: " << f[i];
      failures += !std::isnan(f[i]);
      continue;
    }
    double want = p.f;
    // Documented deviation (spec: hfrt's sign() is -1/0/1, the original's is always 1).
    if (fs::path(model_path).filename() == "math_builtins.hf") {
      if (p.x[0] < 0)
        want -= 2;
      else if (p.x[0] == 0)
        want -= 1;
    }
    bool ok = probe::values_agree(want, f[i], 1e-9);
    EXPECT_TRUE(ok) << where.str() << "original " << want << ", jit " << f[i]
                    << (iv.ok() ? "" : ", interpreter error: " + iv.error);
    // JIT and interpreter: the same libm calls in the same order -> (nearly) bit-identical.
    bool agree = same(f[i], iv.f, 1e-12);
    EXPECT_TRUE(agree) << where.str() << "jit " << f[i] << ", interpreter " << iv.f;
    for (int k = 0; k < ns && k < static_cast<int>(p.s.size()); ++k) {
      bool sok = probe::values_agree(p.s[k], s[k * n + i], 1e-9);
      EXPECT_TRUE(sok) << where.str() << "s" << k + 1 << ": original " << p.s[k] << ", jit "
                       << s[k * n + i];
      ok = ok && sok;
    }
    failures += !(ok && agree);
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, ProbeConformance, ::testing::ValuesIn(probe_files()), test_name);

// --- Models: JIT vs interpreter on a grid ------------------------------------------------

std::vector<std::string> model_files() {
  std::vector<std::string> files;
  fs::path dir = fs::path(HFRT_CORPUS_DIR) / "models";
  if (!fs::exists(dir)) return files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file() && e.path().extension() == ".hf") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string model_test_name(const ::testing::TestParamInfo<std::string>& info) {
  fs::path p(info.param);
  std::string s = p.parent_path().filename().string() + "_" + p.stem().string();
  for (char& c : s) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return s + "_" + std::to_string(info.index);
}

class ModelConformance : public ::testing::TestWithParam<std::string> {};

TEST_P(ModelConformance, JitAgreesWithInterpreter) {
  const std::string path = GetParam();
  ASSERT_TRUE(compiles_in_child(path, ""))
      << path << " does not compile, or aborts in the lowering (see `hfrt ir` on it)";
  ModelOptions mo;
  CompileResult jit = Model::compile_file(path, mo);
  ASSERT_TRUE(jit.ok()) << jit.error << jit.rendered;
  mo.backend = Backend::kInterp;
  CompileResult interp = Model::compile_file(path, mo);
  ASSERT_TRUE(interp.ok());
  // A 7^3 grid over [-6, 6]^3, off the symmetry planes.
  const int g = 7;
  const size_t n = g * g * g;
  const int nx = jit.model->num_inputs();
  std::vector<double> xs(static_cast<size_t>(nx) * n, 0.0), f(n);
  std::vector<std::vector<double>> pts;
  for (int i = 0; i < g; ++i) {
    for (int j = 0; j < g; ++j) {
      for (int k = 0; k < g; ++k) {
        double c[3] = {-6 + 2.0 * i + 0.137, -6 + 2.0 * j + 0.291, -6 + 2.0 * k + 0.053};
        std::vector<double> x(static_cast<size_t>(nx), 0.0);
        for (int d = 0; d < nx && d < 3; ++d) x[d] = c[d];
        pts.push_back(x);
      }
    }
  }
  for (size_t i = 0; i < n; ++i) {
    for (int d = 0; d < nx; ++d) xs[d * n + i] = pts[i][d];
  }
  jit.model->eval_batch(static_cast<int64_t>(n), xs.data(), f.data(), nullptr);
  int failures = 0;
  for (size_t i = 0; i < n && failures < 5; ++i) {
    PointValue iv = interp.model->eval(pts[i]);
    bool agree = same(f[i], iv.f, 1e-12) && (iv.ok() || std::isnan(f[i]));
    EXPECT_TRUE(agree) << path << " point " << i << ": jit " << f[i] << ", interpreter " << iv.f
                       << " " << iv.error;
    failures += !agree;
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, ModelConformance, ::testing::ValuesIn(model_files()),
                         model_test_name);

// --- How many ---------------------------------------------------------------------------

TEST(CorpusConformance, ComparesEveryProbeFileAndModel) {
  // ../shared/corpus holds 63 probe-value files and 34 models (2026-12); each is one test
  // above. Fewer means the corpus moved or a listing lost files.
  EXPECT_GE(probe_files().size(), 63u) << "probe values under " << HFRT_CORPUS_DIR;
  EXPECT_GE(model_files().size(), 34u) << "models under " << HFRT_CORPUS_DIR;
}

}  // namespace
}  // namespace hfrt
