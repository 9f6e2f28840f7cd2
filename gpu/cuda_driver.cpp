// The CUDA driver API loaded at run time (gpu/cuda_driver.h).
//
// The driver's entry points are declared here with the driver's C ABI instead of taken from
// cuda.h, so that hfrt builds without the CUDA toolkit: CUresult and CUdevice are ints, the
// handles are opaque pointers and CUdeviceptr is a 64-bit integer. Where the driver exports
// several versions of a function (cuMemAlloc and cuMemAlloc_v2), the symbol named is the one
// cuda.h maps the plain name to (the `_v2` one, 64-bit sizes).
#include "gpu/cuda_driver.h"

#include <dlfcn.h>

#include <atomic>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <type_traits>

#include "gpu/kernel_abi.h"

namespace hfrt::gpu {

namespace {

using CUresult = int;
using CUdevice = int;
using CUdeviceptr = unsigned long long;
using CUcontext = struct CUctx_st*;
using CUmodule = struct CUmod_st*;
using CUfunction = struct CUfunc_st*;
using CUevent = struct CUevent_st*;
using CUstream = struct CUstream_st*;
using CUjit_option = int;

constexpr CUresult kSuccess = 0;
constexpr CUresult kErrorNoDevice = 100;       // CUDA_ERROR_NO_DEVICE
constexpr int kAttrComputeMajor = 75;          // CU_DEVICE_ATTRIBUTE_COMPUTE_CAPABILITY_MAJOR
constexpr int kAttrComputeMinor = 76;          // CU_DEVICE_ATTRIBUTE_COMPUTE_CAPABILITY_MINOR
constexpr CUjit_option kJitInfoLogBuffer = 3;  // CU_JIT_INFO_LOG_BUFFER
constexpr CUjit_option kJitInfoLogBufferSizeBytes = 4;   // CU_JIT_INFO_LOG_BUFFER_SIZE_BYTES
constexpr CUjit_option kJitErrorLogBuffer = 5;           // CU_JIT_ERROR_LOG_BUFFER
constexpr CUjit_option kJitErrorLogBufferSizeBytes = 6;  // CU_JIT_ERROR_LOG_BUFFER_SIZE_BYTES
constexpr size_t kJitLogBytes = 16384;

/// The loaded library and the entry points hfrt calls.
struct Driver {
  void* handle = nullptr;
  std::string path;

  CUresult (*cuGetErrorName)(CUresult, const char**) = nullptr;
  CUresult (*cuGetErrorString)(CUresult, const char**) = nullptr;
  CUresult (*cuInit)(unsigned) = nullptr;
  CUresult (*cuDeviceGetCount)(int*) = nullptr;
  CUresult (*cuDeviceGet)(CUdevice*, int) = nullptr;
  CUresult (*cuDeviceGetName)(char*, int, CUdevice) = nullptr;
  CUresult (*cuDeviceGetAttribute)(int*, int, CUdevice) = nullptr;
  CUresult (*cuDeviceTotalMem)(size_t*, CUdevice) = nullptr;
  CUresult (*cuDevicePrimaryCtxRetain)(CUcontext*, CUdevice) = nullptr;
  CUresult (*cuDevicePrimaryCtxRelease)(CUdevice) = nullptr;
  CUresult (*cuCtxSetCurrent)(CUcontext) = nullptr;
  CUresult (*cuCtxSynchronize)() = nullptr;
  CUresult (*cuMemAlloc)(CUdeviceptr*, size_t) = nullptr;
  CUresult (*cuMemFree)(CUdeviceptr) = nullptr;
  CUresult (*cuMemcpyHtoD)(CUdeviceptr, const void*, size_t) = nullptr;
  CUresult (*cuMemcpyDtoH)(void*, CUdeviceptr, size_t) = nullptr;
  CUresult (*cuModuleLoadDataEx)(CUmodule*, const void*, unsigned, CUjit_option*, void**) = nullptr;
  CUresult (*cuModuleGetFunction)(CUfunction*, CUmodule, const char*) = nullptr;
  CUresult (*cuModuleUnload)(CUmodule) = nullptr;
  CUresult (*cuLaunchKernel)(CUfunction, unsigned, unsigned, unsigned, unsigned, unsigned, unsigned,
                             unsigned, CUstream, void**, void**) = nullptr;
  CUresult (*cuEventCreate)(CUevent*, unsigned) = nullptr;
  CUresult (*cuEventRecord)(CUevent, CUstream) = nullptr;
  CUresult (*cuEventSynchronize)(CUevent) = nullptr;
  CUresult (*cuEventElapsedTime)(float*, CUevent, CUevent) = nullptr;
  CUresult (*cuEventDestroy)(CUevent) = nullptr;

  ~Driver() {
    if (handle) dlclose(handle);
  }
};

/// "CUDA_ERROR_INVALID_PTX (a PTX JIT compilation failed)", or the number when the driver
/// does not know the code.
std::string describe(const Driver& d, CUresult r) {
  const char* name = nullptr;
  const char* text = nullptr;
  if (d.cuGetErrorName(r, &name) != kSuccess || !name) name = nullptr;
  if (d.cuGetErrorString(r, &text) != kSuccess || !text) text = nullptr;
  std::string s = name ? name : "CUDA error " + std::to_string(r);
  if (text) s += std::string(" (") + text + ")";
  return s;
}

Error failure(const Driver& d, const std::string& step, CUresult r) {
  return Error{step + ": " + describe(d, r)};
}

/// Binds every entry point; the name of the first one the library lacks, or nullptr.
const char* bind_symbols(Driver& d) {
  const char* missing = nullptr;
  auto bind = [&](auto& fn, const char* name, const char* fallback = nullptr) {
    if (missing) return;
    void* p = dlsym(d.handle, name);
    if (!p && fallback) p = dlsym(d.handle, fallback);
    if (!p) {
      missing = name;
      return;
    }
    fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(p);
  };
  bind(d.cuGetErrorName, "cuGetErrorName");
  bind(d.cuGetErrorString, "cuGetErrorString");
  bind(d.cuInit, "cuInit");
  bind(d.cuDeviceGetCount, "cuDeviceGetCount");
  bind(d.cuDeviceGet, "cuDeviceGet");
  bind(d.cuDeviceGetName, "cuDeviceGetName");
  bind(d.cuDeviceGetAttribute, "cuDeviceGetAttribute");
  bind(d.cuDeviceTotalMem, "cuDeviceTotalMem_v2");
  bind(d.cuDevicePrimaryCtxRetain, "cuDevicePrimaryCtxRetain");
  // CUDA 11 renamed it (same signature); drivers before 11 have only the plain name.
  bind(d.cuDevicePrimaryCtxRelease, "cuDevicePrimaryCtxRelease_v2", "cuDevicePrimaryCtxRelease");
  bind(d.cuCtxSetCurrent, "cuCtxSetCurrent");
  bind(d.cuCtxSynchronize, "cuCtxSynchronize");
  bind(d.cuMemAlloc, "cuMemAlloc_v2");
  bind(d.cuMemFree, "cuMemFree_v2");
  bind(d.cuMemcpyHtoD, "cuMemcpyHtoD_v2");
  bind(d.cuMemcpyDtoH, "cuMemcpyDtoH_v2");
  bind(d.cuModuleLoadDataEx, "cuModuleLoadDataEx");
  bind(d.cuModuleGetFunction, "cuModuleGetFunction");
  bind(d.cuModuleUnload, "cuModuleUnload");
  bind(d.cuLaunchKernel, "cuLaunchKernel");
  bind(d.cuEventCreate, "cuEventCreate");
  bind(d.cuEventRecord, "cuEventRecord");
  bind(d.cuEventSynchronize, "cuEventSynchronize");
  bind(d.cuEventElapsedTime, "cuEventElapsedTime");
  bind(d.cuEventDestroy, "cuEventDestroy_v2");
  return missing;
}

// The driver, loaded on first use and kept for the process (unload_driver_for_testing aside).
// A failed load is not remembered: a later open() tries again.
std::mutex g_driver_mutex;
std::unique_ptr<Driver> g_driver;
std::atomic<int> g_open_devices{0};

Result<const Driver*> load_driver() {
  std::lock_guard<std::mutex> lock(g_driver_mutex);
  if (g_driver) return static_cast<const Driver*>(g_driver.get());
  const char* env = std::getenv("HFRT_LIBCUDA");
  std::string path = env && *env ? env : "libcuda.so.1";
  auto d = std::make_unique<Driver>();
  d->path = path;
  d->handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!d->handle) {
    const char* why = dlerror();
    return Error{"no CUDA driver: cannot load " + path + " (" + (why ? why : "unknown reason") +
                 "); install the NVIDIA driver, or render on the CPU (without --device cuda)"};
  }
  if (const char* missing = bind_symbols(*d)) {
    return Error{"the CUDA driver " + path + " lacks the entry point " + missing +
                 " (a driver older than CUDA 11?); update the NVIDIA driver, or render on the "
                 "CPU (without --device cuda)"};
  }
  g_driver = std::move(d);
  return static_cast<const Driver*>(g_driver.get());
}

}  // namespace

void unload_driver_for_testing() {
  HFRT_CHECK_EQ(g_open_devices.load(), 0);
  std::lock_guard<std::mutex> lock(g_driver_mutex);
  g_driver.reset();
}

// ---------------------------------------------------------------------------------------------
// CudaDevice

struct CudaDevice::Impl {
  const Driver* drv = nullptr;
  CUdevice device = 0;
  CUcontext context = nullptr;
  std::string name;
  int major = 0, minor = 0;
  size_t total_memory = 0;

  Impl() { ++g_open_devices; }
  ~Impl() {
    if (context) drv->cuDevicePrimaryCtxRelease(device);
    --g_open_devices;
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;

  /// The context current on the calling thread (the device may be used from one thread, then
  /// from another).
  Result<bool> make_current() const {
    if (CUresult r = drv->cuCtxSetCurrent(context); r != kSuccess) {
      return failure(*drv, "cuCtxSetCurrent", r);
    }
    return true;
  }
};

CudaDevice::CudaDevice(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CudaDevice::~CudaDevice() = default;

Result<std::unique_ptr<CudaDevice>> CudaDevice::open(int ordinal) {
  auto loaded = load_driver();
  if (!loaded) return loaded.error();
  const Driver& d = *loaded.value();
  auto impl = std::make_unique<Impl>();
  impl->drv = &d;
  // cuInit is cheap after the first call; calling it on every open keeps open() stateless.
  if (CUresult r = d.cuInit(0); r != kSuccess) {
    if (r == kErrorNoDevice) return Error{"no CUDA device found (cuInit: " + describe(d, r) + ")"};
    return Error{"cannot initialise the CUDA driver " + d.path + " (cuInit: " + describe(d, r) +
                 ")"};
  }
  int count = 0;
  if (CUresult r = d.cuDeviceGetCount(&count); r != kSuccess) {
    return failure(d, "cuDeviceGetCount", r);
  }
  if (count == 0) return Error{"no CUDA device found"};
  if (ordinal < 0 || ordinal >= count) {
    return Error{"no CUDA device " + std::to_string(ordinal) + " (the machine has " +
                 std::to_string(count) + ")"};
  }
  if (CUresult r = d.cuDeviceGet(&impl->device, ordinal); r != kSuccess) {
    return failure(d, "cuDeviceGet(" + std::to_string(ordinal) + ")", r);
  }
  char name[256] = {};
  if (CUresult r = d.cuDeviceGetName(name, sizeof name - 1, impl->device); r != kSuccess) {
    return failure(d, "cuDeviceGetName", r);
  }
  impl->name = name;
  if (CUresult r = d.cuDeviceGetAttribute(&impl->major, kAttrComputeMajor, impl->device);
      r != kSuccess) {
    return failure(d, "cuDeviceGetAttribute(compute capability major)", r);
  }
  if (CUresult r = d.cuDeviceGetAttribute(&impl->minor, kAttrComputeMinor, impl->device);
      r != kSuccess) {
    return failure(d, "cuDeviceGetAttribute(compute capability minor)", r);
  }
  if (CUresult r = d.cuDeviceTotalMem(&impl->total_memory, impl->device); r != kSuccess) {
    return failure(d, "cuDeviceTotalMem", r);
  }
  if (CUresult r = d.cuDevicePrimaryCtxRetain(&impl->context, impl->device); r != kSuccess) {
    impl->context = nullptr;
    return failure(d, "cuDevicePrimaryCtxRetain (creating the device's context)", r);
  }
  if (auto r = impl->make_current(); !r) return r.error();
  return std::unique_ptr<CudaDevice>(new CudaDevice(std::move(impl)));
}

std::string CudaDevice::name() const {
  return impl_->name;
}
int CudaDevice::compute_major() const {
  return impl_->major;
}
int CudaDevice::compute_minor() const {
  return impl_->minor;
}
size_t CudaDevice::total_memory() const {
  return impl_->total_memory;
}

// ---------------------------------------------------------------------------------------------
// DeviceBuffer

Result<DeviceBuffer> DeviceBuffer::allocate(CudaDevice& device, size_t bytes) {
  CudaDevice::Impl* dev = device.impl_.get();
  if (bytes == 0) return DeviceBuffer();
  if (auto r = dev->make_current(); !r) return r.error();
  CUdeviceptr ptr = 0;
  if (CUresult r = dev->drv->cuMemAlloc(&ptr, bytes); r != kSuccess) {
    return failure(*dev->drv, "cuMemAlloc(" + std::to_string(bytes) + " bytes)", r);
  }
  return DeviceBuffer(dev, ptr, bytes);
}

DeviceBuffer::DeviceBuffer(DeviceBuffer&& o) noexcept
    : device_(o.device_), ptr_(o.ptr_), bytes_(o.bytes_) {
  o.device_ = nullptr;
  o.ptr_ = 0;
  o.bytes_ = 0;
}

DeviceBuffer& DeviceBuffer::operator=(DeviceBuffer&& o) noexcept {
  if (this == &o) return *this;
  DeviceBuffer old(std::move(*this));  // freed at the end of this function
  device_ = o.device_;
  ptr_ = o.ptr_;
  bytes_ = o.bytes_;
  o.device_ = nullptr;
  o.ptr_ = 0;
  o.bytes_ = 0;
  return *this;
}

DeviceBuffer::~DeviceBuffer() {
  if (device_ && ptr_) {
    // A destructor has no one to report to; a failure here means the context is already lost.
    if (device_->drv->cuCtxSetCurrent(device_->context) == kSuccess) device_->drv->cuMemFree(ptr_);
  }
  device_ = nullptr;
  ptr_ = 0;
  bytes_ = 0;
}

Result<bool> DeviceBuffer::upload(const void* src, size_t bytes) {
  HFRT_CHECK_LE(bytes, bytes_);
  if (bytes == 0) return true;
  if (auto r = device_->make_current(); !r) return r.error();
  if (CUresult r = device_->drv->cuMemcpyHtoD(ptr_, src, bytes); r != kSuccess) {
    return failure(*device_->drv, "cuMemcpyHtoD(" + std::to_string(bytes) + " bytes)", r);
  }
  return true;
}

Result<bool> DeviceBuffer::download(void* dst, size_t bytes) const {
  HFRT_CHECK_LE(bytes, bytes_);
  if (bytes == 0) return true;
  if (auto r = device_->make_current(); !r) return r.error();
  if (CUresult r = device_->drv->cuMemcpyDtoH(dst, ptr_, bytes); r != kSuccess) {
    return failure(*device_->drv, "cuMemcpyDtoH(" + std::to_string(bytes) + " bytes)", r);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// CudaModule

struct CudaModule::Impl {
  CudaDevice::Impl* device = nullptr;
  CUmodule module = nullptr;
  std::map<std::string, CUfunction, std::less<>> functions;
  CUevent start = nullptr, stop = nullptr;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl() {
    const Driver& d = *device->drv;
    if (d.cuCtxSetCurrent(device->context) != kSuccess) return;
    if (start) d.cuEventDestroy(start);
    if (stop) d.cuEventDestroy(stop);
    if (module) d.cuModuleUnload(module);
  }
};

CudaModule::CudaModule(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
CudaModule::~CudaModule() = default;

Result<std::unique_ptr<CudaModule>> CudaDevice::load_ptx(std::string_view ptx) {
  const Driver& d = *impl_->drv;
  if (auto r = impl_->make_current(); !r) return r.error();
  std::string text(ptx);  // the driver reads a NUL-terminated image
  std::string error_log(kJitLogBytes, '\0');
  std::string info_log(kJitLogBytes, '\0');
  CUjit_option options[] = {kJitErrorLogBuffer, kJitErrorLogBufferSizeBytes, kJitInfoLogBuffer,
                            kJitInfoLogBufferSizeBytes};
  void* values[] = {error_log.data(), reinterpret_cast<void*>(uintptr_t{kJitLogBytes - 1}),
                    info_log.data(), reinterpret_cast<void*>(uintptr_t{kJitLogBytes - 1})};
  auto impl = std::make_unique<CudaModule::Impl>();
  impl->device = impl_.get();
  CUresult r = d.cuModuleLoadDataEx(&impl->module, text.c_str(), 4, options, values);
  if (r != kSuccess) {
    impl->module = nullptr;
    error_log.resize(std::strlen(error_log.c_str()));
    while (!error_log.empty() && (error_log.back() == '\n' || error_log.back() == ' ')) {
      error_log.pop_back();
    }
    std::string message = "cannot load the PTX module on " + impl_->name +
                          " (cuModuleLoadDataEx: " + describe(d, r) + ")";
    if (!error_log.empty()) message += "; the driver's JIT log:\n" + error_log;
    return Error{message};
  }
  return std::unique_ptr<CudaModule>(new CudaModule(std::move(impl)));
}

Result<double> CudaModule::launch(const char* entry, int64_t threads, std::vector<void*> args) {
  HFRT_CHECK_GE(threads, 0);
  Impl& m = *impl_;
  const Driver& d = *m.device->drv;
  const std::string what = std::string("kernel '") + entry + "'";
  if (auto r = m.device->make_current(); !r) return r.error();
  auto found = m.functions.find(std::string_view(entry));
  if (found == m.functions.end()) {
    CUfunction fn = nullptr;
    if (CUresult r = d.cuModuleGetFunction(&fn, m.module, entry); r != kSuccess) {
      return Error{"no " + what + " in the module (cuModuleGetFunction: " + describe(d, r) + ")"};
    }
    found = m.functions.emplace(entry, fn).first;
  }
  if (threads == 0) return 0.0;
  const int64_t blocks = (threads + kThreadsPerBlock - 1) / kThreadsPerBlock;
  if (blocks > INT_MAX) {
    return Error{"cannot launch " + what + " over " + std::to_string(threads) +
                 " threads: more than 2^31-1 blocks of " + std::to_string(kThreadsPerBlock)};
  }
  if (!m.start) {
    if (CUresult r = d.cuEventCreate(&m.start, 0); r != kSuccess) {
      m.start = nullptr;
      return failure(d, "cuEventCreate", r);
    }
    if (CUresult r = d.cuEventCreate(&m.stop, 0); r != kSuccess) {
      m.stop = nullptr;
      return failure(d, "cuEventCreate", r);
    }
  }
  if (CUresult r = d.cuEventRecord(m.start, nullptr); r != kSuccess) {
    return failure(d, "cuEventRecord before " + what, r);
  }
  if (CUresult r = d.cuLaunchKernel(found->second, static_cast<unsigned>(blocks), 1, 1,
                                    static_cast<unsigned>(kThreadsPerBlock), 1, 1, 0, nullptr,
                                    args.empty() ? nullptr : args.data(), nullptr);
      r != kSuccess) {
    return failure(d,
                   "cannot launch " + what + " (" + std::to_string(blocks) + " blocks of " +
                       std::to_string(kThreadsPerBlock) + " threads; cuLaunchKernel)",
                   r);
  }
  if (CUresult r = d.cuEventRecord(m.stop, nullptr); r != kSuccess) {
    return failure(d, "cuEventRecord after " + what, r);
  }
  // A kernel that faults reports it here (and on every later call: the context is lost).
  if (CUresult r = d.cuEventSynchronize(m.stop); r != kSuccess) {
    return failure(d, what + " failed while running (cuEventSynchronize)", r);
  }
  if (CUresult r = d.cuCtxSynchronize(); r != kSuccess) {
    return failure(d, what + " failed while running (cuCtxSynchronize)", r);
  }
  float ms = 0;
  if (CUresult r = d.cuEventElapsedTime(&ms, m.start, m.stop); r != kSuccess) {
    return failure(d, "cuEventElapsedTime for " + what, r);
  }
  return static_cast<double>(ms);
}

}  // namespace hfrt::gpu
