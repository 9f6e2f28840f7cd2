#pragma once
// The compile driver: HyperFun text -> checked program -> one lowered object, the front half
// that every command (`hfrt ir`, `hfrt emit`, and through Model::compile `render`, `eval`,
// `slice`, the REPL) shares, so that they all read, check, choose the object and lower the
// same way and report the same diagnostics.

#include <memory>
#include <string>
#include <string_view>

#include "base/limits.h"
#include "ir/ir.h"
#include "lang/ast.h"
#include "lang/diagnostics.h"

namespace hfrt {
struct ModelLimits;  // hfrt/model.h
/// The embedding API's limits as the layers below take them (defined in jit/model.cpp).
Limits to_limits(const ModelLimits& limits);
}  // namespace hfrt

namespace hfrt::jit {

/// What compile_source produced. A model exists when ok(); otherwise the reasons are in the
/// DiagnosticSink passed in (source errors, lowering errors such as a mesh file that does
/// not load) or in `no_object` (the asked object does not exist).
struct LoweredSource {
  std::unique_ptr<lang::Program> program;  ///< null when the front end found errors
  int object = -1;                         ///< index of the lowered object in program->objects
  ir::Function fn;                         ///< the lowered object (valid when ok())
  /// When the program has no such object: the message and a hint listing the objects.
  std::string no_object, no_object_hint;
  /// How many of the sink's diagnostics the front end reported (the rest are the lowering's).
  size_t frontend_diagnostics = 0;
  double frontend_ms = 0;  ///< parse and semantic checks
  double lower_ms = 0;     ///< AST -> IR
  bool lowered = false;    ///< fn holds the object (no errors while lowering)
  bool ok() const { return lowered; }
};

/// Parses and checks `sink.file()`, chooses `object` (empty: `my_model`, else the first) and
/// lowers it. Every diagnostic (errors and warnings of the front end and of the lowering) goes
/// to `sink`; the result says how far it got.
/// `limits` bound array sizes (front end) and the lowered model (lower_object).
LoweredSource compile_source(lang::DiagnosticSink& sink, std::string_view object,
                             const Limits& limits = {});

/// Lowers another object of an already checked program (Model::select_object), timing it.
/// Lowering diagnostics go to `sink`; false when they include errors.
bool lower_into(const lang::Program& program, int object, lang::DiagnosticSink& sink,
                LoweredSource* out, const Limits& limits = {});

}  // namespace hfrt::jit
