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

  /// F at n points in precision T (float or double): coordinate k of point i is
  /// inputs[k][i] (inputs beyond inputs.size() read as 0). A point where a kCheck fires is NaN.
  template <typename T>
  void eval(const Tape& tape, size_t n, std::span<const T* const> inputs, T* out);

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

}  // namespace hfrt::jit
