// The GPU kernels of a model (jit/nvptx.h): one LLVM module with
//   - the scalar JIT's body of the model (llvm_jit.cpp, f32, one lane);
//   - the libm functions it calls, defined from device_math.h (LLVM backend below);
//   - the point evaluator and the ray caster of gpu/kernel_abi.h.
// The module is built for NVPTX (entry points read the thread index; LLVM's NVPTX back end
// prints PTX) or for the host (entry points loop over an index range; ORC compiles them), from
// the same code: only the entry wrappers differ.

#include <llvm/IR/IntrinsicsNVPTX.h>
#include <llvm/IR/LegacyPassManager.h>
#include <llvm/MC/TargetRegistry.h>
#include <llvm/Support/CodeGen.h>

#include <cstddef>
#include <mutex>

#include "base/check.h"
#include "jit/device_math.h"
#include "jit/interval.h"
#include "jit/llvm_emit.h"
#include "jit/llvm_session.h"
#include "jit/nvptx.h"

// The ops that are not per-lane C calls (ir.h has the group of those that are).
#define HFRT_OP_IF_NOT_LANE_CALL_None(...) __VA_ARGS__
#define HFRT_OP_IF_NOT_LANE_CALL_Inline(...) __VA_ARGS__
#define HFRT_OP_IF_NOT_LANE_CALL_Intrinsic(...) __VA_ARGS__
#define HFRT_OP_IF_NOT_LANE_CALL_Libm(...)
#define HFRT_OP_IF_NOT_LANE_CALL_Helper(...)
#define HFRT_OP_CASE_NOT_LANE_CALL_X(name, n, f, kind, lane, ...) \
  HFRT_OP_IF_NOT_LANE_CALL_##lane(case ::hfrt::ir::Op::k##name:)
#define HFRT_OP_CASES_NOT_LANE_CALL HFRT_IR_OPS(HFRT_OP_CASE_NOT_LANE_CALL_X)

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

namespace {

// ---------------------------------------------------------------------------------------
// device_math.h's LLVM backend: values of type double in the builder g_b points at.

thread_local llvm::IRBuilder<>* g_b = nullptr;

/// Points g_b at a builder for the lifetime of the scope.
class IrScope {
 public:
  explicit IrScope(llvm::IRBuilder<>& b) : saved_(g_b) { g_b = &b; }
  ~IrScope() { g_b = saved_; }
  IrScope(const IrScope&) = delete;
  IrScope& operator=(const IrScope&) = delete;

 private:
  llvm::IRBuilder<>* saved_;
};

struct IrM {
  llvm::Value* v;
};
struct IrR {
  llvm::Value* v;
  IrR(llvm::Value* value) : v(value) {}
  IrR(double c) : v(llvm::ConstantFP::get(g_b->getDoubleTy(), c)) {}
};

IrR operator+(IrR a, IrR b) {
  return g_b->CreateFAdd(a.v, b.v);
}
IrR operator-(IrR a, IrR b) {
  return g_b->CreateFSub(a.v, b.v);
}
IrR operator*(IrR a, IrR b) {
  return g_b->CreateFMul(a.v, b.v);
}
IrR operator/(IrR a, IrR b) {
  return g_b->CreateFDiv(a.v, b.v);
}
IrR operator-(IrR a) {
  return g_b->CreateFNeg(a.v);
}
// As C++ compares doubles: ordered, except != (true for NaN).
IrM operator<(IrR a, IrR b) {
  return {g_b->CreateFCmpOLT(a.v, b.v)};
}
IrM operator<=(IrR a, IrR b) {
  return {g_b->CreateFCmpOLE(a.v, b.v)};
}
IrM operator>(IrR a, IrR b) {
  return {g_b->CreateFCmpOGT(a.v, b.v)};
}
[[maybe_unused]] IrM operator>=(IrR a, IrR b) {
  return {g_b->CreateFCmpOGE(a.v, b.v)};
}
IrM operator==(IrR a, IrR b) {
  return {g_b->CreateFCmpOEQ(a.v, b.v)};
}
IrM operator!=(IrR a, IrR b) {
  return {g_b->CreateFCmpUNE(a.v, b.v)};
}
IrM operator&(IrM a, IrM b) {
  return {g_b->CreateAnd(a.v, b.v)};
}
IrM operator|(IrM a, IrM b) {
  return {g_b->CreateOr(a.v, b.v)};
}
IrM operator!(IrM a) {
  return {g_b->CreateNot(a.v)};
}
IrR select(IrM m, IrR a, IrR b) {
  return g_b->CreateSelect(m.v, a.v, b.v);
}
IrR unary(llvm::Intrinsic::ID id, IrR x) {
  return g_b->CreateUnaryIntrinsic(id, x.v);
}
IrR fabs_(IrR x) {
  return unary(llvm::Intrinsic::fabs, x);
}
IrR sqrt_(IrR x) {
  return unary(llvm::Intrinsic::sqrt, x);
}
IrR floor_(IrR x) {
  return unary(llvm::Intrinsic::floor, x);
}
IrR trunc_(IrR x) {
  return unary(llvm::Intrinsic::trunc, x);
}
IrR rint_(IrR x) {
  return unary(llvm::Intrinsic::rint, x);
}
IrR copysign_(IrR a, IrR b) {
  return g_b->CreateBinaryIntrinsic(llvm::Intrinsic::copysign, a.v, b.v);
}
llvm::Value* bits_of(IrR x) {
  return g_b->CreateBitCast(x.v, g_b->getInt64Ty());
}
IrR frexp_mantissa_(IrR x) {
  // The fraction bits with the exponent of [0.5, 1) (x is a positive normal number).
  llvm::Value* m = g_b->CreateAnd(bits_of(x), g_b->getInt64(0x000FFFFFFFFFFFFFull));
  m = g_b->CreateOr(m, g_b->getInt64(uint64_t(1022) << 52));
  return g_b->CreateBitCast(m, g_b->getDoubleTy());
}
IrR frexp_exponent_(IrR x) {
  llvm::Value* e = g_b->CreateAnd(g_b->CreateLShr(bits_of(x), 52), g_b->getInt64(0x7FF));
  return g_b->CreateSIToFP(g_b->CreateSub(e, g_b->getInt64(1022)), g_b->getDoubleTy());
}
IrR pow2_(IrR k) {
  llvm::Value* e = g_b->CreateAdd(g_b->CreateFPToSI(k.v, g_b->getInt64Ty()), g_b->getInt64(1023));
  return g_b->CreateBitCast(g_b->CreateShl(e, 52), g_b->getDoubleTy());
}
IrR to_f32_(IrR x) {
  return g_b->CreateFPExt(g_b->CreateFPTrunc(x.v, g_b->getFloatTy()), g_b->getDoubleTy());
}

/// The device value of a per-lane C call op (the Libm and Helper lanes of ir_ops.h), on
/// arguments extended to double.
IrR device_libm(Op op, IrR a, IrR b) {
  switch (op) {
    case Op::kExp:
      return devmath::exp(a);
    case Op::kLog:
      return devmath::log(a);
    case Op::kLog10:
      return devmath::log10(a);
    case Op::kSin:
      return devmath::sin(a);
    case Op::kCos:
      return devmath::cos(a);
    case Op::kTan:
      return devmath::tan(a);
    case Op::kAsin:
      return devmath::asin(a);
    case Op::kAcos:
      return devmath::acos(a);
    case Op::kAtan:
      return devmath::atan(a);
    case Op::kAtan2:
      return devmath::atan2(a, b);
    case Op::kSinh:
      return devmath::sinh(a);
    case Op::kCosh:
      return devmath::cosh(a);
    case Op::kTanh:
      return devmath::tanh(a);
    case Op::kFmod:
      return devmath::fmod(a, b);
    case Op::kPow:
      return devmath::pow(a, b);
    case Op::kPowHF:
      return devmath::powhf_f32(a, b);
    case Op::kCbrt:
      return devmath::cbrt(a);
      HFRT_OP_CASES_NOT_LANE_CALL
      break;
  }
  HFRT_CHECK_MSG(false, "device_libm: not a per-lane call: " << op_name(op));
  return a;
}

/// The op whose f32 C function is `name`, if any.
bool lane_call_op(llvm::StringRef name, Op* out) {
  for (int i = 0; i < kOpCount; ++i) {
    const Op op = static_cast<Op>(i);
    const OpLane lane = op_lane(op);
    if (lane != OpLane::kLibm && lane != OpLane::kHelper) continue;
    if (name == op_libm_name(op, true)) {
      *out = op;
      return true;
    }
  }
  return false;
}

/// The float function `float name(float[, float])` of a lane-call op, declared.
llvm::Function* declare_lane_call(llvm::Module& m, Op op) {
  llvm::Type* f = llvm::Type::getFloatTy(m.getContext());
  std::vector<llvm::Type*> params(op_num_args(op), f);
  auto* ty = llvm::FunctionType::get(f, params, false);
  return llvm::cast<llvm::Function>(m.getOrInsertFunction(op_libm_name(op, true), ty).getCallee());
}

/// Gives every declared lane-call function of `m` its device_math.h body, renamed
/// hfrt_dev_<name> (internal), so that no libm call is left (the GPU has none) and no pass
/// mistakes it for the C function.
void define_device_libm(llvm::Module& m) {
  std::vector<std::pair<llvm::Function*, Op>> todo;
  for (llvm::Function& f : m) {
    Op op;
    if (f.isDeclaration() && lane_call_op(f.getName(), &op)) todo.emplace_back(&f, op);
  }
  for (auto [f, op] : todo) {
    f->setName("hfrt_dev_" + f->getName().str());
    f->setLinkage(llvm::GlobalValue::InternalLinkage);
    f->setDoesNotThrow();
    f->setWillReturn();
    f->setMemoryEffects(llvm::MemoryEffects::none());
    llvm::IRBuilder<> b(llvm::BasicBlock::Create(m.getContext(), "entry", f));
    IrScope scope(b);
    llvm::Type* d = b.getDoubleTy();
    IrR a = b.CreateFPExt(f->getArg(0), d);
    IrR c = f->arg_size() > 1 ? IrR(b.CreateFPExt(f->getArg(1), d)) : IrR(0.0);
    IrR r = device_libm(op, a, c);
    b.CreateRet(b.CreateFPTrunc(r.v, b.getFloatTy()));
  }
}

// ---------------------------------------------------------------------------------------
// The kernels.

enum class Target { kNvptx, kHost };

/// Emits the kernels of `fn` into `m` (whose triple and data layout are set).
class KernelEmitter {
 public:
  /// On the host, the entries are named `host_prefix`_eval and _render (ORC needs names
  /// unique in the session); on NVPTX, as gpu/kernel_abi.h says.
  KernelEmitter(llvm::Module& m, const Function& fn, Target target,
                const std::string& host_prefix = "")
      : m_(m),
        ctx_(m.getContext()),
        fn_(fn),
        target_(target),
        eval_name_(target == Target::kNvptx ? gpu::kEvalEntry : host_prefix + "_eval"),
        render_name_(target == Target::kNvptx ? gpu::kRenderEntry : host_prefix + "_render"),
        interval_name_(target == Target::kNvptx ? gpu::kIntervalEntry : host_prefix + "_interval"),
        b_(m.getContext()) {
    f32_ = b_.getFloatTy();
    i32_ = b_.getInt32Ty();
    i64_ = b_.getInt64Ty();
    ptr_ = b_.getPtrTy();
  }

  /// All kernels, or (eval_only) the point evaluator alone.
  void emit(bool eval_only = false) {
    body_ = emit_scalar_function(m_, fn_, Precision::kF32, 1, "");
    if (eval_only) {
      emit_eval_entry();
      define_device_libm(m_);
      return;
    }
    if (interval_code_is_self_contained(fn_)) {
      interval_body_ =
          emit_interval_function(m_, fn_, 1, kIntervalLoopLimit, "interval_body", &interval_homes_);
      interval_body_->setLinkage(llvm::GlobalValue::InternalLinkage);
      // Called from many places of the ray caster: one copy.
      interval_body_->addFnAttr(llvm::Attribute::NoInline);
      emit_interval_entry();
    }
    emit_eval_entry();
    emit_render_entry(emit_pixel());
    define_device_libm(m_);
  }

  bool has_interval() const { return interval_body_ != nullptr; }

 private:
  // --- Entries: thread index (NVPTX) or a loop over an index range (host) ----------------
  void mark_kernel(llvm::Function* f) {
    llvm::Metadata* md[] = {llvm::ValueAsMetadata::get(f), llvm::MDString::get(ctx_, "kernel"),
                            llvm::ConstantAsMetadata::get(b_.getInt32(1))};
    m_.getOrInsertNamedMetadata("nvvm.annotations")->addOperand(llvm::MDTuple::get(ctx_, md));
  }

  llvm::Value* thread_index() {
    auto sreg = [&](llvm::Intrinsic::ID id) {
      return b_.CreateZExt(b_.CreateIntrinsic(id, {}, {}), i64_);
    };
    return b_.CreateAdd(b_.CreateMul(sreg(llvm::Intrinsic::nvvm_read_ptx_sreg_ctaid_x),
                                     sreg(llvm::Intrinsic::nvvm_read_ptx_sreg_ntid_x)),
                        sreg(llvm::Intrinsic::nvvm_read_ptx_sreg_tid_x));
  }

  /// A function `name(params...)` whose code calls `per_thread(i)` for each thread index i:
  /// on NVPTX for its own thread when i < count(), on the host for i in [begin, end) (two
  /// extra i64 parameters at the end).
  template <typename Count, typename PerThread>
  void emit_entry(const std::string& name, std::vector<llvm::Type*> params, Count count,
                  PerThread per_thread) {
    if (target_ == Target::kHost) params.insert(params.end(), {i64_, i64_});
    auto* fty = llvm::FunctionType::get(b_.getVoidTy(), params, false);
    f_ = llvm::Function::Create(fty, llvm::GlobalValue::ExternalLinkage, name, m_);
    f_->setDoesNotThrow();
    auto* entry = llvm::BasicBlock::Create(ctx_, "entry", f_);
    auto* work = llvm::BasicBlock::Create(ctx_, "work", f_);
    auto* done = llvm::BasicBlock::Create(ctx_, "done", f_);
    b_.SetInsertPoint(entry);
    if (target_ == Target::kNvptx) {
      mark_kernel(f_);
      llvm::Value* i = thread_index();
      b_.CreateCondBr(b_.CreateICmpSLT(i, count()), work, done);
      b_.SetInsertPoint(work);
      per_thread(i);
      b_.CreateBr(done);
    } else {
      llvm::Value* begin = f_->getArg(f_->arg_size() - 2);
      llvm::Value* end = f_->getArg(f_->arg_size() - 1);
      auto* head = llvm::BasicBlock::Create(ctx_, "head", f_, work);
      b_.CreateBr(head);
      b_.SetInsertPoint(head);
      llvm::PHINode* i = b_.CreatePHI(i64_, 2, "i");
      i->addIncoming(begin, entry);
      b_.CreateCondBr(b_.CreateICmpSLT(i, end), work, done);
      b_.SetInsertPoint(work);
      per_thread(i);
      i->addIncoming(b_.CreateAdd(i, b_.getInt64(1)), b_.GetInsertBlock());
      b_.CreateBr(head);
    }
    b_.SetInsertPoint(done);
    b_.CreateRetVoid();
  }

  /// kEvalEntry: hfrt_eval_f32(i64 n, ptr xs, ptr a, ptr out_f, ptr out_s).
  void emit_eval_entry() {
    emit_entry(
        eval_name_, {i64_, ptr_, ptr_, ptr_, ptr_}, [&] { return f_->getArg(0); },
        [&](llvm::Value* i) {
          llvm::Value* n = f_->getArg(0);
          llvm::Value* out_s = f_->getArg(4);
          llvm::Value* s_ptr =
              b_.CreateSelect(b_.CreateIsNotNull(out_s), b_.CreateGEP(f32_, out_s, i),
                              llvm::ConstantPointerNull::get(ptr_));
          b_.CreateCall(body_, {b_.CreateGEP(f32_, f_->getArg(1), i), n, f_->getArg(2),
                                b_.CreateGEP(f32_, f_->getArg(3), i), s_ptr, n});
        });
  }

  /// kIntervalEntry: hfrt_interval_f64(i64 n, ptr xlo, ptr xhi, ptr a, ptr lo, ptr hi, ptr nan).
  void emit_interval_entry() {
    emit_entry(
        interval_name_, {i64_, ptr_, ptr_, ptr_, ptr_, ptr_, ptr_}, [&] { return f_->getArg(0); },
        [&](llvm::Value* i) {
          llvm::Type* f64 = b_.getDoubleTy();
          llvm::Value* scratch = interval_scratch(f_);
          b_.CreateCall(
              interval_body_,
              {b_.CreateGEP(f64, f_->getArg(1), i), b_.CreateGEP(f64, f_->getArg(2), i),
               f_->getArg(0), f_->getArg(3), b_.CreateGEP(f64, f_->getArg(4), i),
               b_.CreateGEP(f64, f_->getArg(5), i), b_.CreateGEP(b_.getInt8Ty(), f_->getArg(6), i),
               llvm::ConstantPointerNull::get(ptr_), scratch});
        });
  }

  /// The interval body's scratch (3 doubles per value home), an entry-block alloca of `f`.
  llvm::Value* interval_scratch(llvm::Function* f) {
    llvm::IRBuilder<> eb(&f->getEntryBlock(), f->getEntryBlock().begin());
    return eb.CreateAlloca(llvm::ArrayType::get(b_.getDoubleTy(), 3 * std::max(interval_homes_, 1)),
                           nullptr, "scratch");
  }

  /// kRenderEntry: hfrt_render_f32(ptr params, ptr a, ptr out).
  void emit_render_entry(llvm::Function* pixel) {
    emit_entry(
        render_name_, {ptr_, ptr_, ptr_},
        [&] {
          llvm::Value* p = f_->getArg(0);
          return b_.CreateMul(
              b_.CreateSExt(load_i32(p, offsetof(gpu::RenderParams, width)), i64_),
              b_.CreateSExt(load_i32(p, offsetof(gpu::RenderParams, height)), i64_));
        },
        [&](llvm::Value* i) {
          b_.CreateCall(pixel, {i, f_->getArg(0), f_->getArg(1), f_->getArg(2)});
        });
  }

  // --- Small helpers over floats -------------------------------------------------------
  struct V3 {
    llvm::Value* x;
    llvm::Value* y;
    llvm::Value* z;
  };
  llvm::Value* c(float v) { return llvm::ConstantFP::get(f32_, v); }
  llvm::Value* load_f32(llvm::Value* p, size_t offset) {
    return b_.CreateLoad(f32_, b_.CreateConstInBoundsGEP1_64(b_.getInt8Ty(), p, offset));
  }
  llvm::Value* load_i32(llvm::Value* p, size_t offset) {
    return b_.CreateLoad(i32_, b_.CreateConstInBoundsGEP1_64(b_.getInt8Ty(), p, offset));
  }
  V3 load_v3(llvm::Value* p, size_t offset) {
    return {load_f32(p, offset), load_f32(p, offset + 4), load_f32(p, offset + 8)};
  }
  llvm::Value* add(llvm::Value* a, llvm::Value* b) { return b_.CreateFAdd(a, b); }
  llvm::Value* sub(llvm::Value* a, llvm::Value* b) { return b_.CreateFSub(a, b); }
  llvm::Value* mul(llvm::Value* a, llvm::Value* b) { return b_.CreateFMul(a, b); }
  llvm::Value* div(llvm::Value* a, llvm::Value* b) { return b_.CreateFDiv(a, b); }
  llvm::Value* fabs(llvm::Value* v) { return b_.CreateUnaryIntrinsic(llvm::Intrinsic::fabs, v); }
  /// i1: v is neither infinite nor NaN.
  llvm::Value* finite(llvm::Value* v) { return b_.CreateFCmpOLT(fabs(v), c(INFINITY)); }
  llvm::Value* fmin(llvm::Value* a, llvm::Value* b) {  // std::min(a, b): b < a ? b : a
    return b_.CreateSelect(b_.CreateFCmpOLT(b, a), b, a);
  }
  llvm::Value* fmax(llvm::Value* a, llvm::Value* b) {  // std::max(a, b): a < b ? b : a
    return b_.CreateSelect(b_.CreateFCmpOLT(a, b), b, a);
  }
  V3 add(V3 a, V3 b) { return {add(a.x, b.x), add(a.y, b.y), add(a.z, b.z)}; }
  V3 sub(V3 a, V3 b) { return {sub(a.x, b.x), sub(a.y, b.y), sub(a.z, b.z)}; }
  V3 scale(V3 a, llvm::Value* s) { return {mul(a.x, s), mul(a.y, s), mul(a.z, s)}; }
  V3 neg(V3 a) { return {b_.CreateFNeg(a.x), b_.CreateFNeg(a.y), b_.CreateFNeg(a.z)}; }
  llvm::Value* dot(V3 a, V3 b) { return add(add(mul(a.x, b.x), mul(a.y, b.y)), mul(a.z, b.z)); }
  llvm::Value* length(V3 a) { return b_.CreateUnaryIntrinsic(llvm::Intrinsic::sqrt, dot(a, a)); }
  V3 normalize(V3 a) { return scale(a, div(c(1.0f), length(a))); }
  V3 select(llvm::Value* m, V3 a, V3 b) {
    return {b_.CreateSelect(m, a.x, b.x), b_.CreateSelect(m, a.y, b.y),
            b_.CreateSelect(m, a.z, b.z)};
  }
  llvm::Value* comp(V3 a, int i) { return i == 0 ? a.x : i == 1 ? a.y : a.z; }

  /// A mutable float/int variable (an entry-block alloca; mem2reg makes it a register).
  llvm::AllocaInst* var(llvm::Type* ty, llvm::Value* init, const char* name) {
    llvm::IRBuilder<> eb(&pixel_->getEntryBlock(), pixel_->getEntryBlock().begin());
    llvm::AllocaInst* a = eb.CreateAlloca(ty, nullptr, name);
    b_.CreateStore(init, a);
    return a;
  }
  llvm::Value* get(llvm::AllocaInst* v) { return b_.CreateLoad(v->getAllocatedType(), v); }
  void set(llvm::AllocaInst* v, llvm::Value* x) { b_.CreateStore(x, v); }
  llvm::BasicBlock* block(const char* name) { return llvm::BasicBlock::Create(ctx_, name, pixel_); }

  /// F at p (and, when s_out is set, the attributes s[1..] into it), by the model's body.
  llvm::Value* eval_f(V3 p, llvm::Value* s_out = nullptr) {
    b_.CreateStore(p.x, b_.CreateConstInBoundsGEP1_64(f32_, xs_, 0));
    b_.CreateStore(p.y, b_.CreateConstInBoundsGEP1_64(f32_, xs_, 1));
    b_.CreateStore(p.z, b_.CreateConstInBoundsGEP1_64(f32_, xs_, 2));
    b_.CreateStore(time_, b_.CreateConstInBoundsGEP1_64(f32_, xs_, 3));
    b_.CreateCall(body_, {xs_, b_.getInt64(1), a_, f_out_,
                          s_out ? s_out : llvm::ConstantPointerNull::get(ptr_), b_.getInt64(1)});
    return b_.CreateLoad(f32_, f_out_);
  }

  /// The ray-box test of render/camera.cpp intersect_box: sets *hit, *te, *tx, *axis.
  void intersect_box(V3 o, V3 d, llvm::Value** hit, llvm::Value** te, llvm::Value** tx,
                     llvm::Value** axis) {
    llvm::Value* t0 = c(-INFINITY);
    llvm::Value* t1 = c(INFINITY);
    llvm::Value* ax = b_.getInt32(-1);
    llvm::Value* ok = b_.getTrue();
    for (int i = 0; i < 3; ++i) {
      llvm::Value* oi = comp(o, i);
      llvm::Value* di = comp(d, i);
      llvm::Value* zero = b_.CreateFCmpOEQ(di, c(0.0f));
      llvm::Value* outside =
          b_.CreateOr(b_.CreateFCmpOLT(oi, comp(lo_, i)), b_.CreateFCmpOGT(oi, comp(hi_, i)));
      ok = b_.CreateAnd(ok, b_.CreateNot(b_.CreateAnd(zero, outside)));
      llvm::Value* inv = div(c(1.0f), di);
      llvm::Value* a = mul(sub(comp(lo_, i), oi), inv);
      llvm::Value* bb = mul(sub(comp(hi_, i), oi), inv);
      llvm::Value* swap = b_.CreateFCmpOGT(a, bb);
      llvm::Value* near = b_.CreateSelect(swap, bb, a);
      llvm::Value* far = b_.CreateSelect(swap, a, bb);
      llvm::Value* later = b_.CreateAnd(b_.CreateNot(zero), b_.CreateFCmpOGT(near, t0));
      t0 = b_.CreateSelect(later, near, t0);
      ax = b_.CreateSelect(later, b_.getInt32(i), ax);
      t1 = b_.CreateSelect(zero, t1, fmin(t1, far));
    }
    *hit = b_.CreateAnd(ok, b_.CreateFCmpOLE(t0, t1));
    *te = t0;
    *tx = t1;
    *axis = ax;
  }

  /// RootSearcher::sign_search over [t0, t1] of o + t d with step `step` (t units): sets
  /// `hit_t` to the refined crossing (or t0 when F(t0) >= 0, `at_start` true) and returns the
  /// i1 "hit". `any_hit`: stop at the first sample inside, without refining.
  llvm::Value* march(V3 o, V3 d, llvm::Value* t0, llvm::Value* t1, llvm::Value* step,
                     llvm::Value* eps, bool any_hit, llvm::AllocaInst* hit_t,
                     llvm::AllocaInst* at_start, llvm::Value* first_k = nullptr) {
    llvm::Type* f64 = b_.getDoubleTy();
    llvm::AllocaInst* hit = var(b_.getInt1Ty(), b_.getFalse(), "hit");
    llvm::BasicBlock* start = block("march.start");
    llvm::BasicBlock* head = block("march.head");
    llvm::BasicBlock* body = block("march.body");
    llvm::BasicBlock* inside = block("march.inside");
    llvm::BasicBlock* next = block("march.next");
    llvm::BasicBlock* done = block("march.done");
    llvm::Value* valid = b_.CreateAnd(b_.CreateFCmpOLE(t0, t1), b_.CreateFCmpOGT(step, c(0.0f)));
    b_.CreateCondBr(valid, start, done);

    b_.SetInsertPoint(start);
    // Sample k at t0 + k step (in double, as the CPU computes it), the last exactly at t1.
    llvm::Value* count = b_.CreateUnaryIntrinsic(
        llvm::Intrinsic::ceil,
        b_.CreateFDiv(b_.CreateFPExt(sub(t1, t0), f64), b_.CreateFPExt(step, f64)));
    llvm::Value* max_steps =
        b_.CreateSIToFP(load_i32(params_, offsetof(gpu::RenderParams, max_steps)), f64);
    count = b_.CreateSelect(b_.CreateFCmpOLT(count, max_steps), count, max_steps);
    llvm::Value* last = b_.CreateFPToSI(count, i64_);
    // The first sample: 0, or where interval culling found the first span that may hold the
    // surface (the samples stay on the grid of t0).
    if (!first_k) first_k = b_.getInt64(0);
    llvm::AllocaInst* k = var(i64_, first_k, "k");
    llvm::AllocaInst* prev_t = var(f32_, t0, "prev_t");
    llvm::AllocaInst* prev_f = var(f32_, c(0.0f), "prev_f");
    llvm::AllocaInst* cur_t = var(f32_, t0, "t");
    llvm::AllocaInst* cur_f = var(f32_, c(0.0f), "f");
    b_.CreateBr(head);

    b_.SetInsertPoint(head);
    b_.CreateCondBr(b_.CreateICmpSLE(get(k), last), body, done);

    b_.SetInsertPoint(body);
    llvm::Value* kv = get(k);
    llvm::Value* tk = b_.CreateFPTrunc(
        b_.CreateFAdd(b_.CreateFPExt(t0, f64),
                      b_.CreateFMul(b_.CreateSIToFP(kv, f64), b_.CreateFPExt(step, f64))),
        f32_);
    tk = b_.CreateSelect(b_.CreateICmpEQ(kv, last), t1, fmin(t1, tk));
    llvm::Value* f = eval_f(add(o, scale(d, tk)));
    set(cur_t, tk);
    set(cur_f, f);
    b_.CreateCondBr(b_.CreateFCmpOGE(f, c(0.0f)), inside, next);

    b_.SetInsertPoint(next);
    set(prev_t, tk);
    set(prev_f, f);
    set(k, b_.CreateAdd(kv, b_.getInt64(1)));
    b_.CreateBr(head);

    b_.SetInsertPoint(inside);
    set(hit, b_.getTrue());
    // Inside at the first sample: no bracket to refine (after culled spans, F < 0 was proven
    // up to this sample's span, so the root is at it within float resolution).
    llvm::Value* first = b_.CreateICmpEQ(get(k), first_k);
    set(at_start, b_.CreateICmpEQ(get(k), b_.getInt64(0)));
    if (any_hit) {
      set(hit_t, get(cur_t));
      b_.CreateBr(done);
    } else {
      llvm::BasicBlock* refine = block("refine");
      llvm::BasicBlock* at_first = block("at_first");
      b_.CreateCondBr(first, at_first, refine);
      b_.SetInsertPoint(at_first);
      set(hit_t, get(cur_t));
      b_.CreateBr(done);
      b_.SetInsertPoint(refine);
      set(hit_t, bisect(o, d, get(prev_t), get(prev_f), get(cur_t), get(cur_f), eps));
      b_.CreateBr(done);
    }
    b_.SetInsertPoint(done);
    return get(hit);
  }

  /// Bisection of [ta, tb] (F(ta) < 0 <= F(tb)) down to eps, then one regula falsi step
  /// (RootSearcher::refine, with halving in place of its 15-point batches).
  llvm::Value* bisect(V3 o, V3 d, llvm::Value* ta0, llvm::Value* fa0, llvm::Value* tb0,
                      llvm::Value* fb0, llvm::Value* eps) {
    llvm::AllocaInst* ta = var(f32_, ta0, "ta");
    llvm::AllocaInst* fa = var(f32_, fa0, "fa");
    llvm::AllocaInst* tb = var(f32_, tb0, "tb");
    llvm::AllocaInst* fb = var(f32_, fb0, "fb");
    llvm::BasicBlock* head = block("bisect.head");
    llvm::BasicBlock* body = block("bisect.body");
    llvm::BasicBlock* step = block("bisect.step");
    llvm::BasicBlock* done = block("bisect.done");
    b_.CreateBr(head);
    b_.SetInsertPoint(head);
    llvm::Value* width = sub(get(tb), get(ta));
    b_.CreateCondBr(b_.CreateFCmpOGT(width, eps), body, done);
    b_.SetInsertPoint(body);
    llvm::Value* mid = add(get(ta), mul(width, c(0.5f)));
    // Float resolution reached: the midpoint is one of the ends.
    llvm::Value* stuck =
        b_.CreateOr(b_.CreateFCmpOLE(mid, get(ta)), b_.CreateFCmpOGE(mid, get(tb)));
    b_.CreateCondBr(stuck, done, step);
    b_.SetInsertPoint(step);
    llvm::Value* fm = eval_f(add(o, scale(d, mid)));
    llvm::Value* in = b_.CreateFCmpOGE(fm, c(0.0f));
    set(tb, b_.CreateSelect(in, mid, get(tb)));
    set(fb, b_.CreateSelect(in, fm, get(fb)));
    set(ta, b_.CreateSelect(in, get(ta), mid));
    set(fa, b_.CreateSelect(in, get(fa), fm));
    b_.CreateBr(head);
    b_.SetInsertPoint(done);
    llvm::Value* a = get(ta);
    llvm::Value* bt = get(tb);
    llvm::Value* fav = get(fa);
    llvm::Value* fbv = get(fb);
    llvm::Value* diff = sub(fbv, fav);
    llvm::Value* ok = b_.CreateAnd(
        b_.CreateAnd(finite(fav), finite(fbv)),
        b_.CreateAnd(b_.CreateAnd(b_.CreateFCmpOLT(fav, c(0.0f)), b_.CreateFCmpOGE(fbv, c(0.0f))),
                     b_.CreateFCmpOGT(diff, c(0.0f))));
    llvm::Value* t = add(a, mul(sub(bt, a), div(b_.CreateFNeg(fav), diff)));
    t = fmin(fmax(t, a), bt);  // std::clamp(t, ta, tb)
    return b_.CreateSelect(ok, t, bt);
  }

  // --- Interval culling of ray ranges ------------------------------------------------------

  /// i1: F over the box of the segment o + t d, t in [ta, tb], may be >= 0 or have no value
  /// (the box is widened by the rounding of o + t d in float, so that every sample point the
  /// march computes in it is inside).
  llvm::Value* segment_may_hit(V3 o, V3 d, llvm::Value* ta, llvm::Value* tb) {
    llvm::Type* f64 = b_.getDoubleTy();
    V3 p0 = add(o, scale(d, ta)), p1 = add(o, scale(d, tb));
    llvm::Value* tmax = fmax(fabs(ta), fabs(tb));
    for (int k = 0; k < 3; ++k) {
      llvm::Value* w =
          add(mul(c(4e-7f), add(fabs(comp(o, k)), mul(fabs(comp(d, k)), tmax))), c(1e-30f));
      llvm::Value* lo = b_.CreateFPExt(sub(fmin(comp(p0, k), comp(p1, k)), w), f64);
      llvm::Value* hi = b_.CreateFPExt(add(fmax(comp(p0, k), comp(p1, k)), w), f64);
      b_.CreateStore(lo, b_.CreateConstInBoundsGEP1_64(f64, box_lo_, k));
      b_.CreateStore(hi, b_.CreateConstInBoundsGEP1_64(f64, box_hi_, k));
    }
    llvm::Value* t = b_.CreateFPExt(time_, f64);
    b_.CreateStore(t, b_.CreateConstInBoundsGEP1_64(f64, box_lo_, 3));
    b_.CreateStore(t, b_.CreateConstInBoundsGEP1_64(f64, box_hi_, 3));
    b_.CreateCall(interval_body_, {box_lo_, box_hi_, b_.getInt64(1), a_f64_, iv_lo_, iv_hi_,
                                   iv_nan_, llvm::ConstantPointerNull::get(ptr_), scratch_});
    llvm::Value* hi = b_.CreateLoad(f64, iv_hi_);
    llvm::Value* nan = b_.CreateICmpNE(b_.CreateLoad(b_.getInt8Ty(), iv_nan_), b_.getInt8(0));
    return b_.CreateOr(nan, b_.CreateNot(b_.CreateFCmpOLT(hi, llvm::ConstantFP::get(f64, 0.0))));
  }

  /// The march's first sample index on the grid t0 + k step: the start of the first of
  /// kRenderCullSpans equal pieces of [t0, t1] that may hold the surface; -1 when none does.
  llvm::Value* first_live_sample(V3 o, V3 d, llvm::Value* t0, llvm::Value* t1, llvm::Value* step) {
    const int spans = gpu::kRenderCullSpans;
    llvm::AllocaInst* k = var(i32_, b_.getInt32(0), "span");
    llvm::BasicBlock* head = block("cull.head");
    llvm::BasicBlock* body = block("cull.body");
    llvm::BasicBlock* next = block("cull.next");
    llvm::BasicBlock* done = block("cull.done");
    llvm::Value* len = sub(t1, t0);
    b_.CreateBr(head);
    b_.SetInsertPoint(head);
    b_.CreateCondBr(b_.CreateICmpSLT(get(k), b_.getInt32(spans)), body, done);
    b_.SetInsertPoint(body);
    llvm::Value* kf = b_.CreateSIToFP(get(k), f32_);
    llvm::Value* ta = add(t0, div(mul(len, kf), c(float(spans))));
    llvm::Value* tb = b_.CreateSelect(b_.CreateICmpEQ(get(k), b_.getInt32(spans - 1)), t1,
                                      add(t0, div(mul(len, add(kf, c(1.0f))), c(float(spans)))));
    b_.CreateCondBr(segment_may_hit(o, d, ta, tb), done, next);
    b_.SetInsertPoint(next);
    set(k, b_.CreateAdd(get(k), b_.getInt32(1)));
    b_.CreateBr(head);
    b_.SetInsertPoint(done);
    llvm::Value* span = get(k);
    // The grid sample at or before the span's start (the march keeps the CPU's positions).
    llvm::Type* f64 = b_.getDoubleTy();
    llvm::Value* start = b_.CreateFAdd(
        b_.CreateFPExt(t0, f64),
        b_.CreateFDiv(b_.CreateFMul(b_.CreateFPExt(len, f64), b_.CreateSIToFP(span, f64)),
                      llvm::ConstantFP::get(f64, spans)));
    llvm::Value* kk = b_.CreateUnaryIntrinsic(
        llvm::Intrinsic::floor,
        b_.CreateFDiv(b_.CreateFSub(start, b_.CreateFPExt(t0, f64)), b_.CreateFPExt(step, f64)));
    kk = b_.CreateSelect(b_.CreateFCmpOGT(kk, llvm::ConstantFP::get(f64, 0.0)), kk,
                         llvm::ConstantFP::get(f64, 0.0));
    // Clamp into i64 range (a zero step is refused by the march itself).
    kk = b_.CreateSelect(b_.CreateFCmpOLT(kk, llvm::ConstantFP::get(f64, 4.0e18)), kk,
                         llvm::ConstantFP::get(f64, 4.0e18));
    return b_.CreateSelect(b_.CreateICmpEQ(span, b_.getInt32(spans)), b_.getInt64(-1),
                           b_.CreateFPToSI(kk, i64_));
  }

  /// march() over [t0, t1], preceded by the interval culling when the model has it.
  llvm::Value* culled_march(V3 o, V3 d, llvm::Value* t0, llvm::Value* t1, llvm::Value* step,
                            llvm::Value* eps, bool any_hit, llvm::AllocaInst* hit_t,
                            llvm::AllocaInst* at_start) {
    if (!interval_body_) return march(o, d, t0, t1, step, eps, any_hit, hit_t, at_start);
    llvm::AllocaInst* hit = var(b_.getInt1Ty(), b_.getFalse(), "culled_hit");
    llvm::BasicBlock* search = block("culled.search");
    llvm::BasicBlock* done = block("culled.done");
    llvm::Value* valid = b_.CreateFCmpOLE(t0, t1);
    llvm::BasicBlock* cull = block("culled.cull");
    b_.CreateCondBr(valid, cull, done);
    b_.SetInsertPoint(cull);
    llvm::Value* first = first_live_sample(o, d, t0, t1, step);
    b_.CreateCondBr(b_.CreateICmpSGE(first, b_.getInt64(0)), search, done);
    b_.SetInsertPoint(search);
    set(hit, march(o, d, t0, t1, step, eps, any_hit, hit_t, at_start, first));
    b_.CreateBr(done);
    b_.SetInsertPoint(done);
    return get(hit);
  }

  /// The per-pixel function: void pixel(i64 i, ptr params, ptr a, ptr out).
  llvm::Function* emit_pixel() {
    auto* fty = llvm::FunctionType::get(b_.getVoidTy(), {i64_, ptr_, ptr_, ptr_}, false);
    pixel_ = llvm::Function::Create(fty, llvm::GlobalValue::InternalLinkage, "pixel", m_);
    pixel_->setDoesNotThrow();
    llvm::BasicBlock* entry = llvm::BasicBlock::Create(ctx_, "entry", pixel_);
    b_.SetInsertPoint(entry);
    llvm::Value* i = pixel_->getArg(0);
    params_ = pixel_->getArg(1);
    a_ = pixel_->getArg(2);
    llvm::Value* out = b_.CreateGEP(f32_, pixel_->getArg(3),
                                    b_.CreateMul(i, b_.getInt64(gpu::kRenderFloatsPerPixel)));
    xs_ = b_.CreateAlloca(llvm::ArrayType::get(f32_, 4), nullptr, "xs");
    f_out_ = b_.CreateAlloca(f32_, nullptr, "f");
    if (interval_body_) {
      llvm::Type* f64 = b_.getDoubleTy();
      box_lo_ = b_.CreateAlloca(llvm::ArrayType::get(f64, 4), nullptr, "box_lo");
      box_hi_ = b_.CreateAlloca(llvm::ArrayType::get(f64, 4), nullptr, "box_hi");
      iv_lo_ = b_.CreateAlloca(f64, nullptr, "iv_lo");
      iv_hi_ = b_.CreateAlloca(f64, nullptr, "iv_hi");
      iv_nan_ = b_.CreateAlloca(b_.getInt8Ty(), nullptr, "iv_nan");
      scratch_ = interval_scratch(pixel_);
      // The interval code reads a[] in double.
      const int np = std::max(fn_.num_params, 1);
      a_f64_ = b_.CreateAlloca(llvm::ArrayType::get(f64, np), nullptr, "a_f64");
      for (int k = 0; k < fn_.num_params; ++k) {
        llvm::Value* v = b_.CreateLoad(f32_, b_.CreateConstInBoundsGEP1_64(f32_, a_, k));
        b_.CreateStore(b_.CreateFPExt(v, f64), b_.CreateConstInBoundsGEP1_64(f64, a_f64_, k));
      }
    }
    const int num_s = static_cast<int>(fn_.s_slots.size());
    llvm::Value* s_buf =
        b_.CreateAlloca(llvm::ArrayType::get(f32_, std::max(num_s, 1)), nullptr, "s");

    using P = gpu::RenderParams;
    time_ = load_f32(params_, offsetof(P, time));
    lo_ = load_v3(params_, offsetof(P, box_lo));
    hi_ = load_v3(params_, offsetof(P, box_hi));
    llvm::Value* width = load_i32(params_, offsetof(P, width));
    llvm::Value* height = load_i32(params_, offsetof(P, height));
    llvm::Value* w64 = b_.CreateSExt(width, i64_);
    llvm::Value* px = b_.CreateSIToFP(b_.CreateSRem(i, w64), f32_);
    llvm::Value* py = b_.CreateSIToFP(b_.CreateSDiv(i, w64), f32_);
    px = add(px, c(0.5f));
    py = add(py, c(0.5f));
    // CameraFrame::ray.
    llvm::Value* sx = mul(sub(div(mul(c(2.0f), px), b_.CreateSIToFP(width, f32_)), c(1.0f)),
                          load_f32(params_, offsetof(P, half_w)));
    llvm::Value* sy = mul(sub(c(1.0f), div(mul(c(2.0f), py), b_.CreateSIToFP(height, f32_))),
                          load_f32(params_, offsetof(P, half_h)));
    V3 eye = load_v3(params_, offsetof(P, eye));
    V3 fwd = load_v3(params_, offsetof(P, forward));
    V3 offset = add(scale(load_v3(params_, offsetof(P, right)), sx),
                    scale(load_v3(params_, offsetof(P, up)), sy));
    llvm::Value* ortho = b_.CreateICmpNE(load_i32(params_, offsetof(P, ortho)), b_.getInt32(0));
    V3 o = select(ortho, add(eye, offset), eye);
    V3 d = select(ortho, fwd, add(fwd, offset));

    V3 background = load_v3(params_, offsetof(P, background));
    auto store_out = [&](int k, llvm::Value* v) {
      b_.CreateStore(v, b_.CreateConstInBoundsGEP1_64(f32_, out, k));
    };
    auto write_miss = [&] {
      store_out(0, background.x);
      store_out(1, background.y);
      store_out(2, background.z);
      for (int k = 3; k < gpu::kRenderFloatsPerPixel; ++k) store_out(k, c(0.0f));
    };

    // The box range (Renderer::box_range): perspective rays start at the eye at the latest.
    llvm::Value *hit_box, *te, *tx, *axis;
    intersect_box(o, d, &hit_box, &te, &tx, &axis);
    llvm::Value* eye_inside = b_.CreateAnd(b_.CreateNot(ortho), b_.CreateFCmpOLT(te, c(0.0f)));
    te = b_.CreateSelect(eye_inside, c(0.0f), te);
    axis = b_.CreateSelect(eye_inside, b_.getInt32(-1), axis);
    llvm::BasicBlock* search = block("search");
    llvm::BasicBlock* miss = block("miss");
    llvm::BasicBlock* shade = block("shade");
    llvm::BasicBlock* end = block("end");
    b_.CreateCondBr(hit_box, search, miss);

    b_.SetInsertPoint(miss);
    write_miss();
    b_.CreateBr(end);

    b_.SetInsertPoint(search);
    llvm::Value* step_w = load_f32(params_, offsetof(P, step));
    llvm::Value* eps_w = load_f32(params_, offsetof(P, eps));
    llvm::Value* dlen = length(d);
    llvm::AllocaInst* hit_t = var(f32_, c(0.0f), "hit_t");
    llvm::AllocaInst* at_start = var(b_.getInt1Ty(), b_.getFalse(), "at_start");
    llvm::Value* hit =
        culled_march(o, d, te, tx, div(step_w, dlen), div(eps_w, dlen), false, hit_t, at_start);
    b_.CreateCondBr(hit, shade, miss);

    b_.SetInsertPoint(shade);
    llvm::Value* t = get(hit_t);
    V3 p = add(o, scale(d, t));
    V3 view = neg(normalize(d));
    // The normal: a cap where the ray enters the box inside the solid, else -grad F (F grows
    // into the solid) by central differences, facing the viewer.
    llvm::Value* cap = b_.CreateAnd(get(at_start), b_.CreateICmpSGE(axis, b_.getInt32(0)));
    llvm::Value* h = mul(step_w, c(0.1f));
    llvm::Value* g[3];
    for (int k = 0; k < 3; ++k) {
      V3 e{c(0.0f), c(0.0f), c(0.0f)};
      (k == 0 ? e.x : k == 1 ? e.y : e.z) = h;
      g[k] = div(sub(eval_f(add(p, e)), eval_f(sub(p, e))), mul(c(2.0f), h));
    }
    V3 grad_n = neg(V3{g[0], g[1], g[2]});
    llvm::Value* glen = length(grad_n);
    llvm::Value* gl_ok =
        b_.CreateAnd(b_.CreateFCmpOGT(glen, c(0.0f)), b_.CreateFCmpOLT(glen, c(INFINITY)));
    V3 nrm = select(gl_ok, scale(grad_n, div(c(1.0f), glen)), view);
    V3 cap_n{c(0.0f), c(0.0f), c(0.0f)};
    for (int k = 0; k < 3; ++k) {
      llvm::Value* sign = b_.CreateSelect(b_.CreateFCmpOGT(comp(d, k), c(0.0f)), c(-1.0f), c(1.0f));
      llvm::Value* v = b_.CreateSelect(b_.CreateICmpEQ(axis, b_.getInt32(k)), sign, c(0.0f));
      (k == 0 ? cap_n.x : k == 1 ? cap_n.y : cap_n.z) = v;
    }
    nrm = select(cap, cap_n, nrm);
    nrm = select(b_.CreateFCmpOLT(dot(nrm, view), c(0.0f)), neg(nrm), nrm);

    // The albedo: s[1..3] clamped to [0, 1] when the model computes them and they are finite.
    V3 albedo = load_v3(params_, offsetof(P, albedo));
    if (num_s >= 3) {
      eval_f(p, s_buf);
      V3 s{b_.CreateLoad(f32_, b_.CreateConstInBoundsGEP1_64(f32_, s_buf, 0)),
           b_.CreateLoad(f32_, b_.CreateConstInBoundsGEP1_64(f32_, s_buf, 1)),
           b_.CreateLoad(f32_, b_.CreateConstInBoundsGEP1_64(f32_, s_buf, 2))};
      llvm::Value* all = b_.CreateAnd(b_.CreateAnd(finite(s.x), finite(s.y)), finite(s.z));
      auto clamp01 = [&](llvm::Value* v) {
        // vmin(vmax(a, 0), 1) as render/vec.h computes it.
        return fmin(fmax(v, c(0.0f)), c(1.0f));
      };
      albedo = select(all, V3{clamp01(s.x), clamp01(s.y), clamp01(s.z)}, albedo);
    }

    // Shading (Renderer::shade): ambient, then per light Lambert and Blinn-Phong, unless a
    // shadow ray finds the surface between the point and the light.
    llvm::AllocaInst* col_r =
        var(f32_, mul(albedo.x, load_f32(params_, offsetof(P, ambient))), "r");
    llvm::AllocaInst* col_g =
        var(f32_, mul(albedo.y, load_f32(params_, offsetof(P, ambient))), "g");
    llvm::AllocaInst* col_b =
        var(f32_, mul(albedo.z, load_f32(params_, offsetof(P, ambient))), "b");
    llvm::Value* num_lights = load_i32(params_, offsetof(P, num_lights));
    llvm::Value* shadows = b_.CreateICmpNE(load_i32(params_, offsetof(P, shadows)), b_.getInt32(0));
    llvm::Value* bias = load_f32(params_, offsetof(P, shadow_bias));
    llvm::Function* powf = declare_lane_call(m_, Op::kPow);
    for (int li = 0; li < gpu::kMaxLights; ++li) {
      llvm::BasicBlock* lit = block("light");
      llvm::BasicBlock* next = block("light.next");
      llvm::BasicBlock* add_light = block("light.add");
      b_.CreateCondBr(b_.CreateICmpSLT(b_.getInt32(li), num_lights), lit, next);
      b_.SetInsertPoint(lit);
      const size_t kind_off = offsetof(P, light_kind) + 4 * size_t(li);
      const size_t v_off = offsetof(P, light_v) + 12 * size_t(li);
      const size_t rad_off = offsetof(P, light_radiance) + 12 * size_t(li);
      llvm::Value* point =
          b_.CreateICmpEQ(load_i32(params_, kind_off), b_.getInt32(gpu::kLightPoint));
      V3 lv = load_v3(params_, v_off);
      V3 l = normalize(select(point, sub(lv, p), lv));
      llvm::Value* ndotl = dot(nrm, l);
      llvm::BasicBlock* facing = block("light.facing");
      b_.CreateCondBr(b_.CreateFCmpOGT(ndotl, c(0.0f)), facing, next);
      b_.SetInsertPoint(facing);
      llvm::BasicBlock* shadow = block("light.shadow");
      b_.CreateCondBr(shadows, shadow, add_light);
      // Renderer::shadow_ray and occluded: from p + n bias towards the light, inside the box
      // and before a point light.
      b_.SetInsertPoint(shadow);
      V3 so = add(p, scale(nrm, bias));
      V3 sl_point = sub(lv, so);
      llvm::Value* dist_point = length(sl_point);
      V3 sl = select(point, scale(sl_point, div(c(1.0f), dist_point)), normalize(lv));
      llvm::Value* dist = b_.CreateSelect(point, dist_point, c(INFINITY));
      llvm::Value *shit, *ste, *stx, *sax;
      intersect_box(so, sl, &shit, &ste, &stx, &sax);
      ste = fmax(ste, c(0.0f));
      stx = fmin(stx, dist);
      llvm::BasicBlock* shadow_search = block("light.shadow.search");
      b_.CreateCondBr(b_.CreateAnd(shit, b_.CreateFCmpOLE(ste, stx)), shadow_search, add_light);
      b_.SetInsertPoint(shadow_search);
      llvm::AllocaInst* st = var(f32_, c(0.0f), "st");
      llvm::AllocaInst* sst = var(b_.getInt1Ty(), b_.getFalse(), "sst");
      llvm::Value* occluded = culled_march(so, sl, ste, stx, step_w, eps_w, true, st, sst);
      b_.CreateCondBr(occluded, next, add_light);

      b_.SetInsertPoint(add_light);
      V3 hv = normalize(add(l, view));
      llvm::Value* spec = mul(load_f32(params_, offsetof(P, specular)),
                              b_.CreateCall(powf, {fmax(c(0.0f), dot(nrm, hv)),
                                                   load_f32(params_, offsetof(P, shininess))}));
      V3 rad = load_v3(params_, rad_off);
      set(col_r, add(get(col_r), add(mul(mul(albedo.x, rad.x), ndotl), mul(rad.x, spec))));
      set(col_g, add(get(col_g), add(mul(mul(albedo.y, rad.y), ndotl), mul(rad.y, spec))));
      set(col_b, add(get(col_b), add(mul(mul(albedo.z, rad.z), ndotl), mul(rad.z, spec))));
      b_.CreateBr(next);
      b_.SetInsertPoint(next);
    }
    store_out(0, get(col_r));
    store_out(1, get(col_g));
    store_out(2, get(col_b));
    store_out(3, c(1.0f));
    store_out(4, mul(t, dlen));
    store_out(5, nrm.x);
    store_out(6, nrm.y);
    store_out(7, nrm.z);
    b_.CreateBr(end);

    b_.SetInsertPoint(end);
    b_.CreateRetVoid();
    return pixel_;
  }

  llvm::Module& m_;
  llvm::LLVMContext& ctx_;
  const Function& fn_;
  const Target target_;
  const std::string eval_name_, render_name_, interval_name_;
  llvm::IRBuilder<> b_;
  llvm::Type* f32_;
  llvm::IntegerType* i32_;
  llvm::IntegerType* i64_;
  llvm::PointerType* ptr_;
  llvm::Function* body_ = nullptr;
  llvm::Function* f_ = nullptr;      ///< the entry being emitted
  llvm::Function* pixel_ = nullptr;  ///< the pixel function
  // Within the pixel function:
  llvm::Value* params_ = nullptr;
  llvm::Value* a_ = nullptr;
  llvm::Value* xs_ = nullptr;
  llvm::Value* f_out_ = nullptr;
  llvm::Value* time_ = nullptr;
  V3 lo_{}, hi_{};
  // The interval culling (when interval_body_ is set).
  llvm::Function* interval_body_ = nullptr;
  int interval_homes_ = 0;
  llvm::Value *box_lo_ = nullptr, *box_hi_ = nullptr, *iv_lo_ = nullptr, *iv_hi_ = nullptr,
              *iv_nan_ = nullptr, *scratch_ = nullptr, *a_f64_ = nullptr;
};

/// Emits the host's dispatcher of the device math functions:
///   float name(i32 op, float a, float b).
void emit_libm_dispatcher(llvm::Module& m, const std::string& name) {
  llvm::LLVMContext& ctx = m.getContext();
  llvm::IRBuilder<> b(ctx);
  auto* fty = llvm::FunctionType::get(b.getFloatTy(),
                                      {b.getInt32Ty(), b.getFloatTy(), b.getFloatTy()}, false);
  auto* f = llvm::Function::Create(fty, llvm::GlobalValue::ExternalLinkage, name, m);
  auto* entry = llvm::BasicBlock::Create(ctx, "entry", f);
  auto* fallback = llvm::BasicBlock::Create(ctx, "none", f);
  b.SetInsertPoint(fallback);
  b.CreateRet(llvm::ConstantFP::getNaN(b.getFloatTy()));
  b.SetInsertPoint(entry);
  llvm::SwitchInst* sw = b.CreateSwitch(f->getArg(0), fallback);
  for (int i = 0; i < kOpCount; ++i) {
    const Op op = static_cast<Op>(i);
    if (op_lane(op) != OpLane::kLibm && op_lane(op) != OpLane::kHelper) continue;
    auto* bb = llvm::BasicBlock::Create(ctx, op_libm_name(op, true), f);
    sw->addCase(b.getInt32(i), bb);
    b.SetInsertPoint(bb);
    llvm::Function* callee = declare_lane_call(m, op);
    std::vector<llvm::Value*> args{f->getArg(1)};
    if (op_num_args(op) == 2) args.push_back(f->getArg(2));
    b.CreateRet(b.CreateCall(callee, args));
  }
  define_device_libm(m);
}

// --- The NVPTX target ------------------------------------------------------------------

const llvm::Target* nvptx_target(std::string* error) {
  static std::once_flag once;
  std::call_once(once, [] {
    LLVMInitializeNVPTXTargetInfo();
    LLVMInitializeNVPTXTarget();
    LLVMInitializeNVPTXTargetMC();
    LLVMInitializeNVPTXAsmPrinter();
  });
  return llvm::TargetRegistry::lookupTarget("nvptx64-nvidia-cuda", *error);
}

Result<std::unique_ptr<llvm::TargetMachine>> nvptx_machine(const PtxOptions& options) {
  std::string error;
  const llvm::Target* target = nvptx_target(&error);
  if (!target) return Error{"this LLVM has no NVPTX back end: " + error};
  llvm::TargetOptions to;
  to.AllowFPOpFusion = llvm::FPOpFusion::Strict;  // no fma contraction: the host's values
  std::unique_ptr<llvm::TargetMachine> tm(target->createTargetMachine(
      "nvptx64-nvidia-cuda", options.sm, "", to, std::nullopt, std::nullopt,
      options.opt_level <= 0 ? llvm::CodeGenOptLevel::None : llvm::CodeGenOptLevel::Default));
  if (!tm) return Error{"cannot create the NVPTX target machine for " + options.sm};
  return tm;
}

void optimize(llvm::Module& m, llvm::TargetMachine* tm, int opt_level) {
  llvm::LoopAnalysisManager lam;
  llvm::FunctionAnalysisManager fam;
  llvm::CGSCCAnalysisManager cgam;
  llvm::ModuleAnalysisManager mam;
  llvm::PassBuilder pb(tm);
  pb.registerModuleAnalyses(mam);
  pb.registerCGSCCAnalyses(cgam);
  pb.registerFunctionAnalyses(fam);
  pb.registerLoopAnalyses(lam);
  pb.crossRegisterProxies(lam, fam, cgam, mam);
  llvm::ModulePassManager mpm =
      opt_level <= 0
          ? pb.buildO0DefaultPipeline(llvm::OptimizationLevel::O0)
          : pb.buildPerModuleDefaultPipeline(opt_level == 1   ? llvm::OptimizationLevel::O1
                                             : opt_level == 2 ? llvm::OptimizationLevel::O2
                                                              : llvm::OptimizationLevel::O3);
  mpm.run(m, mam);
}

void verify(const llvm::Module& m) {
  std::string msg;
  llvm::raw_string_ostream os(msg);
  HFRT_CHECK_MSG(!llvm::verifyModule(m, &os), "invalid device LLVM IR emitted: " << os.str());
}

}  // namespace

std::string device_unsupported_reason(const Function& fn) {
  if (!fn.surfaces.empty()) {
    return "mesh and patch leaves (hfMesh, hfTriangles, hfBezier*) are not on the GPU yet";
  }
  return "";
}

namespace {
/// The kernels of `fn` (or the point evaluator alone) in a fresh, verified NVPTX module.
Result<std::unique_ptr<llvm::Module>> nvptx_module(llvm::LLVMContext& ctx, const Function& fn,
                                                   const PtxOptions& options,
                                                   std::unique_ptr<llvm::TargetMachine>* tm) {
  if (std::string why = device_unsupported_reason(fn); !why.empty()) return Error{why};
  auto machine = nvptx_machine(options);
  if (!machine.ok()) return machine.error();
  *tm = std::move(machine).value();
  auto m = std::make_unique<llvm::Module>("hfrt_device", ctx);
  m->setTargetTriple("nvptx64-nvidia-cuda");
  m->setDataLayout((*tm)->createDataLayout());
  KernelEmitter(*m, fn, Target::kNvptx).emit(options.eval_only);
  verify(*m);
  return m;
}
}  // namespace

Result<std::string> device_llvm_ir(const Function& fn) {
  llvm::LLVMContext ctx;
  std::unique_ptr<llvm::TargetMachine> tm;
  auto m = nvptx_module(ctx, fn, {}, &tm);
  if (!m.ok()) return m.error();
  std::string text;
  llvm::raw_string_ostream os(text);
  m.value()->print(os, nullptr);
  return os.str();
}

Result<std::string> emit_ptx(const Function& fn, const PtxOptions& options) {
  llvm::LLVMContext ctx;
  std::unique_ptr<llvm::TargetMachine> tm;
  auto module = nvptx_module(ctx, fn, options, &tm);
  if (!module.ok()) return module.error();
  llvm::Module& m = *module.value();
  optimize(m, tm.get(), options.opt_level);
  llvm::SmallString<0> ptx;
  llvm::raw_svector_ostream os(ptx);
  llvm::legacy::PassManager pm;
  if (tm->addPassesToEmitFile(pm, os, nullptr, llvm::CodeGenFileType::AssemblyFile)) {
    return Error{"the NVPTX back end cannot emit PTX"};
  }
  pm.run(m);
  return std::string(ptx.str());
}

// --- The kernels on the host --------------------------------------------------------------

namespace {
using HostEvalFn = void (*)(int64_t, const float*, const float*, float*, float*, int64_t, int64_t);
using HostRenderFn = void (*)(const gpu::RenderParams*, const float*, float*, int64_t, int64_t);
using HostIntervalFn = void (*)(int64_t, const double*, const double*, const double*, double*,
                                double*, uint8_t*, int64_t, int64_t);
using HostLibmFn = float (*)(int32_t, float, float);

/// Compiles the kernels (or, without `fn`, the libm dispatcher) for the host; `which` is the
/// entry wanted ("eval", "render" or "libm").
Result<std::unique_ptr<CompiledCode>> compile_for_host(const Function* fn, const char* which) {
  Result<LlvmSession*> session = LlvmSession::get();
  if (!session.ok()) return session.error();
  ModuleUnit unit = session.value()->new_module("hfrt_device_host");
  const std::string entry = unit.name + "_" + which;
  if (fn) {
    KernelEmitter(*unit.module, *fn, Target::kHost, unit.name).emit();
  } else {
    emit_libm_dispatcher(*unit.module, entry);
  }
  PipelineOptions po;
  po.opt_level = 2;
  po.codegen = llvm::CodeGenOptLevel::Default;
  return session.value()->compile(std::move(unit), entry, po, nullptr, nullptr);
}
}  // namespace

struct HostKernels::Impl {
  std::unique_ptr<CompiledCode> eval_code, render_code, interval_code;
  HostEvalFn eval = nullptr;
  HostRenderFn render = nullptr;
  HostIntervalFn interval = nullptr;
};

HostKernels::HostKernels(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
HostKernels::~HostKernels() = default;

Result<std::unique_ptr<HostKernels>> HostKernels::compile(const Function& fn) {
  if (std::string why = device_unsupported_reason(fn); !why.empty()) return Error{why};
  auto impl = std::make_unique<Impl>();
  auto eval = compile_for_host(&fn, "eval");
  if (!eval.ok()) return eval.error();
  auto render = compile_for_host(&fn, "render");
  if (!render.ok()) return render.error();
  impl->eval_code = std::move(eval.value());
  impl->render_code = std::move(render.value());
  impl->eval = reinterpret_cast<HostEvalFn>(impl->eval_code->entry());
  impl->render = reinterpret_cast<HostRenderFn>(impl->render_code->entry());
  if (interval_code_is_self_contained(fn)) {
    auto interval = compile_for_host(&fn, "interval");
    if (!interval.ok()) return interval.error();
    impl->interval_code = std::move(interval.value());
    impl->interval = reinterpret_cast<HostIntervalFn>(impl->interval_code->entry());
  }
  return std::unique_ptr<HostKernels>(new HostKernels(std::move(impl)));
}

void HostKernels::eval(int64_t n, const float* xs, const float* a, float* out_f,
                       float* out_s) const {
  impl_->eval(n, xs, a, out_f, out_s, 0, n);
}

bool HostKernels::has_interval() const {
  return impl_->interval != nullptr;
}

void HostKernels::interval(int64_t n, const double* xlo, const double* xhi, const double* a,
                           double* out_lo, double* out_hi, uint8_t* out_nan) const {
  HFRT_CHECK(impl_->interval);
  impl_->interval(n, xlo, xhi, a, out_lo, out_hi, out_nan, 0, n);
}

void HostKernels::render(const gpu::RenderParams& params, const float* a, float* out, int64_t begin,
                         int64_t end) const {
  impl_->render(&params, a, out, begin, end);
}

struct HostDeviceLibm::Impl {
  std::unique_ptr<CompiledCode> code;
  HostLibmFn fn = nullptr;
};

HostDeviceLibm::HostDeviceLibm(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
HostDeviceLibm::~HostDeviceLibm() = default;

Result<std::unique_ptr<HostDeviceLibm>> HostDeviceLibm::compile() {
  auto code = compile_for_host(nullptr, "libm");
  if (!code.ok()) return code.error();
  auto impl = std::make_unique<Impl>();
  impl->code = std::move(code.value());
  impl->fn = reinterpret_cast<HostLibmFn>(impl->code->entry());
  return std::unique_ptr<HostDeviceLibm>(new HostDeviceLibm(std::move(impl)));
}

float HostDeviceLibm::operator()(Op op, float a, float b) const {
  return impl_->fn(static_cast<int32_t>(op), a, b);
}

}  // namespace hfrt::jit
