#pragma once
// The vectorised scalar evaluator: one IR Function compiled by LLVM ORC (LLJIT) into a batch
// function that evaluates n points W lanes at a time (W = the host's SIMD width). Control
// flow is vectorised with lane masks, so programs with branches and loops stay SIMD.
//
// No LLVM types here (pimpl): only jit/llvm_*.cpp include LLVM headers.

#include <cstdint>
#include <memory>
#include <string>

#include "base/result.h"
#include "ir/ir.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

enum class Precision : uint8_t {
  kF64,  ///< exact conformance with the interpreter (same libm, no fast-math)
  kF32,  ///< rendering speed (twice the lanes)
};

/// The batch ABI of compiled code, a noexcept C-ABI leaf (no exceptions, no globals written,
/// callable from many threads at once). Structure of arrays, point i of n:
///   x[k+1] = xs[k*n + i] for k < Function::num_inputs,  a[k+1] = a[k] (k < num_params),
///   F      -> out_f[i],   s[k+1] -> out_s[k*n + i] (out_s may be null).
/// A point where a run-time error (kCheck) fired gets NaN in out_f and in its s values.
template <typename T>
using BatchFn = void (*)(int64_t n, const T* xs, const T* a, T* out_f, T* out_s) noexcept;

/// Call-heavy code (docs/architecture.md): the point and gradient JITs emit one lane when an
/// object's per-lane calls (libm, hfrt helpers) times the host's lanes exceed this and the
/// calls are at least 1/16 of its instructions (call_heavy_lanes in jit/llvm_session.h).
inline constexpr size_t kCallHeavyLaneCalls = 1000;
/// A function with more calls than this after emission gets the light IR pipeline and code
/// generation at level None (PipelineOptions::fast_codegen_calls): the calls are the run
/// time, and the optimising compile costs seconds (a corpus gear with 805 calls: 1.45 s ->
/// 0.2 s, the same evaluation speed).
inline constexpr size_t kFastCodegenCalls = 500;

struct JitOptions {
  int opt_level = 2;  ///< new pass manager pipeline O0..O3 (and the codegen level to match)
  int lanes = 0;      ///< SIMD width in lanes; 0 = the host's (vector bytes / sizeof(T))
  /// kSurface gives +1 inside / -1 outside (the winding number's side, the sign of its
  /// distance) instead of the signed distance: a fraction of the cost, and F keeps its sign
  /// wherever the mesh and patch leaves sit on a set-operation skeleton (the renderer's
  /// analytic search only looks at signs). Other models get other values: see
  /// Model::eval_batch_sign.
  bool surface_sign_only = false;
  /// Keep the LLVM IR text (JitFunction::llvm_ir). Off by default: printing the module costs
  /// milliseconds (its vector constants above all), which every compile paid, cache hits too.
  bool keep_llvm_ir = false;
  /// Call-heavy code: one lane above this many per-lane calls x lanes (0: never), and fast
  /// code generation above that many calls after emission (0: never).
  size_t call_heavy_lane_calls = kCallHeavyLaneCalls;
  size_t fast_codegen_calls = kFastCodegenCalls;
};

/// Compile-latency figures of one JitFunction (`hfrt eval --stats`).
struct JitStats {
  double emit_ms = 0;      ///< hfrt IR -> LLVM IR
  double optimize_ms = 0;  ///< the new-pass-manager pipeline
  double codegen_ms = 0;   ///< machine code + linking (ORC materialisation on lookup)
  int lanes = 0;
  size_t llvm_insts_before = 0;  ///< LLVM instructions before / after optimisation
  size_t llvm_insts_after = 0;
  size_t llvm_calls = 0;      ///< calls (not intrinsics) of the emitted module's busiest function
  bool fast_codegen = false;  ///< compiled without machine optimisation (too many calls)
  bool from_cache = false;    ///< the code came from the compile cache (hfrt/compile_cache.h)
  double total_ms() const { return emit_ms + optimize_ms + codegen_ms; }
};

/// A compiled Function in one precision. Owns its code through a per-function ORC
/// ResourceTracker and ThreadSafeContext: destroying (or replacing) it frees the code.
/// Immutable after compile(); the batch function may be called concurrently.
class JitFunction {
 public:
  ~JitFunction();
  JitFunction(const JitFunction&) = delete;
  JitFunction& operator=(const JitFunction&) = delete;

  /// Emits, optimises and compiles `fn`. Fails (environment error) only when LLVM cannot
  /// create the JIT or link the code; `fn` must be verified IR (else HFRT_CHECK).
  static Result<std::unique_ptr<JitFunction>> compile(const Function& fn, Precision precision,
                                                      const JitOptions& options = {});

  Precision precision() const;
  /// The entry point; only the one matching precision() is non-null.
  BatchFn<double> f64() const;
  BatchFn<float> f32() const;
  const JitStats& stats() const;
  /// The optimised LLVM IR text (for debugging and `hfrt ir --llvm`-style dumps; the IR
  /// before optimisation when the code came from the compile cache); empty unless compiled
  /// with JitOptions::keep_llvm_ir.
  const std::string& llvm_ir() const;

 private:
  struct Impl;
  explicit JitFunction(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// The host CPU as LLVM sees it (e.g. "znver3"), and the SIMD lanes it gives a precision:
/// 16 floats / 8 doubles with AVX-512, 8 / 4 with AVX2 or AVX, 4 / 2 otherwise.
std::string host_cpu_name();
int host_lanes(Precision precision);

}  // namespace hfrt::jit
