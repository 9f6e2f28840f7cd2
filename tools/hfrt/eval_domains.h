#pragma once
// `hfrt eval --interval` and `hfrt eval --gradient`: the interval and gradient evaluators
// from the command line. Kept apart from cmd_eval.cpp (the scalar evaluator) so the two can
// grow independently; cmd_eval.cpp calls these when the flags are given.

#include <string>
#include <vector>

namespace hfrt::tools {

/// Options shared by both domains.
struct DomainEvalOptions {
  std::string file;           ///< the .hf model
  std::string object;         ///< object name ("" = my_model or the first)
  std::vector<double> params; ///< a[1..] (missing ones are 0)
  bool jit = false;           ///< use the LLVM interval/gradient JIT instead of the interpreter
};

/// Reads boxes `x0 x1 y0 y1 z0 z1` (pairs lo hi per coordinate; missing pairs are the point
/// 0) from stdin, one per line, and prints `lo hi` with 17 significant digits per box, with
/// ` nan` appended when the box may contain points without a value. Exit codes as `hfrt
/// eval`: 0 done, 1 compile errors, 2 usage or input errors.
int run_eval_interval(const DomainEvalOptions& options);

/// Reads points `x y z` from stdin and prints `f dfdx dfdy dfdz` (17 significant digits;
/// `nan` for a point without a value).
int run_eval_gradient(const DomainEvalOptions& options);

}  // namespace hfrt::tools
