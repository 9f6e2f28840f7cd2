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

/// One instruction over kLanes lanes: a loop with a constant trip count around apply_op_t of
/// a constant op, which inlines to the op's formula (vector code for the inline ops, a libm
/// call per lane for the others).
// always_inline: the lane loops must be compiled inside each target clone of the pass (AVX2 or
// the baseline), not once for the baseline and called from both.
#define HFRT_TAPE_INLINE inline __attribute__((always_inline))

template <Op kOp, typename T>
HFRT_TAPE_INLINE void lanes(const TapeInst& t, T* regs) {
  T* out = regs + size_t(t.out) * kLanes;
  constexpr int kArgs = op_num_args(kOp);
  if constexpr (kArgs == 1) {
    const T* a = regs + size_t(t.a) * kLanes;
    for (size_t i = 0; i < kLanes; ++i) out[i] = apply_op_t<T>(kOp, a[i], T(0), T(0));
  } else if constexpr (kArgs == 2) {
    if (t.flags & TapeInst::kImmB) {
      const T* a = regs + size_t(t.a) * kLanes;
      const T b = static_cast<T>(t.imm);
      for (size_t i = 0; i < kLanes; ++i) out[i] = apply_op_t<T>(kOp, a[i], b, T(0));
    } else if (t.flags & TapeInst::kImmA) {
      const T a = static_cast<T>(t.imm);
      const T* b = regs + size_t(t.b) * kLanes;
      for (size_t i = 0; i < kLanes; ++i) out[i] = apply_op_t<T>(kOp, a, b[i], T(0));
    } else {
      const T* a = regs + size_t(t.a) * kLanes;
      const T* b = regs + size_t(t.b) * kLanes;
      for (size_t i = 0; i < kLanes; ++i) out[i] = apply_op_t<T>(kOp, a[i], b[i], T(0));
    }
  } else {
    const T* a = regs + size_t(t.a) * kLanes;
    const T* b = regs + size_t(t.b) * kLanes;
    const T* c = regs + size_t(t.c) * kLanes;
    for (size_t i = 0; i < kLanes; ++i) out[i] = apply_op_t<T>(kOp, a[i], b[i], c[i]);
  }
}

/// One pass of the register code over kLanes points (inputs already in their lanes).
template <typename T>
HFRT_TAPE_INLINE void run_points(std::span<const TapeInst> code, T* regs, uint8_t* err,
                                 std::span<const T* const> inputs, size_t begin, size_t m) {
  for (const TapeInst& t : code) {
    switch (t.op) {
#define HFRT_TAPE_LANES(name, n, f, kind, ...) \
  HFRT_OP_IF_ARITH_##kind(case Op::k##name : lanes<Op::k##name, T>(t, regs); break;)
      HFRT_IR_OPS(HFRT_TAPE_LANES)
#undef HFRT_TAPE_LANES
      case Op::kConst:
        std::fill_n(regs + size_t(t.out) * kLanes, kLanes, static_cast<T>(t.imm));
        break;
      case Op::kInput: {
        T* out = regs + size_t(t.out) * kLanes;
        if (t.a < inputs.size()) {
          std::copy_n(inputs[t.a] + begin, m, out);
          std::fill(out + m, out + kLanes, T(0));
        } else {
          std::fill_n(out, kLanes, T(0));
        }
        break;
      }
      case Op::kCheck: {
        const T* a = regs + size_t(t.a) * kLanes;
        for (size_t i = 0; i < kLanes; ++i) err[i] |= a[i] != 0;  // NaN != 0 fires too
        break;
      }
      case Op::kParam:
      case Op::kLoadSlot:
      case Op::kStoreSlot:
      case Op::kLoadIdx:
      case Op::kStoreIdx:
      case Op::kTableLoad:
      case Op::kSurface:
      case Op::kIf:
      case Op::kElse:
      case Op::kEndIf:
      case Op::kLoop:
      case Op::kLoopTest:
      case Op::kEndLoop:
        HFRT_CHECK_MSG(false, "tape VM: op without a tape form " << op_name(t.op));
        break;
    }
  }
}

/// The float pass, compiled for AVX2 too (chosen at load time): the lane loops are the whole
/// cost, and the baseline x86-64 target has 4-wide vectors only.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void run_points_f32(std::span<const TapeInst> code, float* regs, uint8_t* err,
                    std::span<const float* const> inputs, size_t begin, size_t m) {
  run_points<float>(code, regs, err, inputs, begin, m);
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void run_points_f64(std::span<const TapeInst> code, double* regs, uint8_t* err,
                    std::span<const double* const> inputs, size_t begin, size_t m) {
  run_points<double>(code, regs, err, inputs, begin, m);
}

void run_pass(std::span<const TapeInst> code, float* regs, uint8_t* err,
              std::span<const float* const> inputs, size_t begin, size_t m) {
  run_points_f32(code, regs, err, inputs, begin, m);
}
void run_pass(std::span<const TapeInst> code, double* regs, uint8_t* err,
              std::span<const double* const> inputs, size_t begin, size_t m) {
  run_points_f64(code, regs, err, inputs, begin, m);
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
  const size_t need = size_t(tape.num_regs()) * kLanes;
  if (regs.size() < need) regs.resize(need);
  err_.resize(kLanes);
  const T* result = regs.data() + size_t(tape.result_reg()) * kLanes;
  for (size_t begin = 0; begin < n; begin += kLanes) {
    const size_t m = std::min(kLanes, n - begin);
    std::fill(err_.begin(), err_.end(), 0);
    run_pass(tape.code(), regs.data(), err_.data(), inputs, begin, m);
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
      case Op::kParam:
      case Op::kLoadSlot:
      case Op::kStoreSlot:
      case Op::kLoadIdx:
      case Op::kStoreIdx:
      case Op::kTableLoad:
      case Op::kSurface:
      case Op::kIf:
      case Op::kElse:
      case Op::kEndIf:
      case Op::kLoop:
      case Op::kLoopTest:
      case Op::kEndLoop:
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

}  // namespace hfrt::jit
