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
// calls (registered as an absolute symbol), so f64 results are bit-identical in practice.

#include "jit/llvm_jit.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>

#include "jit/llvm_includes.h"
#include "jit/scalar_ops.h"
#include "lang/check.h"

// Scalar helpers called per lane from JIT code: noexcept C-ABI leaves.
extern "C" {

/// kPowHF (see ir_ops.h): the very function the interpreter and the constant folder use.
double hfrt_jit_powhf_f64(double b, double e) noexcept { return hfrt::jit::hf_pow(b, e); }

/// kPowHF in single precision, the same algorithm as hf_pow.
float hfrt_jit_powhf_f32(float b, float e) noexcept {
  if (std::fabs(b) < 1e-6f) return 0.0f;
  if (std::fabs(e - std::trunc(e)) < 1e-6f) {
    const float n = std::round(std::fabs(e));
    float v = 1.0f;
    if (n <= static_cast<float>(hfrt::jit::kHfPowMaxLoop)) {
      for (int i = 0; i < static_cast<int>(n); ++i) v *= b;
    } else {
      v = std::pow(b, n);
    }
    return e < 0 ? 1.0f / v : v;
  }
  return std::exp(e * std::log(b));
}

}  // extern "C"

namespace hfrt::jit {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string to_string(llvm::Error err) {
  std::string s;
  llvm::raw_string_ostream os(s);
  os << err;
  return os.str();
}

// ---------------------------------------------------------------------------------------
// The host functions compiled code may call. Registered as absolute symbols in the main
// JITDylib; process-wide symbol lookup is switched off so nothing resolves by surprise.

struct HostSymbol {
  const char* name;
  void* addr;
};

template <typename F>
void* fn_addr(F* f) {
  return reinterpret_cast<void*>(f);
}

std::vector<HostSymbol> host_symbols() {
  using D1 = double (*)(double);
  using D2 = double (*)(double, double);
  using F1 = float (*)(float);
  using F2 = float (*)(float, float);
  return {
      {"exp", fn_addr(static_cast<D1>(&::exp))},      {"log", fn_addr(static_cast<D1>(&::log))},
      {"log10", fn_addr(static_cast<D1>(&::log10))},  {"sin", fn_addr(static_cast<D1>(&::sin))},
      {"cos", fn_addr(static_cast<D1>(&::cos))},      {"tan", fn_addr(static_cast<D1>(&::tan))},
      {"asin", fn_addr(static_cast<D1>(&::asin))},    {"acos", fn_addr(static_cast<D1>(&::acos))},
      {"atan", fn_addr(static_cast<D1>(&::atan))},    {"sinh", fn_addr(static_cast<D1>(&::sinh))},
      {"cosh", fn_addr(static_cast<D1>(&::cosh))},    {"tanh", fn_addr(static_cast<D1>(&::tanh))},
      {"atan2", fn_addr(static_cast<D2>(&::atan2))},  {"fmod", fn_addr(static_cast<D2>(&::fmod))},
      {"pow", fn_addr(static_cast<D2>(&::pow))},      {"floor", fn_addr(static_cast<D1>(&::floor))},
      {"ceil", fn_addr(static_cast<D1>(&::ceil))},    {"trunc", fn_addr(static_cast<D1>(&::trunc))},
      {"round", fn_addr(static_cast<D1>(&::round))},  {"sqrt", fn_addr(static_cast<D1>(&::sqrt))},
      {"expf", fn_addr(static_cast<F1>(&::expf))},    {"logf", fn_addr(static_cast<F1>(&::logf))},
      {"log10f", fn_addr(static_cast<F1>(&::log10f))}, {"sinf", fn_addr(static_cast<F1>(&::sinf))},
      {"cosf", fn_addr(static_cast<F1>(&::cosf))},    {"tanf", fn_addr(static_cast<F1>(&::tanf))},
      {"asinf", fn_addr(static_cast<F1>(&::asinf))},  {"acosf", fn_addr(static_cast<F1>(&::acosf))},
      {"atanf", fn_addr(static_cast<F1>(&::atanf))},  {"sinhf", fn_addr(static_cast<F1>(&::sinhf))},
      {"coshf", fn_addr(static_cast<F1>(&::coshf))},  {"tanhf", fn_addr(static_cast<F1>(&::tanhf))},
      {"atan2f", fn_addr(static_cast<F2>(&::atan2f))}, {"fmodf", fn_addr(static_cast<F2>(&::fmodf))},
      {"powf", fn_addr(static_cast<F2>(&::powf))},    {"floorf", fn_addr(static_cast<F1>(&::floorf))},
      {"ceilf", fn_addr(static_cast<F1>(&::ceilf))},  {"truncf", fn_addr(static_cast<F1>(&::truncf))},
      {"roundf", fn_addr(static_cast<F1>(&::roundf))}, {"sqrtf", fn_addr(static_cast<F1>(&::sqrtf))},
      {"hfrt_jit_powhf_f64", fn_addr(&hfrt_jit_powhf_f64)},
      {"hfrt_jit_powhf_f32", fn_addr(&hfrt_jit_powhf_f32)},
      // The optimiser may turn aggregate initialisation into these.
      {"memset", fn_addr(&::memset)},                 {"memcpy", fn_addr(&::memcpy)},
      {"memmove", fn_addr(&::memmove)},
  };
}

// ---------------------------------------------------------------------------------------
// The process-wide LLJIT. Each JitFunction adds its own module (own ThreadSafeContext) under
// its own ResourceTracker, so code is freed per function while the session is shared.

struct Engine {
  std::unique_ptr<llvm::orc::LLJIT> jit;
  llvm::orc::JITTargetMachineBuilder jtmb{llvm::Triple()};
  std::string cpu;
  std::vector<std::string> features;
  std::atomic<uint64_t> next_id{0};
  int vector_bits = 128;
};

Engine* g_engine = nullptr;
std::string g_engine_error;

void init_engine() {
  llvm::InitializeNativeTarget();
  llvm::InitializeNativeTargetAsmPrinter();
  llvm::InitializeNativeTargetAsmParser();

  // The X86 MachineCombiner is quadratic in the length of a basic block (60% of codegen time
  // on a 30k-instruction model) and, without fast-math reassociation, finds nothing to
  // combine in hfrt's FP code; switch it off (process-wide LLVM option, set once here).
  {
    auto& registered = llvm::cl::getRegisteredOptions();
    auto it = registered.find("x86-machine-combiner");
    if (it != registered.end()) {
      if (auto* opt = static_cast<llvm::cl::opt<bool>*>(it->second)) opt->setValue(false);
    }
  }

  auto engine = std::make_unique<Engine>();
  engine->cpu = llvm::sys::getHostCPUName().str();
  auto host_features = llvm::sys::getHostCPUFeatures();
  for (auto& f : host_features) {
    std::string feature(f.second ? "+" : "-");
    feature.append(f.first().data(), f.first().size());
    engine->features.push_back(std::move(feature));
  }
  if (host_features.lookup("avx512f")) {
    engine->vector_bits = 512;
  } else if (host_features.lookup("avx")) {
    engine->vector_bits = 256;
  }
  engine->jtmb = llvm::orc::JITTargetMachineBuilder(llvm::Triple(llvm::sys::getProcessTriple()));
  engine->jtmb.setCPU(engine->cpu);
  engine->jtmb.addFeatures(engine->features);
  engine->jtmb.setCodeGenOptLevel(llvm::CodeGenOptLevel::Aggressive);

  auto jit = llvm::orc::LLJITBuilder()
                 .setJITTargetMachineBuilder(engine->jtmb)
                 // No process symbols (every host function is registered below), hence no
                 // native platform either: JIT code has no static initialisers to run.
                 .setLinkProcessSymbolsByDefault(false)
                 .setPlatformSetUp(llvm::orc::setUpInactivePlatform)
                 .setSupportConcurrentCompilation(true)
                 .create();
  if (!jit) {
    g_engine_error = "cannot create the LLVM JIT: " + to_string(jit.takeError());
    return;
  }
  engine->jit = std::move(*jit);
  llvm::orc::SymbolMap symbols;
  for (const HostSymbol& s : host_symbols()) {
    symbols[engine->jit->mangleAndIntern(s.name)] = {
        llvm::orc::ExecutorAddr::fromPtr(s.addr),
        llvm::JITSymbolFlags::Exported | llvm::JITSymbolFlags::Callable};
  }
  if (auto err = engine->jit->getMainJITDylib().define(llvm::orc::absoluteSymbols(symbols))) {
    g_engine_error = "cannot register host symbols: " + to_string(std::move(err));
    return;
  }
  g_engine = engine.release();  // lives for the process (code of static models may outlive main)
}

Engine* engine() {
  static std::once_flag once;
  std::call_once(once, init_engine);
  return g_engine;
}

int lanes_for(const Engine& e, Precision p) {
  return e.vector_bits / (p == Precision::kF64 ? 64 : 32);
}

// ---------------------------------------------------------------------------------------
// The emitter: one hfrt Function -> the LLVM function `body` that evaluates one block of W
// lanes, and the exported batch function that loops over blocks and handles the tail.

class Emitter {
 public:
  Emitter(llvm::LLVMContext& ctx, llvm::Module& module, const Function& fn, Precision precision,
          int lanes)
      : ctx_(ctx), m_(module), b_(ctx), fn_(fn), prec_(precision), w_(lanes) {
    st_ = precision == Precision::kF64 ? llvm::Type::getDoubleTy(ctx) : llvm::Type::getFloatTy(ctx);
    vt_ = llvm::FixedVectorType::get(st_, w_);
    mt_ = llvm::FixedVectorType::get(llvm::Type::getInt1Ty(ctx), w_);
    i64_ = llvm::Type::getInt64Ty(ctx);
    i32_ = llvm::Type::getInt32Ty(ctx);
    ptr_ = llvm::PointerType::get(ctx, 0);
    align_ = llvm::Align(prec_ == Precision::kF64 ? 8 : 4);
  }

  /// Emits everything; returns the exported function's name.
  void emit(const std::string& entry_name) {
    llvm::Function* body = emit_body();
    emit_entry(entry_name, body);
  }

 private:
  // --- Types and constants -------------------------------------------------------------
  llvm::Constant* splat(double v) { return llvm::ConstantFP::get(vt_, v); }
  llvm::Value* all_true() { return llvm::ConstantInt::getTrue(mt_); }
  llvm::Value* to_real(llvm::Value* cond) { return b_.CreateUIToFP(cond, vt_); }
  llvm::Value* nonzero(llvm::Value* v) { return b_.CreateFCmpUNE(v, splat(0.0)); }
  llvm::Value* truth(llvm::Value* v) {
    return b_.CreateFCmpOGE(b_.CreateUnaryIntrinsic(llvm::Intrinsic::fabs, v), splat(kHfEps));
  }
  llvm::Value* and_mask(llvm::Value* m, llvm::Value* c) { return m ? b_.CreateAnd(m, c) : c; }

  const char* fname(const char* f64_name, const char* f32_name) {
    return prec_ == Precision::kF64 ? f64_name : f32_name;
  }

  /// A declared external scalar libm-style function (pure, no unwinding).
  llvm::FunctionCallee libm(const char* name, int args) {
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

  /// Calls a scalar function on every lane (all lanes: the functions are pure, and inactive
  /// lanes' results are never stored).
  llvm::Value* call_lanes(llvm::FunctionCallee f, llvm::Value* a, llvm::Value* c = nullptr) {
    llvm::Value* r = llvm::PoisonValue::get(vt_);
    for (int i = 0; i < w_; ++i) {
      llvm::Value* ai = b_.CreateExtractElement(a, uint64_t(i));
      llvm::CallInst* call;
      if (c) {
        call = b_.CreateCall(f, {ai, b_.CreateExtractElement(c, uint64_t(i))});
      } else {
        call = b_.CreateCall(f, {ai});
      }
      call->setDoesNotThrow();
      r = b_.CreateInsertElement(r, call, uint64_t(i));
    }
    return r;
  }

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
          slot_ptr_[grp.base + j] = entry.CreateConstInBoundsGEP2_32(
              llvm::ArrayType::get(vt_, grp.size), grp.mem, 0, j);
        }
      }
      for (int j = 0; j < grp.size; ++j) slot_group_[grp.base + j] = static_cast<int>(g);
    }
    groups_ = std::move(groups);
    for (int s = 0; s < fn_.num_slots; ++s) {
      if (!slot_ptr_[s]) slot_ptr_[s] = entry.CreateAlloca(vt_, nullptr, "slot");
    }
    for (int s = 0; s < fn_.num_slots; ++s) {
      double init = s < static_cast<int>(fn_.slot_init.size()) ? fn_.slot_init[s] : std::nan("");
      entry.CreateStore(splat(init), slot_ptr_[s]);
    }
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
                             mask_ ? mask_ : all_true());
      return;
    }
    for (int j = 0; j < size; ++j) {
      store_slot(inst.aux + j, v, and_mask(mask_, b_.CreateFCmpOEQ(idx, splat(j + 1))));
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

  // --- Control flow --------------------------------------------------------------------
  struct Frame {
    bool is_loop = false;
    llvm::Value* outer_mask = nullptr;  ///< mask around the region (null = all lanes)
    llvm::Value* cond = nullptr;        ///< if: lanes where the condition holds
    llvm::BasicBlock* skip = nullptr;   ///< if: where the then-part's skip branch lands
    llvm::BasicBlock* end = nullptr;    ///< if: after kEndIf; loop: exit
    llvm::BasicBlock* header = nullptr;
    llvm::AllocaInst* loop_mask = nullptr;
    bool has_else = false;
  };

  llvm::BasicBlock* new_block(const char* name) {
    return llvm::BasicBlock::Create(ctx_, name, body_);
  }

  void begin_if(llvm::Value* c) {
    Frame f;
    f.outer_mask = mask_;
    f.cond = nonzero(c);
    f.skip = new_block("if.skip");
    f.end = new_block("if.end");
    llvm::Value* then_mask = and_mask(mask_, f.cond);
    llvm::BasicBlock* then_bb = new_block("if.then");
    b_.CreateCondBr(b_.CreateOrReduce(then_mask), then_bb, f.skip);
    b_.SetInsertPoint(then_bb);
    mask_ = then_mask;
    frames_.push_back(f);
  }

  void begin_else() {
    Frame& f = frames_.back();
    HFRT_CHECK(!f.is_loop && !f.has_else);
    f.has_else = true;
    b_.CreateBr(f.skip);
    b_.SetInsertPoint(f.skip);
    llvm::Value* else_mask = and_mask(f.outer_mask, b_.CreateNot(f.cond));
    llvm::BasicBlock* else_bb = new_block("if.else");
    b_.CreateCondBr(b_.CreateOrReduce(else_mask), else_bb, f.end);
    b_.SetInsertPoint(else_bb);
    mask_ = else_mask;
  }

  void end_if() {
    Frame f = frames_.back();
    frames_.pop_back();
    HFRT_CHECK(!f.is_loop);
    b_.CreateBr(f.has_else ? f.end : f.skip);
    if (!f.has_else) {
      b_.SetInsertPoint(f.skip);
      b_.CreateBr(f.end);
    }
    b_.SetInsertPoint(f.end);
    mask_ = f.outer_mask;
  }

  void begin_loop() {
    Frame f;
    f.is_loop = true;
    f.outer_mask = mask_;
    f.loop_mask = entry_alloca(mt_, "loop.mask");
    b_.CreateStore(mask_ ? mask_ : all_true(), f.loop_mask);
    f.header = new_block("loop.header");
    f.end = new_block("loop.exit");
    b_.CreateBr(f.header);
    b_.SetInsertPoint(f.header);
    mask_ = b_.CreateLoad(mt_, f.loop_mask);
    frames_.push_back(f);
  }

  void loop_test(llvm::Value* c) {
    Frame& f = frames_.back();
    HFRT_CHECK(f.is_loop);
    llvm::Value* active = and_mask(mask_, nonzero(c));
    b_.CreateStore(active, f.loop_mask);
    llvm::BasicBlock* body_bb = new_block("loop.body");
    b_.CreateCondBr(b_.CreateOrReduce(active), body_bb, f.end);
    b_.SetInsertPoint(body_bb);
    mask_ = active;
  }

  void end_loop() {
    Frame f = frames_.back();
    frames_.pop_back();
    HFRT_CHECK(f.is_loop);
    b_.CreateBr(f.header);
    b_.SetInsertPoint(f.end);
    mask_ = f.outer_mask;
  }

  llvm::AllocaInst* entry_alloca(llvm::Type* ty, const char* name) {
    llvm::IRBuilder<> eb(&body_->getEntryBlock(), body_->getEntryBlock().begin());
    return eb.CreateAlloca(ty, nullptr, name);
  }

  // --- The body ------------------------------------------------------------------------
  /// void body(const T* xs, i64 stride, const T* a, T* out_f, T* out_s, i64 out_stride)
  llvm::Function* emit_body() {
    auto* fty = llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_),
                                        {ptr_, i64_, ptr_, ptr_, ptr_, i64_}, false);
    body_ = llvm::Function::Create(fty, llvm::GlobalValue::InternalLinkage, "body", m_);
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
    plan_slots(b_);
    err_ = b_.CreateAlloca(mt_, nullptr, "err");
    b_.CreateStore(llvm::ConstantInt::getFalse(mt_), err_);

    values_.assign(fn_.insts.size(), nullptr);
    for (size_t i = 0; i < fn_.insts.size(); ++i) {
      const Inst& inst = fn_.insts[i];
      auto arg = [&](int k) {
        llvm::Value* v = values_[inst.args[k]];
        HFRT_CHECK_MSG(v, "use of a value without code: %" << inst.args[k] << " in %" << i);
        return v;
      };
      llvm::Value* v = nullptr;
      switch (inst.op) {
        case Op::kConst: v = splat(inst.imm); break;
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
        case Op::kLoadSlot: v = load_slot(inst.aux); break;
        case Op::kStoreSlot: store_slot(inst.aux, arg(0), mask_); break;
        case Op::kLoadIdx: v = load_idx(inst, arg(0)); break;
        case Op::kStoreIdx: store_idx(inst, arg(0), arg(1)); break;
        case Op::kTableLoad: v = table_load(inst, arg(0)); break;
        case Op::kAdd: v = b_.CreateFAdd(arg(0), arg(1)); break;
        case Op::kSub: v = b_.CreateFSub(arg(0), arg(1)); break;
        case Op::kMul: v = b_.CreateFMul(arg(0), arg(1)); break;
        case Op::kDiv: v = b_.CreateFDiv(arg(0), arg(1)); break;
        case Op::kNeg: v = b_.CreateFNeg(arg(0)); break;
        case Op::kAbs: v = b_.CreateUnaryIntrinsic(llvm::Intrinsic::fabs, arg(0)); break;
        case Op::kMin: v = b_.CreateSelect(b_.CreateFCmpOLT(arg(0), arg(1)), arg(0), arg(1)); break;
        case Op::kMax: v = b_.CreateSelect(b_.CreateFCmpOGT(arg(0), arg(1)), arg(0), arg(1)); break;
        case Op::kSqrt: v = b_.CreateUnaryIntrinsic(llvm::Intrinsic::sqrt, arg(0)); break;
        case Op::kExp: v = call_lanes(libm(fname("exp", "expf"), 1), arg(0)); break;
        case Op::kLog: v = call_lanes(libm(fname("log", "logf"), 1), arg(0)); break;
        case Op::kLog10: v = call_lanes(libm(fname("log10", "log10f"), 1), arg(0)); break;
        case Op::kSin: v = call_lanes(libm(fname("sin", "sinf"), 1), arg(0)); break;
        case Op::kCos: v = call_lanes(libm(fname("cos", "cosf"), 1), arg(0)); break;
        case Op::kTan: v = call_lanes(libm(fname("tan", "tanf"), 1), arg(0)); break;
        case Op::kAsin: v = call_lanes(libm(fname("asin", "asinf"), 1), arg(0)); break;
        case Op::kAcos: v = call_lanes(libm(fname("acos", "acosf"), 1), arg(0)); break;
        case Op::kAtan: v = call_lanes(libm(fname("atan", "atanf"), 1), arg(0)); break;
        case Op::kAtan2:
          v = call_lanes(libm(fname("atan2", "atan2f"), 2), arg(0), arg(1));
          break;
        case Op::kSinh: v = call_lanes(libm(fname("sinh", "sinhf"), 1), arg(0)); break;
        case Op::kCosh: v = call_lanes(libm(fname("cosh", "coshf"), 1), arg(0)); break;
        case Op::kTanh: v = call_lanes(libm(fname("tanh", "tanhf"), 1), arg(0)); break;
        case Op::kFloor: v = b_.CreateUnaryIntrinsic(llvm::Intrinsic::floor, arg(0)); break;
        case Op::kCeil: v = b_.CreateUnaryIntrinsic(llvm::Intrinsic::ceil, arg(0)); break;
        case Op::kTrunc: v = b_.CreateUnaryIntrinsic(llvm::Intrinsic::trunc, arg(0)); break;
        case Op::kRound: v = b_.CreateUnaryIntrinsic(llvm::Intrinsic::round, arg(0)); break;
        case Op::kFmod: v = call_lanes(libm(fname("fmod", "fmodf"), 2), arg(0), arg(1)); break;
        case Op::kPow: v = call_lanes(libm(fname("pow", "powf"), 2), arg(0), arg(1)); break;
        case Op::kPowHF:
          v = call_lanes(libm(fname("hfrt_jit_powhf_f64", "hfrt_jit_powhf_f32"), 2), arg(0),
                         arg(1));
          break;
        case Op::kSign: {
          llvm::Value* x = arg(0);
          // hf_sign: -1, 0 or 1; NaN stays NaN.
          llvm::Value* zero_or_nan = b_.CreateSelect(b_.CreateFCmpOEQ(x, splat(0.0)), splat(0.0), x);
          v = b_.CreateSelect(b_.CreateFCmpOGT(x, splat(0.0)), splat(1.0),
                              b_.CreateSelect(b_.CreateFCmpOLT(x, splat(0.0)), splat(-1.0),
                                              zero_or_nan));
          break;
        }
        case Op::kLt: v = to_real(b_.CreateFCmpOLT(arg(0), arg(1))); break;
        case Op::kLe: v = to_real(b_.CreateFCmpOLE(arg(0), arg(1))); break;
        case Op::kGt: v = to_real(b_.CreateFCmpOGT(arg(0), arg(1))); break;
        case Op::kGe: v = to_real(b_.CreateFCmpOGE(arg(0), arg(1))); break;
        case Op::kEqTol:
        case Op::kNeTol: {
          llvm::Value* d = b_.CreateUnaryIntrinsic(llvm::Intrinsic::fabs,
                                                   b_.CreateFSub(arg(0), arg(1)));
          // As scalar_ops.h: '=' is |d| < eps, '/=' is |d| >= eps (both false for NaN).
          v = to_real(inst.op == Op::kEqTol ? b_.CreateFCmpOLT(d, splat(kHfEps))
                                            : b_.CreateFCmpOGE(d, splat(kHfEps)));
          break;
        }
        case Op::kEq: v = to_real(b_.CreateFCmpOEQ(arg(0), arg(1))); break;
        case Op::kNe: v = to_real(b_.CreateFCmpUNE(arg(0), arg(1))); break;
        case Op::kTruth: v = to_real(truth(arg(0))); break;
        case Op::kAnd: v = to_real(b_.CreateAnd(truth(arg(0)), truth(arg(1)))); break;
        case Op::kOr: v = to_real(b_.CreateOr(truth(arg(0)), truth(arg(1)))); break;
        case Op::kNot: v = to_real(b_.CreateNot(truth(arg(0)))); break;
        case Op::kSelect: v = b_.CreateSelect(nonzero(arg(0)), arg(1), arg(2)); break;
        case Op::kCheck: {
          llvm::Value* fired = and_mask(mask_, nonzero(arg(0)));
          b_.CreateStore(b_.CreateOr(b_.CreateLoad(mt_, err_), fired), err_);
          break;
        }
        case Op::kIf: begin_if(arg(0)); break;
        case Op::kElse: begin_else(); break;
        case Op::kEndIf: end_if(); break;
        case Op::kLoop: begin_loop(); break;
        case Op::kLoopTest: loop_test(arg(0)); break;
        case Op::kEndLoop: end_loop(); break;
      }
      values_[i] = v;
      if (op_has_value(inst.op)) HFRT_CHECK_MSG(v, "no code for %" << i);
    }
    HFRT_CHECK(frames_.empty());

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
    auto* fty = llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_),
                                        {i64_, ptr_, ptr_, ptr_, ptr_}, false);
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
    llvm::Value* s_ptr = b.CreateSelect(has_s, b.CreateGEP(st_, out_s, i),
                                        llvm::ConstantPointerNull::get(ptr_));
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
    llvm::Value* tail_mask = b.CreateICmpSLT(llvm::ConstantVector::get(lane_ids),
                                             b.CreateVectorSplat(w_, rem));
    for (int k = 0; k < num_in; ++k) {
      llvm::Value* src = b.CreateGEP(st_, xs, b.CreateAdd(b.CreateMul(n, b.getInt64(k)), n_full));
      llvm::Value* v = b.CreateMaskedLoad(vt_, src, align_, tail_mask, splat(0.0));
      b.CreateAlignedStore(v, b.CreateConstGEP1_64(st_, in_buf, uint64_t(k) * w_), align_);
    }
    llvm::Value* out_s_buf = b.CreateConstGEP1_64(st_, out_buf, w_);
    b.CreateCall(body, {in_buf, b.getInt64(w_), a, out_buf, out_s_buf, b.getInt64(w_)});
    b.CreateMaskedStore(b.CreateAlignedLoad(vt_, out_buf, align_),
                        b.CreateGEP(st_, out_f, n_full), align_, tail_mask);
    if (num_s > 0) {
      auto* store_s = llvm::BasicBlock::Create(ctx_, "tail.s", f);
      b.CreateCondBr(has_s, store_s, done);
      b.SetInsertPoint(store_s);
      for (int k = 0; k < num_s; ++k) {
        llvm::Value* v =
            b.CreateAlignedLoad(vt_, b.CreateConstGEP1_64(st_, out_buf, uint64_t(1 + k) * w_), align_);
        llvm::Value* dst =
            b.CreateGEP(st_, out_s, b.CreateAdd(b.CreateMul(n, b.getInt64(k)), n_full));
        b.CreateMaskedStore(v, dst, align_, tail_mask);
      }
    }
    b.CreateBr(done);
    b.SetInsertPoint(done);
    b.CreateRetVoid();
  }

  llvm::LLVMContext& ctx_;
  llvm::Module& m_;
  llvm::IRBuilder<> b_;
  const Function& fn_;
  Precision prec_;
  int w_;
  llvm::Type* st_;
  llvm::FixedVectorType* vt_;
  llvm::FixedVectorType* mt_;
  llvm::IntegerType* i64_;
  llvm::IntegerType* i32_;
  llvm::PointerType* ptr_;
  llvm::Align align_;
  llvm::Function* body_ = nullptr;
  std::vector<llvm::Value*> values_;
  std::vector<llvm::Value*> slot_ptr_;
  std::vector<int> slot_group_;
  std::vector<Group> groups_;
  llvm::AllocaInst* err_ = nullptr;
  llvm::Value* mask_ = nullptr;  ///< active lanes; null = all (outside any control region)
  std::vector<Frame> frames_;
};

size_t count_insts(const llvm::Module& m) {
  size_t n = 0;
  for (const llvm::Function& f : m) {
    for (const llvm::BasicBlock& bb : f) n += bb.size();
  }
  return n;
}

llvm::OptimizationLevel opt_level(int level) {
  switch (level) {
    case 0: return llvm::OptimizationLevel::O0;
    case 1: return llvm::OptimizationLevel::O1;
    case 3: return llvm::OptimizationLevel::O3;
    default: return llvm::OptimizationLevel::O2;
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------

struct JitFunction::Impl {
  Precision precision = Precision::kF64;
  llvm::orc::ResourceTrackerSP tracker;
  void* entry = nullptr;
  JitStats stats;
  std::string llvm_ir;

  ~Impl() {
    if (tracker) {
      if (auto err = tracker->remove()) llvm::consumeError(std::move(err));
    }
  }
};

JitFunction::JitFunction(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
JitFunction::~JitFunction() = default;

Precision JitFunction::precision() const { return impl_->precision; }
BatchFn<double> JitFunction::f64() const {
  return impl_->precision == Precision::kF64 ? reinterpret_cast<BatchFn<double>>(impl_->entry)
                                             : nullptr;
}
BatchFn<float> JitFunction::f32() const {
  return impl_->precision == Precision::kF32 ? reinterpret_cast<BatchFn<float>>(impl_->entry)
                                             : nullptr;
}
const JitStats& JitFunction::stats() const { return impl_->stats; }
const std::string& JitFunction::llvm_ir() const { return impl_->llvm_ir; }

Result<std::unique_ptr<JitFunction>> JitFunction::compile(const Function& fn, Precision precision,
                                                          const JitOptions& options) {
  Engine* e = engine();
  if (!e) return Error{g_engine_error};
  auto impl = std::make_unique<Impl>();
  impl->precision = precision;
  int lanes = options.lanes > 0 ? options.lanes : lanes_for(*e, precision);
  HFRT_CHECK_MSG(lanes > 0 && (lanes & (lanes - 1)) == 0, "lanes must be a power of two");
  impl->stats.lanes = lanes;

  auto tm = e->jtmb.createTargetMachine();
  if (!tm) return Error{"cannot create the target machine: " + to_string(tm.takeError())};

  const std::string name =
      "hfrt_eval_" + std::to_string(e->next_id.fetch_add(1)) +
      (precision == Precision::kF64 ? "_f64" : "_f32");
  auto ctx = std::make_unique<llvm::LLVMContext>();
  auto module = std::make_unique<llvm::Module>(name, *ctx);
  module->setDataLayout((*tm)->createDataLayout());
  module->setTargetTriple((*tm)->getTargetTriple().str());

  auto t0 = std::chrono::steady_clock::now();
  Emitter(*ctx, *module, fn, precision, lanes).emit(name);
  impl->stats.emit_ms = ms_since(t0);
  impl->stats.llvm_insts_before = count_insts(*module);
  {
    std::string msg;
    llvm::raw_string_ostream os(msg);
    HFRT_CHECK_MSG(!llvm::verifyModule(*module, &os), "invalid LLVM IR emitted: " << os.str());
  }

  t0 = std::chrono::steady_clock::now();
  {
    llvm::LoopAnalysisManager lam;
    llvm::FunctionAnalysisManager fam;
    llvm::CGSCCAnalysisManager cgam;
    llvm::ModuleAnalysisManager mam;
    llvm::PassBuilder pb(tm->get());
    pb.registerModuleAnalyses(mam);
    pb.registerCGSCCAnalyses(cgam);
    pb.registerFunctionAnalyses(fam);
    pb.registerLoopAnalyses(lam);
    pb.crossRegisterProxies(lam, fam, cgam, mam);
    llvm::ModulePassManager mpm =
        options.opt_level <= 0 ? pb.buildO0DefaultPipeline(llvm::OptimizationLevel::O0)
                               : pb.buildPerModuleDefaultPipeline(opt_level(options.opt_level));
    mpm.run(*module, mam);
  }
  impl->stats.optimize_ms = ms_since(t0);
  impl->stats.llvm_insts_after = count_insts(*module);
  {
    llvm::raw_string_ostream os(impl->llvm_ir);
    module->print(os, nullptr);
  }

  t0 = std::chrono::steady_clock::now();
  impl->tracker = e->jit->getMainJITDylib().createResourceTracker();
  llvm::orc::ThreadSafeModule tsm(std::move(module), std::move(ctx));
  if (auto err = e->jit->addIRModule(impl->tracker, std::move(tsm))) {
    return Error{"cannot add the module to the JIT: " + to_string(std::move(err))};
  }
  auto sym = e->jit->lookup(name);
  if (!sym) return Error{"cannot compile " + name + ": " + to_string(sym.takeError())};
  impl->entry = sym->toPtr<void*>();
  impl->stats.codegen_ms = ms_since(t0);
  return std::unique_ptr<JitFunction>(new JitFunction(std::move(impl)));
}

std::string host_cpu_name() {
  Engine* e = engine();
  return e ? e->cpu : llvm::sys::getHostCPUName().str();
}

int host_lanes(Precision precision) {
  Engine* e = engine();
  return e ? lanes_for(*e, precision) : (precision == Precision::kF64 ? 2 : 4);
}

}  // namespace hfrt::jit
