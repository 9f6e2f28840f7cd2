#pragma once
// The one LLVM JIT infrastructure of hfrt, shared by every emitter (the scalar JIT of
// llvm_jit.cpp, the interval JIT of llvm_interval.cpp, the gradient JIT of llvm_gradient.cpp):
//
// - one process-wide ORC LLJIT ("the session"), created on first use for the host CPU with
//   all its features, concurrent compilation on, no process symbol lookup: every host
//   function JIT code may call (libm, hfrt's helpers) is registered here as an absolute
//   symbol, so nothing resolves by surprise;
// - the host's SIMD width (lanes per precision);
// - per compiled function: its own LLVMContext (ThreadSafeContext), module and ORC
//   ResourceTracker, so compiled code is freed with its owner while the session is shared;
// - the new-pass-manager pipeline at a chosen level and the code generator at a chosen
//   level (optimisation and code generation are run here, not lazily by ORC, so each can be
//   timed and tuned per function: huge interval functions want a cheaper code generator);
// - compile statistics (JitStats).
//
// Debugging: the environment variable HFRT_LLVM_ARGS is parsed as LLVM command-line options
// when the session starts (e.g. HFRT_LLVM_ARGS="-time-passes" prints LLVM's pass timers).
//
// Only jit/llvm_*.cpp may include this header (it includes LLVM).

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"
#include "ir/ir.h"
#include "jit/llvm_includes.h"
#include "jit/llvm_jit.h"  // JitStats, kCallHeavyLaneCalls, kFastCodegenCalls

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// A host function JIT code may call: registered under `name` at `addr`.
struct HostSymbol {
  const char* name;
  void* addr;
};

/// The host functions of each emitter (defined in its own llvm_*.cpp); the session registers
/// all of them, with libm's, when it starts.
std::span<const HostSymbol> scalar_jit_symbols();
std::span<const HostSymbol> interval_jit_symbols();

/// How one module is optimised and turned into machine code.
struct PipelineOptions {
  /// LLVM's default new-pass-manager pipelines O0..O3, or (light = true) the light pipeline:
  /// SROA (keeping the CFG), EarlyCSE, instcombine-free DCE. The light pipeline is for very
  /// wide code (interval, gradient) where the default pipelines' block merging and
  /// instcombine cost minutes on large models and find little, and for straight-line scalar
  /// code (JitFunction::compile), where they cost most of the optimisation time and find
  /// nothing that changes the code's speed.
  int opt_level = 2;
  bool light = false;
  /// The code generator's level (instruction selection, scheduling, register allocation).
  llvm::CodeGenOptLevel codegen = llvm::CodeGenOptLevel::Aggressive;
  /// Functions compiled without machine optimisation (fast instruction selection; marked
  /// optnone after the IR pipeline, which still optimises them): for huge functions that
  /// are mostly calls, where the optimising code generator costs seconds and gains nothing.
  std::vector<std::string> fast_codegen;
  /// Call-heavy modules (kFastCodegenCalls): when one emitted function makes more than this
  /// many calls (0: never), the whole module takes the light IR pipeline and code generation
  /// at level None. (Not `fast_codegen`'s optnone: the register allocator is chosen per
  /// module, and optnone functions keep the greedy one.) Each call clobbers every vector
  /// register, so the greedy allocator's interference checks grow with calls x live values:
  /// a model of 1221 `^` and ~2000 atan2 (8 and 16 lanes: tens of thousands of libm calls)
  /// took 7.6 s (f64) and ~24 s (f32) to code-generate, for code whose time is in libm.
  size_t fast_codegen_calls = 0;
  /// Keep the optimised IR text (JitFunction::llvm_ir).
  bool keep_ir = false;
};

/// The lanes to emit `fn` with: `host`, or one for call-heavy code, where the ops that call
/// libm or an hfrt helper lane by lane (OpLane kLibm, kHelper; sin and cos too unless
/// `trig_inline`: the f32 and interval emitters' own kernels) times `host` exceed `limit`
/// (0: never) and are at least 1/16 of the instructions (a few calls among thousands of
/// arithmetic ops keep the vector width that the arithmetic needs). A lane call costs the same at
/// any width, and around each call a vector function extracts, inserts and spills every live
/// vector. On four corpus models with 140-2900 such calls (gears, architecture, a garbled prospero)
/// one lane compiled 3-12x faster and evaluated 1.5-3x faster than 8 or 16 (docs/architecture.md).
int call_heavy_lanes(const ir::Function& fn, int host, bool trig_inline, size_t limit);

/// The pipeline of the wide domain emitters (interval, gradient) for their opt_level option:
/// 0 = O0, 1 = the light pipeline, 2 and 3 = LLVM's default O2 / O3 pipelines.
PipelineOptions domain_pipeline(int opt_level);

/// A fresh context and module, set up for the host (data layout, triple), to emit into.
struct ModuleUnit {
  std::unique_ptr<llvm::LLVMContext> ctx;
  std::unique_ptr<llvm::Module> module;
  std::string name;  ///< unique in the session: use it as the entry function's name
};

/// Machine code in its own JITDylib (so that every compile's entry has the same name, and equal
/// code has equal IR for the compile cache): freed, with the JITDylib, when this is destroyed.
class CompiledCode {
 public:
  CompiledCode(llvm::orc::ExecutionSession* session, llvm::orc::JITDylib* dylib, void* entry)
      : session_(session), dylib_(dylib), entry_(entry) {}
  ~CompiledCode();
  CompiledCode(const CompiledCode&) = delete;
  CompiledCode& operator=(const CompiledCode&) = delete;

  void* entry() const { return entry_; }

 private:
  llvm::orc::ExecutionSession* session_;
  llvm::orc::JITDylib* dylib_;
  void* entry_;
};

/// A symbol of `module` whose address is `addr`, an object of this process (a mesh or patch
/// leaf's surface): an external constant named `name`, with the address in its metadata. The
/// address stays out of the code, so that the code can be cached and reused by another
/// process (which loads its own surfaces elsewhere): LlvmSession::compile takes the metadata
/// off before hashing and defines the symbol at that address when it links.
llvm::Constant* host_address(llvm::Module& module, const std::string& name, const void* addr);

class LlvmSession {
 public:
  /// The process-wide session (created on first call; lives for the process, since code of
  /// static models may outlive main). Fails only when LLVM cannot create the JIT.
  static Result<LlvmSession*> get();

  /// The host CPU as LLVM names it (e.g. "znver3").
  const std::string& cpu_name() const { return cpu_; }
  /// SIMD lanes for elements of `element_bytes` (8 for double, 4 for float): 512-bit vectors
  /// with AVX-512, 256 with AVX, else 128.
  int lanes(int element_bytes) const { return vector_bits_ / (8 * element_bytes); }

  /// A new module named `<prefix>_<unique number>`.
  ModuleUnit new_module(std::string_view prefix);

  /// Verifies (HFRT_CHECK: the emitters' output must be valid), optimises and compiles
  /// `unit`, links it into a JITDylib of its own and returns the address of the function
  /// named `entry` (renamed there; the module's other external functions become internal:
  /// only the entry is looked up). Code equal to an earlier compile's (of this or another
  /// process) comes from the compile cache (hfrt/compile_cache.h) instead, unless it holds
  /// addresses of this process. Fills optimize_ms, codegen_ms, from_cache and the
  /// instruction counts of `stats` (emit_ms and lanes are the caller's), and `*ir_text` when
  /// options.keep_ir (the IR before optimisation when the code came from the cache).
  Result<std::unique_ptr<CompiledCode>> compile(ModuleUnit unit, const std::string& entry,
                                                const PipelineOptions& options, JitStats* stats,
                                                std::string* ir_text = nullptr);

 private:
  LlvmSession() = default;
  static Result<LlvmSession*> create();

  std::unique_ptr<llvm::orc::LLJIT> jit_;
  llvm::orc::JITTargetMachineBuilder jtmb_{llvm::Triple()};
  std::string cpu_;
  std::string data_layout_;
  std::string triple_;
  int vector_bits_ = 128;
  std::atomic<uint64_t> next_id_{0};
};

/// The text of an llvm::Error (consumed).
std::string llvm_error_text(llvm::Error err);

/// Number of LLVM instructions in `m`.
size_t count_insts(const llvm::Module& m);

}  // namespace hfrt::jit
