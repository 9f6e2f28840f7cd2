// Front-end times (parse + semantic checks, lang/frontend.h), moved here from the unit tests,
// which now check only what the front end says about these inputs: every corpus model, each
// of the five machine-generated historical_* stress files (1k-14k statements; the tests
// asked for < 0.5 s each), and the hostile inputs of tests/lang/parser_test.cpp (10^4 nested
// parentheses, ifs and calls; a 10 MB program with one error at the end; 10 MB of junk on one
// line), which the tests asked to finish in 10-20 s. Run:
//   build/bench/hfrt_bench_frontend [--benchmark_filter=historical]

#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "base/file.h"
#include "lang/frontend.h"

namespace hfrt::lang {
namespace {

namespace fs = std::filesystem;

/// parse_program + check_program; the number of errors.
size_t front_end(const std::string& name, const std::string& text) {
  auto file = std::make_shared<const SourceFile>(name, text);
  DiagnosticSink diags(file);
  std::unique_ptr<Program> program = parse_program(file, diags);
  check_program(*program, diags);
  return diags.error_count();
}

std::vector<fs::path> corpus_models(bool historical) {
  std::vector<fs::path> out;
  const fs::path root = fs::path(HFRT_CORPUS_DIR) / "models";
  if (!fs::exists(root)) return out;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.path().extension() != ".hf") continue;
    if ((e.path().string().find("historical_") != std::string::npos) == historical)
      out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string read_or_empty(const fs::path& p) {
  Result<std::string> text = read_file(p.string());
  return text.ok() ? std::move(text).value() : std::string();
}

void BM_CorpusModels(benchmark::State& state) {
  std::vector<std::pair<std::string, std::string>> files;
  for (const fs::path& p : corpus_models(false)) files.emplace_back(p.string(), read_or_empty(p));
  if (files.empty()) {
    state.SkipWithError("no corpus models under HFRT_CORPUS_DIR");
    return;
  }
  for (auto _ : state) {
    for (const auto& [name, text] : files) benchmark::DoNotOptimize(front_end(name, text));
  }
  state.counters["files"] = double(files.size());
}
BENCHMARK(BM_CorpusModels)->Unit(benchmark::kMillisecond);

void BM_HistoricalStressFile(benchmark::State& state) {
  const std::vector<fs::path> files = corpus_models(true);
  if (size_t(state.range(0)) >= files.size()) {
    state.SkipWithError("no such historical_* file in the corpus");
    return;
  }
  const fs::path& p = files[size_t(state.range(0))];
  const std::string text = read_or_empty(p);
  state.SetLabel(p.filename().string());
  for (auto _ : state) benchmark::DoNotOptimize(front_end(p.string(), text));
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(text.size()));
}
BENCHMARK(BM_HistoricalStressFile)->DenseRange(0, 4)->Unit(benchmark::kMillisecond);

std::string model(const std::string& body) {
  return "my_model(x[3], a[1])\n{\n" + body + "\n}\n";
}

/// The hostile inputs: 0 nested parentheses, 1 nested ifs, 2 nested calls, 3 a 10 MB program
/// with an error on its last line, 4 a 10 MB line of junk.
std::string hostile(int which) {
  const int n = 10000;
  switch (which) {
    case 0:
      return model("my_model = " + std::string(n, '(') + "1" + std::string(n, ')') + ";");
    case 1: {
      std::string ifs;
      for (int i = 0; i < n; ++i) ifs += "if 1 then ";
      for (int i = 0; i < n; ++i) ifs += "endif; ";
      return model(ifs + "my_model = 1;");
    }
    case 2: {
      std::string calls;
      for (int i = 0; i < n; ++i) calls += "sqrt(";
      return model("my_model = " + calls + "1" + std::string(n, ')') + ";");
    }
    case 3: {
      std::string text = "my_model(x[3], a[1])\n{\n  t0 = x[1];\n";
      for (int i = 1; text.size() < 10u * 1000 * 1000; ++i) {
        text += "  t" + std::to_string(i) + " = (t" + std::to_string(i - 1) +
                " * 0.999000001 + x[2]) / 1.000001;  -- generated statement number " +
                std::to_string(i) + "\n";
      }
      return text + "  my_model = t0 +;\n}\n";
    }
    default: {
      std::string junk(10u * 1000 * 1000, '$');
      for (size_t k = 0; k < junk.size(); k += 97) junk[k] = ' ';
      return junk;
    }
  }
}

void BM_HostileInput(benchmark::State& state) {
  static const char* const kNames[] = {"10^4 parentheses", "10^4 nested ifs", "10^4 nested calls",
                                       "10 MB program", "10 MB junk line"};
  const std::string text = hostile(int(state.range(0)));
  state.SetLabel(kNames[state.range(0)]);
  for (auto _ : state) benchmark::DoNotOptimize(front_end("hostile.hf", text));
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(text.size()));
}
BENCHMARK(BM_HostileInput)->DenseRange(0, 4)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace hfrt::lang

BENCHMARK_MAIN();
