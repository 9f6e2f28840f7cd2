#pragma once
// Shared LLVM plumbing of the interval and gradient JIT emitters (llvm_interval.cpp,
// llvm_gradient.cpp): one process-wide ORC LLJIT for these domains, the new-pass-manager
// pipeline and per-function ResourceTrackers. Follows jit/llvm_jit.cpp (H3's scalar JIT):
// host functions are registered as absolute symbols (no process symbol lookup), each
// compiled function owns its own ThreadSafeContext and ResourceTracker.
// Only jit/llvm_*.cpp may include this header (it includes LLVM).
//
// TODO(lead): this duplicates the Engine of llvm_jit.cpp, which is private to that file;
// once it is exposed through a header the two can share one LLJIT.

#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "jit/llvm_includes.h"
#include <llvm/Transforms/Scalar/DCE.h>
#include <llvm/Transforms/Scalar/EarlyCSE.h>
#include <llvm/Transforms/Scalar/SROA.h>
#include "lang/result.h"

namespace hfrt::jit::domains {

struct HostSymbol {
  const char* name;
  void* addr;
};

/// The domain JIT: created once with every host function any domain emitter may call.
struct DomainEngine {
  std::unique_ptr<llvm::orc::LLJIT> jit;
  llvm::orc::JITTargetMachineBuilder jtmb{llvm::Triple()};
  std::atomic<uint64_t> next_id{0};
  int vector_bits = 128;
  std::string error;
};

inline std::string llvm_error_text(llvm::Error err) {
  std::string s;
  llvm::raw_string_ostream os(s);
  os << err;
  return os.str();
}

/// The engine (created on first use with `symbols`; later calls ignore the argument).
/// Returns null with *error set when LLVM cannot create the JIT.
inline DomainEngine* domain_engine(const std::vector<HostSymbol>& symbols, std::string* error) {
  static DomainEngine* engine = nullptr;
  static std::string init_error;
  static std::once_flag once;
  std::call_once(once, [&] {
    llvm::InitializeNativeTarget();
    llvm::InitializeNativeTargetAsmPrinter();
    llvm::InitializeNativeTargetAsmParser();
    auto e = std::make_unique<DomainEngine>();
    std::string cpu = llvm::sys::getHostCPUName().str();
    auto host_features = llvm::sys::getHostCPUFeatures();
    std::vector<std::string> features;
    for (auto& f : host_features) {
      std::string feature(f.second ? "+" : "-");
      feature.append(f.first().data(), f.first().size());
      features.push_back(std::move(feature));
    }
    if (host_features.lookup("avx512f")) e->vector_bits = 512;
    else if (host_features.lookup("avx")) e->vector_bits = 256;
    e->jtmb = llvm::orc::JITTargetMachineBuilder(llvm::Triple(llvm::sys::getProcessTriple()));
    e->jtmb.setCPU(cpu);
    e->jtmb.addFeatures(features);
    e->jtmb.setCodeGenOptLevel(llvm::CodeGenOptLevel::Aggressive);
    auto jit = llvm::orc::LLJITBuilder()
                   .setJITTargetMachineBuilder(e->jtmb)
                   .setLinkProcessSymbolsByDefault(false)
                   .setPlatformSetUp(llvm::orc::setUpInactivePlatform)
                   .setSupportConcurrentCompilation(true)
                   .create();
    if (!jit) {
      init_error = "cannot create the LLVM JIT: " + llvm_error_text(jit.takeError());
      return;
    }
    e->jit = std::move(*jit);
    llvm::orc::SymbolMap map;
    for (const HostSymbol& s : symbols) {
      map[e->jit->mangleAndIntern(s.name)] = {
          llvm::orc::ExecutorAddr::fromPtr(s.addr),
          llvm::JITSymbolFlags::Exported | llvm::JITSymbolFlags::Callable};
    }
    if (auto err = e->jit->getMainJITDylib().define(llvm::orc::absoluteSymbols(map))) {
      init_error = "cannot register host symbols: " + llvm_error_text(std::move(err));
      return;
    }
    engine = e.release();  // lives for the process
  });
  if (!engine && error) *error = init_error;
  return engine;
}

/// Compiled code owned through a ResourceTracker (freed on destruction).
struct CompiledCode {
  llvm::orc::ResourceTrackerSP tracker;
  void* entry = nullptr;
  ~CompiledCode() {
    if (tracker) {
      if (auto err = tracker->remove()) llvm::consumeError(std::move(err));
    }
  }
};

/// Verifies, optimises (O2 unless opt_level says otherwise) and links `module`; returns the
/// address of `entry_name`.
inline Result<std::unique_ptr<CompiledCode>> compile_module(
    DomainEngine& e, std::unique_ptr<llvm::LLVMContext> ctx, std::unique_ptr<llvm::Module> module,
    llvm::TargetMachine& tm, const std::string& entry_name, int opt_level) {
  {
    std::string msg;
    llvm::raw_string_ostream os(msg);
    HFRT_CHECK_MSG(!llvm::verifyModule(*module, &os), "invalid LLVM IR emitted: " << os.str());
  }
  {
    llvm::LoopAnalysisManager lam;
    llvm::FunctionAnalysisManager fam;
    llvm::CGSCCAnalysisManager cgam;
    llvm::ModuleAnalysisManager mam;
    llvm::PassBuilder pb(&tm);
    pb.registerModuleAnalyses(mam);
    pb.registerCGSCCAnalyses(cgam);
    pb.registerFunctionAnalyses(fam);
    pb.registerLoopAnalyses(lam);
    pb.crossRegisterProxies(lam, fam, cgam, mam);
    llvm::OptimizationLevel level = opt_level >= 3 ? llvm::OptimizationLevel::O3
                                                   : llvm::OptimizationLevel::O2;
    if (opt_level == 1) {
      // The light pipeline: promote slots to registers and share common subexpressions, but
      // keep the emitter's basic blocks. Domain code is wide (tens of LLVM instructions per
      // hfrt op) and deep (select chains); the emitters cut it into small blocks because
      // SelectionDAG's combiner is superlinear in the size of a block. The default
      // pipelines merge those blocks again (SimplifyCFG) and take minutes on big models.
      llvm::FunctionPassManager fpm;
      fpm.addPass(llvm::SROAPass(llvm::SROAOptions::PreserveCFG));
      fpm.addPass(llvm::EarlyCSEPass());
      fpm.addPass(llvm::DCEPass());
      llvm::ModulePassManager mpm;
      mpm.addPass(llvm::createModuleToFunctionPassAdaptor(std::move(fpm)));
      mpm.run(*module, mam);
    } else {
      llvm::ModulePassManager mpm = opt_level <= 0
                                        ? pb.buildO0DefaultPipeline(llvm::OptimizationLevel::O0)
                                        : pb.buildPerModuleDefaultPipeline(level);
      mpm.run(*module, mam);
    }
  }
  auto code = std::make_unique<CompiledCode>();
  code->tracker = e.jit->getMainJITDylib().createResourceTracker();
  llvm::orc::ThreadSafeModule tsm(std::move(module), std::move(ctx));
  if (auto err = e.jit->addIRModule(code->tracker, std::move(tsm))) {
    return Error{"cannot add the module to the JIT: " + llvm_error_text(std::move(err))};
  }
  auto sym = e.jit->lookup(entry_name);
  if (!sym) return Error{"cannot compile " + entry_name + ": " + llvm_error_text(sym.takeError())};
  code->entry = sym->toPtr<void*>();
  return code;
}

}  // namespace hfrt::jit::domains
