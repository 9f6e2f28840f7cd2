// Conformance of the lowering + reference interpreter with the ORIGINAL HyperFun:
//  - corpus/parse/EXPECTED.txt: every file the original accepted, at x=(1,2,3), a=[0];
//  - corpus/probe_values: every probe that calls no library function, on its 9x9x9 grid.
// The reference values are read from the corpus files, never copied here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "base/result.h"
#include "ir/print.h"
#include "tests/jit/compile_util.h"
#include "tests/jit/probe_values.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

const std::string kCorpus = HFRT_CORPUS_DIR;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// One "== file" entry of EXPECTED.txt whose first line is "OK ...".
struct ExpectedRun {
  std::string file;
  std::string header;  // the OK line
  std::string point;   // "1 2 3 value s1=..." or "1 2 3 RUNTIME_ERROR message (line L pos P)"
};

std::vector<ExpectedRun> read_expected() {
  std::vector<ExpectedRun> out;
  std::ifstream in(kCorpus + "/parse/EXPECTED.txt");
  std::string line, file;
  std::vector<std::string> lines;
  auto flush = [&] {
    if (!file.empty() && lines.size() >= 2 && lines[0].rfind("OK", 0) == 0) {
      out.push_back({file, lines[0], lines[1]});
    }
    lines.clear();
  };
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) == 0) continue;
    if (line.rfind("== ", 0) == 0) {
      flush();
      file = line.substr(3);
      continue;
    }
    if (!line.empty()) lines.push_back(line);
  }
  flush();
  return out;
}

ErrorKind kind_of_message(const std::string& message) {
  for (int k = 0; k < error_kind_count(); ++k) {
    auto kind = static_cast<ErrorKind>(k);
    if (message.rfind(std::string(error_message(kind)), 0) == 0) return kind;
  }
  ADD_FAILURE() << "unknown run-time error message: " << message;
  return ErrorKind::kLoopLimit;
}

class ExpectedTest : public ::testing::TestWithParam<ExpectedRun> {};

TEST_P(ExpectedTest, InterpreterMatchesTheOriginal) {
  const ExpectedRun& run = GetParam();
  testutil::Compiled c = testutil::compile(read_text(kCorpus + "/parse/" + run.file), "", run.file);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  std::istringstream words(run.point);
  double x[3];
  words >> x[0] >> x[1] >> x[2];
  std::string value;
  words >> value;
  std::vector<double> a(c.fn.num_params, 0.0);
  EvalResult r = Interpreter(c.fn).eval(x, a);
  if (value == "RUNTIME_ERROR") {
    std::string rest;
    std::getline(words, rest);
    rest.erase(0, rest.find_first_not_of(' '));
    const ErrorKind want = kind_of_message(rest);
    size_t at = rest.find("(line ");
    ASSERT_NE(at, std::string::npos) << rest;
    const unsigned want_line = static_cast<unsigned>(std::stoi(rest.substr(at + 6)));
    ASSERT_TRUE(r.error) << "expected " << rest << ", got " << r.value << "\n" << print(c.fn);
    EXPECT_EQ(error_kind_name(r.error->kind), error_kind_name(want)) << rest;
    EXPECT_EQ(r.error->loc.line, want_line) << rest;
    EXPECT_TRUE(std::isnan(r.value));
    return;
  }
  double want = std::stod(value);
  // Documented deviation (spec §3): sign() is -1/0/1 in hfrt; the original gives 111 here.
  if (run.file == "semantics_sign_bug.hf") want = 99;
  ASSERT_FALSE(r.error) << describe_runtime_error(*r.error, c.fn);
  EXPECT_TRUE(probe::values_agree(want, r.value)) << "want " << want << " got " << r.value << "\n"
                                                  << print(c.fn);
  // Attributes: s1=.. s2=..
  std::vector<double> s;
  for (std::string tok; words >> tok;) {
    size_t eq = tok.find('=');
    ASSERT_NE(eq, std::string::npos);
    s.push_back(std::stod(tok.substr(eq + 1)));
  }
  ASSERT_EQ(r.s.size(), s.size());
  for (size_t i = 0; i < s.size(); ++i) {
    EXPECT_TRUE(probe::values_agree(s[i], r.s[i]))
        << "s" << i + 1 << " want " << s[i] << " got " << r.s[i];
  }
}

std::string run_name(const ::testing::TestParamInfo<ExpectedRun>& info) {
  std::string n = info.param.file.substr(0, info.param.file.find('.'));
  for (char& ch : n) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return n;
}

INSTANTIATE_TEST_SUITE_P(ParseCorpus, ExpectedTest, ::testing::ValuesIn(read_expected()), run_name);

TEST(ExpectedFile, HasTheRuntimeEntries) {
  // Guards against a silently empty parameter list (e.g. a moved corpus).
  std::vector<ExpectedRun> runs = read_expected();
  EXPECT_GE(runs.size(), 15u);
  int errors = 0;
  for (const auto& r : runs) errors += r.point.find("RUNTIME_ERROR") != std::string::npos;
  EXPECT_GE(errors, 4);
}

// ---- probe values -----------------------------------------------------------------------

// Probes whose model calls no library function (only the language itself is tested here;
// the library probes belong to the stdlib tests).
bool calls_library(const std::string& text) {
  std::string lower;
  for (char ch : text) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  std::istringstream lines(lower);
  for (std::string line; std::getline(lines, line);) {
    line = line.substr(0, line.find("--"));
    for (size_t p = line.find("hf"); p != std::string::npos; p = line.find("hf", p + 1)) {
      size_t q = p + 2;
      while (q < line.size() &&
             (std::isalnum(static_cast<unsigned char>(line[q])) || line[q] == '_'))
        ++q;
      while (q < line.size() && line[q] == ' ') ++q;
      const bool starts_word =
          p == 0 || !(std::isalnum(static_cast<unsigned char>(line[p - 1])) || line[p - 1] == '_');
      if (starts_word && q < line.size() && line[q] == '(') return true;
    }
  }
  return false;
}

// HFRT_ALL_PROBES=1 in the environment runs every probe here (library ones included), a
// quick way to see the whole pipeline against the original while working on stdlib/.
std::vector<std::string> language_probes() {
  const bool all = std::getenv("HFRT_ALL_PROBES") != nullptr;
  std::vector<std::string> out;
  for (const std::string& path : probe::list_probe_value_files(kCorpus)) {
    probe::ProbeValues v;
    std::string err;
    if (!probe::read_probe_values(path, &v, &err)) continue;
    if (all || !calls_library(read_text(probe::probe_model_path(kCorpus, v)))) out.push_back(path);
  }
  return out;
}

class ProbeTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ProbeTest, InterpreterMatchesTheOriginalOnTheGrid) {
  probe::ProbeValues v;
  std::string err;
  ASSERT_TRUE(probe::read_probe_values(GetParam(), &v, &err)) << err;
  testutil::Compiled c =
      testutil::compile(read_text(probe::probe_model_path(kCorpus, v)), v.selected, v.model);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  Interpreter interp(c.fn);
  ASSERT_EQ(v.points.size(), 729u);
  std::vector<double> a(v.a_size, 0.0);
  int mismatches = 0;
  for (const probe::ProbePoint& p : v.points) {
    std::vector<double> x(std::max(v.x_size, 3), 0.0);
    x[0] = p.x[0];
    x[1] = p.x[1];
    x[2] = p.x[2];
    EvalResult r = interp.eval(x, a);
    double want = p.f;
    // Documented deviation (spec §3): the original's sign() is always 1.
    if (v.model == "math_builtins.hf") {
      if (p.x[0] < 0)
        want -= 2;
      else if (p.x[0] == 0)
        want -= 1;
    }
    if (p.runtime_error) {
      if (!r.error && ++mismatches <= 5) {
        ADD_FAILURE() << "at " << p.x[0] << " " << p.x[1] << " " << p.x[2] << ": want error "
                      << p.error_message << ", got " << r.value;
      }
      continue;
    }
    bool ok = !r.error && probe::values_agree(want, r.value);
    for (size_t i = 0; ok && i < p.s.size(); ++i)
      ok = i < r.s.size() && probe::values_agree(p.s[i], r.s[i]);
    if (!ok && ++mismatches <= 5) {
      ADD_FAILURE() << "at " << p.x[0] << " " << p.x[1] << " " << p.x[2] << ": want " << want
                    << " got " << r.value
                    << (r.error ? " (" + describe_runtime_error(*r.error, c.fn) + ")" : "");
    }
  }
  EXPECT_EQ(mismatches, 0);
}

std::string probe_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string n = info.param.substr(info.param.find_last_of('/') + 1);
  n = n.substr(0, n.find('.'));
  for (char& ch : n) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return n;
}

INSTANTIATE_TEST_SUITE_P(Corpus, ProbeTest, ::testing::ValuesIn(language_probes()), probe_name);

TEST(ProbeValuesFile, LanguageProbesAreFound) {
  std::vector<std::string> probes = language_probes();
  EXPECT_GE(probes.size(), 3u);  // math_builtins, op_setops, pow_semantics at least
  bool has_math = false;
  for (const auto& p : probes) has_math |= p.find("math_builtins") != std::string::npos;
  EXPECT_TRUE(has_math);
  // language_probes() passes over a file it cannot read: none may be unreadable.
  int files = 0;
  for (const std::string& path : probe::list_probe_value_files(kCorpus)) {
    probe::ProbeValues v;
    std::string err;
    EXPECT_TRUE(probe::read_probe_values(path, &v, &err)) << path << ": " << err;
    ++files;
  }
  EXPECT_GE(files, 63);  // the corpus's probe-value files (2026-12)
}

TEST(ProbeValuesFile, ReaderParsesHeaderPointsAndAttributes) {
  probe::ProbeValues v;
  std::string err;
  ASSERT_TRUE(probe::read_probe_values(kCorpus + "/probe_values/oracle_probes__quirk_sentinels.txt",
                                       &v, &err))
      << err;
  EXPECT_EQ(v.model, "quirk_sentinels.hf");
  EXPECT_EQ(v.selected, "my_model");
  EXPECT_EQ(v.x_size, 4);
  EXPECT_EQ(v.s_size, 3);
  ASSERT_EQ(v.points.size(), 729u);
  EXPECT_EQ(v.points[0].s.size(), 3u);
  EXPECT_FALSE(probe::read_probe_values(kCorpus + "/probe_values/no_such_file.txt", &v, &err));
}

}  // namespace
}  // namespace hfrt::jit
