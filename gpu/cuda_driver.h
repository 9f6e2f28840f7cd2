#pragma once
// The CUDA driver API, loaded at run time (dlopen("libcuda.so.1"), as Blender's Cycles does
// with its wrangler): the build and every CPU test need nothing from NVIDIA, and a machine
// without a driver or a device gets a clear error instead of a loader failure at start-up.
// The dozen driver entry points hfrt uses are declared in gpu/cuda_driver.cpp, not taken from
// cuda.h. Environment failures are Result errors; nothing here throws.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"

namespace hfrt::gpu {

class CudaModule;

/// A CUDA context on one device (the primary context), with the driver loaded. Not copyable;
/// use from one thread at a time.
class CudaDevice {
 public:
  /// Loads the driver ($HFRT_LIBCUDA if set, else libcuda.so.1), initialises it and opens
  /// device `ordinal`. Errors say which step failed and what to do ("no CUDA driver ...
  /// (install the NVIDIA driver, or render on the CPU without --device cuda)", "no CUDA
  /// device", the driver's own error name and text).
  static Result<std::unique_ptr<CudaDevice>> open(int ordinal = 0);
  ~CudaDevice();
  CudaDevice(const CudaDevice&) = delete;
  CudaDevice& operator=(const CudaDevice&) = delete;

  std::string name() const;   ///< e.g. "NVIDIA H200"
  int compute_major() const;  ///< compute capability, e.g. 9 and 0
  int compute_minor() const;
  size_t total_memory() const;  ///< bytes

  /// JIT-compiles PTX text with the driver; the error carries the driver's log.
  Result<std::unique_ptr<CudaModule>> load_ptx(std::string_view ptx);

  struct Impl;

 private:
  explicit CudaDevice(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
  friend class CudaModule;
  friend class DeviceBuffer;
};

/// Device memory (cuMemAlloc); freed on destruction. Buffers and modules must go before the
/// CudaDevice they came from.
class DeviceBuffer {
 public:
  /// An empty buffer: address 0 (a null pointer for a kernel), size 0.
  DeviceBuffer() = default;
  /// `bytes` of uninitialised device memory; 0 bytes gives an empty buffer without asking the
  /// driver (cuMemAlloc refuses 0). The error names the size and the driver's error.
  static Result<DeviceBuffer> allocate(CudaDevice& device, size_t bytes);
  DeviceBuffer(DeviceBuffer&&) noexcept;
  DeviceBuffer& operator=(DeviceBuffer&&) noexcept;
  ~DeviceBuffer();
  /// Copies `bytes` (at most size()) from the host to the start of the buffer.
  Result<bool> upload(const void* src, size_t bytes);
  /// Copies `bytes` (at most size()) from the start of the buffer to the host.
  Result<bool> download(void* dst, size_t bytes) const;
  uint64_t address() const { return ptr_; }  ///< the CUdeviceptr, for kernel arguments
  size_t size() const { return bytes_; }

 private:
  DeviceBuffer(CudaDevice::Impl* device, uint64_t ptr, size_t bytes)
      : device_(device), ptr_(ptr), bytes_(bytes) {}
  CudaDevice::Impl* device_ = nullptr;
  uint64_t ptr_ = 0;
  size_t bytes_ = 0;
};

/// A loaded module; its kernels are launched by name.
class CudaModule {
 public:
  ~CudaModule();
  /// Launches `entry` on a 1-D grid covering `threads` threads (blocks of kThreadsPerBlock),
  /// with `args` pointing at each argument's value (cuLaunchKernel's kernelParams), waits for
  /// it and returns the kernel's time in milliseconds (CUDA events). `threads` == 0 launches
  /// nothing and returns 0. Errors name the entry: one the module lacks, a launch the driver
  /// refuses, a kernel that faults while running (cuGetErrorName and cuGetErrorString).
  Result<double> launch(const char* entry, int64_t threads, std::vector<void*> args);

  struct Impl;

 private:
  friend class CudaDevice;
  explicit CudaModule(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Test hook: forgets the loaded driver (dlclose), so that the next CudaDevice::open loads
/// $HFRT_LIBCUDA again; the tests switch between fake drivers with it. Outside tests the
/// driver is loaded once per process and kept. Only while no CudaDevice, DeviceBuffer or
/// CudaModule exists.
void unload_driver_for_testing();

}  // namespace hfrt::gpu
