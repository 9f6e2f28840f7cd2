// Shared emitter code: see llvm_emit.h.

#include "jit/llvm_emit.h"

#include <algorithm>
#include <cmath>

#include "base/check.h"
#include "ir/scalar_ops.h"
#include "ir/trig.h"
#include "jit/llvm_session.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

std::vector<int> written_slots(const Function& fn, size_t begin, size_t end) {
  std::vector<char> w(fn.num_slots, 0);
  for (size_t i = begin; i < end; ++i) {
    const Inst& in = fn.insts[i];
    if (in.op == Op::kStoreSlot) w[in.aux] = 1;
    if (in.op == Op::kStoreIdx) {
      for (int k = 0; k < static_cast<int>(in.imm); ++k) w[in.aux + k] = 1;
    }
  }
  std::vector<int> out;
  for (int s = 0; s < fn.num_slots; ++s) {
    if (w[s]) out.push_back(s);
  }
  return out;
}

ValueHomes plan_value_homes(const Function& fn, bool params_at_use,
                            const std::vector<ValueId>& extra_uses) {
  const size_t n = fn.insts.size();
  // The innermost loop around each instruction (-1: none); a kLoop marker is outside its loop.
  std::vector<int32_t> loop_of(n, -1), loop_end(n, -1), parent(n, -1);
  std::vector<int32_t> open;
  for (size_t i = 0; i < n; ++i) {
    loop_of[i] = open.empty() ? -1 : open.back();
    if (fn.insts[i].op == Op::kLoop) {
      parent[i] = loop_of[i];
      open.push_back(static_cast<int32_t>(i));
    } else if (fn.insts[i].op == Op::kEndLoop) {
      HFRT_CHECK(!open.empty());
      loop_end[open.back()] = static_cast<int32_t>(i);
      open.pop_back();
      loop_of[i] = open.empty() ? -1 : open.back();
    }
  }
  // Last use of each value, extended to the end of the outermost loop that encloses a use
  // but not the definition (the use runs again on the next iteration).
  std::vector<int64_t> last(n, -1);
  auto use = [&](ValueId v, size_t at) {
    int64_t end = static_cast<int64_t>(at);
    for (int32_t l = loop_of[at]; l > static_cast<int32_t>(v); l = parent[l]) {
      end = std::max<int64_t>(end, loop_end[l]);
    }
    last[v] = std::max(last[v], end);
  };
  for (size_t i = 0; i < n; ++i) {
    for (ValueId a : fn.insts[i].args) {
      if (a != kNoValue) use(a, i);
    }
    if (!extra_uses.empty()) {
      for (int k = 0; k < 2; ++k) {
        if (extra_uses[2 * i + k] != kNoValue) use(extra_uses[2 * i + k], i);
      }
    }
  }
  if (fn.result != kNoValue) last[fn.result] = static_cast<int64_t>(n);

  ValueHomes h;
  h.home.assign(n, -1);
  std::vector<int32_t> free_homes;
  std::vector<std::vector<int32_t>> dies_at(n + 1);
  for (size_t i = 0; i < n; ++i) {
    const Op op = fn.insts[i].op;
    if (op_has_value(op) && op != Op::kConst && !(params_at_use && op == Op::kParam)) {
      if (free_homes.empty()) {
        h.home[i] = h.num_homes++;
      } else {
        h.home[i] = free_homes.back();
        free_homes.pop_back();
      }
      // Freed after its last use (after the definition when it has none).
      const int64_t end = std::min<int64_t>(std::max<int64_t>(last[i], static_cast<int64_t>(i)),
                                            static_cast<int64_t>(n));
      dies_at[static_cast<size_t>(end)].push_back(h.home[i]);
    }
    // Homes whose value was used for the last time here serve later definitions.
    for (int32_t d : dies_at[i]) free_homes.push_back(d);
    dies_at[i].clear();
  }
  return h;
}

VectorEmitter::VectorEmitter(llvm::Module& module, const Function& fn, llvm::Type* element,
                             int lanes)
    : ctx_(module.getContext()),
      m_(module),
      b_(module.getContext()),
      fn_(fn),
      w_(lanes),
      is_f32_(element->isFloatTy()),
      st_(element) {
  HFRT_CHECK_MSG(lanes > 0 && (lanes & (lanes - 1)) == 0, "lanes must be a power of two");
  vt_ = llvm::FixedVectorType::get(st_, w_);
  mt_ = llvm::FixedVectorType::get(llvm::Type::getInt1Ty(ctx_), w_);
  i64_ = llvm::Type::getInt64Ty(ctx_);
  i32_ = llvm::Type::getInt32Ty(ctx_);
  i8_ = llvm::Type::getInt8Ty(ctx_);
  ptr_ = llvm::PointerType::get(ctx_, 0);
  align_ = llvm::Align(is_f32_ ? 4 : 8);
}

llvm::Value* VectorEmitter::truth(llvm::Value* v) {
  return b_.CreateFCmpOGE(fabs(v), splat(kHfEps));
}

void VectorEmitter::cut_block(llvm::Value* positive) {
  if (escape_of_ != f_) {
    escape_of_ = f_;
    escape_ = llvm::BasicBlock::Create(ctx_, "escape", f_);
    llvm::IRBuilder<> eb(escape_);
    HFRT_CHECK(f_->getReturnType()->isVoidTy());
    eb.CreateRetVoid();
  }
  llvm::BasicBlock* next = new_block("ops");
  llvm::Value* never =
      b_.CreateICmpEQ(positive, llvm::ConstantInt::get(positive->getType(), -++cuts_));
  b_.CreateCondBr(never, escape_, next);
  b_.SetInsertPoint(next);
}

llvm::AllocaInst* VectorEmitter::entry_alloca(llvm::Type* ty, const char* name) {
  llvm::BasicBlock& entry = f_->getEntryBlock();
  llvm::IRBuilder<> eb(&entry, entry.begin());
  return eb.CreateAlloca(ty, nullptr, name);
}

llvm::FunctionCallee VectorEmitter::pure_function(const char* name, int args) {
  std::vector<llvm::Type*> params(args, st_);
  auto* ty = llvm::FunctionType::get(st_, params, false);
  llvm::FunctionCallee callee = m_.getOrInsertFunction(name, ty);
  if (auto* f = llvm::dyn_cast<llvm::Function>(callee.getCallee())) {
    f->setDoesNotThrow();
    f->setWillReturn();
    f->setMemoryEffects(llvm::MemoryEffects::none());
  }
  return callee;
}

llvm::Value* VectorEmitter::call_lanes(llvm::FunctionCallee f, llvm::Value* a, llvm::Value* b) {
  if (uniform_op_) {
    llvm::Value* a0 = b_.CreateExtractElement(a, uint64_t(0));
    llvm::CallInst* call = b ? b_.CreateCall(f, {a0, b_.CreateExtractElement(b, uint64_t(0))})
                             : b_.CreateCall(f, {a0});
    call->setDoesNotThrow();
    return b_.CreateVectorSplat(w_, call);
  }
  llvm::Value* r = llvm::PoisonValue::get(vt_);
  for (int i = 0; i < w_; ++i) {
    llvm::Value* ai = b_.CreateExtractElement(a, uint64_t(i));
    llvm::CallInst* call = b ? b_.CreateCall(f, {ai, b_.CreateExtractElement(b, uint64_t(i))})
                             : b_.CreateCall(f, {ai});
    call->setDoesNotThrow();
    r = b_.CreateInsertElement(r, call, uint64_t(i));
  }
  return r;
}

llvm::Value* VectorEmitter::surface_pointer(int index) {
  HFRT_CHECK(index >= 0 && index < static_cast<int>(fn_.surfaces.size()));
  // A symbol, not the address itself: the code stays cacheable (host_address()).
  return host_address(m_, "hfrt.surface." + std::to_string(index), fn_.surfaces[index].get());
}

llvm::FunctionCallee VectorEmitter::surface_helper(const char* name) {
  auto* ty = llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_), {ptr_, ptr_, ptr_}, false);
  llvm::FunctionCallee callee = m_.getOrInsertFunction(name, ty);
  if (auto* f = llvm::dyn_cast<llvm::Function>(callee.getCallee())) f->setDoesNotThrow();
  return callee;
}

llvm::Value* VectorEmitter::surface_lanes(int index, llvm::Value* x, llvm::Value* y, llvm::Value* z,
                                          bool sign_only) {
  auto* ty = llvm::FunctionType::get(st_, {ptr_, st_, st_, st_}, false);
  llvm::FunctionCallee f =
      m_.getOrInsertFunction(sign_only ? pick_name("hfrt_surface_sign_f64", "hfrt_surface_sign_f32")
                                       : pick_name("hfrt_surface_f64", "hfrt_surface_f32"),
                             ty);
  if (auto* fn = llvm::dyn_cast<llvm::Function>(f.getCallee())) {
    // Reads the immutable surface only: no side effect the optimiser must keep.
    fn->setDoesNotThrow();
    fn->setWillReturn();
    fn->setOnlyReadsMemory();
  }
  llvm::Value* s = surface_pointer(index);
  llvm::Value* r = llvm::PoisonValue::get(vt_);
  for (int i = 0; i < w_; ++i) {
    auto e = [&](llvm::Value* v) { return b_.CreateExtractElement(v, uint64_t(i)); };
    llvm::CallInst* call = b_.CreateCall(f, {s, e(x), e(y), e(z)});
    call->setDoesNotThrow();
    r = b_.CreateInsertElement(r, call, uint64_t(i));
  }
  return r;
}

llvm::Value* VectorEmitter::trig_kernel(llvm::Value* x, bool cos) {
  using namespace trig_detail;
  auto* dt = llvm::cast<llvm::FixedVectorType>(x->getType());
  auto k_ = [&](double v) { return llvm::ConstantFP::get(dt, v); };
  auto add = [&](llvm::Value* p, llvm::Value* q) { return b_.CreateFAdd(p, q); };
  auto sub = [&](llvm::Value* p, llvm::Value* q) { return b_.CreateFSub(p, q); };
  auto mul = [&](llvm::Value* p, llvm::Value* q) { return b_.CreateFMul(p, q); };
  auto eq = [&](llvm::Value* p, double v) { return b_.CreateFCmpOEQ(p, k_(v)); };
  llvm::Value* k = sub(add(mul(x, k_(kTwoOverPi)), k_(kRoundShift)), k_(kRoundShift));
  llvm::Value* r = sub(x, mul(k, k_(kPio2Hi)));
  llvm::Value* w = mul(k, k_(kPio2Mid));
  llvm::Value* t = r;
  r = sub(t, w);
  w = sub(mul(k, k_(kPio2Lo)), sub(sub(t, r), w));
  llvm::Value* y0 = sub(r, w);
  llvm::Value* y1 = sub(sub(r, y0), w);
  llvm::Value* z = mul(y0, y0);
  // Horner from the highest coefficient: c0 + z (c1 + z (... + z c5)).
  auto horner = [&](std::initializer_list<double> c) {
    const double* cs = c.begin();
    llvm::Value* p = k_(cs[c.size() - 1]);
    for (size_t i = c.size() - 1; i-- > 0;) p = add(k_(cs[i]), mul(z, p));
    return p;
  };
  llvm::Value* v = mul(z, y0);
  llvm::Value* ps = horner({kS2, kS3, kS4, kS5, kS6});
  llvm::Value* s =
      sub(y0, sub(sub(mul(z, sub(mul(k_(0.5), y1), mul(v, ps))), y1), mul(v, k_(kS1))));
  llvm::Value* pc = mul(z, horner({kC1, kC2, kC3, kC4, kC5, kC6}));
  llvm::Value* hz = mul(k_(0.5), z);
  llvm::Value* wc = sub(k_(1.0), hz);
  llvm::Value* c = add(wc, add(sub(sub(k_(1.0), wc), hz), sub(mul(z, pc), mul(y0, y1))));
  llvm::Value* q =
      sub(k, mul(k_(4.0), b_.CreateUnaryIntrinsic(llvm::Intrinsic::floor, mul(k, k_(0.25)))));
  q = add(q, k_(cos ? 1.0 : 0.0));
  llvm::Value* odd = b_.CreateOr(eq(q, 1.0), eq(q, 3.0));
  llvm::Value* negative = b_.CreateOr(eq(q, 2.0), eq(q, 3.0));
  llvm::Value* res = b_.CreateSelect(odd, c, s);
  return b_.CreateSelect(negative, b_.CreateFNeg(res), res);
}

llvm::Value* VectorEmitter::sin_cos_f32(llvm::Value* a, bool cos) {
  auto* dt = llvm::FixedVectorType::get(llvm::Type::getDoubleTy(ctx_), w_);
  llvm::Value* d = b_.CreateFPExt(a, dt);
  llvm::Value* fast = b_.CreateFPTrunc(trig_kernel(d, cos), vt_);
  llvm::Value* beyond = b_.CreateFCmpOGT(b_.CreateUnaryIntrinsic(llvm::Intrinsic::fabs, d),
                                         llvm::ConstantFP::get(dt, kTrigKernelLimit));
  // Lanes beyond the kernel's range (rare: |x| > 2^20) take libm's double function.
  llvm::BasicBlock* from = b_.GetInsertBlock();
  llvm::BasicBlock* slow = new_block("trig_libm");
  llvm::BasicBlock* join = new_block("trig_join");
  b_.CreateCondBr(any(beyond), slow, join);
  b_.SetInsertPoint(slow);
  // Every lane by libm's double function, in one call of a host helper (llvm_jit.cpp's
  // hfrt_jit_trig_lanes_f32): per-lane calls here made each sin or cos w_ calls of code.
  llvm::Type* i32 = b_.getInt32Ty();
  auto* fty =
      llvm::FunctionType::get(b_.getVoidTy(), {b_.getPtrTy(), b_.getPtrTy(), i32, i32}, false);
  llvm::FunctionCallee f = m_.getOrInsertFunction("hfrt_jit_trig_lanes_f32", fty);
  if (auto* fn = llvm::dyn_cast<llvm::Function>(f.getCallee())) {
    fn->setDoesNotThrow();
    fn->setWillReturn();
  }
  llvm::AllocaInst* in = entry_alloca(dt, "trig.in");
  llvm::AllocaInst* out = entry_alloca(vt_, "trig.out");
  b_.CreateStore(d, in);
  llvm::CallInst* call = b_.CreateCall(
      f, {in, out, llvm::ConstantInt::get(i32, w_), llvm::ConstantInt::get(i32, cos ? 1 : 0)});
  call->setDoesNotThrow();
  llvm::Value* libm = b_.CreateLoad(vt_, out);
  llvm::Value* mixed = b_.CreateSelect(beyond, libm, fast);
  llvm::BasicBlock* slow_end = b_.GetInsertBlock();
  b_.CreateBr(join);
  b_.SetInsertPoint(join);
  llvm::PHINode* phi = b_.CreatePHI(vt_, 2);
  phi->addIncoming(fast, from);
  phi->addIncoming(mixed, slow_end);
  return phi;
}

llvm::Value* VectorEmitter::scalar_op(Op op, llvm::Value* a, llvm::Value* b, llvm::Value* c) {
  auto unary = [&](llvm::Intrinsic::ID id) { return b_.CreateUnaryIntrinsic(id, a); };
  switch (op) {
    case Op::kAdd:
      return b_.CreateFAdd(a, b);
    case Op::kSub:
      return b_.CreateFSub(a, b);
    case Op::kMul:
      return b_.CreateFMul(a, b);
    case Op::kDiv:
      return b_.CreateFDiv(a, b);
    case Op::kNeg:
      return b_.CreateFNeg(a);
    case Op::kAbs:
      return fabs(a);
    // As written in ir_ops.h: a < b ? a : b (NaN -> b), which is x86's minps/maxps.
    case Op::kMin:
      return b_.CreateSelect(b_.CreateFCmpOLT(a, b), a, b);
    case Op::kMax:
      return b_.CreateSelect(b_.CreateFCmpOGT(a, b), a, b);
    case Op::kSqrt:
      return unary(llvm::Intrinsic::sqrt);
      // A per-lane call of the libm function or hfrt helper named by ir_ops.h (the very
      // function the interpreter calls).
      HFRT_OP_CASES_LANE_CALL {
        // Except f32 sin and cos: hfrt's kernel (ir/trig.h) in vector code.
        if ((op == Op::kSin || op == Op::kCos) && is_f32_ && inline_trig_) {
          return sin_cos_f32(a, op == Op::kCos);
        }
        const int n = op_num_args(op);
        return call_lanes(
            pure_function(pick_name(op_libm_name(op, false), op_libm_name(op, true)), n), a,
            n == 2 ? b : nullptr);
      }
    case Op::kFloor:
      return unary(llvm::Intrinsic::floor);
    case Op::kCeil:
      return unary(llvm::Intrinsic::ceil);
    case Op::kTrunc:
      return unary(llvm::Intrinsic::trunc);
    case Op::kRound:
      return unary(llvm::Intrinsic::round);
    case Op::kSign: {
      // hf_sign: -1, 0 or 1; NaN stays NaN.
      llvm::Value* zero_or_nan = b_.CreateSelect(b_.CreateFCmpOEQ(a, splat(0.0)), splat(0.0), a);
      return b_.CreateSelect(
          b_.CreateFCmpOGT(a, splat(0.0)), splat(1.0),
          b_.CreateSelect(b_.CreateFCmpOLT(a, splat(0.0)), splat(-1.0), zero_or_nan));
    }
    case Op::kLt:
      return to_real(b_.CreateFCmpOLT(a, b));
    case Op::kLe:
      return to_real(b_.CreateFCmpOLE(a, b));
    case Op::kGt:
      return to_real(b_.CreateFCmpOGT(a, b));
    case Op::kGe:
      return to_real(b_.CreateFCmpOGE(a, b));
    case Op::kEqTol:
    case Op::kNeTol: {
      llvm::Value* d = fabs(b_.CreateFSub(a, b));
      // As scalar_ops.h: '=' is |d| < eps, '/=' is |d| >= eps (both false for NaN).
      return to_real(op == Op::kEqTol ? b_.CreateFCmpOLT(d, splat(kHfEps))
                                      : b_.CreateFCmpOGE(d, splat(kHfEps)));
    }
    case Op::kEq:
      return to_real(b_.CreateFCmpOEQ(a, b));
    case Op::kNe:
      return to_real(b_.CreateFCmpUNE(a, b));
    case Op::kTruth:
      return to_real(truth(a));
    case Op::kAnd:
      return to_real(b_.CreateAnd(truth(a), truth(b)));
    case Op::kOr:
      return to_real(b_.CreateOr(truth(a), truth(b)));
    case Op::kNot:
      return to_real(b_.CreateNot(truth(a)));
    case Op::kSelect:
      return b_.CreateSelect(nonzero(a), b, c);
      HFRT_OP_CASES_NON_ARITH
      break;
  }
  HFRT_CHECK_MSG(false, "scalar_op: not a pure op with arguments: " << op_name(op));
  return nullptr;
}

// --- Lane-mask control flow ---------------------------------------------------------------

void VectorEmitter::begin_if(llvm::Value* cond) {
  MaskFrame f;
  f.outer = mask_;
  f.cond = cond;
  f.skip = new_block("if.skip");
  f.end = new_block("if.end");
  llvm::Value* then_mask = and_mask(mask_, cond);
  llvm::BasicBlock* then_bb = new_block("if.then");
  b_.CreateCondBr(any(then_mask), then_bb, f.skip);
  b_.SetInsertPoint(then_bb);
  mask_ = then_mask;
  frames_.push_back(f);
}

void VectorEmitter::begin_else() {
  HFRT_CHECK(!frames_.empty());
  MaskFrame& f = frames_.back();
  HFRT_CHECK(!f.is_loop && !f.has_else);
  f.has_else = true;
  b_.CreateBr(f.skip);
  b_.SetInsertPoint(f.skip);
  llvm::Value* else_mask = and_mask(f.outer, b_.CreateNot(f.cond));
  llvm::BasicBlock* else_bb = new_block("if.else");
  b_.CreateCondBr(any(else_mask), else_bb, f.end);
  b_.SetInsertPoint(else_bb);
  mask_ = else_mask;
}

void VectorEmitter::end_if() {
  HFRT_CHECK(!frames_.empty());
  MaskFrame f = frames_.back();
  frames_.pop_back();
  HFRT_CHECK(!f.is_loop);
  b_.CreateBr(f.has_else ? f.end : f.skip);
  if (!f.has_else) {
    b_.SetInsertPoint(f.skip);
    b_.CreateBr(f.end);
  }
  b_.SetInsertPoint(f.end);
  mask_ = f.outer;
}

void VectorEmitter::begin_loop() {
  MaskFrame f;
  f.is_loop = true;
  f.outer = mask_;
  f.active = entry_alloca(mt_, "loop.mask");
  b_.CreateStore(mask_ ? mask_ : all_true(), f.active);
  f.header = new_block("loop.header");
  f.end = new_block("loop.exit");
  b_.CreateBr(f.header);
  b_.SetInsertPoint(f.header);
  mask_ = b_.CreateLoad(mt_, f.active);
  frames_.push_back(f);
}

void VectorEmitter::loop_continue(llvm::Value* stay) {
  HFRT_CHECK(!frames_.empty() && frames_.back().is_loop);
  MaskFrame& f = frames_.back();
  b_.CreateStore(stay, f.active);
  llvm::BasicBlock* body = new_block("loop.body");
  b_.CreateCondBr(any(stay), body, f.end);
  b_.SetInsertPoint(body);
  mask_ = stay;
}

void VectorEmitter::end_loop() {
  HFRT_CHECK(!frames_.empty() && frames_.back().is_loop);
  MaskFrame f = frames_.back();
  frames_.pop_back();
  b_.CreateBr(f.header);
  b_.SetInsertPoint(f.end);
  mask_ = f.outer;
}

}  // namespace hfrt::jit
