#pragma once
// A small harness for testing library functions without the front end: builds a Function
// whose array arguments are slots (the point array copied from x like the lowering does),
// emits one or more library calls and evaluates the result with the reference interpreter.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ir/builder.h"
#include "ir/ir.h"
#include "jit/interpreter.h"
#include "lang/diagnostics.h"
#include "stdlib/library.h"

namespace hfrt::stdlib::testing {

class LibHarness {
 public:
  explicit LibHarness(std::string source_text = std::string(200, ' '))
      : file_(std::make_shared<lang::SourceFile>("test.hf", std::move(source_text))),
        diags_(file_),
        b_(fn_) {
    fn_.num_inputs = 3;
    fn_.num_params = 1;
  }

  ir::IrBuilder& builder() { return b_; }
  lang::DiagnosticSink& diags() { return diags_; }
  LibState& state() { return state_; }

  /// An array argument whose elements start as `init` (constants of the slots).
  LibArg array(const std::vector<double>& init, lang::SourceRange range = {}) {
    LibArg a;
    a.is_array = true;
    a.size = static_cast<int>(init.size());
    a.range = range;
    a.base_slot = fn_.num_slots;
    for (double v : init) b_.new_slot(v);
    return a;
  }

  /// The point array: `n` slots holding x[1..n] of the evaluated point (as the lowering's
  /// x copy), so that transformations can move it.
  LibArg point(int n = 3, lang::SourceRange range = {}) {
    fn_.num_inputs = n;
    LibArg a;
    a.is_array = true;
    a.size = n;
    a.range = range;
    a.base_slot = fn_.num_slots;
    for (int i = 0; i < n; ++i) b_.new_slot(0);
    for (int i = 0; i < n; ++i) b_.store(a.base_slot + i, b_.input(i));
    return a;
  }

  LibArg real(double v) {
    LibArg a;
    a.value = b_.constant(v);
    return a;
  }
  /// A real argument computed from x[index0 + 1] (not a compile-time constant).
  LibArg real_from_input(int index0) {
    LibArg a;
    a.value = b_.input(index0);
    return a;
  }
  LibArg real_value(ir::ValueId v) {
    LibArg a;
    a.value = v;
    return a;
  }

  ir::ValueId call(lang::LibraryFn fn, const std::vector<LibArg>& args,
                   lang::SourceRange call_range = {}) {
    LibContext ctx{b_, &diags_, call_range, state_};
    return lower_library_call(fn, ctx, args);
  }

  /// Finishes the function with `result`; the slots of `watched` arrays are reported as s.
  void finish(ir::ValueId result, const std::vector<LibArg>& watched = {}) {
    for (const LibArg& a : watched) {
      for (int i = 0; i < a.size; ++i) fn_.s_slots.push_back(a.base_slot + i);
    }
    b_.finish(result);
    interp_ = std::make_unique<jit::Interpreter>(fn_);
  }

  jit::EvalResult eval(std::vector<double> x, std::vector<double> a = {0}) const {
    return interp_->eval(x, a);
  }
  const ir::Function& function() const { return fn_; }

 private:
  std::shared_ptr<const lang::SourceFile> file_;
  lang::DiagnosticSink diags_;
  ir::Function fn_;
  ir::IrBuilder b_;
  LibState state_;
  std::unique_ptr<jit::Interpreter> interp_;
};

/// Shorthand: evaluates a single call at the point x.
inline jit::EvalResult eval_call(lang::LibraryFn fn,
                                 const std::function<std::vector<LibArg>(LibHarness&)>& make_args,
                                 std::vector<double> x) {
  LibHarness h;
  auto args = make_args(h);
  h.finish(h.call(fn, args));
  return h.eval(std::move(x));
}

}  // namespace hfrt::stdlib::testing
