#pragma once
// The interval domain: a sound enclosure of F over an axis-aligned box.
//
// Contract (what "sound" means here): for every point p of the box (every coordinate
// x[k] in [lo_k, hi_k], both signs of zero included, infinite endpoints included) the value
// that the double-precision scalar evaluator computes for F(p) is either inside [lo, hi] or
// NaN, and when it may be NaN (a NaN produced by an op, or a kCheck that may fire) the
// maybe_nan bit is set. Every op is extended separately (apply_interval) with outward rounding
// (the result of every inexact op is widened by one ulp or more, never fast-math), so soundness
// of whole programs, the FRep library included, follows from op-level soundness.
//
// Control flow in the interpreter: a condition that is {1} or {0} over the box runs one side;
// an ambiguous one runs both sides from the same slot state and takes the hull of every slot.
// Loops run while the test may be true; the states of lanes that may leave are accumulated by
// hull; after `loop_limit` iterations the interpreter gives up and sets every slot the loop
// writes to [-inf, inf] with maybe_nan.
//
// The min/max trace: IntervalInterpreter::eval can fill, per instruction, which operand of
// kMin/kMax (and which branch of kSelect) decided the result over the box, so a renderer can
// prune the program for a sub-box (libfive/fidget style).

#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "base/interval.h"
#include "base/result.h"
#include "ir/interval_ops.h"
#include "ir/ir.h"
#include "ir/r_functions.h"
#include "jit/llvm_jit.h"  // JitStats (no LLVM types)

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// Default bound on interval loop iterations before giving up with [-inf, inf].
inline constexpr int kIntervalLoopLimit = 256;

/// Evaluates a Function over boxes in double-precision interval arithmetic.
/// Owns its scratch memory: one per thread. The Function must outlive it.
class IntervalInterpreter {
 public:
  explicit IntervalInterpreter(const Function& fn, int loop_limit = kIntervalLoopLimit);

  /// F over the box x[k+1] in x[k] (missing coordinates are the point 0), parameters a
  /// (missing ones are 0). When `choices` is non-null it is resized to fn.insts.size() and
  /// filled with the kChoice* bits of every kMin/kMax/kSelect reached.
  Interval eval(std::span<const Interval> x, std::span<const double> a,
                std::vector<uint8_t>* choices = nullptr);

  /// Convenience for 3-D boxes: [x0,x1] x [y0,y1] x [z0,z1].
  Interval eval_box(double x0, double x1, double y0, double y1, double z0, double z1,
                    std::span<const double> a = {});

  /// The slot state after the last eval (s attributes live in Function::s_slots).
  const std::vector<Interval>& slots() const { return slots_; }

 private:
  void run(size_t begin, size_t end);
  void run_loop(size_t at);

  const Function& fn_;
  int loop_limit_;
  std::vector<int32_t> match_;  ///< kIf -> kElse or kEndIf; kElse -> kEndIf; kLoop -> kLoopTest;
                                ///< kLoopTest -> kEndLoop
  RFunctionNodes r_nodes_;      ///< tightened by r_function_interval
  std::vector<Interval> values_;
  std::vector<Interval> slots_;
  std::span<const Interval> x_;
  std::span<const double> a_;
  std::vector<uint8_t>* choices_ = nullptr;
  bool error_possible_ = false;
};

/// The compiled interval evaluator (LLVM, f64, W boxes per SIMD block; see llvm_interval.cpp
/// for the design). Same contract and the same results as IntervalInterpreter on every op;
/// control flow follows the same rules lane by lane (an ambiguous `if` runs both sides and
/// takes the hull, loops accumulate the states of lanes that may leave and give up after
/// `loop_limit` iterations). Immutable after compile(); eval may be called from many threads.
class IntervalJit {
 public:
  ~IntervalJit();
  IntervalJit(const IntervalJit&) = delete;
  IntervalJit& operator=(const IntervalJit&) = delete;

  struct Options {
    int lanes = 0;  ///< boxes per SIMD block (a power of two); 0 = the host's f64 width
    int loop_limit = kIntervalLoopLimit;
    int opt_level = 1;  ///< LLVM pipeline O0..O3 (O1: large models compile much faster)
    bool trace = true;  ///< emit the min/max/select trace (else `choices` stays untouched)
    /// Functions with more IR instructions than this call one shared helper per op kind
    /// instead of inlining every op: compile time stays small and linear (seconds, not
    /// minutes, for 10k-instruction models) for a modest loss of throughput. Same results.
    int inline_limit = 1500;
  };

  /// Emits, optimises and links `fn` (verified IR).
  static Result<std::unique_ptr<IntervalJit>> compile(const Function& fn, const Options& options);
  static Result<std::unique_ptr<IntervalJit>> compile(const Function& fn) {
    return compile(fn, Options{});
  }

  /// n boxes, structure of arrays: coordinate k of box i is [x_lo[k*n + i], x_hi[k*n + i]]
  /// for k < Function::num_inputs; results to out_lo/out_hi/out_nan (0 or 1). `choices`,
  /// when non-null, has fn.insts.size() bytes and receives the kChoice* bits OR-ed over all
  /// n boxes (callers wanting one box's trace pass n = 1). Thread-safe.
  void eval(int64_t n, const double* x_lo, const double* x_hi, std::span<const double> a,
            double* out_lo, double* out_hi, uint8_t* out_nan, uint8_t* choices = nullptr) const;

  /// One box (convenience; slow path for tests and tools).
  Interval eval_one(std::span<const Interval> x, std::span<const double> a,
                    std::vector<uint8_t>* choices = nullptr) const;

  int lanes() const;
  /// Compile-latency figures (emit, optimise, code generation).
  const JitStats& stats() const;

 private:
  struct Impl;
  explicit IntervalJit(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace hfrt::jit
