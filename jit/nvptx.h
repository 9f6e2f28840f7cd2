#pragma once
// The GPU path from the one IR (issue 22): the kernels of gpu/kernel_abi.h — the point
// evaluator and the ray caster — emitted from a Function as LLVM IR and compiled either by
// LLVM's NVPTX back end into PTX text (no CUDA toolkit involved) or, the very same LLVM IR,
// for the host CPU (so that every CPU test and the device check's expectations run the code
// that goes into the PTX). The scalar f32 emitter of the CPU JIT (llvm_jit.cpp) evaluates the
// model, one lane per thread; the libm functions it calls are defined by device_math.h.
//
// No LLVM types here (jit/llvm_nvptx.cpp holds them).

#include <cstdint>
#include <memory>
#include <string>

#include "base/result.h"
#include "gpu/kernel_abi.h"
#include "ir/ir.h"

namespace hfrt::jit {

struct PtxOptions {
  /// The GPU architecture the PTX targets; the driver JIT-compiles it for newer GPUs too.
  std::string sm = "sm_60";
  int opt_level = 2;
  /// Only kEvalEntry (no ray caster, no interval kernel).
  bool eval_only = false;
};

/// Why `fn` cannot run on the GPU ("" when it can): mesh and patch leaves (kSurface) read
/// host memory and are not on the device yet.
std::string device_unsupported_reason(const ir::Function& fn);

/// Whether the interval JIT's code of `fn` (llvm_interval.cpp) calls no host function (no
/// libm-based op, no R-function node, no mesh or patch leaf): then it runs on the GPU too, and
/// the kernels include kIntervalEntry.
bool interval_code_is_self_contained(const ir::Function& fn);

/// PTX text with the kernels kEvalEntry and kRenderEntry for `fn` (float precision).
/// Fails for a model device_unsupported_reason names, or when LLVM lacks the NVPTX target.
Result<std::string> emit_ptx(const ir::Function& fn, const PtxOptions& options = {});

/// The LLVM IR of the device module before optimisation (for tests and `hfrt emit --ptx
/// --llvm`).
Result<std::string> device_llvm_ir(const ir::Function& fn);

/// The device kernels compiled for the host CPU: the same LLVM IR as the PTX with a host
/// target (a loop over threads in place of the thread index). Const and thread-safe.
class HostKernels {
 public:
  static Result<std::unique_ptr<HostKernels>> compile(const ir::Function& fn);
  ~HostKernels();
  HostKernels(const HostKernels&) = delete;
  HostKernels& operator=(const HostKernels&) = delete;

  /// kEvalEntry's threads 0..n-1.
  void eval(int64_t n, const float* xs, const float* a, float* out_f, float* out_s) const;
  /// Whether the kernels include kIntervalEntry (interval_code_is_self_contained: the ray
  /// caster then culls), and its threads 0..n-1.
  bool has_interval() const;
  void interval(int64_t n, const double* xlo, const double* xhi, const double* a, double* out_lo,
                double* out_hi, uint8_t* out_nan) const;
  /// kRenderEntry's threads [begin, end) (pixels in row-major order).
  void render(const gpu::RenderParams& params, const float* a, float* out, int64_t begin,
              int64_t end) const;

 private:
  struct Impl;
  explicit HostKernels(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// The device math functions (device_math.h's LLVM backend, as they go into the PTX) compiled
/// for the host: the value of op (a Libm or Helper lane op of ir_ops.h) in single precision.
/// For the tests that compare them with the `double` instantiation.
class HostDeviceLibm {
 public:
  static Result<std::unique_ptr<HostDeviceLibm>> compile();
  ~HostDeviceLibm();
  HostDeviceLibm(const HostDeviceLibm&) = delete;
  HostDeviceLibm& operator=(const HostDeviceLibm&) = delete;
  float operator()(ir::Op op, float a, float b = 0.0f) const;

 private:
  struct Impl;
  explicit HostDeviceLibm(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace hfrt::jit
