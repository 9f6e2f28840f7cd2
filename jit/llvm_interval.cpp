// The interval JIT: hfrt IR -> LLVM IR over W boxes per SIMD block -> ORC LLJIT.
//
// Design
// - Each IR value is three vectors: lo and hi (<W x double>) and a maybe-NaN mask (<W x i1>);
//   lane i is box i of the block. Every op computes exactly what apply_interval computes
//   (interval_interpreter.cpp) for its box, so the JIT and the interpreter give the same
//   intervals: the cheap ops (add, sub, mul, square, neg, abs, min/max, sqrt, floor/ceil/
//   trunc/round, comparisons, logic, select) are emitted as vector code with the same
//   formulas, outward rounding included (v +- max(|v| 2^-52, denorm_min): a few FP ops per
//   endpoint, no rounding-mode changes, no fast-math); the
//   libm-based ops (exp, log, trig, pow, fmod, ...: the lanes Libm and Helper of
//   ir/ir_ops.h) and sign call apply_interval per lane through a C-ABI helper.
// - Code shape (compile time): every computed value lives in a home of a scratch buffer
//   (ValueHomes, llvm_emit.h): stored where it is defined, loaded where it is used, so each
//   op is a small independent piece of code, cut into basic blocks of a few ops
//   (cut_block). Functions above Options::inline_limit instructions go further: each op is
//   a call of a helper emitted once per op kind into the module (the same code), and the
//   main function, a list of calls, gets the fast code generator. Prospero (8k
//   instructions) compiles in ~2 s instead of ~100 s; the inline shape keeps small models
//   at full speed.
// - Slots are allocas of the three vectors (promoted to registers by mem2reg).
// - Control flow, tri-state per lane: a condition is definitely true, definitely false or
//   ambiguous over each box. An `if` saves the slots its sides write, runs the then side
//   (skipped by a branch when no lane may take it), saves the result, restores the entry
//   state, runs the else side likewise, and merges per lane: definitely-true lanes take the
//   then state, definitely-false lanes the else state, ambiguous lanes the hull of both.
//   This is exactly the interpreter's rule, lane by lane. kCheck ORs (lanes that may reach
//   it) & (condition may be nonzero) into an error mask.
// - Loops run while any lane is active. At the test, lanes whose test may be false add
//   their state to an exit accumulator (hull); lanes whose test may be true stay active.
//   Stores inside a loop are masked by the active lanes, so lanes that left keep their state.
//   After `loop_limit` iterations the remaining lanes give up: the slots the loop writes
//   become [-inf, inf] with maybe-NaN. At the exit every written slot is hulled with the
//   accumulator.
// - Dynamic indices are intervals too: kLoadIdx takes the hull of every element the index
//   interval may address, kStoreIdx assigns where the index is one known element and hulls
//   where it may be several (select chains over the array's slots).
// - The min/max/select trace: each kMin/kMax/kSelect ORs, over the lanes that may reach it,
//   which operands may decide the result into choices[instruction].
// Only f64: single-precision intervals would need their own widening of every libm call.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>

#include "base/check.h"
#include "ir/r_functions.h"
#include "ir/regions.h"
#include "ir/scalar_ops.h"
#include "ir/trig.h"
#include "jit/interval.h"
#include "jit/llvm_emit.h"
#include "jit/llvm_session.h"
#include "jit/nvptx.h"

/// apply_interval for one lane, called from JIT code for the libm-based ops. A block that holds
/// fewer boxes than lanes (one box per call from a bisection, the tail of a batch) repeats its
/// last box in the spare lanes: the previous call's result is reused when the operands are the
/// same bits, so those lanes cost a comparison instead of a libm enclosure.
extern "C" void hfrt_interval_lane(int32_t op, double alo, double ahi, double anan, double blo,
                                   double bhi, double bnan, double* out) noexcept {
  using ::hfrt::Interval;
  struct Last {
    int32_t op = -1;
    double args[6];
    double out[3];
  };
  thread_local Last last;
  const double args[6] = {alo, ahi, anan, blo, bhi, bnan};
  if (last.op == op && std::memcmp(last.args, args, sizeof args) == 0) {
    std::memcpy(out, last.out, sizeof last.out);
    return;
  }
  Interval r = hfrt::jit::apply_interval(static_cast<hfrt::jit::Op>(op), {alo, ahi, anan != 0},
                                         {blo, bhi, bnan != 0}, {}, false);
  out[0] = r.lo;
  out[1] = r.hi;
  out[2] = r.maybe_nan ? 1.0 : 0.0;
  last.op = op;
  std::memcpy(last.args, args, sizeof args);
  std::memcpy(last.out, out, sizeof last.out);
}

/// r_function_interval for one lane, called from JIT code after an R-function node.
extern "C" void hfrt_interval_rfunc(int32_t plus, double rlo, double rhi, double rnan, double alo,
                                    double ahi, double anan, double blo, double bhi, double bnan,
                                    double* out) noexcept {
  using ::hfrt::Interval;
  Interval r = hfrt::jit::r_function_interval({rlo, rhi, rnan != 0}, {alo, ahi, anan != 0},
                                              {blo, bhi, bnan != 0}, plus != 0);
  out[0] = r.lo;
  out[1] = r.hi;
  out[2] = r.maybe_nan ? 1.0 : 0.0;
}

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
const HostSymbol kIntervalSymbols[] = {
    {"hfrt_interval_lane", reinterpret_cast<void*>(&hfrt_interval_lane)},
    {"hfrt_interval_rfunc", reinterpret_cast<void*>(&hfrt_interval_rfunc)},
};
std::span<const HostSymbol> interval_jit_symbols() {
  return kIntervalSymbols;
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct IV {
  llvm::Value* lo = nullptr;
  llvm::Value* hi = nullptr;
  llvm::Value* nan = nullptr;
};

struct Tri {
  llvm::Value* can_true;
  llvm::Value* can_false;
};

class IntervalEmitter : public VectorEmitter {
 public:
  IntervalEmitter(llvm::Module& m, const Function& fn, int lanes, int loop_limit, bool trace,
                  bool outline)
      : VectorEmitter(m, fn, llvm::Type::getDoubleTy(m.getContext()), lanes),
        loop_limit_(loop_limit),
        trace_(trace),
        outline_(outline) {
    dt_ = st_;
    match_ = match_regions(fn);
    r_nodes_ = find_r_functions(fn);
  }

  void emit(const std::string& name) {
    auto* fty = llvm::FunctionType::get(
        llvm::Type::getVoidTy(ctx_), {ptr_, ptr_, i64_, ptr_, ptr_, ptr_, ptr_, ptr_, ptr_}, false);
    f_ = llvm::Function::Create(fty, llvm::Function::ExternalLinkage, name, m_);
    f_->setDoesNotThrow();
    auto arg = f_->arg_begin();
    xlo_ = &*arg++;
    xhi_ = &*arg++;
    stride_ = &*arg++;
    a_ = &*arg++;
    olo_ = &*arg++;
    ohi_ = &*arg++;
    onan_ = &*arg++;
    choices_ = &*arg++;
    scratch_ = &*arg++;
    f_->addParamAttr(8, llvm::Attribute::NoAlias);
    homes_ = plan_value_homes(fn_, /*params_at_use=*/!outline_, r_nodes_.args);
    auto* entry = llvm::BasicBlock::Create(ctx_, "entry", f_);
    b_.SetInsertPoint(entry);
    err_ = b_.CreateAlloca(mt_, nullptr, "err");
    b_.CreateStore(fals(), err_);
    slots_.resize(fn_.num_slots);
    for (int s = 0; s < fn_.num_slots; ++s) {
      slots_[s] = {b_.CreateAlloca(vt_), b_.CreateAlloca(vt_), b_.CreateAlloca(mt_)};
      double init = s < static_cast<int>(fn_.slot_init.size()) ? fn_.slot_init[s] : 0.0;
      store_slot_raw(s, point(init));
    }
    values_.resize(fn_.insts.size());
    for (size_t i = 0; i < fn_.insts.size(); ++i) {
      // Small basic blocks keep instruction selection and scheduling linear.
      if (i % kOpsPerBlock == kOpsPerBlock - 1) cut_block(stride_);  // n >= 1
      emit_inst(i);
    }
    IV r = value(fn_.result);
    HFRT_CHECK(r.lo);
    // The caller's arrays are only element-aligned.
    b_.CreateAlignedStore(r.lo, olo_, llvm::Align(8));
    b_.CreateAlignedStore(r.hi, ohi_, llvm::Align(8));
    llvm::Value* nan = b_.CreateOr(r.nan, b_.CreateLoad(mt_, err_));
    b_.CreateAlignedStore(b_.CreateZExt(nan, llvm::FixedVectorType::get(i8_, w_)), onan_,
                          llvm::Align(1));
    b_.CreateRetVoid();
  }

  int num_homes() const { return homes_.num_homes; }

 private:
  static constexpr size_t kOpsPerBlock = 8;
  // --- constants and small helpers ------------------------------------------------------
  llvm::Value* tru() { return all_true(); }
  llvm::Value* fals() { return all_false(); }
  llvm::Value* sel(llvm::Value* c, llvm::Value* a, llvm::Value* b) {
    return b_.CreateSelect(c, a, b);
  }
  llvm::Value* OR(llvm::Value* a, llvm::Value* b) { return b_.CreateOr(a, b); }
  llvm::Value* AND(llvm::Value* a, llvm::Value* b) { return b_.CreateAnd(a, b); }
  llvm::Value* NOT(llvm::Value* a) { return b_.CreateNot(a); }
  llvm::Value* lt(llvm::Value* a, llvm::Value* b) { return b_.CreateFCmpOLT(a, b); }
  llvm::Value* le(llvm::Value* a, llvm::Value* b) { return b_.CreateFCmpOLE(a, b); }
  llvm::Value* eq(llvm::Value* a, llvm::Value* b) { return b_.CreateFCmpOEQ(a, b); }
  llvm::Value* isnan(llvm::Value* a) { return b_.CreateFCmpUNO(a, a); }
  llvm::Value* isinf(llvm::Value* a) {
    return b_.CreateFCmpOEQ(b_.CreateUnaryIntrinsic(llvm::Intrinsic::fabs, a), splat(kInf));
  }
  /// std::min / std::max on non-NaN values (the sign of a zero may differ; widening and the
  /// comparisons that use these treat both zeros alike).
  llvm::Value* vmin(llvm::Value* a, llvm::Value* b) { return sel(lt(b, a), b, a); }
  llvm::Value* vmax(llvm::Value* a, llvm::Value* b) { return sel(lt(a, b), b, a); }

  IV point(double v) {
    if (v != v) return {splat(0), splat(0), tru()};
    return {splat(v), splat(v), fals()};
  }

  /// Outward widening, the interpreter's formula: v +- max(|v| 2^-52, denorm_min), with
  /// -inf (up) / +inf (down) moved to the largest finite double. Floating-point ops only: integer
  /// bit tricks here made SelectionDAG's known-bits analysis dominate compile time.
  llvm::Value* step(llvm::Value* v) {
    llvm::Value* s = b_.CreateFMul(fabs(v), splat(0x1p-52));
    llvm::Value* dm = splat(std::numeric_limits<double>::denorm_min());
    return sel(b_.CreateFCmpOGT(s, dm), s, dm);
  }
  llvm::Value* up(llvm::Value* v) {
    return sel(eq(v, splat(-kInf)), splat(-std::numeric_limits<double>::max()),
               b_.CreateFAdd(v, step(v)));
  }
  llvm::Value* down(llvm::Value* v) {
    return sel(eq(v, splat(kInf)), splat(std::numeric_limits<double>::max()),
               b_.CreateFSub(v, step(v)));
  }

  llvm::Value* contains_zero(const IV& a) {
    return AND(le(a.lo, splat(0)), b_.CreateFCmpOGE(a.hi, splat(0)));
  }

  IV from_tri(Tri t) {
    return {sel(t.can_false, splat(0), splat(1)), sel(t.can_true, splat(1), splat(0)), fals()};
  }
  Tri nonzero(const IV& c) {
    llvm::Value* t =
        OR(c.nan, OR(b_.CreateFCmpUNE(c.lo, splat(0)), b_.CreateFCmpUNE(c.hi, splat(0))));
    return {t, contains_zero(c)};
  }
  Tri truth(const IV& a) {
    llvm::Value* mag_hi = vmax(fabs(a.lo), fabs(a.hi));
    llvm::Value* mag_lo = sel(contains_zero(a), splat(0), vmin(fabs(a.lo), fabs(a.hi)));
    return {b_.CreateFCmpOGE(mag_hi, splat(kHfEps)), OR(lt(mag_lo, splat(kHfEps)), a.nan)};
  }
  IV hull(const IV& a, const IV& b) {
    return {vmin(a.lo, b.lo), vmax(a.hi, b.hi), OR(a.nan, b.nan)};
  }
  IV select_iv(llvm::Value* c, const IV& a, const IV& b) {
    return {sel(c, a.lo, b.lo), sel(c, a.hi, b.hi), sel(c, a.nan, b.nan)};
  }

  // --- ops ----------------------------------------------------------------------------
  IV add(const IV& a, const IV& b) {
    llvm::Value* nan = OR(OR(a.nan, b.nan), OR(AND(eq(a.lo, splat(-kInf)), eq(b.hi, splat(kInf))),
                                               AND(eq(a.hi, splat(kInf)), eq(b.lo, splat(-kInf)))));
    llvm::Value* lo = b_.CreateFAdd(a.lo, b.lo);
    llvm::Value* hi = b_.CreateFAdd(a.hi, b.hi);
    lo = sel(isnan(lo), splat(-kInf), down(lo));
    hi = sel(isnan(hi), splat(kInf), up(hi));
    return {lo, hi, nan};
  }
  IV neg(const IV& a) { return {b_.CreateFNeg(a.hi), b_.CreateFNeg(a.lo), a.nan}; }
  IV mul(const IV& a, const IV& b) {
    llvm::Value* nan =
        OR(OR(a.nan, b.nan), OR(AND(contains_zero(a), OR(isinf(b.lo), isinf(b.hi))),
                                AND(contains_zero(b), OR(isinf(a.lo), isinf(a.hi)))));
    auto p = [&](llvm::Value* u, llvm::Value* v) {
      llvm::Value* r = b_.CreateFMul(u, v);
      return sel(isnan(r), splat(0), r);
    };
    llvm::Value *c0 = p(a.lo, b.lo), *c1 = p(a.lo, b.hi), *c2 = p(a.hi, b.lo), *c3 = p(a.hi, b.hi);
    llvm::Value* lo = vmin(vmin(c0, c1), vmin(c2, c3));
    llvm::Value* hi = vmax(vmax(c0, c1), vmax(c2, c3));
    return {down(lo), up(hi), nan};
  }
  /// The interpreter's div(): the four quotients where the divisor excludes 0, else
  /// [-inf, inf]. Vector code (one correctly rounded fdiv per quotient), so that models dividing
  /// by constants (blends: h / k) do not take the per-lane helper.
  IV div(const IV& a, const IV& b) {
    llvm::Value* nan0 = OR(a.nan, b.nan);
    llvm::Value* b_inf = OR(isinf(b.lo), isinf(b.hi));
    llvm::Value* a_inf = OR(isinf(a.lo), isinf(a.hi));
    llvm::Value* bz = contains_zero(b);
    auto q = [&](llvm::Value* u, llvm::Value* v) {
      llvm::Value* r = b_.CreateFDiv(u, v);
      return sel(isnan(r), splat(0), r);
    };
    llvm::Value *c0 = q(a.lo, b.lo), *c1 = q(a.lo, b.hi), *c2 = q(a.hi, b.lo), *c3 = q(a.hi, b.hi);
    llvm::Value* lo = down(vmin(vmin(c0, c1), vmin(c2, c3)));
    llvm::Value* hi = up(vmax(vmax(c0, c1), vmax(c2, c3)));
    llvm::Value* nan_z = OR(nan0, OR(contains_zero(a), b_inf));
    llvm::Value* nan_nz = OR(nan0, AND(a_inf, b_inf));
    return {sel(bz, splat(-kInf), lo), sel(bz, splat(kInf), hi), sel(bz, nan_z, nan_nz)};
  }
  IV square(const IV& a) {
    llvm::Value *al = fabs(a.lo), *ah = fabs(a.hi);
    llvm::Value* m_lo = sel(contains_zero(a), splat(0), vmin(al, ah));
    llvm::Value* m_hi = vmax(al, ah);
    llvm::Value* lo = b_.CreateFMul(m_lo, m_lo);
    lo = sel(eq(lo, splat(0)), splat(0), down(lo));
    return {lo, up(b_.CreateFMul(m_hi, m_hi)), a.nan};
  }
  IV abs(const IV& a) {
    llvm::Value* pos = b_.CreateFCmpOGE(a.lo, splat(0));
    llvm::Value* negv = le(a.hi, splat(0));
    IV n = neg(a);
    IV mixed{splat(0), vmax(b_.CreateFNeg(a.lo), a.hi), a.nan};
    return select_iv(pos, a, select_iv(negv, n, mixed));
  }
  IV min_max(const IV& a, const IV& b, bool is_min, llvm::Value* choice) {
    llvm::Value *left_only, *right_only;
    llvm::Value* no_nan = NOT(OR(a.nan, b.nan));
    if (is_min) {
      left_only = AND(no_nan, lt(a.hi, b.lo));
      right_only = le(b.hi, a.lo);
    } else {
      left_only = AND(no_nan, b_.CreateFCmpOGT(a.lo, b.hi));
      right_only = b_.CreateFCmpOGE(b.lo, a.hi);
    }
    record_choice(choice, NOT(right_only), NOT(left_only));
    IV mixed;
    if (is_min) {
      mixed.lo = vmin(a.lo, b.lo);
      mixed.hi = sel(a.nan, b.hi, vmin(a.hi, b.hi));
    } else {
      mixed.lo = sel(a.nan, b.lo, vmax(a.lo, b.lo));
      mixed.hi = vmax(a.hi, b.hi);
    }
    mixed.nan = b.nan;
    return select_iv(left_only, a, select_iv(right_only, b, mixed));
  }
  IV sqrt(const IV& a) {
    llvm::Value* nan = OR(a.nan, lt(a.lo, splat(0)));
    llvm::Value* lo = sel(lt(a.lo, splat(0)), splat(0), a.lo);
    llvm::Value* hi = sel(lt(a.hi, splat(0)), splat(0), a.hi);
    lo = down(b_.CreateUnaryIntrinsic(llvm::Intrinsic::sqrt, lo));
    hi = up(b_.CreateUnaryIntrinsic(llvm::Intrinsic::sqrt, hi));
    lo = sel(lt(lo, splat(0)), splat(0), lo);
    return {lo, hi, nan};
  }
  IV rounding(const IV& a, llvm::Intrinsic::ID id) {
    return {b_.CreateUnaryIntrinsic(id, a.lo), b_.CreateUnaryIntrinsic(id, a.hi), a.nan};
  }
  Tri cmp_lt(const IV& a, const IV& b) {
    return {lt(a.lo, b.hi), OR(NOT(lt(a.hi, b.lo)), OR(a.nan, b.nan))};
  }
  Tri cmp_le(const IV& a, const IV& b) {
    return {le(a.lo, b.hi), OR(b_.CreateFCmpOGT(a.hi, b.lo), OR(a.nan, b.nan))};
  }

  /// kSurface: hfrt_surface_interval per lane (jit/surface_ops.h).
  IV surface_iv(int index, const IV& x, const IV& y, const IV& z) {
    llvm::FunctionCallee f = surface_helper("hfrt_surface_interval");
    auto* in_ty = llvm::ArrayType::get(dt_, 9);
    auto* out_ty = llvm::ArrayType::get(dt_, 3);
    llvm::AllocaInst* in_buf = entry_alloca(in_ty, "surf_in");
    llvm::AllocaInst* out_buf = entry_alloca(out_ty, "surf_out");
    llvm::Value* s = surface_pointer(index);
    const IV* args[3] = {&x, &y, &z};
    llvm::Value* nans[3];
    for (int a = 0; a < 3; ++a) nans[a] = b_.CreateUIToFP(args[a]->nan, vt_);
    IV r{llvm::PoisonValue::get(vt_), llvm::PoisonValue::get(vt_), llvm::PoisonValue::get(vt_)};
    for (int lane = 0; lane < w_; ++lane) {
      for (int a = 0; a < 3; ++a) {
        llvm::Value* parts[3] = {args[a]->lo, args[a]->hi, nans[a]};
        for (int c = 0; c < 3; ++c) {
          b_.CreateStore(b_.CreateExtractElement(parts[c], uint64_t(lane)),
                         b_.CreateConstInBoundsGEP2_32(in_ty, in_buf, 0, unsigned(3 * a + c)));
        }
      }
      b_.CreateCall(f, {s, in_buf, out_buf})->setDoesNotThrow();
      auto part = [&](unsigned k) {
        return b_.CreateLoad(dt_, b_.CreateConstInBoundsGEP2_32(out_ty, out_buf, 0, k));
      };
      r.lo = b_.CreateInsertElement(r.lo, part(0), uint64_t(lane));
      r.hi = b_.CreateInsertElement(r.hi, part(1), uint64_t(lane));
      r.nan = b_.CreateInsertElement(r.nan, part(2), uint64_t(lane));
    }
    r.nan = b_.CreateFCmpUNE(r.nan, splat(0));
    return r;
  }

  /// kSin / kCos: ir/interval_ops.cpp's sin_cos, operation for operation, on hfrt's trig
  /// kernel (ir/trig.h) instead of per-lane libm calls.
  IV sin_cos(const IV& a, bool is_cos) {
    constexpr double kPi = 3.141592653589793;
    auto c = [&](double v) { return splat(v); };
    auto add = [&](llvm::Value* p, llvm::Value* q) { return b_.CreateFAdd(p, q); };
    auto sub = [&](llvm::Value* p, llvm::Value* q) { return b_.CreateFSub(p, q); };
    auto mul = [&](llvm::Value* p, llvm::Value* q) { return b_.CreateFMul(p, q); };
    auto floor = [&](llvm::Value* v) { return b_.CreateUnaryIntrinsic(llvm::Intrinsic::floor, v); };
    llvm::Value* nan = OR(a.nan, OR(isinf(a.lo), isinf(a.hi)));
    llvm::Value* alo = fabs(a.lo);
    llvm::Value* ahi = fabs(a.hi);
    llvm::Value* whole = OR(
        NOT(lt(sub(a.hi, a.lo), c(64.0))),
        OR(b_.CreateFCmpOGT(alo, c(kTrigKernelLimit)), b_.CreateFCmpOGT(ahi, c(kTrigKernelLimit))));
    // std::max(a, b) is (a < b) ? b : a.
    llvm::Value* tol = mul(c(1e-9), vmax(c(1.0), vmax(alo, ahi)));
    const double offset = is_cos ? 0.0 : kPi / 2;
    llvm::Value* k0 = b_.CreateUnaryIntrinsic(
        llvm::Intrinsic::ceil, b_.CreateFDiv(sub(sub(a.lo, c(offset)), tol), c(kPi)));
    llvm::Value* k1 = floor(b_.CreateFDiv(add(sub(a.hi, c(offset)), tol), c(kPi)));
    llvm::Value* f_lo = trig_kernel(a.lo, is_cos);
    llvm::Value* f_hi = trig_kernel(a.hi, is_cos);
    llvm::Value* lo = vmin(f_lo, f_hi);
    llvm::Value* hi = vmax(f_lo, f_hi);
    for (int i = 0; i < 2; ++i) {
      lo = down(lo);
      hi = up(hi);
    }
    llvm::Value* some = le(k0, k1);
    llvm::Value* several = lt(k0, k1);
    llvm::Value* k0_even = eq(sub(k0, mul(c(2.0), floor(mul(k0, c(0.5))))), c(0.0));
    hi = sel(AND(some, OR(several, k0_even)), c(1.0), hi);
    lo = sel(AND(some, OR(several, NOT(k0_even))), c(-1.0), lo);
    lo = vmax(lo, c(-1.0));
    hi = vmin(hi, c(1.0));
    return {sel(whole, c(-1.0), lo), sel(whole, c(1.0), hi), nan};
  }

  /// The per-lane helper (apply_interval) for the libm-based ops.
  IV lane_call(Op op, const IV& a, const IV& b) {
    return call_per_lane("hfrt_interval_lane", static_cast<int32_t>(op), {&a, &b});
  }

  /// Calls the C helper `void name(i32 code, (lo, hi, nan as double) per argument..., ptr out)`
  /// lane by lane; out receives lo, hi and the NaN flag.
  IV call_per_lane(const char* name, int32_t code, std::initializer_list<const IV*> args) {
    std::vector<llvm::Type*> params{i32_};
    for (size_t k = 0; k < 3 * args.size(); ++k) params.push_back(dt_);
    params.push_back(ptr_);
    auto* fty = llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_), params, false);
    llvm::FunctionCallee f = m_.getOrInsertFunction(name, fty);
    if (auto* fn = llvm::dyn_cast<llvm::Function>(f.getCallee())) fn->setDoesNotThrow();
    std::vector<llvm::Value*> nans;
    for (const IV* a : args) nans.push_back(b_.CreateUIToFP(a->nan, vt_));
    IV r{llvm::PoisonValue::get(vt_), llvm::PoisonValue::get(vt_), llvm::PoisonValue::get(vt_)};
    auto* at = llvm::ArrayType::get(dt_, 3);
    llvm::AllocaInst* lane_out = entry_alloca(at, "lane_out");
    for (int i = 0; i < w_; ++i) {
      auto e = [&](llvm::Value* v) { return b_.CreateExtractElement(v, uint64_t(i)); };
      std::vector<llvm::Value*> call_args{llvm::ConstantInt::get(i32_, code)};
      size_t k = 0;
      for (const IV* a : args) {
        call_args.push_back(e(a->lo));
        call_args.push_back(e(a->hi));
        call_args.push_back(e(nans[k++]));
      }
      call_args.push_back(lane_out);
      b_.CreateCall(f, call_args);
      auto part = [&](unsigned c) {
        return b_.CreateLoad(dt_, b_.CreateConstInBoundsGEP2_32(at, lane_out, 0, c));
      };
      r.lo = b_.CreateInsertElement(r.lo, part(0), uint64_t(i));
      r.hi = b_.CreateInsertElement(r.hi, part(1), uint64_t(i));
      r.nan = b_.CreateInsertElement(r.nan, part(2), uint64_t(i));
    }
    r.nan = b_.CreateFCmpUNE(r.nan, splat(0));
    return r;
  }

  /// ORs the trace bits of the lanes that may reach this point into the byte at `p` (no
  /// trace when null).
  void record_choice(llvm::Value* p, llvm::Value* left_possible, llvm::Value* right_possible) {
    if (!p) return;
    llvm::Value* region = region_ ? region_ : tru();
    llvm::Value* l = b_.CreateZExt(any(AND(region, left_possible)), i8_);
    llvm::Value* r = b_.CreateZExt(any(AND(region, right_possible)), i8_);
    llvm::Value* bits = b_.CreateOr(l, b_.CreateShl(r, 1));
    b_.CreateStore(b_.CreateOr(b_.CreateLoad(i8_, p), bits), p);
  }

  // --- values: constants in SSA form, computed values in their homes (see ValueHomes) ------
  /// Home h holds lo (W doubles), hi (W doubles) and the NaN mask (W x i64, 0 or -1).
  llvm::Value* home_ptr(ValueId v, int part) {
    const uint64_t at = (static_cast<uint64_t>(homes_.home[v]) * 3 + part) * w_;
    return b_.CreateConstInBoundsGEP1_64(dt_, scratch_, at);
  }
  /// a[k] as a point interval (NaN: maybe-NaN over [0, 0]; a hoisted number is finite).
  IV param(int k) {
    llvm::Value* v = b_.CreateLoad(dt_, b_.CreateConstInBoundsGEP1_64(dt_, a_, k));
    llvm::Value* vs = b_.CreateVectorSplat(w_, v);
    if (k >= fn_.hoisted_params_from) return {vs, vs, fals()};
    llvm::Value* n = isnan(vs);
    vs = sel(n, splat(0), vs);
    return {vs, vs, n};
  }
  IV value(ValueId v) {
    HFRT_CHECK(v != kNoValue);
    if (homes_.home[v] < 0 && fn_.insts[v].op == Op::kParam) return param(fn_.insts[v].aux);
    if (homes_.home[v] < 0) {
      HFRT_CHECK_MSG(values_[v].lo, "use of a value without code: %" << v);
      return values_[v];
    }
    auto* it = llvm::FixedVectorType::get(i64_, w_);
    return {b_.CreateAlignedLoad(vt_, home_ptr(v, 0), llvm::Align(8)),
            b_.CreateAlignedLoad(vt_, home_ptr(v, 1), llvm::Align(8)),
            b_.CreateTrunc(b_.CreateAlignedLoad(it, home_ptr(v, 2), llvm::Align(8)), mt_)};
  }
  void define(size_t i, const IV& r) {
    if (homes_.home[i] < 0) {
      values_[i] = r;
      return;
    }
    const ValueId v = static_cast<ValueId>(i);
    b_.CreateAlignedStore(r.lo, home_ptr(v, 0), llvm::Align(8));
    b_.CreateAlignedStore(r.hi, home_ptr(v, 1), llvm::Align(8));
    b_.CreateAlignedStore(b_.CreateSExt(r.nan, llvm::FixedVectorType::get(i64_, w_)),
                          home_ptr(v, 2), llvm::Align(8));
  }

  // --- slots --------------------------------------------------------------------------
  struct SlotMem {
    llvm::AllocaInst* lo;
    llvm::AllocaInst* hi;
    llvm::AllocaInst* nan;
  };
  IV load_slot(int s) {
    return {b_.CreateLoad(vt_, slots_[s].lo), b_.CreateLoad(vt_, slots_[s].hi),
            b_.CreateLoad(mt_, slots_[s].nan)};
  }
  void store_slot_raw(int s, const IV& v) {
    b_.CreateStore(v.lo, slots_[s].lo);
    b_.CreateStore(v.hi, slots_[s].hi);
    b_.CreateStore(v.nan, slots_[s].nan);
  }
  /// A store by the program: lanes that already left the innermost loop keep their value.
  void store_slot(int s, IV v) {
    if (store_mask_) v = select_iv(store_mask_, v, load_slot(s));
    store_slot_raw(s, v);
  }
  void add_error(llvm::Value* lanes) {
    if (region_) lanes = AND(lanes, region_);
    b_.CreateStore(OR(b_.CreateLoad(mt_, err_), lanes), err_);
  }

  // --- control flow -------------------------------------------------------------------
  struct IfFrame {
    std::vector<int> written;
    std::vector<IV> s0, s1;
    Tri cond;
    llvm::Value* parent_region;
    llvm::BasicBlock* join;
    bool has_else = false;
  };
  struct LoopFrame {
    std::vector<int> written;
    std::vector<SlotMem> exit;
    llvm::AllocaInst* active;
    llvm::AllocaInst* counter;
    llvm::BasicBlock* header;
    llvm::BasicBlock* exit_bb;
    llvm::Value* parent_region;
    llvm::Value* parent_store_mask;
    llvm::Value* act = nullptr;
  };

  llvm::BasicBlock* block(const char* name) { return new_block(name); }

  /// Runs the side that starts now only when some lane may take it.
  void guard(llvm::Value* region, llvm::BasicBlock* side, llvm::BasicBlock* skip) {
    b_.CreateCondBr(any(region), side, skip);
    b_.SetInsertPoint(side);
  }

  void begin_if(size_t i) {
    IfFrame fr;
    fr.cond = nonzero(value(fn_.insts[i].args[0]));
    size_t m = static_cast<size_t>(match_[i]);
    fr.has_else = fn_.insts[m].op == Op::kElse;
    size_t end = fr.has_else ? static_cast<size_t>(match_[m]) : m;
    fr.written = written_slots(fn_, i + 1, end);
    for (int s : fr.written) fr.s0.push_back(load_slot(s));
    fr.parent_region = region_;
    llvm::Value* then_region = region_ ? AND(region_, fr.cond.can_true) : fr.cond.can_true;
    fr.join = block("then_done");
    guard(then_region, block("then"), fr.join);
    region_ = then_region;
    ifs_.push_back(std::move(fr));
  }
  void begin_else() {
    IfFrame& fr = ifs_.back();
    b_.CreateBr(fr.join);
    b_.SetInsertPoint(fr.join);
    for (int s : fr.written) fr.s1.push_back(load_slot(s));
    for (size_t k = 0; k < fr.written.size(); ++k) store_slot_raw(fr.written[k], fr.s0[k]);
    llvm::Value* else_region =
        fr.parent_region ? AND(fr.parent_region, fr.cond.can_false) : fr.cond.can_false;
    fr.join = block("else_done");
    guard(else_region, block("else"), fr.join);
    region_ = else_region;
  }
  void end_if() {
    IfFrame fr = std::move(ifs_.back());
    ifs_.pop_back();
    b_.CreateBr(fr.join);
    b_.SetInsertPoint(fr.join);
    std::vector<IV> s2;
    if (fr.has_else) {
      for (int s : fr.written) s2.push_back(load_slot(s));
    } else {
      for (int s : fr.written) fr.s1.push_back(load_slot(s));
      s2 = fr.s0;
    }
    llvm::Value* def_true = AND(fr.cond.can_true, NOT(fr.cond.can_false));
    llvm::Value* def_false = NOT(fr.cond.can_true);
    for (size_t k = 0; k < fr.written.size(); ++k) {
      IV merged = select_iv(def_true, fr.s1[k], select_iv(def_false, s2[k], hull(fr.s1[k], s2[k])));
      store_slot_raw(fr.written[k], merged);
    }
    region_ = fr.parent_region;
  }

  void begin_loop(size_t i) {
    LoopFrame fr;
    size_t test = static_cast<size_t>(match_[i]);
    size_t end = static_cast<size_t>(match_[test]);
    fr.written = written_slots(fn_, i + 1, end);
    for (size_t k = 0; k < fr.written.size(); ++k) {
      SlotMem e{entry_alloca(vt_), entry_alloca(vt_), entry_alloca(mt_)};
      b_.CreateStore(splat(kInf), e.lo);  // the empty interval: identity of the hull
      b_.CreateStore(splat(-kInf), e.hi);
      b_.CreateStore(fals(), e.nan);
      fr.exit.push_back(e);
    }
    fr.active = entry_alloca(mt_);
    fr.counter = entry_alloca(i64_);
    b_.CreateStore(region_ ? region_ : tru(), fr.active);
    b_.CreateStore(llvm::ConstantInt::get(i64_, 0), fr.counter);
    fr.header = block("loop");
    fr.exit_bb = block("loop_exit");
    fr.parent_region = region_;
    fr.parent_store_mask = store_mask_;
    b_.CreateBr(fr.header);
    b_.SetInsertPoint(fr.header);
    fr.act = b_.CreateLoad(mt_, fr.active);
    region_ = fr.act;
    store_mask_ = fr.act;
    loops_.push_back(std::move(fr));
  }
  void loop_test(size_t t) {
    LoopFrame& fr = loops_.back();
    Tri c = nonzero(value(fn_.insts[t].args[0]));
    llvm::Value* maybe_exit = AND(fr.act, c.can_false);
    for (size_t k = 0; k < fr.written.size(); ++k) {
      const SlotMem& e = fr.exit[k];
      IV ev{b_.CreateLoad(vt_, e.lo), b_.CreateLoad(vt_, e.hi), b_.CreateLoad(mt_, e.nan)};
      IV h = select_iv(maybe_exit, hull(ev, load_slot(fr.written[k])), ev);
      b_.CreateStore(h.lo, e.lo);
      b_.CreateStore(h.hi, e.hi);
      b_.CreateStore(h.nan, e.nan);
    }
    llvm::Value* active = AND(fr.act, c.can_true);
    llvm::Value* count = b_.CreateLoad(i64_, fr.counter);
    llvm::Value* over = b_.CreateICmpSGE(count, llvm::ConstantInt::get(i64_, loop_limit_));
    llvm::Value* gave_up = AND(active, b_.CreateVectorSplat(w_, over));
    IV entire{splat(-kInf), splat(kInf), tru()};
    for (int s : fr.written) store_slot_raw(s, select_iv(gave_up, entire, load_slot(s)));
    b_.CreateStore(OR(b_.CreateLoad(mt_, err_), gave_up), err_);
    active = AND(active, NOT(gave_up));
    b_.CreateStore(active, fr.active);
    b_.CreateStore(b_.CreateAdd(count, llvm::ConstantInt::get(i64_, 1)), fr.counter);
    b_.CreateCondBr(any(active), block("loop_body"), fr.exit_bb);
    b_.SetInsertPoint(&f_->back());
    // The body block was created last: continue there.
    region_ = active;
    store_mask_ = active;
  }
  void end_loop() {
    LoopFrame fr = std::move(loops_.back());
    loops_.pop_back();
    b_.CreateBr(fr.header);
    b_.SetInsertPoint(fr.exit_bb);
    for (size_t k = 0; k < fr.written.size(); ++k) {
      const SlotMem& e = fr.exit[k];
      IV ev{b_.CreateLoad(vt_, e.lo), b_.CreateLoad(vt_, e.hi), b_.CreateLoad(mt_, e.nan)};
      store_slot_raw(fr.written[k], hull(load_slot(fr.written[k]), ev));
    }
    region_ = fr.parent_region;
    store_mask_ = fr.parent_store_mask;
  }

  // --- one instruction ------------------------------------------------------------------
  void emit_inst(size_t i) {
    const Inst& in = fn_.insts[i];
    auto arg = [&](int k) { return value(in.args[k]); };
    switch (in.op) {
      case Op::kConst:
        define(i, point(in.imm));
        return;
      case Op::kInput: {
        if (in.aux >= fn_.num_inputs) {
          define(i, point(0));
          return;
        }
        llvm::Value* off = b_.CreateMul(stride_, llvm::ConstantInt::get(i64_, in.aux));
        define(i, {b_.CreateAlignedLoad(vt_, b_.CreateInBoundsGEP(dt_, xlo_, off), llvm::Align(8)),
                   b_.CreateAlignedLoad(vt_, b_.CreateInBoundsGEP(dt_, xhi_, off), llvm::Align(8)),
                   fals()});
        return;
      }
      case Op::kParam:
        if (homes_.home[i] >= 0) define(i, param(in.aux));  // else loaded where used
        return;
      case Op::kLoadSlot:
        define(i, load_slot(in.aux));
        return;
      case Op::kStoreSlot:
        store_slot(in.aux, arg(0));
        return;
      case Op::kLoadIdx:
      case Op::kStoreIdx: {
        const IV& idx = arg(0);
        const int size = static_cast<int>(in.imm);
        llvm::Value* klo = b_.CreateUnaryIntrinsic(llvm::Intrinsic::ceil, idx.lo);
        klo = sel(lt(klo, splat(1)), splat(1), klo);
        llvm::Value* khi = b_.CreateUnaryIntrinsic(llvm::Intrinsic::floor, idx.hi);
        khi = sel(lt(splat(size), khi), splat(size), khi);
        llvm::Value* empty = b_.CreateFCmpOGT(klo, khi);
        add_error(OR(idx.nan, empty));
        if (in.op == Op::kLoadIdx) {
          IV r{splat(kInf), splat(-kInf), fals()};
          for (int k = 1; k <= size; ++k) {
            llvm::Value* in_k = AND(le(klo, splat(k)), le(splat(k), khi));
            r = select_iv(in_k, hull(r, load_slot(in.aux + k - 1)), r);
          }
          define(i, select_iv(empty, point(std::nan("")), r));
        } else {
          const IV& v = arg(1);
          for (int k = 1; k <= size; ++k) {
            llvm::Value* in_k = AND(le(klo, splat(k)), le(splat(k), khi));
            llvm::Value* exact = AND(eq(klo, splat(k)), eq(khi, splat(k)));
            IV old = load_slot(in.aux + k - 1);
            store_slot(in.aux + k - 1, select_iv(exact, v, select_iv(in_k, hull(old, v), old)));
          }
        }
        return;
      }
      case Op::kTableLoad: {
        const std::vector<double>& t = fn_.tables[in.aux];
        const IV& idx = arg(0);
        llvm::Value* klo = b_.CreateUnaryIntrinsic(llvm::Intrinsic::ceil, idx.lo);
        klo = sel(lt(klo, splat(0)), splat(0), klo);
        llvm::Value* khi = b_.CreateUnaryIntrinsic(llvm::Intrinsic::floor, idx.hi);
        double last = static_cast<double>(t.size()) - 1;
        khi = sel(lt(splat(last), khi), splat(last), khi);
        llvm::Value* empty = b_.CreateFCmpOGT(klo, khi);
        IV r{splat(kInf), splat(-kInf), fals()};
        for (size_t k = 0; k < t.size(); ++k) {
          double kd = static_cast<double>(k);
          llvm::Value* in_k = AND(le(klo, splat(kd)), le(splat(kd), khi));
          r = select_iv(in_k, hull(r, point(t[k])), r);
        }
        r.nan = OR(r.nan, idx.nan);
        define(i, select_iv(empty, point(std::nan("")), r));
        return;
      }
      case Op::kSurface:
        define(i, surface_iv(in.aux, arg(0), arg(1), arg(2)));
        return;
      case Op::kCheck:
        add_error(nonzero(arg(0)).can_true);
        return;
      case Op::kIf:
        begin_if(i);
        return;
      case Op::kElse:
        begin_else();
        return;
      case Op::kEndIf:
        end_if();
        return;
      case Op::kLoop:
        begin_loop(i);
        return;
      case Op::kLoopTest:
        loop_test(i);
        return;
      case Op::kEndLoop:
        end_loop();
        return;
        // Every op computed from its arguments (case labels generated from ir_ops.h): below.
        HFRT_OP_CASES_ARITH
        break;
    }
    const bool same = in.args[0] == in.args[1] && in.args[0] != kNoValue;
    if (same && (in.op == Op::kMin || in.op == Op::kMax)) {
      define(i, arg(0));  // min(a, a) = a, no trace (as apply_interval)
      return;
    }
    if (outline_) {
      call_helper(i, same);
    } else {
      const IV none = point(0);
      llvm::Value* choice = trace_ ? b_.CreateConstInBoundsGEP1_64(i8_, choices_, i) : nullptr;
      define(i, compute(in.op, same, arg(0), in.args[1] != kNoValue ? arg(1) : none,
                        in.args[2] != kNoValue ? arg(2) : none, choice));
    }
    if (r_nodes_.kind[i]) {
      // r_function_interval per lane (hfrt_interval_rfunc): the interpreter's very code.
      const IV r = value(ValueId(i)), f1 = value(r_nodes_.args[2 * i]),
               f2 = value(r_nodes_.args[2 * i + 1]);
      define(i,
             call_per_lane("hfrt_interval_rfunc", r_nodes_.kind[i] == 1 ? 1 : 0, {&r, &f1, &f2}));
    }
  }

  /// The interval extension of a pure op, as apply_interval computes it; `choice`: where the
  /// min/max/select trace bits go (null: no trace).
  IV compute(Op op, bool same, const IV& a, const IV& b, const IV& c, llvm::Value* choice) {
    IV r;
    switch (op) {
      case Op::kAdd:
        r = add(a, b);
        break;
      case Op::kSub:
        r = add(a, neg(b));
        break;
      case Op::kMul:
        r = same ? square(a) : mul(a, b);
        break;
      case Op::kDiv:
        r = div(a, b);
        break;
      case Op::kNeg:
        r = neg(a);
        break;
      case Op::kAbs:
        r = abs(a);
        break;
      case Op::kMin:
        r = same ? a : min_max(a, b, true, choice);
        break;
      case Op::kMax:
        r = same ? a : min_max(a, b, false, choice);
        break;
      case Op::kSqrt:
        r = sqrt(a);
        break;
      case Op::kFloor:
        r = rounding(a, llvm::Intrinsic::floor);
        break;
      case Op::kCeil:
        r = rounding(a, llvm::Intrinsic::ceil);
        break;
      case Op::kTrunc:
        r = rounding(a, llvm::Intrinsic::trunc);
        break;
      case Op::kRound:
        r = rounding(a, llvm::Intrinsic::round);
        break;
      case Op::kLt:
        r = from_tri(cmp_lt(a, b));
        break;
      case Op::kLe:
        r = from_tri(cmp_le(a, b));
        break;
      case Op::kGt:
        r = from_tri(cmp_lt(b, a));
        break;
      case Op::kGe:
        r = from_tri(cmp_le(b, a));
        break;
      case Op::kEqTol:
      case Op::kNeTol: {
        IV d = abs(add(a, neg(b)));
        llvm::Value* below = lt(d.lo, splat(kHfEps));
        llvm::Value* above = OR(b_.CreateFCmpOGE(d.hi, splat(kHfEps)), d.nan);
        if (op == Op::kEqTol) {
          r = from_tri({below, above});
        } else {
          r = from_tri({b_.CreateFCmpOGE(d.hi, splat(kHfEps)), OR(below, d.nan)});
        }
        break;
      }
      case Op::kEq:
      case Op::kNe: {
        llvm::Value* overlap = AND(le(a.lo, b.hi), le(b.lo, a.hi));
        llvm::Value* all_equal = AND(AND(eq(a.lo, a.hi), eq(b.lo, b.hi)), eq(a.lo, b.lo));
        llvm::Value* differ = OR(NOT(all_equal), OR(a.nan, b.nan));
        r = op == Op::kEq ? from_tri({overlap, differ}) : from_tri({differ, overlap});
        break;
      }
      case Op::kTruth:
        r = from_tri(truth(a));
        break;
      case Op::kAnd: {
        Tri ta = truth(a), tb = truth(b);
        r = from_tri({AND(ta.can_true, tb.can_true), OR(ta.can_false, tb.can_false)});
        break;
      }
      case Op::kOr: {
        Tri ta = truth(a), tb = truth(b);
        r = from_tri({OR(ta.can_true, tb.can_true), AND(ta.can_false, tb.can_false)});
        break;
      }
      case Op::kNot: {
        Tri t = truth(a);
        r = from_tri({t.can_false, t.can_true});
        break;
      }
      case Op::kSelect: {
        Tri t = nonzero(a);
        record_choice(choice, t.can_true, t.can_false);
        r = select_iv(NOT(t.can_false), b, select_iv(NOT(t.can_true), c, hull(b, c)));
        break;
      }
      // Sign, and the libm-based ops, pow, fmod and the hfrt helpers (the lanes Libm and
      // Helper of ir_ops.h): apply_interval per lane.
      case Op::kSign:
        HFRT_OP_CASES_LANE_CALL
        if (op == Op::kSin || op == Op::kCos) {  // but these two: vector code
          r = sin_cos(a, op == Op::kCos);
          break;
        }
        r = lane_call(op, a, b);
        break;
        // Not computed from arguments: emit_inst handles them (and helper() never sees them).
        HFRT_OP_CASES_NON_ARITH
        HFRT_CHECK_MSG(false, "interval of an op without arguments: " << op_name(op));
        break;
    }
    return r;
  }

  // --- outlined ops ----------------------------------------------------------------------
  // Large functions (more than Options::inline_limit instructions) call one helper per op
  // kind, emitted once into the module, with pointers to the operands' and the result's
  // homes (constants live in constant globals of the home layout). The main function is then a
  // short call per op, whose code generation is cheap and linear; the helpers are the very code the
  // inline path emits, so both give the same bits.
  llvm::Value* operand_ptr(ValueId v) {
    HFRT_CHECK(v != kNoValue);
    if (homes_.home[v] >= 0) return home_ptr(v, 0);
    auto it = const_homes_.find(v);
    if (it != const_homes_.end()) return it->second;
    const double imm = fn_.insts[v].imm;
    std::vector<uint64_t> bits(3 * w_);
    for (int k = 0; k < w_; ++k) {
      const double lo = imm != imm ? 0.0 : imm;
      std::memcpy(&bits[k], &lo, sizeof lo);
      std::memcpy(&bits[w_ + k], &lo, sizeof lo);
      bits[2 * w_ + k] = imm != imm ? ~uint64_t(0) : 0;
    }
    auto* init = llvm::ConstantDataArray::get(ctx_, bits);
    auto* gv = new llvm::GlobalVariable(m_, init->getType(), true,
                                        llvm::GlobalValue::PrivateLinkage, init, "const");
    gv->setAlignment(llvm::Align(32));
    const_homes_[v] = gv;
    return gv;
  }

  IV load_iv(llvm::Value* p) {
    auto* it = llvm::FixedVectorType::get(i64_, w_);
    auto at = [&](int part) { return b_.CreateConstInBoundsGEP1_64(dt_, p, uint64_t(part) * w_); };
    return {b_.CreateAlignedLoad(vt_, at(0), llvm::Align(8)),
            b_.CreateAlignedLoad(vt_, at(1), llvm::Align(8)),
            b_.CreateTrunc(b_.CreateAlignedLoad(it, at(2), llvm::Align(8)), mt_)};
  }
  void store_iv(llvm::Value* p, const IV& r) {
    auto at = [&](int part) { return b_.CreateConstInBoundsGEP1_64(dt_, p, uint64_t(part) * w_); };
    b_.CreateAlignedStore(r.lo, at(0), llvm::Align(8));
    b_.CreateAlignedStore(r.hi, at(1), llvm::Align(8));
    b_.CreateAlignedStore(b_.CreateSExt(r.nan, llvm::FixedVectorType::get(i64_, w_)), at(2),
                          llvm::Align(8));
  }

  static bool traced(Op op) { return op_flags_of(op) & op_flags::kTraced; }

  /// The helper of `op`: void(ptr a[, ptr b[, ptr c]], ptr out[, <W x i1> region]
  /// [, ptr choice]), with one operand when `same` (x*x), the region only inside control
  /// flow and the choice byte only for traced ops.
  llvm::Function* helper(Op op, bool same, bool with_region) {
    const int operands = same ? 1 : op_num_args(op);
    const bool with_choice = trace_ && traced(op);
    llvm::Function*& h = helpers_[(static_cast<int>(op) * 2 + (same ? 1 : 0)) * 2 + with_region];
    if (h) return h;
    std::vector<llvm::Type*> params(operands + 1, ptr_);
    if (with_region) params.push_back(mt_);
    if (with_choice) params.push_back(ptr_);
    auto* fty = llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_), params, false);
    h = llvm::Function::Create(
        fty, llvm::Function::InternalLinkage,
        "iv_" + std::string(op_name(op)) + (same ? "_same" : "") + (with_region ? "_masked" : ""),
        m_);
    h->setDoesNotThrow();
    h->addFnAttr(llvm::Attribute::NoInline);
    h->setCallingConv(llvm::CallingConv::Fast);
    // Emit the body with the emitter's state switched to the helper.
    auto saved_ip = b_.saveIP();
    llvm::Function* saved_f = f_;
    llvm::Value* saved_region = region_;
    f_ = h;
    b_.SetInsertPoint(llvm::BasicBlock::Create(ctx_, "entry", h));
    region_ = with_region ? h->getArg(operands + 1) : nullptr;
    IV v[3] = {point(0), point(0), point(0)};
    for (int k = 0; k < operands; ++k) v[k] = load_iv(h->getArg(k));
    if (same) v[1] = v[0];  // f(x, x): one operand passed
    llvm::Value* choice =
        with_choice ? h->getArg(static_cast<unsigned>(params.size() - 1)) : nullptr;
    store_iv(h->getArg(operands), compute(op, same, v[0], v[1], v[2], choice));
    b_.CreateRetVoid();
    f_ = saved_f;
    region_ = saved_region;
    b_.restoreIP(saved_ip);
    return h;
  }

  void call_helper(size_t i, bool same) {
    const Inst& in = fn_.insts[i];
    HFRT_CHECK(homes_.home[i] >= 0);
    llvm::Function* h = helper(in.op, same, region_ != nullptr);
    const int operands = same ? 1 : op_num_args(in.op);
    std::vector<llvm::Value*> args;
    for (int k = 0; k < operands; ++k) args.push_back(operand_ptr(in.args[k]));
    args.push_back(home_ptr(static_cast<ValueId>(i), 0));
    if (region_) args.push_back(region_);
    if (trace_ && traced(in.op)) args.push_back(b_.CreateConstInBoundsGEP1_64(i8_, choices_, i));
    llvm::CallInst* call = b_.CreateCall(h, args);
    call->setCallingConv(llvm::CallingConv::Fast);
    call->setDoesNotThrow();
  }

  int loop_limit_;
  bool trace_;
  llvm::Type* dt_;
  llvm::Value *xlo_, *xhi_, *stride_, *a_, *olo_, *ohi_, *onan_, *choices_, *scratch_;
  ValueHomes homes_;
  bool outline_ = false;
  std::unordered_map<int, llvm::Function*> helpers_;
  RFunctionNodes r_nodes_;  ///< as IntervalInterpreter: tightened by r_function_interval
  std::unordered_map<ValueId, llvm::Constant*> const_homes_;
  llvm::AllocaInst* err_ = nullptr;
  std::vector<int32_t> match_;
  std::vector<IV> values_;
  std::vector<SlotMem> slots_;
  llvm::Value* region_ = nullptr;      ///< lanes that may reach this point (null = all)
  llvm::Value* store_mask_ = nullptr;  ///< lanes still in the innermost loop (null = none)
  std::vector<IfFrame> ifs_;
  std::vector<LoopFrame> loops_;
};

}  // namespace

bool interval_code_is_self_contained(const Function& fn) {
  for (const Inst& in : fn.insts) {
    if (op_lane(in.op) == OpLane::kLibm || op_lane(in.op) == OpLane::kHelper) return false;
    if (in.op == Op::kSurface) return false;
  }
  for (uint8_t k : find_r_functions(fn).kind) {
    if (k != 0) return false;
  }
  return true;
}

llvm::Function* emit_interval_function(llvm::Module& module, const Function& fn, int lanes,
                                       int loop_limit, const std::string& name, int* num_homes) {
  IntervalEmitter emitter(module, fn, lanes, loop_limit, /*trace=*/false, /*outline=*/false);
  emitter.emit(name);
  *num_homes = emitter.num_homes();
  return module.getFunction(name);
}

namespace {

using BlockFn = void (*)(const double* xlo, const double* xhi, int64_t stride, const double* a,
                         double* out_lo, double* out_hi, uint8_t* out_nan, uint8_t* choices,
                         double* scratch) noexcept;

}  // namespace

struct IntervalJit::Impl {
  std::unique_ptr<CompiledCode> code;
  BlockFn block = nullptr;
  int lanes = 0;
  int num_inputs = 0;
  int num_params = 0;
  size_t num_insts = 0;
  int num_homes = 0;  ///< scratch: 3 W doubles per value home
  JitStats stats;
};

IntervalJit::IntervalJit(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
IntervalJit::~IntervalJit() = default;
int IntervalJit::lanes() const {
  return impl_->lanes;
}
const JitStats& IntervalJit::stats() const {
  return impl_->stats;
}

Result<std::unique_ptr<IntervalJit>> IntervalJit::compile(const Function& fn,
                                                          const Options& options) {
  Result<LlvmSession*> session = LlvmSession::get();
  if (!session.ok()) return session.error();
  auto impl = std::make_unique<Impl>();
  // The host's lanes and the optimising code generator even for call-heavy code (unlike the
  // point and gradient JITs): on a corpus model with 140 lane calls the renderer's batches of
  // boxes ran ~10 % slower either way, for 0.6 s less compile of a 30 s render.
  impl->lanes = options.lanes > 0 ? options.lanes : session.value()->lanes(8);
  ModuleUnit unit = session.value()->new_module("hfrt_interval");
  const std::string name = unit.name;
  auto t0 = std::chrono::steady_clock::now();
  const bool outline = static_cast<int64_t>(fn.insts.size()) > options.inline_limit;
  IntervalEmitter emitter(*unit.module, fn, impl->lanes, options.loop_limit, options.trace,
                          outline);
  emitter.emit(name);
  impl->num_homes = emitter.num_homes();
  impl->stats.emit_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  impl->stats.lanes = impl->lanes;
  PipelineOptions pipeline = domain_pipeline(options.opt_level);
  // The outlined main function is a list of calls: the optimising code generator costs
  // seconds on it and gains nothing measurable (same throughput on prospero).
  if (outline) pipeline.fast_codegen.push_back(name);
  auto code = session.value()->compile(std::move(unit), name, pipeline, &impl->stats);
  if (!code.ok()) return code.error();
  impl->block = reinterpret_cast<BlockFn>(code.value()->entry());
  impl->code = std::move(code.value());
  impl->num_inputs = fn.num_inputs;
  impl->num_params = fn.num_params;
  impl->num_insts = fn.insts.size();
  return std::unique_ptr<IntervalJit>(new IntervalJit(std::move(impl)));
}

void IntervalJit::eval(int64_t n, const double* x_lo, const double* x_hi, std::span<const double> a,
                       double* out_lo, double* out_hi, uint8_t* out_nan, uint8_t* choices) const {
  const Impl& im = *impl_;
  const int w = im.lanes, dims = im.num_inputs;
  // The renderer calls this for every few boxes of a bisection, millions of times a frame:
  // per-thread buffers, so that no call allocates.
  struct Scratch {
    std::vector<double> params, homes, lo, hi, olo, ohi;
    std::vector<uint8_t> no_choices, onan;
  };
  thread_local Scratch sc;
  sc.params.assign(std::max(im.num_params, 1), 0.0);
  for (size_t k = 0; k < a.size() && k < sc.params.size(); ++k) sc.params[k] = a[k];
  if (!choices) {
    // Only OR-ed into: its contents do not matter.
    if (sc.no_choices.size() < im.num_insts) sc.no_choices.resize(im.num_insts);
    choices = sc.no_choices.data();
  }
  const size_t home_doubles = static_cast<size_t>(std::max(im.num_homes, 1)) * 3 * w;
  if (sc.homes.size() < home_doubles) sc.homes.resize(home_doubles);
  double* scratch = sc.homes.data();
  const double* params = sc.params.data();
  int64_t full = n - n % w;
  for (int64_t i = 0; i < full; i += w) {
    im.block(x_lo + i, x_hi + i, n, params, out_lo + i, out_hi + i, out_nan + i, choices, scratch);
  }
  if (full < n) {
    // The tail: a padded block whose extra lanes repeat the last box (harmless for the trace,
    // and cheap for the per-lane helpers, which reuse the previous lane's result).
    const int64_t m = n - full;
    sc.lo.resize(static_cast<size_t>(w) * std::max(dims, 1));
    sc.hi.resize(sc.lo.size());
    for (int k = 0; k < dims; ++k) {
      for (int j = 0; j < w; ++j) {
        int64_t src = full + std::min<int64_t>(j, m - 1);
        sc.lo[k * w + j] = x_lo[k * n + src];
        sc.hi[k * w + j] = x_hi[k * n + src];
      }
    }
    sc.olo.resize(w);
    sc.ohi.resize(w);
    sc.onan.resize(w);
    im.block(sc.lo.data(), sc.hi.data(), w, params, sc.olo.data(), sc.ohi.data(), sc.onan.data(),
             choices, scratch);
    for (int64_t j = 0; j < m; ++j) {
      out_lo[full + j] = sc.olo[j];
      out_hi[full + j] = sc.ohi[j];
      out_nan[full + j] = sc.onan[j];
    }
  }
}

Interval IntervalJit::eval_one(std::span<const Interval> x, std::span<const double> a,
                               std::vector<uint8_t>* choices) const {
  const int dims = impl_->num_inputs;
  std::vector<double> lo(std::max(dims, 1), 0.0), hi(lo.size(), 0.0);
  for (int k = 0; k < dims && k < static_cast<int>(x.size()); ++k) {
    lo[k] = x[k].lo;
    hi[k] = x[k].hi;
  }
  double rl, rh;
  uint8_t rn;
  if (choices) choices->assign(impl_->num_insts, 0);
  eval(1, lo.data(), hi.data(), a, &rl, &rh, &rn, choices ? choices->data() : nullptr);
  return {rl, rh, rn != 0};
}

}  // namespace hfrt::jit
