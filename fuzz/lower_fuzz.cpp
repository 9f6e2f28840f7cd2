// Fuzz target: lowering (jit/lower.h) and the IR verifier (ir/verify.h). Bytes that pass the
// front end are lowered object by object; every lowered Function must verify, print, survive
// constant hoisting (and verify again), and evaluate in the reference interpreter at a few
// points without a crash (run-time errors are values, not crashes).
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "base/check.h"
#include "ir/hoist_constants.h"
#include "ir/print.h"
#include "ir/verify.h"
#include "jit/interpreter.h"
#include "jit/lower.h"
#include "lang/diagnostics.h"
#include "lang/frontend.h"
#include "lang/source.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hfrt;
  auto file = std::make_shared<const lang::SourceFile>(
      "fuzz.hf", std::string(reinterpret_cast<const char*>(data), size));
  lang::DiagnosticSink diags(file);
  std::unique_ptr<lang::Program> program = lang::compile_source(file, diags);
  if (!program) return 0;  // the front end's target covers these
  const int objects = std::min<int>(static_cast<int>(program->objects.size()), 4);
  for (int i = 0; i < objects; ++i) {
    lang::DiagnosticSink sink(file);
    ir::Function fn = jit::lower_object(*program, i, &sink);
    if (sink.has_errors()) continue;  // e.g. a mesh file that does not load
    const std::string problem = ir::verify(fn);
    HFRT_CHECK_MSG(problem.empty(), problem);
    (void)ir::print(fn);
    // A small loop bound: the point is reaching every op, not running long loops.
    const jit::Interpreter interp(fn, 100'000);
    const std::vector<double> a(static_cast<size_t>(std::max(fn.num_params, 0)) + 1, 0.5);
    for (const double t : {0.0, 0.37, -1.25}) {
      const std::vector<double> x = {t, 2 * t + 0.1, -t, 0.0};
      (void)interp.eval(x, a);
    }
    ir::Function hoisted = fn;
    std::vector<double> values = ir::hoist_constants(&hoisted);
    const std::string hoisted_problem = ir::verify(hoisted);
    HFRT_CHECK_MSG(hoisted_problem.empty(), hoisted_problem);
    std::vector<double> ha = a;
    ha.resize(static_cast<size_t>(fn.num_params));
    ha.insert(ha.end(), values.begin(), values.end());
    const jit::Interpreter hinterp(hoisted, 100'000);
    const std::vector<double> x = {0.37, 0.84, -0.37};
    const jit::EvalResult plain = interp.eval(x, ha);
    const jit::EvalResult with_hoisted = hinterp.eval(x, ha);
    // Hoisting promises the same values bit for bit (NaN counts as equal to NaN).
    HFRT_CHECK((plain.value != plain.value && with_hoisted.value != with_hoisted.value) ||
               std::bit_cast<uint64_t>(plain.value) == std::bit_cast<uint64_t>(with_hoisted.value));
  }
  return 0;
}
