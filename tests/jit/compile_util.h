#pragma once
// Test helpers: HyperFun text -> checked program -> lowered Function.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "base/file.h"
#include "jit/interpreter.h"
#include "jit/lower.h"
#include "lang/frontend.h"

namespace hfrt::jit::testutil {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

struct Compiled {
  std::unique_ptr<lang::Program> program;
  Function fn;
  std::string diagnostics;  ///< rendered diagnostics (errors and warnings)
  bool ok = false;
};

/// Compiles `text` and lowers object `object` (default: the model by the spec's rule) within
/// `limits`. `ok` says that the front end passed and the object was lowered (the lowering's
/// own errors, such as a limit, are in `diagnostics`).
inline Compiled compile(const std::string& text, const std::string& object = "",
                        const std::string& name = "test.hf", const Limits& limits = {}) {
  Compiled c;
  auto file = std::make_shared<const lang::SourceFile>(name, text);
  lang::DiagnosticSink diags(file);
  c.program = lang::compile_source(file, diags, limits);
  if (c.program) {
    int index = object.empty() ? c.program->default_object() : c.program->find_object(object);
    if (index >= 0) {
      c.fn = lower_object(*c.program, index, &diags, limits);
      c.ok = true;
    }
  }
  c.diagnostics = diags.render(false);
  return c;
}

/// The .hf files under `dir` (recursively), sorted; none when it does not exist.
inline std::vector<std::string> hf_files(const std::string& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir, ec)) {
    if (e.path().extension() == ".hf") out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// The default object of a corpus file, lowered; nullopt when it cannot be read or compiled.
inline std::optional<Function> lower_file(const std::string& path) {
  Result<std::string> text = read_file(path);
  if (!text.ok()) return std::nullopt;
  auto file = std::make_shared<const lang::SourceFile>(path, std::move(text.value()));
  lang::DiagnosticSink diags(file);
  auto program = lang::compile_source(file, diags);
  if (!program || program->default_object() < 0) return std::nullopt;
  return lower_object(*program, program->default_object(), nullptr);
}

/// Evaluates the model of `text` at x with a = 0.
inline EvalResult eval_source(const std::string& text, std::vector<double> x = {1, 2, 3}) {
  Compiled c = compile(text);
  EXPECT_TRUE(c.ok) << c.diagnostics;
  if (!c.ok) return EvalResult{std::nan(""), {}, std::nullopt};
  std::vector<double> a(static_cast<size_t>(std::max(c.fn.num_params, 0)), 0.0);
  return Interpreter(c.fn).eval(x, a);
}

}  // namespace hfrt::jit::testutil
