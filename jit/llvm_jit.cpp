// The vectorised scalar evaluator: hfrt IR -> LLVM IR over <W x T> lanes -> ORC LLJIT.
//
// Every IR value becomes a <W x T> vector (one lane per point). Control flow is vectorised
// with lane masks: both sides of an `if` run under their masks (a side whose mask is empty
// is skipped by a branch), a `while` loop runs while any lane is active, and only the
// side-effecting ops look at the mask: kStoreSlot stores select(mask, new, old), kCheck ORs
// mask & cond into a per-lane error mask. At the end lanes with an error get NaN.
//
// Slots are allocas of <W x T> (promoted to registers by SROA/mem2reg). Arrays addressed
// with a dynamic index (kLoadIdx/kStoreIdx) use select chains when small, else one
// [size x <W x T>] alloca addressed with gathers/scatters.
//
// Exactness: no fast-math flags; sqrt/floor/ceil/trunc/round/fabs are IEEE-exact intrinsics;
// every other math function is a per-lane call to the very libm function the interpreter
// calls (the `lane` and `libm` columns of ir/ir_ops.h; registered as an absolute symbol), so
// f64 results are bit-identical in practice.

#include "jit/llvm_jit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include "base/check.h"
#include "base/timer.h"
#include "ir/scalar_ops.h"
#include "ir/uniform_values.h"
#include "jit/llvm_emit.h"
#include "jit/llvm_session.h"

// Scalar helpers called per lane from JIT code: noexcept C-ABI leaves.
extern "C" {

/// kPowHF (see ir_ops.h): the very function the interpreter and the constant folder use.
double hfrt_jit_powhf_f64(double b, double e) noexcept {
  return hfrt::jit::hf_pow(b, e);
}

/// kPowHF in single precision: hf_pow's algorithm in float (scalar_ops.h hf_pow_t, which the
/// tape VM's f32 lanes use too).
float hfrt_jit_powhf_f32(float b, float e) noexcept {
  return hfrt::jit::hf_pow_t<float>(b, e);
}

/// f32 sin or cos (`cos` != 0) of n doubles by libm's double function, rounded to float: the
/// trig kernel's slow path (VectorEmitter::sin_cos_f32), one call for all lanes instead of
/// one per lane, which cost every use of sin or cos 8-16 calls of code to compile (the
/// gyroid's f32 code: 96 calls).
void hfrt_jit_trig_lanes_f32(const double* in, float* out, int32_t n, int32_t cos) noexcept {
  for (int32_t i = 0; i < n; ++i) {
    out[i] = static_cast<float>(cos ? std::cos(in[i]) : std::sin(in[i]));
  }
}

}  // extern "C"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
const HostSymbol kScalarSymbols[] = {
    {"hfrt_jit_powhf_f64", reinterpret_cast<void*>(&hfrt_jit_powhf_f64)},
    {"hfrt_jit_powhf_f32", reinterpret_cast<void*>(&hfrt_jit_powhf_f32)},
    {"hfrt_jit_trig_lanes_f32", reinterpret_cast<void*>(&hfrt_jit_trig_lanes_f32)},
};
std::span<const HostSymbol> scalar_jit_symbols() {
  return kScalarSymbols;
}

namespace {

// ---------------------------------------------------------------------------------------
// The emitter: one hfrt Function -> the LLVM function `body` that evaluates one block of W
// lanes, and the exported batch function that loops over blocks and handles the tail.

class Emitter : public VectorEmitter {
 public:
  Emitter(llvm::Module& module, const Function& fn, Precision precision, int lanes,
          bool surface_sign_only = false)
      : VectorEmitter(module, fn,
                      precision == Precision::kF64 ? llvm::Type::getDoubleTy(module.getContext())
                                                   : llvm::Type::getFloatTy(module.getContext()),
                      lanes),
        surface_sign_only_(surface_sign_only) {}

  /// f32 sin and cos as calls of sinf / cosf instead of the kernel's vector code (the NVPTX
  /// kernels give those calls the device's math).
  void use_libm_trig() { inline_trig_ = false; }

  /// Emits the body and, unless `entry_name` is empty, the exported batch function of that
  /// name. Returns the body (emit_scalar_function).
  llvm::Function* emit(const std::string& entry_name) {
    llvm::Function* body = emit_body();
    if (!entry_name.empty()) emit_entry(entry_name, body);
    return body;
  }

 private:
  const bool surface_sign_only_;  ///< JitOptions::surface_sign_only

  // --- Slots ---------------------------------------------------------------------------
  // Arrays accessed with dynamic indices larger than this live in memory (gathers);
  // smaller ones use select chains over their slots' registers.
  static constexpr int kSelectChainMax = 8;

  struct Group {
    int base = 0;
    int size = 0;
    llvm::AllocaInst* mem = nullptr;  ///< non-null: memory array addressed by gathers
  };

  void plan_slots(llvm::IRBuilder<>& entry) {
    // Merge the index ranges of kLoadIdx/kStoreIdx into groups of contiguous slots.
    std::vector<std::pair<int, int>> ranges;
    for (const Inst& inst : fn_.insts) {
      if (inst.op == Op::kLoadIdx || inst.op == Op::kStoreIdx) {
        ranges.emplace_back(inst.aux, inst.aux + static_cast<int>(inst.imm));
      }
    }
    std::sort(ranges.begin(), ranges.end());
    std::vector<Group> groups;
    for (auto [lo, hi] : ranges) {
      if (!groups.empty() && lo < groups.back().base + groups.back().size) {
        groups.back().size = std::max(groups.back().size, hi - groups.back().base);
      } else {
        groups.push_back({lo, hi - lo, nullptr});
      }
    }
    slot_ptr_.assign(fn_.num_slots, nullptr);
    slot_group_.assign(fn_.num_slots, -1);
    for (size_t g = 0; g < groups.size(); ++g) {
      Group& grp = groups[g];
      if (grp.size > kSelectChainMax) {
        grp.mem = entry.CreateAlloca(llvm::ArrayType::get(vt_, grp.size), nullptr, "array");
        for (int j = 0; j < grp.size; ++j) {
          slot_ptr_[grp.base + j] =
              entry.CreateConstInBoundsGEP2_32(llvm::ArrayType::get(vt_, grp.size), grp.mem, 0, j);
        }
      }
      for (int j = 0; j < grp.size; ++j) slot_group_[grp.base + j] = static_cast<int>(g);
    }
    groups_ = std::move(groups);
    for (int s = 0; s < fn_.num_slots; ++s) {
      if (!slot_ptr_[s]) slot_ptr_[s] = entry.CreateAlloca(vt_, nullptr, "slot");
    }
    auto init_of = [&](int s) {
      return s < static_cast<int>(fn_.slot_init.size()) ? fn_.slot_init[s] : std::nan("");
    };
    std::vector<char> done(fn_.num_slots, 0);
    // A memory array whose slots all start equal (NaN values, 0 flags) is filled by a loop:
    // one store per element made the optimised code, and LLVM's time, grow with the square
    // of the array size (2048 elements: 4 s).
    for (const Group& grp : groups_) {
      if (!grp.mem) continue;
      const double first = init_of(grp.base);
      bool uniform = true;
      for (int j = 1; j < grp.size && uniform; ++j) {
        const double v = init_of(grp.base + j);
        uniform = v == first || (std::isnan(v) && std::isnan(first));
      }
      if (!uniform) continue;
      fill_array(entry, grp, first);
      for (int j = 0; j < grp.size; ++j) done[grp.base + j] = 1;
    }
    for (int s = 0; s < fn_.num_slots; ++s) {
      if (!done[s]) entry.CreateStore(splat(init_of(s)), slot_ptr_[s]);
    }
  }

  // Stores `init` in every element of a memory group, by a loop; leaves `b` after it.
  void fill_array(llvm::IRBuilder<>& b, const Group& grp, double init) {
    llvm::Type* at = llvm::ArrayType::get(vt_, grp.size);
    llvm::BasicBlock* before = b.GetInsertBlock();
    llvm::BasicBlock* loop = llvm::BasicBlock::Create(ctx_, "fill", f_);
    llvm::BasicBlock* after = llvm::BasicBlock::Create(ctx_, "fill.done", f_);
    b.CreateBr(loop);
    b.SetInsertPoint(loop);
    llvm::PHINode* j = b.CreatePHI(i64_, 2, "j");
    j->addIncoming(b.getInt64(0), before);
    b.CreateStore(splat(init), b.CreateInBoundsGEP(at, grp.mem, {b.getInt64(0), j}));
    llvm::Value* next = b.CreateAdd(j, b.getInt64(1));
    j->addIncoming(next, loop);
    b.CreateCondBr(b.CreateICmpULT(next, b.getInt64(grp.size)), loop, after);
    b.SetInsertPoint(after);
  }

  llvm::Value* load_slot(int s) { return b_.CreateLoad(vt_, slot_ptr_[s]); }
  void store_slot(int s, llvm::Value* v, llvm::Value* mask) {
    if (mask) v = b_.CreateSelect(mask, v, load_slot(s));
    b_.CreateStore(v, slot_ptr_[s]);
  }

  /// A 1-based index value clamped into [1, size] (NaN -> 1), as i32 0-based lane offsets
  /// into the memory array `grp`: element (aux - base + idx - 1), lane i.
  llvm::Value* gather_ptrs(const Group& grp, int aux, int size, llvm::Value* idx) {
    llvm::Value* c = b_.CreateSelect(b_.CreateFCmpOGE(idx, splat(1.0)), idx, splat(1.0));
    c = b_.CreateSelect(b_.CreateFCmpOLE(c, splat(size)), c, splat(size));
    llvm::Value* j = b_.CreateFPToSI(c, llvm::FixedVectorType::get(i32_, w_));
    auto* vi32 = llvm::FixedVectorType::get(i32_, w_);
    j = b_.CreateAdd(j, llvm::ConstantInt::get(vi32, aux - grp.base - 1));
    j = b_.CreateMul(j, llvm::ConstantInt::get(vi32, w_));
    std::vector<llvm::Constant*> lane_ids;
    for (int i = 0; i < w_; ++i) lane_ids.push_back(llvm::ConstantInt::get(i32_, i));
    j = b_.CreateAdd(j, llvm::ConstantVector::get(lane_ids));
    return b_.CreateInBoundsGEP(st_, grp.mem, j);
  }

  llvm::Value* load_idx(const Inst& inst, llvm::Value* idx) {
    int size = static_cast<int>(inst.imm);
    const Group& grp = groups_[slot_group_[inst.aux]];
    if (grp.mem) {
      return b_.CreateMaskedGather(vt_, gather_ptrs(grp, inst.aux, size, idx), align_, all_true(),
                                   llvm::PoisonValue::get(vt_));
    }
    llvm::Value* r = load_slot(inst.aux);
    for (int j = 1; j < size; ++j) {
      r = b_.CreateSelect(b_.CreateFCmpOEQ(idx, splat(j + 1)), load_slot(inst.aux + j), r);
    }
    return r;
  }

  void store_idx(const Inst& inst, llvm::Value* idx, llvm::Value* v) {
    int size = static_cast<int>(inst.imm);
    const Group& grp = groups_[slot_group_[inst.aux]];
    if (grp.mem) {
      b_.CreateMaskedScatter(v, gather_ptrs(grp, inst.aux, size, idx), align_,
                             mask() ? mask() : all_true());
      return;
    }
    for (int j = 0; j < size; ++j) {
      store_slot(inst.aux + j, v, and_mask(mask(), b_.CreateFCmpOEQ(idx, splat(j + 1))));
    }
  }

  llvm::Value* table_load(const Inst& inst, llvm::Value* idx) {
    const std::vector<double>& table = fn_.tables[inst.aux];
    HFRT_CHECK(!table.empty());
    if (table.size() == 1) return splat(table[0]);
    std::vector<llvm::Constant*> elems;
    for (double v : table) elems.push_back(llvm::ConstantFP::get(st_, v));
    auto* aty = llvm::ArrayType::get(st_, table.size());
    auto* gv = new llvm::GlobalVariable(m_, aty, true, llvm::GlobalValue::PrivateLinkage,
                                        llvm::ConstantArray::get(aty, elems), "table");
    double last = static_cast<double>(table.size() - 1);
    llvm::Value* c = b_.CreateSelect(b_.CreateFCmpOGE(idx, splat(0.0)), idx, splat(0.0));
    c = b_.CreateSelect(b_.CreateFCmpOLE(c, splat(last)), c, splat(last));
    llvm::Value* j = b_.CreateFPToSI(c, llvm::FixedVectorType::get(i32_, w_));
    llvm::Value* ptrs = b_.CreateInBoundsGEP(st_, gv, j);
    return b_.CreateMaskedGather(vt_, ptrs, align_, all_true(), llvm::PoisonValue::get(vt_));
  }

  // --- The body ------------------------------------------------------------------------
  /// void body(const T* xs, i64 stride, const T* a, T* out_f, T* out_s, i64 out_stride)
  llvm::Function* emit_body() {
    auto* fty = llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_),
                                        {ptr_, i64_, ptr_, ptr_, ptr_, i64_}, false);
    body_ = llvm::Function::Create(fty, llvm::GlobalValue::InternalLinkage, "body", m_);
    f_ = body_;
    body_->setDoesNotThrow();
    // Called twice (full blocks and the tail): one copy of the code halves compile time, and
    // a call per W points costs nothing next to the body.
    body_->addFnAttr(llvm::Attribute::NoInline);
    for (int i : {0, 2, 3, 4}) body_->addParamAttr(i, llvm::Attribute::NoAlias);
    llvm::Value* xs = body_->getArg(0);
    llvm::Value* stride = body_->getArg(1);
    llvm::Value* a = body_->getArg(2);
    llvm::Value* out_f = body_->getArg(3);
    llvm::Value* out_s = body_->getArg(4);
    llvm::Value* out_stride = body_->getArg(5);

    llvm::BasicBlock* entry = llvm::BasicBlock::Create(ctx_, "entry", body_);
    b_.SetInsertPoint(entry);
    // In the entry block (plan_slots may leave the builder after a loop).
    err_ = b_.CreateAlloca(mt_, nullptr, "err");
    plan_slots(b_);
    b_.CreateStore(llvm::ConstantInt::getFalse(mt_), err_);

    values_.assign(fn_.insts.size(), nullptr);
    uniform_ = uniform_values(fn_);
    for (size_t i = 0; i < fn_.insts.size(); ++i) {
      const Inst& inst = fn_.insts[i];
      auto arg = [&](int k) {
        llvm::Value* v = values_[inst.args[k]];
        HFRT_CHECK_MSG(v, "use of a value without code: %" << inst.args[k] << " in %" << i);
        return v;
      };
      llvm::Value* v = nullptr;
      switch (inst.op) {
        case Op::kConst:
          v = splat(inst.imm);
          break;
        case Op::kInput:
          if (inst.aux < fn_.num_inputs) {
            llvm::Value* p = b_.CreateGEP(st_, xs, b_.CreateMul(stride, b_.getInt64(inst.aux)));
            v = b_.CreateAlignedLoad(vt_, p, align_);
          } else {
            v = splat(0.0);
          }
          break;
        case Op::kParam:
          if (inst.aux < fn_.num_params) {
            llvm::Value* s = b_.CreateLoad(st_, b_.CreateConstGEP1_64(st_, a, inst.aux));
            v = b_.CreateVectorSplat(w_, s);
          } else {
            v = splat(0.0);
          }
          break;
        case Op::kLoadSlot:
          v = load_slot(inst.aux);
          break;
        case Op::kStoreSlot:
          store_slot(inst.aux, arg(0), mask());
          break;
        case Op::kLoadIdx:
          v = load_idx(inst, arg(0));
          break;
        case Op::kStoreIdx:
          store_idx(inst, arg(0), arg(1));
          break;
        case Op::kTableLoad:
          v = table_load(inst, arg(0));
          break;
        case Op::kSurface:
          v = surface_lanes(inst.aux, arg(0), arg(1), arg(2), surface_sign_only_);
          break;
        case Op::kCheck: {
          llvm::Value* fired = and_mask(mask(), nonzero(arg(0)));
          b_.CreateStore(b_.CreateOr(b_.CreateLoad(mt_, err_), fired), err_);
          break;
        }
        case Op::kIf:
          begin_if(nonzero(arg(0)));
          break;
        case Op::kElse:
          begin_else();
          break;
        case Op::kEndIf:
          end_if();
          break;
        case Op::kLoop:
          begin_loop();
          break;
        case Op::kLoopTest:
          loop_continue(and_mask(mask(), nonzero(arg(0))));
          break;
        case Op::kEndLoop:
          end_loop();
          break;
          // Every op computed from its arguments (case labels generated from ir_ops.h).
          HFRT_OP_CASES_ARITH
          uniform_op_ = uniform_[i] != 0;
          v = scalar_op(inst.op, arg(0), inst.args[1] != kNoValue ? arg(1) : nullptr,
                        inst.args[2] != kNoValue ? arg(2) : nullptr);
          uniform_op_ = false;
          break;
      }
      values_[i] = v;
      if (op_has_value(inst.op)) HFRT_CHECK_MSG(v, "no code for %" << i);
    }

    // Results: lanes with an error get NaN.
    HFRT_CHECK(fn_.result != kNoValue && values_[fn_.result]);
    llvm::Value* err = b_.CreateLoad(mt_, err_);
    llvm::Value* nan = splat(std::nan(""));
    b_.CreateAlignedStore(b_.CreateSelect(err, nan, values_[fn_.result]), out_f, align_);
    if (!fn_.s_slots.empty()) {
      llvm::BasicBlock* store_s = new_block("store.s");
      llvm::BasicBlock* done = new_block("done");
      b_.CreateCondBr(b_.CreateIsNotNull(out_s), store_s, done);
      b_.SetInsertPoint(store_s);
      for (size_t k = 0; k < fn_.s_slots.size(); ++k) {
        llvm::Value* p = b_.CreateGEP(st_, out_s, b_.CreateMul(out_stride, b_.getInt64(k)));
        b_.CreateAlignedStore(b_.CreateSelect(err, nan, load_slot(fn_.s_slots[k])), p, align_);
      }
      b_.CreateBr(done);
      b_.SetInsertPoint(done);
    }
    b_.CreateRetVoid();
    return body_;
  }

  /// void entry(i64 n, const T* xs, const T* a, T* out_f, T* out_s): full blocks of W lanes
  /// straight from the caller's arrays, then the tail through padded stack buffers.
  void emit_entry(const std::string& name, llvm::Function* body) {
    auto* fty =
        llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_), {i64_, ptr_, ptr_, ptr_, ptr_}, false);
    auto* f = llvm::Function::Create(fty, llvm::GlobalValue::ExternalLinkage, name, m_);
    f->setDoesNotThrow();
    llvm::Value* n = f->getArg(0);
    llvm::Value* xs = f->getArg(1);
    llvm::Value* a = f->getArg(2);
    llvm::Value* out_f = f->getArg(3);
    llvm::Value* out_s = f->getArg(4);
    const int num_s = static_cast<int>(fn_.s_slots.size());
    const int num_in = std::max(fn_.num_inputs, 0);

    auto* entry = llvm::BasicBlock::Create(ctx_, "entry", f);
    auto* loop = llvm::BasicBlock::Create(ctx_, "loop", f);
    auto* loop_body = llvm::BasicBlock::Create(ctx_, "loop.body", f);
    auto* tail_check = llvm::BasicBlock::Create(ctx_, "tail.check", f);
    auto* tail = llvm::BasicBlock::Create(ctx_, "tail", f);
    auto* done = llvm::BasicBlock::Create(ctx_, "done", f);
    llvm::IRBuilder<> b(entry);
    // Stack buffers for the tail (allocas in the entry block).
    auto* in_ty = llvm::ArrayType::get(st_, std::max(num_in, 1) * w_);
    auto* out_ty = llvm::ArrayType::get(st_, (1 + num_s) * w_);
    llvm::Value* in_buf = b.CreateAlloca(in_ty, nullptr, "tail.in");
    llvm::Value* out_buf = b.CreateAlloca(out_ty, nullptr, "tail.out");
    llvm::Value* n_pos = b.CreateSelect(b.CreateICmpSGT(n, b.getInt64(0)), n, b.getInt64(0));
    llvm::Value* n_full = b.CreateAnd(n_pos, b.getInt64(~int64_t(w_ - 1)));
    llvm::Value* has_s = b.CreateIsNotNull(out_s);
    b.CreateBr(loop);

    b.SetInsertPoint(loop);
    llvm::PHINode* i = b.CreatePHI(i64_, 2, "i");
    i->addIncoming(b.getInt64(0), entry);
    b.CreateCondBr(b.CreateICmpSLT(i, n_full), loop_body, tail_check);

    b.SetInsertPoint(loop_body);
    llvm::Value* s_ptr =
        b.CreateSelect(has_s, b.CreateGEP(st_, out_s, i), llvm::ConstantPointerNull::get(ptr_));
    b.CreateCall(body, {b.CreateGEP(st_, xs, i), n, a, b.CreateGEP(st_, out_f, i), s_ptr, n});
    llvm::Value* next = b.CreateAdd(i, b.getInt64(w_));
    i->addIncoming(next, loop_body);
    b.CreateBr(loop);

    b.SetInsertPoint(tail_check);
    llvm::Value* rem = b.CreateSub(n_pos, n_full);
    b.CreateCondBr(b.CreateICmpSGT(rem, b.getInt64(0)), tail, done);

    b.SetInsertPoint(tail);
    std::vector<llvm::Constant*> lane_ids;
    for (int l = 0; l < w_; ++l) lane_ids.push_back(llvm::ConstantInt::get(i64_, l));
    llvm::Value* tail_mask =
        b.CreateICmpSLT(llvm::ConstantVector::get(lane_ids), b.CreateVectorSplat(w_, rem));
    for (int k = 0; k < num_in; ++k) {
      llvm::Value* src = b.CreateGEP(st_, xs, b.CreateAdd(b.CreateMul(n, b.getInt64(k)), n_full));
      llvm::Value* v = b.CreateMaskedLoad(vt_, src, align_, tail_mask, splat(0.0));
      b.CreateAlignedStore(v, b.CreateConstGEP1_64(st_, in_buf, uint64_t(k) * w_), align_);
    }
    llvm::Value* out_s_buf = b.CreateConstGEP1_64(st_, out_buf, w_);
    b.CreateCall(body, {in_buf, b.getInt64(w_), a, out_buf, out_s_buf, b.getInt64(w_)});
    b.CreateMaskedStore(b.CreateAlignedLoad(vt_, out_buf, align_), b.CreateGEP(st_, out_f, n_full),
                        align_, tail_mask);
    if (num_s > 0) {
      auto* store_s = llvm::BasicBlock::Create(ctx_, "tail.s", f);
      b.CreateCondBr(has_s, store_s, done);
      b.SetInsertPoint(store_s);
      for (int k = 0; k < num_s; ++k) {
        llvm::Value* v = b.CreateAlignedLoad(
            vt_, b.CreateConstGEP1_64(st_, out_buf, uint64_t(1 + k) * w_), align_);
        llvm::Value* dst =
            b.CreateGEP(st_, out_s, b.CreateAdd(b.CreateMul(n, b.getInt64(k)), n_full));
        b.CreateMaskedStore(v, dst, align_, tail_mask);
      }
    }
    b.CreateBr(done);
    b.SetInsertPoint(done);
    b.CreateRetVoid();
  }

  llvm::Function* body_ = nullptr;
  std::vector<llvm::Value*> values_;
  std::vector<uint8_t> uniform_;  ///< uniform_values(fn_): per-lane libm calls made once
  std::vector<llvm::Value*> slot_ptr_;
  std::vector<int> slot_group_;
  std::vector<Group> groups_;
  llvm::AllocaInst* err_ = nullptr;
};

}  // namespace

llvm::Function* emit_scalar_function(llvm::Module& module, const Function& fn, Precision precision,
                                     int lanes, const std::string& batch_entry) {
  Emitter e(module, fn, precision, lanes);
  e.use_libm_trig();
  return e.emit(batch_entry);
}

// ---------------------------------------------------------------------------------------

struct JitFunction::Impl {
  Precision precision = Precision::kF64;
  std::unique_ptr<CompiledCode> code;
  JitStats stats;
  std::string llvm_ir;
};

JitFunction::JitFunction(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
JitFunction::~JitFunction() = default;

Precision JitFunction::precision() const {
  return impl_->precision;
}
BatchFn<double> JitFunction::f64() const {
  return impl_->precision == Precision::kF64
             ? reinterpret_cast<BatchFn<double>>(impl_->code->entry())
             : nullptr;
}
BatchFn<float> JitFunction::f32() const {
  return impl_->precision == Precision::kF32
             ? reinterpret_cast<BatchFn<float>>(impl_->code->entry())
             : nullptr;
}
const JitStats& JitFunction::stats() const {
  return impl_->stats;
}
const std::string& JitFunction::llvm_ir() const {
  return impl_->llvm_ir;
}

Result<std::unique_ptr<JitFunction>> JitFunction::compile(const Function& fn, Precision precision,
                                                          const JitOptions& options) {
  Result<LlvmSession*> session = LlvmSession::get();
  if (!session.ok()) return session.error();
  auto impl = std::make_unique<Impl>();
  impl->precision = precision;
  // (f32 sin and cos are vector code: VectorEmitter::sin_cos_f32.)
  const int lanes = options.lanes > 0
                        ? options.lanes
                        : call_heavy_lanes(fn, host_lanes(precision), precision == Precision::kF32,
                                           options.call_heavy_lane_calls);
  impl->stats.lanes = lanes;

  ModuleUnit unit =
      session.value()->new_module(precision == Precision::kF64 ? "hfrt_eval_f64" : "hfrt_eval_f32");
  const std::string name = unit.name;
  auto t0 = std::chrono::steady_clock::now();
  Emitter(*unit.module, fn, precision, lanes, options.surface_sign_only).emit(name);
  impl->stats.emit_ms = ms_since(t0);

  PipelineOptions po;
  po.opt_level = options.opt_level;
  po.codegen = options.opt_level <= 0   ? llvm::CodeGenOptLevel::None
               : options.opt_level == 1 ? llvm::CodeGenOptLevel::Less
                                        : llvm::CodeGenOptLevel::Aggressive;
  // Straight-line code (no if/while) takes the light IR pipeline at levels 1 and 2: SROA and
  // EarlyCSE do what the default pipelines find in it, and the rest of O2 (instcombine and
  // simplifycfg above all) is most of the optimisation time. A 993-instruction model (72
  // spheres joined by max): optimise 19-28 -> 5-8 ms for 844 -> 846 LLVM instructions; c1_gear's
  // compile 34-44 -> 24-29 ms; renders of spheres, c1_gear, the blend, gyroid and twist as fast
  // (bench/README.md, "The compile time of a 1000-instruction model"). Code with branches and
  // loops, and -O3, keep the default pipelines.
  po.light = !fn.has_control_flow && (options.opt_level == 1 || options.opt_level == 2);
  po.keep_ir = options.keep_llvm_ir;
  po.fast_codegen_calls = options.fast_codegen_calls;
  auto code = session.value()->compile(std::move(unit), name, po, &impl->stats, &impl->llvm_ir);
  if (!code.ok()) return code.error();
  impl->code = std::move(code.value());
  return std::unique_ptr<JitFunction>(new JitFunction(std::move(impl)));
}

std::string host_cpu_name() {
  Result<LlvmSession*> session = LlvmSession::get();
  return session.ok() ? session.value()->cpu_name() : llvm::sys::getHostCPUName().str();
}

int host_lanes(Precision precision) {
  Result<LlvmSession*> session = LlvmSession::get();
  const int bytes = precision == Precision::kF64 ? 8 : 4;
  return session.ok() ? session.value()->lanes(bytes) : 16 / bytes;
}

}  // namespace hfrt::jit
