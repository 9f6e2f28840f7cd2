// The compile driver (driver.h).
#include "jit/driver.h"

#include "base/timer.h"
#include "jit/lower.h"
#include "lang/frontend.h"

namespace hfrt::jit {

bool lower_into(const lang::Program& program, int object, lang::DiagnosticSink& sink,
                LoweredSource* out, const Limits& limits) {
  const auto t0 = Clock::now();
  out->object = object;
  out->fn = lower_object(program, object, &sink, limits);
  out->lower_ms = ms_since(t0);
  // Errors found while lowering: a mesh or patch file that does not load (the surfaces are
  // built at compile time). No model then, like a front-end error.
  out->lowered = !sink.has_errors();
  return out->lowered;
}

LoweredSource compile_source(lang::DiagnosticSink& sink, std::string_view object,
                             const Limits& limits) {
  LoweredSource out;
  const auto t0 = Clock::now();
  out.program = lang::compile_source(sink.file(), sink, limits);
  out.frontend_ms = ms_since(t0);
  out.frontend_diagnostics = sink.diagnostics().size();
  if (!out.program) return out;
  const int index = out.program->select_object(object, &out.no_object, &out.no_object_hint);
  if (index < 0) return out;
  lower_into(*out.program, index, sink, &out, limits);
  return out;
}

}  // namespace hfrt::jit
