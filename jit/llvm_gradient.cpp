// The gradient JIT: hfrt IR -> LLVM IR over W points per SIMD block, forward-mode AD.
//
// Design
// - Each IR value is a dual number of four <W x T> vectors (value, d/dx[1], d/dx[2],
//   d/dx[3]); T is double or float. The formulas are apply_dual's (ir/dual_ops.cpp):
//   the value is the scalar op (IEEE intrinsics for sqrt/fabs/floor/ceil/trunc/round, a
//   per-lane call of the very libm function the interpreter calls for the others, the
//   interpreter's hf_pow for kPowHF), the derivatives the chain rule, where a component whose
//   input derivative is exactly 0 stays 0. No fast-math flags.
// - Control flow uses lane masks, as the scalar JIT does: both sides of an `if` run under
//   their masks (a side no lane takes is skipped by a branch), loops run while any lane is
//   active, stores are select(mask, new, old) on all four components, kCheck ORs
//   mask & (cond != 0) into an error mask; lanes with an error leave loops and get NaN in
//   all four outputs at the end.

#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "base/check.h"
#include "ir/scalar_ops.h"
#include "jit/gradient.h"
#include "jit/llvm_emit.h"
#include "jit/llvm_session.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

struct DV {
  llvm::Value* v = nullptr;
  llvm::Value* d[3] = {nullptr, nullptr, nullptr};
};

class GradientEmitter : public VectorEmitter {
 public:
  GradientEmitter(llvm::Module& m, const Function& fn, bool f32, int lanes)
      : VectorEmitter(
            m, fn,
            f32 ? llvm::Type::getFloatTy(m.getContext()) : llvm::Type::getDoubleTy(m.getContext()),
            lanes) {}

  void emit(const std::string& name) {
    // void block(const T* x, i64 stride, const T* a, T* out)   (out rows: F, d1, d2, d3)
    auto* fty =
        llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_), {ptr_, i64_, ptr_, ptr_}, false);
    f_ = llvm::Function::Create(fty, llvm::Function::ExternalLinkage, name, m_);
    f_->setDoesNotThrow();
    auto arg = f_->arg_begin();
    x_ = &*arg++;
    stride_ = &*arg++;
    a_ = &*arg++;
    out_ = &*arg++;
    b_.SetInsertPoint(llvm::BasicBlock::Create(ctx_, "entry", f_));
    err_ = b_.CreateAlloca(mt_);
    b_.CreateStore(llvm::ConstantInt::getFalse(mt_), err_);
    slots_.resize(fn_.num_slots);
    for (int s = 0; s < fn_.num_slots; ++s) {
      for (auto*& p : slots_[s]) p = b_.CreateAlloca(vt_);
      double init = s < static_cast<int>(fn_.slot_init.size()) ? fn_.slot_init[s] : 0.0;
      store_raw(s, flat(splat(init)));
    }
    values_.resize(fn_.insts.size());
    for (size_t i = 0; i < fn_.insts.size(); ++i) {
      emit_inst(i);
    }
    DV r = values_[fn_.result];
    llvm::Value* err = b_.CreateLoad(mt_, err_);
    llvm::Value* nan = splat(std::nan(""));
    llvm::Value* comps[4] = {r.v, r.d[0], r.d[1], r.d[2]};
    for (int c = 0; c < 4; ++c) {
      llvm::Value* p =
          b_.CreateInBoundsGEP(st_, out_, b_.CreateMul(stride_, llvm::ConstantInt::get(i64_, c)));
      b_.CreateAlignedStore(b_.CreateSelect(err, nan, comps[c]), p, align_);
    }
    b_.CreateRetVoid();
  }

 private:
  llvm::Value* sel(llvm::Value* c, llvm::Value* a, llvm::Value* b) {
    return b_.CreateSelect(c, a, b);
  }
  llvm::Value* add(llvm::Value* a, llvm::Value* b) { return b_.CreateFAdd(a, b); }
  llvm::Value* sub(llvm::Value* a, llvm::Value* b) { return b_.CreateFSub(a, b); }
  llvm::Value* mul(llvm::Value* a, llvm::Value* b) { return b_.CreateFMul(a, b); }
  llvm::Value* div(llvm::Value* a, llvm::Value* b) { return b_.CreateFDiv(a, b); }

  DV flat(llvm::Value* v) { return {v, {splat(0), splat(0), splat(0)}}; }

  /// Per-lane call of a scalar function (libm or helper).
  llvm::Value* call(const char* f64_name, const char* f32_name, llvm::Value* a,
                    llvm::Value* c = nullptr) {
    return call_lanes(pure_function(pick_name(f64_name, f32_name), c ? 2 : 1), a, c);
  }

  /// chain rule; zero input components stay zero.
  DV chain(llvm::Value* v, const DV& a, llvm::Value* k) {
    DV r{v, {}};
    for (int i = 0; i < 3; ++i) {
      r.d[i] = sel(b_.CreateFCmpOEQ(a.d[i], splat(0)), splat(0), mul(k, a.d[i]));
    }
    return r;
  }
  DV chain2(llvm::Value* v, const DV& a, llvm::Value* ka, const DV& b, llvm::Value* kb) {
    DV r{v, {}};
    for (int i = 0; i < 3; ++i) {
      llvm::Value* t = sel(b_.CreateFCmpOEQ(a.d[i], splat(0)), splat(0), mul(ka, a.d[i]));
      llvm::Value* u = sel(b_.CreateFCmpOEQ(b.d[i], splat(0)), splat(0), mul(kb, b.d[i]));
      r.d[i] = add(t, u);
    }
    return r;
  }
  DV pick(llvm::Value* c, const DV& a, const DV& b) {
    DV r{sel(c, a.v, b.v), {}};
    for (int i = 0; i < 3; ++i) r.d[i] = sel(c, a.d[i], b.d[i]);
    return r;
  }

  // --- slots ----------------------------------------------------------------------------
  DV load(int s) {
    DV r{b_.CreateLoad(vt_, slots_[s][0]), {}};
    for (int i = 0; i < 3; ++i) r.d[i] = b_.CreateLoad(vt_, slots_[s][i + 1]);
    return r;
  }
  void store_raw(int s, const DV& v) {
    b_.CreateStore(v.v, slots_[s][0]);
    for (int i = 0; i < 3; ++i) b_.CreateStore(v.d[i], slots_[s][i + 1]);
  }
  void store(int s, DV v, llvm::Value* extra = nullptr) {
    llvm::Value* m = mask();
    if (extra) m = and_mask(m, extra);
    if (m) v = pick(m, v, load(s));
    store_raw(s, v);
  }
  void add_error(llvm::Value* lanes) {
    b_.CreateStore(b_.CreateOr(b_.CreateLoad(mt_, err_), and_mask(mask(), lanes)), err_);
  }

  /// kSurface: hfrt_surface_dual per lane (in f64; f32 code converts), jit/surface_ops.h.
  DV surface_dual_lanes(int index, const DV& x, const DV& y, const DV& z) {
    llvm::FunctionCallee f = surface_helper("hfrt_surface_dual");
    llvm::Type* dt = llvm::Type::getDoubleTy(ctx_);
    auto* in_ty = llvm::ArrayType::get(dt, 12);
    auto* out_ty = llvm::ArrayType::get(dt, 4);
    llvm::AllocaInst* in_buf = entry_alloca(in_ty, "surf_in");
    llvm::AllocaInst* out_buf = entry_alloca(out_ty, "surf_out");
    llvm::Value* s = surface_pointer(index);
    const DV* args[3] = {&x, &y, &z};
    DV r;
    r.v = llvm::PoisonValue::get(vt_);
    for (int k = 0; k < 3; ++k) r.d[k] = llvm::PoisonValue::get(vt_);
    for (int lane = 0; lane < w_; ++lane) {
      for (int a = 0; a < 3; ++a) {
        for (int c = 0; c < 4; ++c) {
          llvm::Value* vec = c == 0 ? args[a]->v : args[a]->d[c - 1];
          llvm::Value* e = b_.CreateExtractElement(vec, uint64_t(lane));
          if (is_f32_) e = b_.CreateFPExt(e, dt);
          b_.CreateStore(e, b_.CreateConstInBoundsGEP2_32(in_ty, in_buf, 0, unsigned(4 * a + c)));
        }
      }
      b_.CreateCall(f, {s, in_buf, out_buf})->setDoesNotThrow();
      for (int c = 0; c < 4; ++c) {
        llvm::Value* e =
            b_.CreateLoad(dt, b_.CreateConstInBoundsGEP2_32(out_ty, out_buf, 0, unsigned(c)));
        if (is_f32_) e = b_.CreateFPTrunc(e, st_);
        llvm::Value*& dst = c == 0 ? r.v : r.d[c - 1];
        dst = b_.CreateInsertElement(dst, e, uint64_t(lane));
      }
    }
    return r;
  }

  void emit_inst(size_t i) {
    const Inst& in = fn_.insts[i];
    auto arg = [&](int k) -> const DV& { return values_[in.args[k]]; };
    switch (in.op) {
      case Op::kConst:
        values_[i] = flat(splat(in.imm));
        return;
      case Op::kInput: {
        if (in.aux >= fn_.num_inputs) {
          values_[i] = flat(splat(0));
          return;
        }
        llvm::Value* p = b_.CreateInBoundsGEP(
            st_, x_, b_.CreateMul(stride_, llvm::ConstantInt::get(i64_, in.aux)));
        DV r = flat(b_.CreateAlignedLoad(vt_, p, align_));
        if (in.aux < 3) r.d[in.aux] = splat(1);
        values_[i] = r;
        return;
      }
      case Op::kParam: {
        llvm::Value* v = b_.CreateLoad(st_, b_.CreateConstInBoundsGEP1_64(st_, a_, in.aux));
        values_[i] = flat(b_.CreateVectorSplat(w_, v));
        return;
      }
      case Op::kLoadSlot:
        values_[i] = load(in.aux);
        return;
      case Op::kStoreSlot:
        store(in.aux, arg(0));
        return;
      case Op::kLoadIdx:
      case Op::kStoreIdx: {
        llvm::Value* idx = arg(0).v;
        const int size = static_cast<int>(in.imm);
        llvm::Value* ok =
            b_.CreateAnd(b_.CreateFCmpOGE(idx, splat(1)), b_.CreateFCmpOLE(idx, splat(size)));
        add_error(b_.CreateNot(ok));
        llvm::Value* ti = b_.CreateUnaryIntrinsic(llvm::Intrinsic::trunc, idx);
        if (in.op == Op::kLoadIdx) {
          DV r = load(in.aux);
          for (int k = 2; k <= size; ++k)
            r = pick(b_.CreateFCmpOEQ(ti, splat(k)), load(in.aux + k - 1), r);
          values_[i] = r;
        } else {
          for (int k = 1; k <= size; ++k)
            store(in.aux + k - 1, arg(1), b_.CreateFCmpOEQ(ti, splat(k)));
        }
        return;
      }
      case Op::kTableLoad: {
        const std::vector<double>& t = fn_.tables[in.aux];
        llvm::Value* idx = arg(0).v;
        llvm::Value* ok = b_.CreateAnd(b_.CreateFCmpOGE(idx, splat(0)),
                                       b_.CreateFCmpOLT(idx, splat(static_cast<double>(t.size()))));
        add_error(b_.CreateNot(ok));
        llvm::Value* ti = b_.CreateUnaryIntrinsic(llvm::Intrinsic::trunc, idx);
        llvm::Value* r = splat(t.empty() ? 0.0 : t[0]);
        for (size_t k = 1; k < t.size(); ++k) {
          r = sel(b_.CreateFCmpOEQ(ti, splat(static_cast<double>(k))), splat(t[k]), r);
        }
        values_[i] = flat(r);
        return;
      }
      case Op::kSurface:
        values_[i] = surface_dual_lanes(in.aux, arg(0), arg(1), arg(2));
        return;
      case Op::kCheck:
        add_error(b_.CreateFCmpUNE(arg(0).v, splat(0)));
        return;
      case Op::kIf:
        begin_if(nonzero(arg(0).v));
        return;
      case Op::kElse:
        begin_else();
        return;
      case Op::kEndIf:
        end_if();
        return;
      case Op::kLoop: {
        llvm::AllocaInst* trips = entry_alloca(i64_, "trips");
        b_.CreateStore(llvm::ConstantInt::get(i64_, 0), trips);
        trips_.push_back(trips);
        begin_loop();
        return;
      }
      case Op::kLoopTest: {
        // Lanes with an error leave (their result is NaN anyway); after kGradientLoopLimit
        // iterations the remaining lanes give up with an error, like the interpreter.
        llvm::Value* stay = and_mask(mask(), nonzero(arg(0).v));
        stay = b_.CreateAnd(stay, b_.CreateNot(b_.CreateLoad(mt_, err_)));
        llvm::Value* trips =
            b_.CreateAdd(b_.CreateLoad(i64_, trips_.back()), llvm::ConstantInt::get(i64_, 1));
        b_.CreateStore(trips, trips_.back());
        llvm::Value* over = b_.CreateVectorSplat(
            w_, b_.CreateICmpSGT(trips, llvm::ConstantInt::get(i64_, kGradientLoopLimit)));
        llvm::Value* gave_up = b_.CreateAnd(stay, over);
        b_.CreateStore(b_.CreateOr(b_.CreateLoad(mt_, err_), gave_up), err_);
        loop_continue(b_.CreateAnd(stay, b_.CreateNot(gave_up)));
        return;
      }
      case Op::kEndLoop:
        end_loop();
        trips_.pop_back();
        return;
        // Every op computed from its arguments (case labels generated from ir_ops.h): below.
        HFRT_OP_CASES_ARITH
        break;
    }
    const DV zero = flat(splat(0));
    const DV& a = arg(0);
    const DV& b = in.args[1] != kNoValue ? arg(1) : zero;
    llvm::Value* av = a.v;
    llvm::Value* bv = b.v;
    // The value part is the scalar JIT's code for the op (bit-identical to apply_op).
    llvm::Value* v = scalar_op(in.op, av, bv, in.args[2] != kNoValue ? arg(2).v : nullptr);
    auto powhf = [&](llvm::Value* base, llvm::Value* e) {
      return call("hfrt_jit_powhf_f64", "hfrt_jit_powhf_f32", base, e);
    };
    DV r;
    switch (in.op) {
      case Op::kAdd:
        r = chain2(v, a, splat(1), b, splat(1));
        break;
      case Op::kSub:
        r = chain2(v, a, splat(1), b, splat(-1));
        break;
      case Op::kMul:
        r = chain2(v, a, bv, b, av);
        break;
      case Op::kDiv:
        r = chain2(v, a, div(splat(1), bv), b, b_.CreateFNeg(div(v, bv)));
        break;
      case Op::kNeg:
        r = chain(v, a, splat(-1));
        break;
      case Op::kAbs:
        r = chain(v, a, sel(b_.CreateFCmpOLT(av, splat(0)), splat(-1), splat(1)));
        break;
      case Op::kMin:
        r = pick(b_.CreateFCmpOLT(av, bv), a, b);
        break;
      case Op::kMax:
        r = pick(b_.CreateFCmpOGT(av, bv), a, b);
        break;
      case Op::kSqrt:
        r = chain(v, a, div(splat(0.5), v));
        break;
      case Op::kExp:
        r = chain(v, a, v);
        break;
      case Op::kLog:
        r = chain(v, a, div(splat(1), av));
        break;
      case Op::kLog10:
        r = chain(v, a, div(splat(1), mul(av, splat(std::log(10.0)))));
        break;
      // The derivative in the value's arithmetic: f32 from hfrt's kernel (ir/trig.h) as
      // the value itself, f64 from libm.
      case Op::kSin:
        r = chain(v, a, is_f32_ && inline_trig_ ? sin_cos_f32(av, true) : call("cos", "cosf", av));
        break;
      case Op::kCos:
        r = chain(v, a,
                  b_.CreateFNeg(is_f32_ && inline_trig_ ? sin_cos_f32(av, false)
                                                        : call("sin", "sinf", av)));
        break;
      case Op::kTan:
        r = chain(v, a, add(splat(1), mul(v, v)));
        break;
      case Op::kAsin:
      case Op::kAcos: {
        llvm::Value* k =
            div(splat(in.op == Op::kAsin ? 1 : -1),
                b_.CreateUnaryIntrinsic(llvm::Intrinsic::sqrt, sub(splat(1), mul(av, av))));
        r = chain(v, a, k);
        break;
      }
      case Op::kAtan:
        r = chain(v, a, div(splat(1), add(splat(1), mul(av, av))));
        break;
      case Op::kAtan2: {
        llvm::Value* r2 = add(mul(av, av), mul(bv, bv));
        r = chain2(v, a, div(bv, r2), b, b_.CreateFNeg(div(av, r2)));
        break;
      }
      case Op::kSinh:
        r = chain(v, a, call("cosh", "coshf", av));
        break;
      case Op::kCosh:
        r = chain(v, a, call("sinh", "sinhf", av));
        break;
      case Op::kTanh:
        r = chain(v, a, sub(splat(1), mul(v, v)));
        break;
      case Op::kFmod: {
        llvm::Value* q = b_.CreateUnaryIntrinsic(llvm::Intrinsic::round, div(sub(av, v), bv));
        r = chain2(v, a, splat(1), b, b_.CreateFNeg(q));
        break;
      }
      case Op::kPow: {
        llvm::Value* ka = sel(b_.CreateFCmpOEQ(bv, splat(0)), splat(0),
                              mul(bv, call("pow", "powf", av, sub(bv, splat(1)))));
        r = chain2(v, a, ka, b, mul(v, call("log", "logf", av)));
        break;
      }
      case Op::kPowHF: {
        llvm::Value* small = b_.CreateFCmpOLT(fabs(av), splat(kHfEps));
        llvm::Value* integral = b_.CreateFCmpOLT(
            fabs(sub(bv, b_.CreateUnaryIntrinsic(llvm::Intrinsic::trunc, bv))), splat(kHfEps));
        llvm::Value* n = b_.CreateUnaryIntrinsic(llvm::Intrinsic::round, fabs(bv));
        n = sel(b_.CreateFCmpOLT(bv, splat(0)), b_.CreateFNeg(n), n);
        llvm::Value* ka_int =
            sel(b_.CreateFCmpOEQ(n, splat(0)), splat(0), mul(n, powhf(av, sub(n, splat(1)))));
        llvm::Value* ka_gen = div(mul(v, bv), av);
        llvm::Value* kb_gen = mul(v, call("log", "logf", av));
        llvm::Value* ka = sel(small, splat(0), sel(integral, ka_int, ka_gen));
        llvm::Value* kb = sel(b_.CreateOr(small, integral), splat(0), kb_gen);
        r = chain2(v, a, ka, b, kb);
        break;
      }
      case Op::kSelect:
        r = pick(nonzero(av), b, arg(2));
        break;
      case Op::kCbrt:  // 1 / (3 cbrt(a)^2), as apply_dual
        r = chain(v, a, div(splat(1), mul(splat(3), mul(v, v))));
        break;
        // Piecewise constant: floor, ceil, trunc, round, sign, comparisons and logic.
        HFRT_OP_CASES_PIECEWISE_CONSTANT
        r = flat(v);
        break;
        // Not computed from arguments: handled above (scalar_op would have failed first).
        HFRT_OP_CASES_NON_ARITH
        HFRT_CHECK_MSG(false, "gradient of an op without arguments: " << op_name(in.op));
        break;
    }
    values_[i] = r;
  }

  llvm::Value *x_, *stride_, *a_, *out_;
  llvm::AllocaInst* err_ = nullptr;
  std::vector<std::array<llvm::AllocaInst*, 4>> slots_;
  std::vector<DV> values_;
  std::vector<llvm::AllocaInst*> trips_;  ///< iteration counters of the enclosing loops
};

template <typename T>
using BlockFn = void (*)(const T* x, int64_t stride, const T* a, T* out) noexcept;

template <typename T>
void run_blocks(BlockFn<T> block, int w, int dims, int num_params, int64_t n, const T* xs,
                std::span<const double> a, T* out) {
  std::vector<T> params(std::max(num_params, 1), T(0));
  for (size_t k = 0; k < a.size() && k < params.size(); ++k) params[k] = static_cast<T>(a[k]);
  const int64_t full = n - n % w;
  for (int64_t i = 0; i < full; i += w) block(xs + i, n, params.data(), out + i);
  if (full < n) {
    const int64_t m = n - full;
    std::vector<T> x(static_cast<size_t>(w) * std::max(dims, 1)), o(4 * static_cast<size_t>(w));
    for (int k = 0; k < dims; ++k) {
      for (int j = 0; j < w; ++j) x[k * w + j] = xs[k * n + full + std::min<int64_t>(j, m - 1)];
    }
    block(x.data(), w, params.data(), o.data());
    for (int c = 0; c < 4; ++c) {
      for (int64_t j = 0; j < m; ++j) out[c * n + full + j] = o[c * w + j];
    }
  }
}

}  // namespace

struct GradientJit::Impl {
  std::unique_ptr<CompiledCode> code;
  Precision precision = Precision::kF64;
  int lanes = 0;
  int num_inputs = 0;
  int num_params = 0;
  JitStats stats;
};

GradientJit::GradientJit(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
GradientJit::~GradientJit() = default;
Precision GradientJit::precision() const {
  return impl_->precision;
}
int GradientJit::lanes() const {
  return impl_->lanes;
}
const JitStats& GradientJit::stats() const {
  return impl_->stats;
}

Result<std::unique_ptr<GradientJit>> GradientJit::compile(const Function& fn,
                                                          const Options& options) {
  Result<LlvmSession*> session = LlvmSession::get();
  if (!session.ok()) return session.error();
  const bool f32 = options.precision == Precision::kF32;
  auto impl = std::make_unique<Impl>();
  // (f32 sin and cos are vector code, GradientEmitter::sin_cos_f32; f64 ones call libm.)
  impl->lanes = options.lanes > 0 ? options.lanes
                                  : call_heavy_lanes(fn, session.value()->lanes(f32 ? 4 : 8), f32,
                                                     kCallHeavyLaneCalls);
  ModuleUnit unit = session.value()->new_module("hfrt_gradient");
  const std::string name = unit.name;
  auto t0 = std::chrono::steady_clock::now();
  GradientEmitter(*unit.module, fn, f32, impl->lanes).emit(name);
  impl->stats.emit_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  impl->stats.lanes = impl->lanes;
  PipelineOptions pipeline = domain_pipeline(options.opt_level);
  pipeline.fast_codegen_calls = kFastCodegenCalls;
  auto code = session.value()->compile(std::move(unit), name, pipeline, &impl->stats);
  if (!code.ok()) return code.error();
  impl->code = std::move(code.value());
  impl->precision = options.precision;
  impl->num_inputs = fn.num_inputs;
  impl->num_params = fn.num_params;
  return std::unique_ptr<GradientJit>(new GradientJit(std::move(impl)));
}

void GradientJit::eval(int64_t n, const double* xs, std::span<const double> a, double* out) const {
  HFRT_CHECK(impl_->precision == Precision::kF64);
  run_blocks(reinterpret_cast<BlockFn<double>>(impl_->code->entry()), impl_->lanes,
             impl_->num_inputs, impl_->num_params, n, xs, a, out);
}

void GradientJit::eval(int64_t n, const float* xs, std::span<const double> a, float* out) const {
  HFRT_CHECK(impl_->precision == Precision::kF32);
  run_blocks(reinterpret_cast<BlockFn<float>>(impl_->code->entry()), impl_->lanes,
             impl_->num_inputs, impl_->num_params, n, xs, a, out);
}

Dual GradientJit::eval_one(std::span<const double> x, std::span<const double> a) const {
  const int dims = std::max(impl_->num_inputs, 1);
  Dual d;
  if (impl_->precision == Precision::kF64) {
    std::vector<double> xs(dims, 0.0), out(4);
    for (int k = 0; k < dims && k < static_cast<int>(x.size()); ++k) xs[k] = x[k];
    eval(1, xs.data(), a, out.data());
    d = {out[0], {out[1], out[2], out[3]}};
  } else {
    std::vector<float> xs(dims, 0.0f), out(4);
    for (int k = 0; k < dims && k < static_cast<int>(x.size()); ++k)
      xs[k] = static_cast<float>(x[k]);
    eval(1, xs.data(), a, out.data());
    d = {out[0], {out[1], out[2], out[3]}};
  }
  return d;
}

}  // namespace hfrt::jit
