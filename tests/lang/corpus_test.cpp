// Conformance against the shared corpus: every real model and probe is accepted, every
// grammar edge case of corpus/parse is accepted or rejected as the original did (first
// error on the same line), and the examples shipped with hfrt are valid.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "base/file.h"
#include "base/result.h"
#include "tests/lang/test_util.h"

namespace hfrt::lang {
namespace {

namespace fs = std::filesystem;
using testing::Compiled;

const fs::path kCorpus = HFRT_CORPUS_DIR;

std::vector<fs::path> hf_files(const fs::path& dir, bool recursive) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  if (recursive) {
    for (const auto& e : fs::recursive_directory_iterator(dir)) {
      if (e.is_regular_file() && e.path().extension() == ".hf") out.push_back(e.path());
    }
  } else {
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.is_regular_file() && e.path().extension() == ".hf") out.push_back(e.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

Compiled compile_file(const fs::path& path) {
  Result<std::string> text = read_file(path.string());
  EXPECT_TRUE(text.ok()) << path;
  return testing::compile(text.ok() ? std::move(text).value() : std::string(),
                          path.filename().string());
}

void expect_all_accepted(const std::vector<fs::path>& files) {
  for (const fs::path& f : files) {
    Compiled c = compile_file(f);
    EXPECT_TRUE(c.ok()) << f << "\n" << c.rendered();
    EXPECT_FALSE(c.program->objects.empty()) << f;
  }
}

TEST(Corpus, EveryModelIsAccepted) {
  std::vector<fs::path> files = hf_files(kCorpus / "models", true);
  ASSERT_GE(files.size(), 34u) << "corpus not found at " << kCorpus;
  expect_all_accepted(files);
}

// Their front-end times (a few ms each) are measured by bench/frontend_bench.cpp.
TEST(Corpus, HistoricalStressModelsAreAccepted) {
  std::vector<fs::path> files;
  for (const fs::path& f : hf_files(kCorpus / "models", true)) {
    if (f.parent_path().filename().string().rfind("historical_", 0) == 0) files.push_back(f);
  }
  ASSERT_EQ(files.size(), 5u);
  for (const fs::path& f : files) {
    Compiled c = compile_file(f);
    EXPECT_TRUE(c.ok()) << f << "\n" << c.rendered();
    ASSERT_EQ(c.program->objects.size(), 1u);
    // Machine-generated: thousands of temporaries, all resolved.
    EXPECT_GT(c.program->objects[0].scalars.size(), 100u) << f;
    EXPECT_EQ(c.program->objects[0].body.size() + 1,
              static_cast<size_t>(std::count(c.file->text().begin(), c.file->text().end(), ';')))
        << f;
  }
}

TEST(Corpus, EveryProbeIsAccepted) {
  std::vector<fs::path> files = hf_files(kCorpus / "probes", true);
  ASSERT_GE(files.size(), 63u);
  expect_all_accepted(files);
}

TEST(Corpus, ProsperoBenchmarkIsAccepted) {
  expect_all_accepted({kCorpus / "bench" / "prospero.hf"});
}

TEST(Corpus, ExamplesAreAccepted) {
  std::vector<fs::path> files = hf_files(fs::path(HFRT_SOURCE_DIR) / "examples", false);
  ASSERT_GE(files.size(), 4u);
  bool has_default = false;
  for (const fs::path& f : files) has_default |= f.filename() == "default.hf";
  EXPECT_TRUE(has_default);
  for (const fs::path& f : files) {
    Compiled c = compile_file(f);
    EXPECT_TRUE(c.ok()) << f << "\n" << c.rendered();
    EXPECT_TRUE(c.warnings().empty()) << f << "\n" << c.rendered();
  }
}

// ---- corpus/parse against EXPECTED.txt --------------------------------------------------

struct Expectation {
  bool ok = false;
  int line = 0;          // PARSE_ERROR line
  std::string original;  // the original's message, for the failure output
};

// EXPECTED.txt: "== file" then the original's verdict, "OK ..." or
// "PARSE_ERROR line N pos M: message".
std::map<std::string, Expectation> read_expected() {
  std::map<std::string, Expectation> out;
  std::ifstream in(kCorpus / "parse" / "EXPECTED.txt");
  std::string line, current;
  while (std::getline(in, line)) {
    if (line.rfind("== ", 0) == 0) {
      current = line.substr(3);
      continue;
    }
    if (current.empty() || out.count(current)) continue;
    Expectation e;
    if (line.rfind("OK", 0) == 0) {
      e.ok = true;
    } else if (line.rfind("PARSE_ERROR line ", 0) == 0) {
      std::istringstream ss(line.substr(17));
      ss >> e.line;
      e.original = line;
    } else {
      continue;
    }
    out[current] = e;
  }
  return out;
}

// hfrt deviations from the original (spec: "hfrt:" notes).
bool is_deviation(const std::string& name) {
  return name == "crlf_line_endings.hf" || name == "paren_arith_in_condition.hf";
}

TEST(CorpusParse, MatchesTheOriginal) {
  std::map<std::string, Expectation> expected = read_expected();
  ASSERT_GE(expected.size(), 42u);
  int accepted = 0, rejected = 0;
  for (const fs::path& f : hf_files(kCorpus / "parse", false)) {
    const std::string name = f.filename().string();
    ASSERT_TRUE(expected.count(name)) << name << " is not in EXPECTED.txt";
    const Expectation& e = expected[name];
    Compiled c = compile_file(f);
    if (e.ok || is_deviation(name)) {
      EXPECT_TRUE(c.ok()) << name << "\n" << c.rendered();
      ++accepted;
    } else {
      ASSERT_FALSE(c.ok()) << name << " should be rejected like: " << e.original;
      EXPECT_EQ(c.errors()[0]->range.begin.line, static_cast<uint32_t>(e.line))
          << name << ": original " << e.original << "\nhfrt:\n"
          << c.rendered();
      ++rejected;
    }
  }
  EXPECT_EQ(accepted + rejected, static_cast<int>(expected.size()));
  int want_accepted = 2;  // the two deviations
  for (const auto& [name, e] : expected) want_accepted += e.ok ? 1 : 0;
  EXPECT_EQ(accepted, want_accepted);
  EXPECT_GT(rejected, 15);
}

TEST(CorpusParse, DeviationsAreRejectedByTheOriginal) {
  // The test above accepts these two on purpose; make sure that is still a deviation.
  std::map<std::string, Expectation> expected = read_expected();
  EXPECT_FALSE(expected["crlf_line_endings.hf"].ok);
  EXPECT_FALSE(expected["paren_arith_in_condition.hf"].ok);
}

}  // namespace
}  // namespace hfrt::lang
