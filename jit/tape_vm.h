#pragma once
// The tape VMs (Fidget's design): interpreters of a Tape's register code that win over
// compiled brute force by doing far less work, because the tape they run has been pruned for
// the box at hand (tape.h). Two domains, each with the one semantics of its domain:
//  - points, in float or double: kLanes points per pass, one tight loop per instruction over
//    a structure-of-arrays register file (the compiler vectorises the loops); each op is
//    ir/scalar_ops.h apply_op_t in that precision;
//  - intervals (f64, one box): ir/interval_ops.h apply_interval per instruction, recording
//    the min/max/select choice bits and whether each check may fire, for Tape::prune; and
//    the same enclosures for many boxes at once (kLanes per pass), which record nothing.
// A TapeVm holds the scratch memory (registers, choices): one per thread; it never allocates
// once its buffers have grown to the longest tape it ran.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "base/interval.h"
#include "jit/tape.h"

namespace hfrt::jit {

class TapeVm {
 public:
  /// Points evaluated per pass of the register code.
  static constexpr size_t kLanes = 64;
  /// Points per pass of eval() for calls of at most this many points.
  static constexpr size_t kNarrowLanes = 8;

  /// F at n points in precision T (float or double): coordinate k of point i is
  /// inputs[k][i] (inputs beyond inputs.size() read as 0). A point where a kCheck fires is NaN.
  /// kLanes points per pass, or kNarrowLanes for calls of that many points or fewer (the same
  /// values: each lane is computed alone).
  template <typename T>
  void eval(const Tape& tape, size_t n, std::span<const T* const> inputs, T* out);

  /// F and dF/dx[1..3] at n points in precision T (float or double) by forward-mode dual numbers,
  /// kLanes points per pass. Coordinate k of point i is inputs[k][i], one array per input of
  /// the tape (inputs.size() == tape.num_inputs()); out[c*n + i] gets F (c = 0) and dF/dx[c]
  /// (c = 1..3), NaN in all four where a kCheck fires. Requires is_exact(tape). The
  /// formulas are apply_dual's (ir/dual_ops.cpp) operation for operation in T, so the results
  /// are the gradient JIT's of the same precision bit for bit (and, in double, the gradient
  /// interpreter's): an engine may answer with either (GradientEngine's background compile).
  template <typename T>
  void eval_gradient(const Tape& tape, size_t n, std::span<const T* const> inputs, T* out);
  /// Whether every instruction of `tape` is exact IEEE arithmetic (+ - * /, neg, abs, min,
  /// max, sqrt, select) or piecewise constant (comparisons, floor, ...): then eval_gradient
  /// runs it, and eval() and eval_gradient() give the scalar and gradient JITs' bits of the
  /// same precision (no op whose rounding depends on how it is computed), which lets the
  /// engines answer with the VM while those JITs compile. The libm-based ops are left to the
  /// JITs and the interpreters, whose lane-by-lane calls and vector forms the VM does not
  /// reproduce bit for bit.
  static bool is_exact(const Tape& tape);

  /// An enclosure of F over the box inputs[k] (missing coordinates are the point 0), sound in
  /// the sense of jit/interval.h. Records choices() and check_can_fire() for prune_last().
  Interval eval_interval(const Tape& tape, std::span<const Interval> inputs);

  /// Enclosures of F over n boxes at once, each equal (bit for bit) to eval_interval() of the
  /// same box: box i is [lo[k][i], hi[k][i]] in coordinate k (missing coordinates are the
  /// point 0); out_nan[i] is 1 where F may have no value. kLanes boxes per pass of the register
  /// code, one loop over them per instruction, so the dispatch of an instruction is paid once
  /// per kLanes boxes (the renderer's searches batch their boxes by the hundred). Records no
  /// choices: nothing is pruned from a batch.
  void eval_intervals(const Tape& tape, size_t n, std::span<const double* const> lo,
                      std::span<const double* const> hi, double* out_lo, double* out_hi,
                      uint8_t* out_nan);

  /// The child of `tape` (the tape of the last eval_interval) for that call's box, as
  /// Tape::prune: false when nothing was decided (then `tape` itself serves the box).
  bool prune_last(const Tape& tape, Tape* child) const {
    return tape.prune(choices_, fire_, child);
  }

  /// Per instruction of the last eval_interval's tape: the kChoice bits of kMin/kMax/kSelect.
  std::span<const uint8_t> choices() const { return choices_; }
  /// Per instruction of the last eval_interval's tape: 1 where a kCheck may fire.
  std::span<const uint8_t> check_can_fire() const { return fire_; }

 private:
  std::vector<float> regs_f32_;
  std::vector<double> regs_f64_;
  std::vector<uint8_t> err_;
  // eval_gradient: per register kLanes values then kLanes of each derivative.
  std::vector<float> grad_f32_;
  std::vector<double> grad_f64_;
  std::vector<Interval> regs_iv_;
  // eval_intervals: per register kLanes lower bounds, upper bounds and NaN flags, the checks
  // that may fire per box, and scratch lanes (constants, R-function results).
  std::vector<double> batch_lo_, batch_hi_;
  std::vector<int64_t> batch_nan_, batch_fire_;
  std::vector<double> batch_scratch_d_;
  std::vector<int64_t> batch_scratch_i_;
  std::vector<uint8_t> choices_, fire_;
};

extern template void TapeVm::eval<float>(const Tape&, size_t, std::span<const float* const>,
                                         float*);
extern template void TapeVm::eval<double>(const Tape&, size_t, std::span<const double* const>,
                                          double*);
extern template void TapeVm::eval_gradient<float>(const Tape&, size_t,
                                                  std::span<const float* const>, float*);
extern template void TapeVm::eval_gradient<double>(const Tape&, size_t,
                                                   std::span<const double* const>, double*);

}  // namespace hfrt::jit
