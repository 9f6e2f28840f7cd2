#pragma once
// A seeded generator of random, well-formed IR programs (built through IrBuilder, so they
// also pass the builder's folding and CSE), for differential tests of the evaluators against
// the reference interpreter. Programs use every op of ir_ops.h, nested ifs and bounded
// while loops, scalar slots, small and large arrays with dynamic indices, constant tables,
// run-time checks and s[] attributes.

#include <cstdint>
#include <vector>

#include "ir/builder.h"
#include "ir/ir.h"

namespace hfrt::jit::testing {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

struct RandomProgramOptions {
  int num_inputs = 3;
  int num_params = 2;
  int statements = 40;  ///< top-level statement budget (nested regions add more)
  int max_depth = 3;    ///< nesting of ifs and loops
  int max_loop_trips = 5;
  /// Restrict to ops that are well conditioned in single precision (no chaotic functions,
  /// no equality/tolerance tests) for the f32 comparison.
  bool tame = false;
};

/// The program of `seed`: the same seed always gives the same Function.
Function random_program(uint64_t seed, const RandomProgramOptions& options = {});

/// Evaluation points for random programs: mostly uniform in [-3, 3], plus integers, halves,
/// zeros and near-ties that exercise round/floor/compare edge cases.
std::vector<std::vector<double>> random_points(uint64_t seed, int count, int dims);

}  // namespace hfrt::jit::testing
