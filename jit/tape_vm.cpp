// The tape VMs: points (float / double lanes) and intervals. See tape_vm.h.

#include "jit/tape_vm.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/check.h"
#include "ir/interval_ops.h"
#include "ir/scalar_ops.h"

namespace hfrt::jit {

using namespace ::hfrt::ir;

namespace {

constexpr size_t kLanes = TapeVm::kLanes;

/// One instruction over W lanes: a loop with a constant trip count around apply_op_t of
/// a constant op, which inlines to the op's formula (vector code for the inline ops, a libm
/// call per lane for the others).
// always_inline: the lane loops must be compiled inside each target clone of the pass (AVX2 or
// the baseline), not once for the baseline and called from both.
#define HFRT_TAPE_INLINE inline __attribute__((always_inline))

/// The ops a tape never holds (Tape::build refuses the functions that have them): every
/// VM pass aborts on them, under one list of case labels.
#define HFRT_TAPE_NO_FORM_CASES \
  case Op::kParam:              \
  case Op::kLoadSlot:           \
  case Op::kStoreSlot:          \
  case Op::kLoadIdx:            \
  case Op::kStoreIdx:           \
  case Op::kTableLoad:          \
  case Op::kSurface:            \
  case Op::kIf:                 \
  case Op::kElse:               \
  case Op::kEndIf:              \
  case Op::kLoop:               \
  case Op::kLoopTest:           \
  case Op::kEndLoop:

template <Op kOp, typename T, size_t W>
HFRT_TAPE_INLINE void lanes(const TapeInst& t, T* regs) {
  T* out = regs + size_t(t.out) * W;
  constexpr int kArgs = op_num_args(kOp);
  if constexpr (kArgs == 1) {
    const T* a = regs + size_t(t.a) * W;
    for (size_t i = 0; i < W; ++i) out[i] = apply_op_t<T>(kOp, a[i], T(0), T(0));
  } else if constexpr (kArgs == 2) {
    if (t.flags & TapeInst::kImmB) {
      const T* a = regs + size_t(t.a) * W;
      const T b = static_cast<T>(t.imm);
      for (size_t i = 0; i < W; ++i) out[i] = apply_op_t<T>(kOp, a[i], b, T(0));
    } else if (t.flags & TapeInst::kImmA) {
      const T a = static_cast<T>(t.imm);
      const T* b = regs + size_t(t.b) * W;
      for (size_t i = 0; i < W; ++i) out[i] = apply_op_t<T>(kOp, a, b[i], T(0));
    } else {
      const T* a = regs + size_t(t.a) * W;
      const T* b = regs + size_t(t.b) * W;
      for (size_t i = 0; i < W; ++i) out[i] = apply_op_t<T>(kOp, a[i], b[i], T(0));
    }
  } else {
    const T* a = regs + size_t(t.a) * W;
    const T* b = regs + size_t(t.b) * W;
    const T* c = regs + size_t(t.c) * W;
    for (size_t i = 0; i < W; ++i) out[i] = apply_op_t<T>(kOp, a[i], b[i], c[i]);
  }
}

/// One pass of the register code over W points (W lanes per register; the inputs' m <= W
/// points copied into their lanes).
template <typename T, size_t W>
HFRT_TAPE_INLINE void run_points(std::span<const TapeInst> code, T* regs, uint8_t* err,
                                 std::span<const T* const> inputs, size_t begin, size_t m) {
  for (const TapeInst& t : code) {
    switch (t.op) {
#define HFRT_TAPE_LANES(name, n, f, kind, ...) \
  HFRT_OP_IF_ARITH_##kind(case Op::k##name : lanes<Op::k##name, T, W>(t, regs); break;)
      HFRT_IR_OPS(HFRT_TAPE_LANES)
#undef HFRT_TAPE_LANES
      case Op::kConst:
        std::fill_n(regs + size_t(t.out) * W, W, static_cast<T>(t.imm));
        break;
      case Op::kInput: {
        T* out = regs + size_t(t.out) * W;
        if (t.a < inputs.size()) {
          std::copy_n(inputs[t.a] + begin, m, out);
          std::fill(out + m, out + W, T(0));
        } else {
          std::fill_n(out, W, T(0));
        }
        break;
      }
      case Op::kCheck: {
        const T* a = regs + size_t(t.a) * W;
        for (size_t i = 0; i < W; ++i) err[i] |= a[i] != 0;  // NaN != 0 fires too
        break;
      }
        HFRT_TAPE_NO_FORM_CASES
        HFRT_CHECK_MSG(false, "tape VM: op without a tape form " << op_name(t.op));
        break;
    }
  }
}

// The AVX-512 (x86-64-v4) and AVX2 clones of the lane loops: GCC's target_clones, an ifunc
// whose resolver the dynamic loader runs while it relocates the program. The AVX-512 clone
// halves the batched interval pass on a host that has it (hfrt_bench_interval c1_gear, Xeon:
// 2.06-2.48 -> 1.08-1.12 ns per instruction and box): 8 doubles per vector and mask
// registers for the selects. -ffp-contract=off (cmake/HfrtWarnings.cmake) keeps every clone
// free of fused multiply-adds, so all give the same bits. Not in sanitizer builds: GCC instruments
// the resolver, which then runs before the sanitizer's runtime is set up and crashes every program
// that links the JIT at start-up (found by `make test-tsan`; the baseline loops are used).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && \
    !defined(__SANITIZE_THREAD__) && !defined(__SANITIZE_ADDRESS__)
#define HFRT_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define HFRT_SIMD_CLONES
#endif

/// The float pass, compiled for AVX2 too (chosen at load time): the lane loops are the whole
/// cost, and the baseline x86-64 target has 4-wide vectors only.
HFRT_SIMD_CLONES
void run_points_f32(std::span<const TapeInst> code, float* regs, uint8_t* err,
                    std::span<const float* const> inputs, size_t begin, size_t m) {
  run_points<float, kLanes>(code, regs, err, inputs, begin, m);
}

HFRT_SIMD_CLONES
void run_points_f64(std::span<const TapeInst> code, double* regs, uint8_t* err,
                    std::span<const double* const> inputs, size_t begin, size_t m) {
  run_points<double, kLanes>(code, regs, err, inputs, begin, m);
}

/// The narrow passes: kNarrowLanes points, for calls of a few points (a ray's candidates in
/// the analytic search, a shading point), where a full pass would evaluate 64 lanes for one.
HFRT_SIMD_CLONES
void run_points_f32_narrow(std::span<const TapeInst> code, float* regs, uint8_t* err,
                           std::span<const float* const> inputs, size_t begin, size_t m) {
  run_points<float, TapeVm::kNarrowLanes>(code, regs, err, inputs, begin, m);
}

HFRT_SIMD_CLONES
void run_points_f64_narrow(std::span<const TapeInst> code, double* regs, uint8_t* err,
                           std::span<const double* const> inputs, size_t begin, size_t m) {
  run_points<double, TapeVm::kNarrowLanes>(code, regs, err, inputs, begin, m);
}

void run_pass(bool narrow, std::span<const TapeInst> code, float* regs, uint8_t* err,
              std::span<const float* const> inputs, size_t begin, size_t m) {
  if (narrow) {
    run_points_f32_narrow(code, regs, err, inputs, begin, m);
  } else {
    run_points_f32(code, regs, err, inputs, begin, m);
  }
}
void run_pass(bool narrow, std::span<const TapeInst> code, double* regs, uint8_t* err,
              std::span<const double* const> inputs, size_t begin, size_t m) {
  if (narrow) {
    run_points_f64_narrow(code, regs, err, inputs, begin, m);
  } else {
    run_points_f64(code, regs, err, inputs, begin, m);
  }
}

template <typename T>
std::vector<T>& regs_of(std::vector<float>& f, std::vector<double>& d) {
  if constexpr (std::is_same_v<T, float>) {
    return f;
  } else {
    return d;
  }
}

}  // namespace

template <typename T>
void TapeVm::eval(const Tape& tape, size_t n, std::span<const T* const> inputs, T* out) {
  std::vector<T>& regs = regs_of<T>(regs_f32_, regs_f64_);
  const bool narrow = n <= kNarrowLanes;
  const size_t width = narrow ? kNarrowLanes : kLanes;
  const size_t need = size_t(tape.num_regs()) * width;
  if (regs.size() < need) regs.resize(need);
  err_.resize(kLanes);
  const T* result = regs.data() + size_t(tape.result_reg()) * width;
  for (size_t begin = 0; begin < n; begin += width) {
    const size_t m = std::min(width, n - begin);
    std::fill(err_.begin(), err_.end(), 0);
    run_pass(narrow, tape.code(), regs.data(), err_.data(), inputs, begin, m);
    for (size_t i = 0; i < m; ++i) {
      out[begin + i] = err_[i] ? std::numeric_limits<T>::quiet_NaN() : result[i];
    }
  }
}

template void TapeVm::eval<float>(const Tape&, size_t, std::span<const float* const>, float*);
template void TapeVm::eval<double>(const Tape&, size_t, std::span<const double* const>, double*);

Interval TapeVm::eval_interval(const Tape& tape, std::span<const Interval> inputs) {
  const std::span<const TapeInst> code = tape.code();
  if (regs_iv_.size() < tape.num_regs()) regs_iv_.resize(tape.num_regs());
  choices_.assign(code.size(), kChoiceNone);
  fire_.assign(code.size(), 0);
  Interval* regs = regs_iv_.data();
  bool error_possible = false;
  for (size_t k = 0; k < code.size(); ++k) {
    const TapeInst& t = code[k];
    switch (t.op) {
      case Op::kConst:
        regs[t.out] = Interval::point(t.imm);
        break;
      case Op::kInput:
        regs[t.out] = t.a < inputs.size() ? inputs[t.a] : Interval::point(0);
        break;
      case Op::kCheck:
        if (nonzero(regs[t.a]).can_true) {
          fire_[k] = 1;
          error_possible = true;
        }
        break;
        HFRT_TAPE_NO_FORM_CASES
        HFRT_CHECK_MSG(false, "tape VM: op without a tape form " << op_name(t.op));
        break;
        HFRT_OP_CASES_ARITH {
          const int nargs = op_num_args(t.op);
          const Interval a = (t.flags & TapeInst::kImmA) ? Interval::point(t.imm) : regs[t.a];
          Interval b, c;
          if (nargs >= 2) b = (t.flags & TapeInst::kImmB) ? Interval::point(t.imm) : regs[t.b];
          if (nargs >= 3) c = regs[t.c];
          // The frequent ops in place (the same functions apply_interval calls for them).
          const bool same = (t.flags & TapeInst::kSame) != 0;
          uint8_t* choice = &choices_[k];
          Interval r;
          if (t.op == Op::kAdd) {
            r = interval_detail::add(a, b);
          } else if (t.op == Op::kSub) {
            r = interval_detail::add(a, interval_detail::neg(b));
          } else if (t.op == Op::kMul) {
            r = same ? interval_detail::square(a) : interval_detail::mul(a, b);
          } else if (t.op == Op::kMin || t.op == Op::kMax) {
            r = same ? a : interval_detail::min_max(a, b, t.op == Op::kMin, choice);
          } else if (t.op == Op::kNeg) {
            r = interval_detail::neg(a);
          } else {
            r = apply_interval(t.op, a, b, c, same, choice);
          }
          if (t.flags & (TapeInst::kRPlus | TapeInst::kRMinus)) {
            // Read before the write: the result may reuse f1's or f2's register.
            r = r_function_interval(r, regs[t.r1], regs[t.r2], (t.flags & TapeInst::kRPlus) != 0);
          }
          regs[t.out] = r;
          break;
        }
    }
  }
  Interval r = regs[tape.result_reg()];
  r.maybe_nan = r.maybe_nan || error_possible;
  return r;
}

namespace {

// eval_intervals: the interval ops of eval_interval over arrays of kLanes boxes, as lane
// loops that the compiler vectorises (jit/CMakeLists.txt: -fno-trapping-math). The ops of
// ir/interval_ops.h's interval_detail (add, sub, neg, square, min, max) are called as they
// are; mul (the vectoriser does not take interval_detail::mul as it is), abs, div, sqrt and
// the comparisons (out of line in ir/interval_ops.cpp) are written here operation for
// operation as selects, so both give the same bits (tested on the corpus:
// TapeTest.BatchedIntervalsEqualOneBoxAtATime). The other ops go through apply_interval lane
// by lane.

constexpr double kIvInf = std::numeric_limits<double>::infinity();

/// The registers of one pass: per register kLanes lower bounds, upper bounds and NaN flags
/// (0 or 1, as wide as the bounds so that the flag arithmetic vectorises with them).
struct IvRegs {
  double* lo;
  double* hi;
  int64_t* nan;
  double* lo_of(uint32_t r) const { return lo + size_t(r) * kLanes; }
  double* hi_of(uint32_t r) const { return hi + size_t(r) * kLanes; }
  int64_t* nan_of(uint32_t r) const { return nan + size_t(r) * kLanes; }
};

/// One operand's lanes: a register, or (kImmA / kImmB) the constant spread over `imm_*`.
struct IvArg {
  const double* lo;
  const double* hi;
  const int64_t* nan;
};

/// kLanes-long scratch lanes: a constant operand spread out, an R-function node's result.
struct IvScratch {
  double *imm_lo, *imm_hi, *tmp_lo, *tmp_hi;
  int64_t *imm_nan, *tmp_nan;
};

HFRT_TAPE_INLINE IvArg iv_arg(const IvRegs& regs, IvScratch& sc, const TapeInst& t, bool imm,
                              uint32_t reg) {
  if (!imm) return {regs.lo_of(reg), regs.hi_of(reg), regs.nan_of(reg)};
  const Interval c = Interval::point(t.imm);
  std::fill_n(sc.imm_lo, kLanes, c.lo);
  std::fill_n(sc.imm_hi, kLanes, c.hi);
  std::fill_n(sc.imm_nan, kLanes, int64_t(c.maybe_nan));
  return {sc.imm_lo, sc.imm_hi, sc.imm_nan};
}

/// A constant operand (kImmA / kImmB) of the ops whose lane loops take one as it is: the same
/// lanes as iv_arg's spread copy, without writing kLanes of each and reading them back (on
/// c1_gear about half the instructions have a constant operand).
struct IvConst {
  double lo, hi;
  int64_t nan;
};

HFRT_TAPE_INLINE IvConst iv_const(const TapeInst& t) {
  const Interval c = Interval::point(t.imm);
  return {c.lo, c.hi, int64_t(c.maybe_nan)};
}

/// Lane i of an operand, and the store of lane i of a result: the ops of ir/interval_ops.h's
/// interval_detail (inline, free of branches the vectoriser cannot turn into selects under
/// -fno-trapping-math) run on them directly.
HFRT_TAPE_INLINE double lo_at(const IvArg& a, size_t i) {
  return a.lo[i];
}
HFRT_TAPE_INLINE double hi_at(const IvArg& a, size_t i) {
  return a.hi[i];
}
HFRT_TAPE_INLINE int64_t nan_at(const IvArg& a, size_t i) {
  return a.nan[i];
}
HFRT_TAPE_INLINE double lo_at(const IvConst& a, size_t) {
  return a.lo;
}
HFRT_TAPE_INLINE double hi_at(const IvConst& a, size_t) {
  return a.hi;
}
HFRT_TAPE_INLINE int64_t nan_at(const IvConst& a, size_t) {
  return a.nan;
}
template <typename A>
HFRT_TAPE_INLINE Interval lane(const A& a, size_t i) {
  return {lo_at(a, i), hi_at(a, i), nan_at(a, i) != 0};
}

/// f(a, b) with the two operands of binary instruction t: registers, or one of them a
/// constant (IvConst); both constants (folded away before a tape is built) through the spread
/// copies.
template <typename F>
HFRT_TAPE_INLINE void with_operands(const TapeInst& t, const IvRegs& regs, IvScratch& sc, F&& f) {
  const bool ia = (t.flags & TapeInst::kImmA) != 0, ib = (t.flags & TapeInst::kImmB) != 0;
  if (ia == ib) {
    f(iv_arg(regs, sc, t, ia, t.a), iv_arg(regs, sc, t, ib, t.b));
  } else if (ib) {
    f(iv_arg(regs, sc, t, false, t.a), iv_const(t));
  } else {
    f(iv_const(t), iv_arg(regs, sc, t, false, t.b));
  }
}
HFRT_TAPE_INLINE void store(const Interval& r, size_t i, double* olo, double* ohi, int64_t* onan) {
  olo[i] = r.lo;
  ohi[i] = r.hi;
  onan[i] = r.maybe_nan;
}

// The lane loops. `o*` may be the same arrays as an operand's (a register freed at its last
// use is reused for the result): every lane is read before it is written and no lane reads
// another, which is what `ivdep` promises.

/// interval_detail::add (and sub = add(a, neg(b)) with `kNegateB`).
template <bool kNegateB, typename A, typename B>
HFRT_TAPE_INLINE void lanes_add(size_t m, A a, B b, double* olo, double* ohi, int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    const Interval y = lane(b, i);
    store(interval_detail::add(lane(a, i), kNegateB ? interval_detail::neg(y) : y), i, olo, ohi,
          onan);
  }
}

/// interval_detail::neg.
HFRT_TAPE_INLINE void lanes_neg(size_t m, IvArg a, double* olo, double* ohi, int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    store(interval_detail::neg(lane(a, i)), i, olo, ohi, onan);
  }
}

/// interval_detail::square.
HFRT_TAPE_INLINE void lanes_square(size_t m, IvArg a, double* olo, double* ohi, int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    store(interval_detail::square(lane(a, i)), i, olo, ohi, onan);
  }
}

/// interval_detail::mul, written out as selects: called as it is (its || and isinf), it is not
/// vectorised and prospero's batched pass loses a third of its speed.
template <typename A, typename B>
HFRT_TAPE_INLINE void lanes_mul(size_t m, A a, B b, double* olo, double* ohi, int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    const double alo = lo_at(a, i), ahi = hi_at(a, i), blo = lo_at(b, i), bhi = hi_at(b, i);
    const bool az = (alo <= 0) & (ahi >= 0), bz = (blo <= 0) & (bhi >= 0);
    const int64_t nan = nan_at(a, i) | nan_at(b, i) |
                        int64_t(az & ((std::fabs(blo) == kIvInf) | (std::fabs(bhi) == kIvInf))) |
                        int64_t(bz & ((std::fabs(alo) == kIvInf) | (std::fabs(ahi) == kIvInf)));
    double c0 = alo * blo, c1 = alo * bhi, c2 = ahi * blo, c3 = ahi * bhi;
    c0 = c0 != c0 ? 0.0 : c0;
    c1 = c1 != c1 ? 0.0 : c1;
    c2 = c2 != c2 ? 0.0 : c2;
    c3 = c3 != c3 ? 0.0 : c3;
    const double lo = interval_detail::down(std::min(std::min(c0, c1), std::min(c2, c3)));
    const double hi = interval_detail::up(std::max(std::max(c0, c1), std::max(c2, c3)));
    olo[i] = lo != lo ? -kIvInf : lo;
    ohi[i] = hi != hi ? kIvInf : hi;
    onan[i] = nan;
  }
}

/// interval_detail::min_max without the choice record, written out as selects: called as it
/// is (its early returns on the one-sided cases), the loop of two register operands was not
/// vectorised and took ~20 % of c1_gear's batched pass.
template <bool kMin, typename A, typename B>
HFRT_TAPE_INLINE void lanes_min_max(size_t m, A a, B b, double* olo, double* ohi, int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    const double alo = lo_at(a, i), ahi = hi_at(a, i), blo = lo_at(b, i), bhi = hi_at(b, i);
    const bool an = nan_at(a, i) != 0, bn = nan_at(b, i) != 0;
    bool left_only, right_only;
    double lo, hi;
    if constexpr (kMin) {
      left_only = !an & !bn & (ahi < blo);
      right_only = bhi <= alo;
      lo = std::min(alo, blo);
      hi = an ? bhi : std::min(ahi, bhi);
    } else {
      left_only = !an & !bn & (alo > bhi);
      right_only = blo >= ahi;
      lo = an ? blo : std::max(alo, blo);
      hi = std::max(ahi, bhi);
    }
    // One-sided: that operand; otherwise the hull, NaN as b's (interval_detail::min_max).
    olo[i] = left_only ? alo : right_only ? blo : lo;
    ohi[i] = left_only ? ahi : right_only ? bhi : hi;
    onan[i] = int64_t(left_only ? an : bn);
  }
}

/// apply_interval's kSqrt: monotone(a, sqrt, 0, inf, 1), then the lower bound kept >= 0.
HFRT_TAPE_INLINE void lanes_sqrt(size_t m, IvArg a, double* olo, double* ohi, int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    const double alo = a.lo[i], ahi = a.hi[i];
    const int64_t nan = a.nan[i] | int64_t(alo < 0) | int64_t(ahi > kIvInf);
    const double lo_c = alo < 0 ? 0.0 : (kIvInf < alo ? kIvInf : alo);
    const double hi_c = ahi < 0 ? 0.0 : (kIvInf < ahi ? kIvInf : ahi);
    double lo = interval_detail::down(std::sqrt(lo_c)), hi = interval_detail::up(std::sqrt(hi_c));
    lo = lo != lo ? -kIvInf : lo;
    hi = hi != hi ? kIvInf : hi;
    olo[i] = lo < 0.0 ? 0.0 : lo;
    ohi[i] = hi;
    onan[i] = nan;
  }
}

/// apply_interval's comparisons: from_tri(lt(a, b)) for kLt, lt(b, a) for kGt, le(a, b) for
/// kLe, le(b, a) for kGe.
template <bool kSwap, bool kOrEqual>
HFRT_TAPE_INLINE void lanes_compare(size_t m, IvArg a, IvArg b, double* olo, double* ohi,
                                    int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    const double xlo = kSwap ? b.lo[i] : a.lo[i], xhi = kSwap ? b.hi[i] : a.hi[i];
    const double ylo = kSwap ? a.lo[i] : b.lo[i], yhi = kSwap ? a.hi[i] : b.hi[i];
    const bool any_nan = (a.nan[i] | b.nan[i]) != 0;
    const bool can_true = kOrEqual ? xlo <= yhi : xlo < yhi;
    const bool can_false = (kOrEqual ? xhi > ylo : !(xhi < ylo)) | any_nan;
    olo[i] = can_false ? 0.0 : 1.0;
    ohi[i] = can_true ? 1.0 : 0.0;
    onan[i] = 0;
  }
}

/// ir/interval_ops.cpp abs_i.
HFRT_TAPE_INLINE void lanes_abs(size_t m, IvArg a, double* olo, double* ohi, int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    const double alo = a.lo[i], ahi = a.hi[i];
    const double straddle_hi = std::max(-alo, ahi);
    olo[i] = alo >= 0 ? alo : ahi <= 0 ? -ahi : 0.0;
    ohi[i] = alo >= 0 ? ahi : ahi <= 0 ? -alo : straddle_hi;
    onan[i] = a.nan[i];
  }
}

/// ir/interval_ops.cpp div.
HFRT_TAPE_INLINE void lanes_div(size_t m, IvArg a, IvArg b, double* olo, double* ohi,
                                int64_t* onan) {
#pragma GCC ivdep
  for (size_t i = 0; i < m; ++i) {
    const double alo = a.lo[i], ahi = a.hi[i], blo = b.lo[i], bhi = b.hi[i];
    const bool az = (alo <= 0) & (ahi >= 0), bz = (blo <= 0) & (bhi >= 0);
    const bool ainf = (std::fabs(alo) == kIvInf) | (std::fabs(ahi) == kIvInf);
    const bool binf = (std::fabs(blo) == kIvInf) | (std::fabs(bhi) == kIvInf);
    const int64_t nan0 = a.nan[i] | b.nan[i];
    double c0 = alo / blo, c1 = alo / bhi, c2 = ahi / blo, c3 = ahi / bhi;
    c0 = c0 != c0 ? 0.0 : c0;
    c1 = c1 != c1 ? 0.0 : c1;
    c2 = c2 != c2 ? 0.0 : c2;
    c3 = c3 != c3 ? 0.0 : c3;
    double lo = interval_detail::down(std::min(std::min(c0, c1), std::min(c2, c3)));
    double hi = interval_detail::up(std::max(std::max(c0, c1), std::max(c2, c3)));
    lo = lo != lo ? -kIvInf : lo;
    hi = hi != hi ? kIvInf : hi;
    olo[i] = bz ? -kIvInf : lo;
    ohi[i] = bz ? kIvInf : hi;
    onan[i] = bz ? nan0 | int64_t(az | binf) : nan0 | int64_t(ainf & binf);
  }
}

/// The vector code of the frequent ops (add, sub, mul, min, max, neg, abs, div, sqrt and the
/// comparisons) for one instruction of eval_intervals; false for every other op.
HFRT_TAPE_INLINE bool fast_interval_lanes(const TapeInst& t, const IvRegs& regs, IvScratch& sc,
                                          size_t m, double* olo, double* ohi, int64_t* onan) {
  if (t.op == Op::kAdd) {
    with_operands(t, regs, sc, [&](auto a, auto b) { lanes_add<false>(m, a, b, olo, ohi, onan); });
    return true;
  }
  if (t.op == Op::kSub) {
    with_operands(t, regs, sc, [&](auto a, auto b) { lanes_add<true>(m, a, b, olo, ohi, onan); });
    return true;
  }
  if (t.op == Op::kMul) {
    if (t.flags & TapeInst::kSame) {
      lanes_square(m, iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a), olo, ohi, onan);
    } else {
      with_operands(t, regs, sc, [&](auto a, auto b) { lanes_mul(m, a, b, olo, ohi, onan); });
    }
    return true;
  }
  if (t.op == Op::kMin || t.op == Op::kMax) {
    if (t.flags & TapeInst::kSame) {
      const IvArg a = iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a);
      std::copy_n(a.lo, m, olo);
      std::copy_n(a.hi, m, ohi);
      std::copy_n(a.nan, m, onan);
    } else if (t.op == Op::kMin) {
      with_operands(t, regs, sc,
                    [&](auto a, auto b) { lanes_min_max<true>(m, a, b, olo, ohi, onan); });
    } else {
      with_operands(t, regs, sc,
                    [&](auto a, auto b) { lanes_min_max<false>(m, a, b, olo, ohi, onan); });
    }
    return true;
  }
  if (t.op == Op::kNeg) {
    lanes_neg(m, iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a), olo, ohi, onan);
    return true;
  }
  if (t.op == Op::kAbs) {
    lanes_abs(m, iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a), olo, ohi, onan);
    return true;
  }
  if (t.op == Op::kDiv) {
    lanes_div(m, iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a),
              iv_arg(regs, sc, t, t.flags & TapeInst::kImmB, t.b), olo, ohi, onan);
    return true;
  }
  if (t.op == Op::kSqrt) {
    lanes_sqrt(m, iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a), olo, ohi, onan);
    return true;
  }
  if (t.op == Op::kLt || t.op == Op::kGt || t.op == Op::kLe || t.op == Op::kGe) {
    const IvArg a = iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a);
    const IvArg b = iv_arg(regs, sc, t, t.flags & TapeInst::kImmB, t.b);
    switch (t.op) {
      case Op::kLt:
        lanes_compare<false, false>(m, a, b, olo, ohi, onan);
        break;
      case Op::kGt:
        lanes_compare<true, false>(m, a, b, olo, ohi, onan);
        break;
      case Op::kLe:
        lanes_compare<false, true>(m, a, b, olo, ohi, onan);
        break;
      default:
        lanes_compare<true, true>(m, a, b, olo, ohi, onan);
        break;
    }
    return true;
  }
  return false;
}

/// One pass of the register code over m <= kLanes boxes (eval_intervals).
HFRT_TAPE_INLINE void run_intervals(std::span<const TapeInst> code, const IvRegs& regs,
                                    IvScratch& sc, int64_t* fire,
                                    std::span<const double* const> in_lo,
                                    std::span<const double* const> in_hi, size_t begin, size_t m) {
  for (const TapeInst& t : code) {
    const bool r_node = (t.flags & (TapeInst::kRPlus | TapeInst::kRMinus)) != 0;
    // An R-function node's result goes to scratch first: its tightening reads f1 and f2,
    // whose registers the result may reuse.
    double* olo = r_node ? sc.tmp_lo : regs.lo_of(t.out);
    double* ohi = r_node ? sc.tmp_hi : regs.hi_of(t.out);
    int64_t* onan = r_node ? sc.tmp_nan : regs.nan_of(t.out);
    switch (t.op) {
      case Op::kConst: {
        const Interval c = Interval::point(t.imm);
        std::fill_n(olo, m, c.lo);
        std::fill_n(ohi, m, c.hi);
        std::fill_n(onan, m, int64_t(c.maybe_nan));
        break;
      }
      case Op::kInput:
        if (t.a < in_lo.size()) {
          std::copy_n(in_lo[t.a] + begin, m, olo);
          std::copy_n(in_hi[t.a] + begin, m, ohi);
        } else {
          std::fill_n(olo, m, 0.0);
          std::fill_n(ohi, m, 0.0);
        }
        std::fill_n(onan, m, int64_t(0));
        break;
      case Op::kCheck: {
        const IvArg a = iv_arg(regs, sc, t, false, t.a);
        // nonzero(a).can_true, as eval_interval asks.
#pragma GCC ivdep
        for (size_t i = 0; i < m; ++i) {
          fire[i] |= a.nan[i] | int64_t(a.lo[i] != 0) | int64_t(a.hi[i] != 0);
        }
        continue;  // no result register
      }
        HFRT_TAPE_NO_FORM_CASES
        HFRT_CHECK_MSG(false, "tape VM: op without a tape form " << op_name(t.op));
        break;
        HFRT_OP_CASES_ARITH {
          // The frequent ops as vector code (an if-chain on the op: paid once per kLanes boxes),
          // every other one through apply_interval lane by lane.
          if (fast_interval_lanes(t, regs, sc, m, olo, ohi, onan)) break;
          const int nargs = op_num_args(t.op);
          const bool same = (t.flags & TapeInst::kSame) != 0;
          const IvArg a = iv_arg(regs, sc, t, t.flags & TapeInst::kImmA, t.a);
          const IvArg b = nargs >= 2 ? iv_arg(regs, sc, t, t.flags & TapeInst::kImmB, t.b) : a;
          const IvArg c = nargs >= 3 ? iv_arg(regs, sc, t, false, t.c) : a;
          for (size_t i = 0; i < m; ++i) {
            const Interval ia{a.lo[i], a.hi[i], a.nan[i] != 0};
            const Interval ib = nargs >= 2 ? Interval{b.lo[i], b.hi[i], b.nan[i] != 0} : Interval{};
            const Interval ic = nargs >= 3 ? Interval{c.lo[i], c.hi[i], c.nan[i] != 0} : Interval{};
            const Interval r = apply_interval(t.op, ia, ib, ic, same, nullptr);
            olo[i] = r.lo;
            ohi[i] = r.hi;
            onan[i] = r.maybe_nan;
          }
          break;
        }
    }
    if (r_node) {
      const double *lo1 = regs.lo_of(t.r1), *hi1 = regs.hi_of(t.r1);
      const double *lo2 = regs.lo_of(t.r2), *hi2 = regs.hi_of(t.r2);
      const int64_t *n1 = regs.nan_of(t.r1), *n2 = regs.nan_of(t.r2);
      double* rlo = regs.lo_of(t.out);
      double* rhi = regs.hi_of(t.out);
      int64_t* rnan = regs.nan_of(t.out);
      const bool plus = (t.flags & TapeInst::kRPlus) != 0;
      for (size_t i = 0; i < m; ++i) {
        const Interval r =
            r_function_interval({olo[i], ohi[i], onan[i] != 0}, {lo1[i], hi1[i], n1[i] != 0},
                                {lo2[i], hi2[i], n2[i] != 0}, plus);
        rlo[i] = r.lo;
        rhi[i] = r.hi;
        rnan[i] = r.maybe_nan;
      }
    }
  }
}

/// The interval pass, compiled for AVX2 too (chosen at load time), as the float point pass.
HFRT_SIMD_CLONES
void run_intervals_pass(std::span<const TapeInst> code, const IvRegs& regs, IvScratch& sc,
                        int64_t* fire, std::span<const double* const> in_lo,
                        std::span<const double* const> in_hi, size_t begin, size_t m) {
  run_intervals(code, regs, sc, fire, in_lo, in_hi, begin, m);
}

}  // namespace

void TapeVm::eval_intervals(const Tape& tape, size_t n, std::span<const double* const> in_lo,
                            std::span<const double* const> in_hi, double* out_lo, double* out_hi,
                            uint8_t* out_nan) {
  HFRT_CHECK(in_lo.size() == in_hi.size());
  const size_t need = size_t(tape.num_regs()) * kLanes;
  if (batch_lo_.size() < need) {
    batch_lo_.resize(need);
    batch_hi_.resize(need);
    batch_nan_.resize(need);
  }
  batch_scratch_d_.resize(4 * kLanes);
  batch_scratch_i_.resize(2 * kLanes);
  double* sd = batch_scratch_d_.data();
  int64_t* si = batch_scratch_i_.data();
  IvScratch sc{sd, sd + kLanes, sd + 2 * kLanes, sd + 3 * kLanes, si, si + kLanes};
  batch_fire_.resize(kLanes);
  const IvRegs regs{batch_lo_.data(), batch_hi_.data(), batch_nan_.data()};
  int64_t* fire = batch_fire_.data();
  const double* res_lo = regs.lo_of(tape.result_reg());
  const double* res_hi = regs.hi_of(tape.result_reg());
  const int64_t* res_nan = regs.nan_of(tape.result_reg());
  for (size_t begin = 0; begin < n; begin += kLanes) {
    const size_t m = std::min(kLanes, n - begin);
    std::fill_n(fire, kLanes, int64_t(0));
    run_intervals_pass(tape.code(), regs, sc, fire, in_lo, in_hi, begin, m);
    for (size_t i = 0; i < m; ++i) {
      out_lo[begin + i] = res_lo[i];
      out_hi[begin + i] = res_hi[i];
      out_nan[begin + i] = uint8_t((res_nan[i] | fire[i]) != 0);
    }
  }
}

// --- The gradient pass --------------------------------------------------------------------------

namespace {

/// The ops the gradient pass runs: those whose value and derivatives are exact IEEE arithmetic
/// (or piecewise constant), so that it gives the gradient JIT's and the gradient interpreter's
/// bits in the same precision. The others (libm calls, powers) are left to those engines:
/// a libm call lane by lane need not round as the JIT's code does.
constexpr bool gradient_op(Op op) {
  switch (op) {
    case Op::kConst:
    case Op::kInput:
    case Op::kCheck:
    case Op::kAdd:
    case Op::kSub:
    case Op::kMul:
    case Op::kDiv:
    case Op::kNeg:
    case Op::kAbs:
    case Op::kMin:
    case Op::kMax:
    case Op::kSqrt:
    case Op::kSelect:
      HFRT_OP_CASES_PIECEWISE_CONSTANT
      return true;
      // The ops computed by a libm or hfrt helper call per lane (ir_ops.h's lane column).
      HFRT_OP_CASES_LANE_CALL
      HFRT_TAPE_NO_FORM_CASES
      return false;
  }
  return false;
}

/// The gradient registers of one pass: per register kLanes values, then kLanes of each of the
/// three partial derivatives.
template <typename T>
struct DualLanes {
  T* v;
  T* d[3];
};

template <typename T>
HFRT_TAPE_INLINE DualLanes<T> dual_reg(T* regs, uint32_t r) {
  T* base = regs + size_t(r) * 4 * kLanes;
  return {base, {base + kLanes, base + 2 * kLanes, base + 3 * kLanes}};
}

/// The chain rule's term k * a' with the gradient JIT's and apply_dual's convention: a
/// component that is exactly 0 stays 0 (no 0 * inf NaN from a constant sub-expression).
template <typename T>
HFRT_TAPE_INLINE T chain_term(T ad, T k) {
  return ad == T(0) ? T(0) : k * ad;
}

// The lane loops of the dual ops, the formulas of ir/dual_ops.cpp (and of the gradient JIT,
// llvm_gradient.cpp) operation for operation. The result may be one of the operands'
// registers (freed at its last use): every lane reads all it needs before it writes, and no
// lane reads another, which is what `ivdep` promises.

/// v = op(a, b) with derivative ka a' + kb b' (the unary ops pass kb = 0 over b = a).
template <Op kOp, typename T>
HFRT_TAPE_INLINE void dual_lanes(DualLanes<T> o, DualLanes<T> a, DualLanes<T> b) {
#pragma GCC ivdep
  for (size_t i = 0; i < kLanes; ++i) {
    const T av = a.v[i], bv = b.v[i];
    const T v = apply_op_t<T>(kOp, av, bv, T(0));
    T ka, kb;
    if constexpr (kOp == Op::kAdd) {
      ka = T(1), kb = T(1);
    } else if constexpr (kOp == Op::kSub) {
      ka = T(1), kb = T(-1);
    } else if constexpr (kOp == Op::kMul) {
      ka = bv, kb = av;
    } else if constexpr (kOp == Op::kDiv) {
      ka = T(1) / bv, kb = -(v / bv);
    } else if constexpr (kOp == Op::kNeg) {
      ka = T(-1), kb = T(0);
    } else if constexpr (kOp == Op::kAbs) {
      ka = av < T(0) ? T(-1) : T(1), kb = T(0);
    } else {
      static_assert(kOp == Op::kSqrt);
      ka = T(0.5) / v, kb = T(0);
    }
    T d[3];
    for (int c = 0; c < 3; ++c) {
      d[c] = chain_term(a.d[c][i], ka);
      if constexpr (op_num_args(kOp) == 2) d[c] = d[c] + chain_term(b.d[c][i], kb);
    }
    o.v[i] = v;
    for (int c = 0; c < 3; ++c) o.d[c][i] = d[c];
  }
}

/// min / max / select: the chosen operand's dual (the value as apply_op_t computes it).
template <Op kOp, typename T>
HFRT_TAPE_INLINE void pick_lanes(DualLanes<T> o, DualLanes<T> a, DualLanes<T> b, DualLanes<T> c) {
#pragma GCC ivdep
  for (size_t i = 0; i < kLanes; ++i) {
    bool first;
    DualLanes<T> x = a, y = b;
    if constexpr (kOp == Op::kMin) {
      first = a.v[i] < b.v[i];
    } else if constexpr (kOp == Op::kMax) {
      first = a.v[i] > b.v[i];
    } else {
      static_assert(kOp == Op::kSelect);
      first = a.v[i] != T(0);  // NaN counts as nonzero, as the JIT's `nonzero`
      x = b, y = c;
    }
    const T v = first ? x.v[i] : y.v[i];
    T d[3];
    for (int k = 0; k < 3; ++k) d[k] = first ? x.d[k][i] : y.d[k][i];
    o.v[i] = v;
    for (int k = 0; k < 3; ++k) o.d[k][i] = d[k];
  }
}

/// The piecewise-constant ops: the value, derivative 0.
template <Op kOp, typename T>
HFRT_TAPE_INLINE void step_lanes(DualLanes<T> o, DualLanes<T> a, DualLanes<T> b) {
#pragma GCC ivdep
  for (size_t i = 0; i < kLanes; ++i) o.v[i] = apply_op_t<T>(kOp, a.v[i], b.v[i], T(0));
  for (int k = 0; k < 3; ++k) std::fill_n(o.d[k], kLanes, T(0));
}

/// One pass of the register code over kLanes points, in dual numbers. Register num_regs() is
/// the constant operand's: its derivatives stay 0, its value is spread per instruction.
template <typename T>
HFRT_TAPE_INLINE void run_gradient(std::span<const TapeInst> code, T* regs, uint32_t imm_reg,
                                   uint8_t* err, std::span<const T* const> inputs, size_t begin,
                                   size_t m) {
  const DualLanes<T> imm = dual_reg(regs, imm_reg);
  for (const TapeInst& t : code) {
    const DualLanes<T> o = dual_reg(regs, t.out);
    if (t.flags & (TapeInst::kImmA | TapeInst::kImmB)) std::fill_n(imm.v, kLanes, T(t.imm));
    const DualLanes<T> a = (t.flags & TapeInst::kImmA) ? imm : dual_reg(regs, t.a);
    const DualLanes<T> b = (t.flags & TapeInst::kImmB) ? imm : dual_reg(regs, t.b);
    switch (t.op) {
      case Op::kConst:
        std::fill_n(o.v, kLanes, static_cast<T>(t.imm));
        for (int k = 0; k < 3; ++k) std::fill_n(o.d[k], kLanes, T(0));
        break;
      case Op::kInput:
        if (t.a < inputs.size()) {
          std::copy_n(inputs[t.a] + begin, m, o.v);
          std::fill(o.v + m, o.v + kLanes, T(0));
        } else {
          std::fill_n(o.v, kLanes, T(0));
        }
        for (uint32_t k = 0; k < 3; ++k) {
          std::fill_n(o.d[k], kLanes, T(k == t.a && t.a < inputs.size() ? 1 : 0));
        }
        break;
      case Op::kCheck:
        for (size_t i = 0; i < kLanes; ++i) err[i] |= a.v[i] != T(0);  // NaN fires too
        break;
#define HFRT_GRADIENT_CASE(name)         \
  case Op::k##name:                      \
    dual_lanes<Op::k##name, T>(o, a, b); \
    break;
        HFRT_GRADIENT_CASE(Add)
        HFRT_GRADIENT_CASE(Sub)
        HFRT_GRADIENT_CASE(Mul)
        HFRT_GRADIENT_CASE(Div)
        HFRT_GRADIENT_CASE(Neg)
        HFRT_GRADIENT_CASE(Abs)
        HFRT_GRADIENT_CASE(Sqrt)
#undef HFRT_GRADIENT_CASE
      case Op::kMin:
        pick_lanes<Op::kMin, T>(o, a, b, b);
        break;
      case Op::kMax:
        pick_lanes<Op::kMax, T>(o, a, b, b);
        break;
      case Op::kSelect:
        pick_lanes<Op::kSelect, T>(o, a, b, dual_reg(regs, t.c));
        break;
#define HFRT_STEP_CASE(name, n, f, kind, ...)                                 \
  HFRT_OP_IF_PIECEWISE_CONSTANT_##kind(case Op::k##name                       \
                                       : step_lanes<Op::k##name, T>(o, a, b); \
                                       break;)
        HFRT_IR_OPS(HFRT_STEP_CASE)
#undef HFRT_STEP_CASE
        HFRT_OP_CASES_LANE_CALL
        HFRT_TAPE_NO_FORM_CASES
        HFRT_CHECK_MSG(false, "tape VM: no gradient form for " << op_name(t.op));
        break;
    }
  }
}

HFRT_SIMD_CLONES
void run_gradient_f32(std::span<const TapeInst> code, float* regs, uint32_t imm_reg, uint8_t* err,
                      std::span<const float* const> inputs, size_t begin, size_t m) {
  run_gradient<float>(code, regs, imm_reg, err, inputs, begin, m);
}

HFRT_SIMD_CLONES
void run_gradient_f64(std::span<const TapeInst> code, double* regs, uint32_t imm_reg, uint8_t* err,
                      std::span<const double* const> inputs, size_t begin, size_t m) {
  run_gradient<double>(code, regs, imm_reg, err, inputs, begin, m);
}

void run_gradient_pass(std::span<const TapeInst> code, float* regs, uint32_t imm_reg, uint8_t* err,
                       std::span<const float* const> inputs, size_t begin, size_t m) {
  run_gradient_f32(code, regs, imm_reg, err, inputs, begin, m);
}
void run_gradient_pass(std::span<const TapeInst> code, double* regs, uint32_t imm_reg, uint8_t* err,
                       std::span<const double* const> inputs, size_t begin, size_t m) {
  run_gradient_f64(code, regs, imm_reg, err, inputs, begin, m);
}

}  // namespace

bool TapeVm::is_exact(const Tape& tape) {
  for (const TapeInst& t : tape.code()) {
    if (!gradient_op(t.op)) return false;
  }
  return true;
}

template <typename T>
void TapeVm::eval_gradient(const Tape& tape, size_t n, std::span<const T* const> inputs, T* out) {
  HFRT_CHECK_MSG(is_exact(tape), "tape VM: eval_gradient on a tape without a gradient form");
  // (The JIT reads an input's value and gives it its unit derivative by the function's
  // inputs: the same only when the caller passes them all.)
  HFRT_CHECK(inputs.size() == size_t(std::max(tape.num_inputs(), 0)));
  std::vector<T>& regs = regs_of<T>(grad_f32_, grad_f64_);
  const uint32_t imm_reg = tape.num_regs();
  const size_t need = (size_t(imm_reg) + 1) * 4 * kLanes;
  if (regs.size() < need) regs.resize(need);
  // The constant operand's derivatives: 0, never written.
  std::fill(regs.begin() + ptrdiff_t(imm_reg) * 4 * kLanes + kLanes, regs.begin() + ptrdiff_t(need),
            T(0));
  err_.resize(kLanes);
  const DualLanes<T> r = dual_reg(regs.data(), tape.result_reg());
  for (size_t begin = 0; begin < n; begin += kLanes) {
    const size_t m = std::min(kLanes, n - begin);
    std::fill(err_.begin(), err_.end(), 0);
    run_gradient_pass(tape.code(), regs.data(), imm_reg, err_.data(), inputs, begin, m);
    for (size_t i = 0; i < m; ++i) {
      const bool nan = err_[i] != 0;
      out[begin + i] = nan ? std::numeric_limits<T>::quiet_NaN() : r.v[i];
      for (int k = 0; k < 3; ++k) {
        out[(k + 1) * n + begin + i] = nan ? std::numeric_limits<T>::quiet_NaN() : r.d[k][i];
      }
    }
  }
}

template void TapeVm::eval_gradient<float>(const Tape&, size_t, std::span<const float* const>,
                                           float*);
template void TapeVm::eval_gradient<double>(const Tape&, size_t, std::span<const double* const>,
                                            double*);

}  // namespace hfrt::jit
