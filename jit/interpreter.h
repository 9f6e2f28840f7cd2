#pragma once
// The reference interpreter: evaluates a Function in double precision, instruction by
// instruction, exactly as ir_ops.h defines each op (through ir/scalar_ops.h). It is the
// oracle every other evaluator (LLVM scalar, interval, gradient, ...) is tested against, and
// the one evaluator that can say which run-time error happened and where.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "ir/ir.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// A run-time error of the evaluated program (division by zero, ...) and the location of
/// the instruction that raised it.
struct RuntimeError {
  ErrorKind kind = ErrorKind::kDivisionByZero;
  lang::SourceLoc loc;
};

/// The outcome of evaluating one point.
struct EvalResult {
  double value = 0;                   ///< F; NaN when `error` is set
  std::vector<double> s;              ///< s[1..k] at the end of the evaluation (Function::s_slots)
  std::optional<RuntimeError> error;  ///< the FIRST run-time error of the evaluation
};

/// Evaluates one lowered object. Immutable after construction: concurrent eval calls from
/// several threads are safe (each call has its own scratch memory).
class Interpreter {
 public:
  /// Loops are bounded twice: lowering adds a LoopLimit check per loop, and the interpreter
  /// itself stops after this many loop iterations in one evaluation (a LoopLimit error),
  /// so even hand-built IR without the check cannot hang it.
  static constexpr uint64_t kMaxIterations = 100'000'000;

  /// Copies `fn` (which must verify) and precomputes its control-flow targets.
  /// `max_iterations` bounds the loop iterations of one evaluation (tests lower it).
  explicit Interpreter(const Function& fn, uint64_t max_iterations = kMaxIterations);

  /// Evaluates F at x with parameters a. Missing x/a entries read as 0, extra ones are ignored.
  EvalResult eval(std::span<const double> x, std::span<const double> a) const;

  const Function& function() const { return fn_; }

 private:
  Function fn_;
  uint64_t max_iterations_;
  std::vector<uint32_t> target_;  ///< per control marker: where execution continues (see .cpp)
};

/// "file:line:col: Division by zero" (or without the file part when unknown), the message a
/// tool prints to explain a NaN value.
std::string describe_runtime_error(const RuntimeError& error, const Function& fn);

}  // namespace hfrt::jit
