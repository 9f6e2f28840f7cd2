// The shared LLVM JIT session: see llvm_session.h.

#include "jit/llvm_session.h"

#include <llvm/Bitcode/BitcodeWriter.h>
#include <llvm/ExecutionEngine/Orc/CompileUtils.h>
#include <llvm/ExecutionEngine/Orc/ExecutorProcessControl.h>
#include <llvm/ExecutionEngine/Orc/TaskDispatch.h>
#include <llvm/IR/Operator.h>
#include <llvm/Object/ELFObjectFile.h>
#include <llvm/Passes/StandardInstrumentations.h>
#include <llvm/Support/BLAKE3.h>
#include <llvm/Support/MemoryBuffer.h>
#include <llvm/Support/Timer.h>
#include <llvm/Transforms/Scalar/DCE.h>
#include <llvm/Transforms/Scalar/EarlyCSE.h>
#include <llvm/Transforms/Scalar/SROA.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>

#include "base/check.h"
#include "base/timer.h"
#include "hfrt/compile_cache.h"
#include "jit/compile_cache.h"
#include "jit/surface_ops.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

template <typename F>
void* fn_addr(F* f) {
  return reinterpret_cast<void*>(f);
}

/// The size of function `name` in an ELF object file (0 when it is not there, or the object
/// is not ELF: only ELF symbols carry a size).
uint64_t object_symbol_size(llvm::MemoryBufferRef buffer, llvm::StringRef name) {
  auto obj = llvm::object::ObjectFile::createObjectFile(buffer);
  if (!obj) {
    llvm::consumeError(obj.takeError());
    return 0;
  }
  const auto* elf = llvm::dyn_cast<llvm::object::ELFObjectFileBase>(obj->get());
  if (!elf) return 0;
  for (const llvm::object::ELFSymbolRef& s : elf->symbols()) {
    auto n = s.getName();
    if (!n) {
      llvm::consumeError(n.takeError());
      continue;
    }
    if (*n == name) return s.getSize();
  }
  return 0;
}

/// A line of /tmp/perf-PID.map, the file in which `perf report` looks up the names of JIT
/// code (HFRT_PERF_MAP=1, for profiling: the evaluators then show by unit instead of as bare
/// addresses).
void append_perf_map(uint64_t addr, uint64_t size, const std::string& name) {
  static std::mutex mu;
  std::lock_guard lock(mu);
  const std::string path = "/tmp/perf-" + std::to_string(getpid()) + ".map";
  if (FILE* f = std::fopen(path.c_str(), "a")) {
    std::fprintf(f, "%llx %llx hfrt:%s\n", static_cast<unsigned long long>(addr),
                 static_cast<unsigned long long>(size ? size : 1), name.c_str());
    std::fclose(f);
  }
}

/// libm (the very functions the interpreters call, so f64 results are bit-identical) and the
/// C library functions the optimiser may introduce. The libm functions are those of the
/// Libm and Intrinsic lanes of ir_ops.h (an intrinsic may be lowered to its libm function).
std::vector<HostSymbol> libc_symbols() {
  using D1 = double (*)(double);
  using D2 = double (*)(double, double);
  using F1 = float (*)(float);
  using F2 = float (*)(float, float);
#define HFRT_LIBC_SYMBOLS_None(n, t)
#define HFRT_LIBC_SYMBOLS_Inline(n, t)
#define HFRT_LIBC_SYMBOLS_Libm(n, t) \
  {#t, fn_addr(static_cast<D##n>(&::t))}, {#t "f", fn_addr(static_cast<F##n>(&::t##f))},
#define HFRT_LIBC_SYMBOLS_Intrinsic(n, t) HFRT_LIBC_SYMBOLS_Libm(n, t)
#define HFRT_LIBC_SYMBOLS_Helper(n, t)  // hfrt's own helpers: scalar_jit_symbols()
#define HFRT_X(name, n, f, kind, lane, libm, poly) HFRT_LIBC_SYMBOLS_##lane(n, libm)
  return {
      HFRT_IR_OPS(HFRT_X)
      // The optimiser may turn aggregate initialisation and copies into these.
      {"memset", fn_addr(&::memset)},
      {"memcpy", fn_addr(&::memcpy)},
      {"memmove", fn_addr(&::memmove)},
  };
#undef HFRT_X
#undef HFRT_LIBC_SYMBOLS_None
#undef HFRT_LIBC_SYMBOLS_Inline
#undef HFRT_LIBC_SYMBOLS_Libm
#undef HFRT_LIBC_SYMBOLS_Intrinsic
#undef HFRT_LIBC_SYMBOLS_Helper
}

/// Sets a process-wide LLVM boolean option if this LLVM build has it.
void set_bool_option(const char* name, bool value) {
  auto& registered = llvm::cl::getRegisteredOptions();
  auto it = registered.find(name);
  if (it != registered.end()) {
    if (auto* opt = static_cast<llvm::cl::opt<bool>*>(it->second)) opt->setValue(value);
  }
}

}  // namespace

std::string llvm_error_text(llvm::Error err) {
  std::string s;
  llvm::raw_string_ostream os(s);
  os << err;
  return os.str();
}

size_t count_insts(const llvm::Module& m) {
  size_t n = 0;
  for (const llvm::Function& f : m) {
    for (const llvm::BasicBlock& bb : f) n += bb.size();
  }
  return n;
}

/// Calls of functions (not intrinsics) in `f`: each is a real call in the machine code.
size_t count_calls(const llvm::Function& f) {
  size_t n = 0;
  for (const llvm::BasicBlock& bb : f) {
    for (const llvm::Instruction& inst : bb) {
      if (const auto* call = llvm::dyn_cast<llvm::CallInst>(&inst)) {
        const llvm::Function* callee = call->getCalledFunction();
        n += !callee || !callee->isIntrinsic();
      }
    }
  }
  return n;
}

int call_heavy_lanes(const ir::Function& fn, int host, bool trig_inline, size_t limit) {
  if (limit == 0) return host;
  size_t calls = 0;
  for (const ir::Inst& inst : fn.insts) {
    const ir::OpLane lane = ir::op_lane(inst.op);
    calls += (lane == ir::OpLane::kLibm || lane == ir::OpLane::kHelper) &&
             !(trig_inline && (inst.op == ir::Op::kSin || inst.op == ir::Op::kCos));
  }
  const bool heavy = calls * size_t(std::max(host, 1)) > limit && calls * 16 >= fn.insts.size();
  return heavy ? 1 : host;
}

PipelineOptions domain_pipeline(int opt_level) {
  PipelineOptions o;
  o.opt_level = opt_level;
  o.light = opt_level == 1;
  // Not Aggressive: at that level x86 runs the post-RA list scheduler, whose dependence
  // graph is quadratic in the memory operations of a block.
  o.codegen = opt_level <= 0 ? llvm::CodeGenOptLevel::None : llvm::CodeGenOptLevel::Default;
  return o;
}

CompiledCode::~CompiledCode() {
  if (dylib_) {
    if (auto err = session_->removeJITDylib(*dylib_)) llvm::consumeError(std::move(err));
  }
}

namespace {

/// The name every compile's entry gets in its own JITDylib.
constexpr const char* kEntryName = "hfrt_entry";
/// Bumped whenever something that shapes the machine code but not the IR changes (the
/// session's codegen options, the pipelines): old entries then stop matching.
constexpr int kCacheFormat = 1;

/// Whether `module` holds an address of this process (an integer turned into a pointer; the
/// surfaces of mesh and patch leaves are symbols instead, see host_address()): such code must
/// not be cached.
bool holds_process_addresses(const llvm::Module& module) {
  for (const llvm::Function& f : module) {
    for (const llvm::BasicBlock& bb : f) {
      for (const llvm::Instruction& inst : bb) {
        for (const llvm::Use& op : inst.operands()) {
          if (auto* ce = llvm::dyn_cast<llvm::ConstantExpr>(op.get())) {
            if (ce->getOpcode() == llvm::Instruction::IntToPtr) return true;
          }
        }
      }
    }
  }
  return false;
}

/// The metadata of host_address(): the address as an i64 constant.
constexpr const char* kHostAddressMd = "hfrt.host_address";

/// Takes host_address()'s metadata off `module`'s globals: (name, address) of each.
std::vector<std::pair<std::string, uint64_t>> take_host_addresses(llvm::Module& module) {
  std::vector<std::pair<std::string, uint64_t>> out;
  for (llvm::GlobalVariable& g : module.globals()) {
    llvm::MDNode* md = g.getMetadata(kHostAddressMd);
    if (!md) continue;
    auto* value = llvm::mdconst::extract<llvm::ConstantInt>(md->getOperand(0));
    out.emplace_back(g.getName().str(), value->getZExtValue());
    g.setMetadata(kHostAddressMd, nullptr);
  }
  return out;
}

}  // namespace

llvm::Constant* host_address(llvm::Module& module, const std::string& name, const void* addr) {
  if (llvm::GlobalVariable* g = module.getGlobalVariable(name)) return g;
  llvm::LLVMContext& ctx = module.getContext();
  auto* g = new llvm::GlobalVariable(module, llvm::Type::getInt8Ty(ctx), /*isConstant=*/true,
                                     llvm::GlobalValue::ExternalLinkage, nullptr, name);
  const uint64_t bits = reinterpret_cast<uintptr_t>(addr);
  g->setMetadata(kHostAddressMd,
                 llvm::MDNode::get(ctx, {llvm::ConstantAsMetadata::get(llvm::ConstantInt::get(
                                            llvm::Type::getInt64Ty(ctx), bits))}));
  return g;
}

Result<LlvmSession*> LlvmSession::get() {
  static Result<LlvmSession*> session = create();
  return session;
}

Result<LlvmSession*> LlvmSession::create() {
  llvm::InitializeNativeTarget();
  llvm::InitializeNativeTargetAsmPrinter();
  llvm::InitializeNativeTargetAsmParser();

  // The X86 MachineCombiner is quadratic in the length of a basic block (60% of codegen time
  // on a 30k-instruction model) and, without fast-math reassociation, finds nothing to
  // combine in hfrt's FP code; switch it off (process-wide LLVM option, set once here).
  set_bool_option("x86-machine-combiner", false);
  // Debugging and profiling: LLVM options from the environment (e.g. -time-passes).
  if (std::getenv("HFRT_LLVM_ARGS")) {
    const char* argv[] = {"hfrt"};
    llvm::cl::ParseCommandLineOptions(1, argv, "", nullptr, "HFRT_LLVM_ARGS");
  }

  std::unique_ptr<LlvmSession> s(new LlvmSession());
  s->cpu_ = llvm::sys::getHostCPUName().str();
  auto host_features = llvm::sys::getHostCPUFeatures();
  std::vector<std::string> features;
  for (auto& f : host_features) {
    std::string feature(f.second ? "+" : "-");
    feature.append(f.first().data(), f.first().size());
    features.push_back(std::move(feature));
  }
  if (host_features.lookup("avx512f")) {
    s->vector_bits_ = 512;
  } else if (host_features.lookup("avx")) {
    s->vector_bits_ = 256;
  }
  s->jtmb_ = llvm::orc::JITTargetMachineBuilder(llvm::Triple(llvm::sys::getProcessTriple()));
  s->jtmb_.setCPU(s->cpu_);
  s->jtmb_.addFeatures(features);
  s->jtmb_.setCodeGenOptLevel(llvm::CodeGenOptLevel::Aggressive);

  // Materialisation (linking an object into memory) runs on the thread that asks for the
  // symbol. ORC's default for an in-process session, a DynamicThreadPoolTaskDispatcher, starts
  // a new thread for every task: ~20 threads created and joined per teapot render, for work
  // of well under a millisecond each, while the asking thread waits anyway. Compiles stay
  // concurrent (setSupportConcurrentCompilation below): each thread links what it compiled.
  auto epc = llvm::orc::SelfExecutorProcessControl::Create(
      nullptr, std::make_unique<llvm::orc::InPlaceTaskDispatcher>());
  if (!epc) return Error{"cannot create the LLVM JIT: " + llvm_error_text(epc.takeError())};
  auto jit = llvm::orc::LLJITBuilder()
                 .setExecutorProcessControl(std::move(*epc))
                 .setJITTargetMachineBuilder(s->jtmb_)
                 // No process symbols (every host function is registered below), hence no
                 // native platform either: JIT code has no static initialisers to run.
                 .setLinkProcessSymbolsByDefault(false)
                 .setPlatformSetUp(llvm::orc::setUpInactivePlatform)
                 .setSupportConcurrentCompilation(true)
                 .create();
  if (!jit) return Error{"cannot create the LLVM JIT: " + llvm_error_text(jit.takeError())};
  s->jit_ = std::move(*jit);
  {
    auto tm = s->jtmb_.createTargetMachine();
    if (!tm) return Error{"cannot create the target machine: " + llvm_error_text(tm.takeError())};
    s->data_layout_ = (*tm)->createDataLayout().getStringRepresentation();
    s->triple_ = (*tm)->getTargetTriple().str();
  }

  llvm::orc::SymbolMap symbols;
  auto add = [&](const HostSymbol& h) {
    symbols[s->jit_->mangleAndIntern(h.name)] = {
        llvm::orc::ExecutorAddr::fromPtr(h.addr),
        llvm::JITSymbolFlags::Exported | llvm::JITSymbolFlags::Callable};
  };
  for (const HostSymbol& h : libc_symbols()) add(h);
  for (const HostSymbol& h : scalar_jit_symbols()) add(h);
  for (const HostSymbol& h : interval_jit_symbols()) add(h);
  // kSurface's helpers (jit/surface_ops.h).
  add({"hfrt_surface_f64", fn_addr(&hfrt_surface_f64)});
  add({"hfrt_surface_f32", fn_addr(&hfrt_surface_f32)});
  add({"hfrt_surface_sign_f64", fn_addr(&hfrt_surface_sign_f64)});
  add({"hfrt_surface_sign_f32", fn_addr(&hfrt_surface_sign_f32)});
  add({"hfrt_surface_interval", fn_addr(&hfrt_surface_interval)});
  add({"hfrt_surface_dual", fn_addr(&hfrt_surface_dual)});
  if (auto err = s->jit_->getMainJITDylib().define(llvm::orc::absoluteSymbols(symbols))) {
    return Error{"cannot register host symbols: " + llvm_error_text(std::move(err))};
  }
  return s.release();
}

ModuleUnit LlvmSession::new_module(std::string_view prefix) {
  ModuleUnit u;
  u.name = std::string(prefix) + "_" + std::to_string(next_id_.fetch_add(1));
  u.ctx = std::make_unique<llvm::LLVMContext>();
  u.module = std::make_unique<llvm::Module>(u.name, *u.ctx);
  u.module->setDataLayout(data_layout_);
  u.module->setTargetTriple(triple_);
  return u;
}

Result<std::unique_ptr<CompiledCode>> LlvmSession::compile(ModuleUnit unit,
                                                           const std::string& entry,
                                                           const PipelineOptions& options,
                                                           JitStats* stats, std::string* ir_text) {
  llvm::Module& module = *unit.module;
  {
    std::string msg;
    llvm::raw_string_ostream os(msg);
    HFRT_CHECK_MSG(!llvm::verifyModule(module, &os), "invalid LLVM IR emitted: " << os.str());
  }
  // Names that do not depend on the session: the entry's is fixed (each compile links into a
  // JITDylib of its own), the other external functions become internal and nameless.
  llvm::Function* entry_fn = module.getFunction(entry);
  HFRT_CHECK_MSG(entry_fn && !entry_fn->isDeclaration(), "no function " << entry << " to compile");
  std::vector<llvm::Function*> fast;
  for (const std::string& name : options.fast_codegen) {
    if (llvm::Function* f = module.getFunction(name)) fast.push_back(f);
  }
  entry_fn->setName(kEntryName);
  // Addresses of this process leave the IR (they are defined at link time below).
  const std::vector<std::pair<std::string, uint64_t>> host_symbols = take_host_addresses(module);
  module.setModuleIdentifier("hfrt");
  module.setSourceFileName("hfrt");
  for (llvm::Function& f : module) {
    if (&f != entry_fn && !f.isDeclaration() && !f.hasLocalLinkage()) {
      f.setLinkage(llvm::GlobalValue::InternalLinkage);
      f.setName("");
    }
  }
  if (stats) stats->llvm_insts_before = count_insts(module);
  // Call-heavy code (PipelineOptions::fast_codegen_calls): the light IR pipeline and code
  // generation at level None (fast instruction selection and the fast register allocator,
  // which is chosen per module: optnone on a function alone keeps the greedy one).
  size_t most_calls = 0;
  for (const llvm::Function& f : module) most_calls = std::max(most_calls, count_calls(f));
  const bool call_heavy = options.fast_codegen_calls > 0 && most_calls > options.fast_codegen_calls;
  const bool light = options.light || call_heavy;
  const llvm::CodeGenOptLevel codegen = call_heavy ? llvm::CodeGenOptLevel::None : options.codegen;
  if (stats) {
    stats->llvm_calls = most_calls;
    stats->fast_codegen = call_heavy;
  }

  // The compile cache: the key is the IR before optimisation and everything else that shapes
  // the machine code.
  std::string key;
  std::unique_ptr<llvm::MemoryBuffer> object;
  if (compile_cache_enabled()) {
    if (holds_process_addresses(module)) {
      compile_cache_bypass();
    } else {
      llvm::SmallVector<char, 0> bitcode;
      llvm::raw_svector_ostream bos(bitcode);
      llvm::WriteBitcodeToFile(module, bos);
      std::string ctx = "format " + std::to_string(kCacheFormat) + "\nllvm " LLVM_VERSION_STRING +
                        "\ncpu " + cpu_ + "\ntriple " + triple_ + "\nlayout " + data_layout_ +
                        "\nopt " + std::to_string(options.opt_level) + (light ? " light" : "") +
                        " codegen " + std::to_string(static_cast<int>(codegen)) + "\nfast";
      for (llvm::Function* f : fast) ctx += " " + std::to_string(f == entry_fn ? 0 : 1);
      for (const std::string& feature : jtmb_.getFeatures().getFeatures()) ctx += "\n" + feature;
      llvm::BLAKE3 hash;
      hash.update(llvm::ArrayRef<uint8_t>(reinterpret_cast<const uint8_t*>(bitcode.data()),
                                          bitcode.size()));
      hash.update(ctx);
      const auto digest = hash.final();
      static const char* kHex = "0123456789abcdef";
      for (uint8_t b : digest) {
        key.push_back(kHex[b >> 4]);
        key.push_back(kHex[b & 15]);
      }
      if (std::optional<std::string> cached = compile_cache_load(key)) {
        object = llvm::MemoryBuffer::getMemBufferCopy(*cached, key);
        if (stats) stats->from_cache = true;
        if (options.keep_ir && ir_text) {
          ir_text->assign("; from hfrt's compile cache: the IR before optimisation\n");
          llvm::raw_string_ostream os(*ir_text);
          module.print(os, nullptr);
        }
      }
    }
  }

  auto t0 = std::chrono::steady_clock::now();
  if (!object) {
    auto tm_or = jtmb_.createTargetMachine();
    if (!tm_or) {
      return Error{"cannot create the target machine: " + llvm_error_text(tm_or.takeError())};
    }
    std::unique_ptr<llvm::TargetMachine> tm = std::move(*tm_or);
    tm->setOptLevel(codegen);

    // --- Optimisation (new pass manager).
    {
      llvm::LoopAnalysisManager lam;
      llvm::FunctionAnalysisManager fam;
      llvm::CGSCCAnalysisManager cgam;
      llvm::ModuleAnalysisManager mam;
      // Standard instrumentation makes -time-passes and -print-after-all (HFRT_LLVM_ARGS) work.
      llvm::PassInstrumentationCallbacks pic;
      llvm::StandardInstrumentations si(*unit.ctx, /*DebugLogging=*/false);
      si.registerCallbacks(pic, &mam);
      llvm::PassBuilder pb(tm.get(), llvm::PipelineTuningOptions(), std::nullopt, &pic);
      pb.registerModuleAnalyses(mam);
      pb.registerCGSCCAnalyses(cgam);
      pb.registerFunctionAnalyses(fam);
      pb.registerLoopAnalyses(lam);
      pb.crossRegisterProxies(lam, fam, cgam, mam);
      llvm::ModulePassManager mpm;
      if (light) {
        // Promote slots to registers and share common subexpressions, but keep the emitter's
        // basic blocks (no SimplifyCFG, no instcombine).
        llvm::FunctionPassManager fpm;
        fpm.addPass(llvm::SROAPass(llvm::SROAOptions::PreserveCFG));
        fpm.addPass(llvm::EarlyCSEPass());
        fpm.addPass(llvm::DCEPass());
        mpm.addPass(llvm::createModuleToFunctionPassAdaptor(std::move(fpm)));
      } else if (options.opt_level <= 0) {
        mpm = pb.buildO0DefaultPipeline(llvm::OptimizationLevel::O0);
      } else {
        llvm::OptimizationLevel level = options.opt_level == 1   ? llvm::OptimizationLevel::O1
                                        : options.opt_level == 2 ? llvm::OptimizationLevel::O2
                                                                 : llvm::OptimizationLevel::O3;
        mpm = pb.buildPerModuleDefaultPipeline(level);
      }
      mpm.run(module, mam);
    }
    for (llvm::Function* f : fast) {
      f->addFnAttr(llvm::Attribute::NoInline);
      f->addFnAttr(llvm::Attribute::OptimizeNone);
    }
    if (stats) {
      stats->optimize_ms = ms_since(t0);
      stats->llvm_insts_after = count_insts(module);
    }
    if (options.keep_ir && ir_text) {
      ir_text->clear();
      llvm::raw_string_ostream os(*ir_text);
      module.print(os, nullptr);
    }

    // --- Code generation (here rather than lazily in ORC, at the level asked for).
    t0 = std::chrono::steady_clock::now();
    llvm::orc::SimpleCompiler compiler(*tm);
    auto compiled = compiler(module);
    if (!compiled) {
      return Error{"cannot compile " + entry + ": " + llvm_error_text(compiled.takeError())};
    }
    object = std::move(*compiled);
    if (!key.empty()) compile_cache_store(key, object->getBuffer());
  }

  // --- Linking, into a JITDylib of its own (which sees the host symbols of the main one).
  auto dylib = jit_->createJITDylib(unit.name);
  if (!dylib) return Error{"cannot create a JITDylib: " + llvm_error_text(dylib.takeError())};
  llvm::orc::JITDylib& jd = *dylib;
  jd.addToLinkOrder(jit_->getMainJITDylib());  // libm and hfrt's helpers
  auto drop = [&](std::string message) -> Error {
    if (auto err = jit_->getExecutionSession().removeJITDylib(jd)) {
      llvm::consumeError(std::move(err));
    }
    return Error{std::move(message)};
  };
  if (!host_symbols.empty()) {
    llvm::orc::SymbolMap symbols;
    for (const auto& [name, addr] : host_symbols) {
      symbols[jit_->mangleAndIntern(name)] = {llvm::orc::ExecutorAddr(addr),
                                              llvm::JITSymbolFlags::Exported};
    }
    if (auto err = jd.define(llvm::orc::absoluteSymbols(std::move(symbols)))) {
      return drop("cannot define the surfaces' symbols: " + llvm_error_text(std::move(err)));
    }
  }
  // HFRT_PERF_MAP=1: the entry's size in the object, for perf's map of JIT code (below).
  static const bool perf_map = std::getenv("HFRT_PERF_MAP") != nullptr;
  uint64_t entry_size = 0;
  if (perf_map) entry_size = object_symbol_size(object->getMemBufferRef(), kEntryName);
  if (auto err = jit_->addObjectFile(jd, std::move(object))) {
    return drop("cannot add the object to the JIT: " + llvm_error_text(std::move(err)));
  }
  auto sym = jit_->lookup(jd, kEntryName);
  if (!sym) return drop("cannot link " + entry + ": " + llvm_error_text(sym.takeError()));
  if (perf_map) append_perf_map(sym->getValue(), entry_size, unit.name);
  auto code =
      std::make_unique<CompiledCode>(&jit_->getExecutionSession(), &jd, sym->toPtr<void*>());
  if (stats) stats->codegen_ms = ms_since(t0);
  // The context and module die here: the object code no longer needs them.
  return code;
}

}  // namespace hfrt::jit
