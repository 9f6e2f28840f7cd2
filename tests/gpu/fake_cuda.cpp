// A fake CUDA driver for the tests of gpu/ and tools/gpu_runner/: a shared library exporting
// the driver entry points gpu/cuda_driver.cpp resolves, loaded through HFRT_LIBCUDA.
//
// Its behaviour is read from HFRT_FAKE_CUDA at every cuInit:
//   ok (or unset)   one device "Fake GPU", compute 9.0, 1 GiB; memory is malloc, copies are
//                   memcpy; a module is PTX text whose first line that is neither blank nor a
//                   `//` comment contains ".version" (else CUDA_ERROR_INVALID_PTX with a log),
//                   and its kernels are the names after ".entry"; a launch is recorded and
//                   writes nothing.
//   no_device       cuInit succeeds, cuDeviceGetCount reports 0 devices
//   init_no_device  cuInit fails with CUDA_ERROR_NO_DEVICE (what a real driver does)
//   init_fails      cuInit fails with CUDA_ERROR_SYSTEM_DRIVER_MISMATCH
//   launch_fails    cuLaunchKernel fails with CUDA_ERROR_LAUNCH_OUT_OF_RESOURCES
//   kernel_faults   the kernel "faults": cuEventSynchronize gives CUDA_ERROR_ILLEGAL_ADDRESS
// Built a second time with HFRT_FAKE_CUDA_OMIT_MEMALLOC (no cuMemAlloc_v2) for the test of a
// driver that lacks an entry point. hfrt_fake_cuda_* report what happened since the last
// cuInit (launches) or ever (objects not freed), for the tests.
//
// It checks what a real driver checks and hfrt could get wrong: cuInit before anything, the
// context current on the calling thread, copies inside an allocation, a non-empty launch.
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace {

using CUresult = int;
using CUdevice = int;
using CUdeviceptr = unsigned long long;

constexpr CUresult kSuccess = 0;
constexpr CUresult kInvalidValue = 1;
constexpr CUresult kNotInitialized = 3;
constexpr CUresult kNoDevice = 100;
constexpr CUresult kInvalidDevice = 101;
constexpr CUresult kInvalidContext = 201;
constexpr CUresult kInvalidPtx = 218;
constexpr CUresult kInvalidHandle = 400;
constexpr CUresult kNotFound = 500;
constexpr CUresult kIllegalAddress = 700;
constexpr CUresult kLaunchOutOfResources = 701;
constexpr CUresult kSystemDriverMismatch = 803;

struct ErrorText {
  CUresult code;
  const char* name;
  const char* text;
};
constexpr ErrorText kErrors[] = {
    {kSuccess, "CUDA_SUCCESS", "no error"},
    {kInvalidValue, "CUDA_ERROR_INVALID_VALUE", "invalid argument"},
    {kNotInitialized, "CUDA_ERROR_NOT_INITIALIZED", "initialization error"},
    {kNoDevice, "CUDA_ERROR_NO_DEVICE", "no CUDA-capable device is detected"},
    {kInvalidDevice, "CUDA_ERROR_INVALID_DEVICE", "invalid device ordinal"},
    {kInvalidContext, "CUDA_ERROR_INVALID_CONTEXT", "invalid device context"},
    {kInvalidPtx, "CUDA_ERROR_INVALID_PTX", "a PTX JIT compilation failed"},
    {kInvalidHandle, "CUDA_ERROR_INVALID_HANDLE", "invalid resource handle"},
    {kNotFound, "CUDA_ERROR_NOT_FOUND", "named symbol not found"},
    {kIllegalAddress, "CUDA_ERROR_ILLEGAL_ADDRESS", "an illegal memory access was encountered"},
    {kLaunchOutOfResources, "CUDA_ERROR_LAUNCH_OUT_OF_RESOURCES",
     "too many resources requested for launch"},
    {kSystemDriverMismatch, "CUDA_ERROR_SYSTEM_DRIVER_MISMATCH",
     "system has unsupported display driver / cuda driver combination"},
};

struct FakeContext {
  int unused = 0;
};
struct FakeFunction {
  std::string name;
};
struct FakeModule {
  std::vector<std::unique_ptr<FakeFunction>> functions;
};
struct FakeEvent {
  std::chrono::steady_clock::time_point when;
  bool recorded = false;
};

std::mutex g_mutex;
std::string g_mode = "ok";
bool g_initialised = false;
FakeContext g_context;
int g_context_refs = 0;
thread_local FakeContext* t_current = nullptr;
std::map<uintptr_t, size_t> g_allocations;  // address -> bytes
std::set<FakeModule*> g_modules;
std::set<FakeEvent*> g_events;
int g_launches = 0;
std::string g_last_entry;
unsigned g_last_grid = 0, g_last_block = 0;
uint64_t g_last_arg0 = 0;

bool has_device() {
  return g_mode != "no_device";
}

/// Whether [p, p + bytes) lies inside one allocation.
bool inside_allocation(CUdeviceptr p, size_t bytes) {
  auto it = g_allocations.upper_bound(static_cast<uintptr_t>(p));
  if (it == g_allocations.begin()) return false;
  --it;
  return p >= it->first && p + bytes <= it->first + it->second;
}

CUresult need_context() {
  if (!g_initialised) return kNotInitialized;
  if (t_current != &g_context || g_context_refs == 0) return kInvalidContext;
  return kSuccess;
}

}  // namespace

#define FAKE_API extern "C" __attribute__((visibility("default")))

FAKE_API CUresult cuGetErrorName(CUresult error, const char** str) {
  for (const ErrorText& e : kErrors) {
    if (e.code == error) {
      *str = e.name;
      return kSuccess;
    }
  }
  *str = nullptr;
  return kInvalidValue;
}

FAKE_API CUresult cuGetErrorString(CUresult error, const char** str) {
  for (const ErrorText& e : kErrors) {
    if (e.code == error) {
      *str = e.text;
      return kSuccess;
    }
  }
  *str = nullptr;
  return kInvalidValue;
}

FAKE_API CUresult cuInit(unsigned flags) {
  std::lock_guard<std::mutex> lock(g_mutex);
  const char* mode = std::getenv("HFRT_FAKE_CUDA");
  g_mode = mode && *mode ? mode : "ok";
  // The record of launches starts again: dlclose leaves this library loaded (a static inside
  // libstdc++'s std::to_string is a GNU unique symbol, and glibc never unloads such objects).
  g_launches = 0;
  g_last_entry.clear();
  g_last_grid = g_last_block = 0;
  g_last_arg0 = 0;
  g_initialised = false;
  if (flags != 0) return kInvalidValue;
  if (g_mode == "init_no_device") return kNoDevice;
  if (g_mode == "init_fails") return kSystemDriverMismatch;
  g_initialised = true;
  return kSuccess;
}

FAKE_API CUresult cuDeviceGetCount(int* count) {
  if (!g_initialised) return kNotInitialized;
  *count = has_device() ? 1 : 0;
  return kSuccess;
}

FAKE_API CUresult cuDeviceGet(CUdevice* device, int ordinal) {
  if (!g_initialised) return kNotInitialized;
  if (!has_device() || ordinal != 0) return kInvalidDevice;
  *device = 0;
  return kSuccess;
}

FAKE_API CUresult cuDeviceGetName(char* name, int len, CUdevice device) {
  if (!g_initialised) return kNotInitialized;
  if (device != 0 || len <= 0) return device != 0 ? kInvalidDevice : kInvalidValue;
  std::strncpy(name, "Fake GPU", static_cast<size_t>(len));
  name[len - 1] = '\0';
  return kSuccess;
}

FAKE_API CUresult cuDeviceGetAttribute(int* value, int attribute, CUdevice device) {
  if (!g_initialised) return kNotInitialized;
  if (device != 0) return kInvalidDevice;
  if (attribute == 75)
    *value = 9;  // CU_DEVICE_ATTRIBUTE_COMPUTE_CAPABILITY_MAJOR
  else if (attribute == 76)
    *value = 0;  // ..._MINOR
  else
    return kInvalidValue;
  return kSuccess;
}

FAKE_API CUresult cuDeviceTotalMem_v2(size_t* bytes, CUdevice device) {
  if (!g_initialised) return kNotInitialized;
  if (device != 0) return kInvalidDevice;
  *bytes = size_t{1} << 30;
  return kSuccess;
}

FAKE_API CUresult cuDevicePrimaryCtxRetain(void** context, CUdevice device) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (!g_initialised) return kNotInitialized;
  if (device != 0) return kInvalidDevice;
  ++g_context_refs;
  *context = &g_context;
  return kSuccess;
}

FAKE_API CUresult cuDevicePrimaryCtxRelease_v2(CUdevice device) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (!g_initialised) return kNotInitialized;
  if (device != 0) return kInvalidDevice;
  if (g_context_refs == 0) return kInvalidContext;
  --g_context_refs;
  return kSuccess;
}

FAKE_API CUresult cuCtxSetCurrent(void* context) {
  if (!g_initialised) return kNotInitialized;
  if (context && context != &g_context) return kInvalidContext;
  t_current = static_cast<FakeContext*>(context);
  return kSuccess;
}

FAKE_API CUresult cuCtxSynchronize() {
  return need_context();
}

#ifndef HFRT_FAKE_CUDA_OMIT_MEMALLOC
FAKE_API CUresult cuMemAlloc_v2(CUdeviceptr* ptr, size_t bytes) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  if (bytes == 0) return kInvalidValue;
  void* p = std::malloc(bytes);
  if (!p) return 2;  // CUDA_ERROR_OUT_OF_MEMORY
  g_allocations[reinterpret_cast<uintptr_t>(p)] = bytes;
  *ptr = reinterpret_cast<uintptr_t>(p);
  return kSuccess;
}
#endif

FAKE_API CUresult cuMemFree_v2(CUdeviceptr ptr) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  auto it = g_allocations.find(static_cast<uintptr_t>(ptr));
  if (it == g_allocations.end()) return kInvalidValue;
  std::free(reinterpret_cast<void*>(it->first));
  g_allocations.erase(it);
  return kSuccess;
}

FAKE_API CUresult cuMemcpyHtoD_v2(CUdeviceptr dst, const void* src, size_t bytes) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  if (!src || !inside_allocation(dst, bytes)) return kInvalidValue;
  std::memcpy(reinterpret_cast<void*>(static_cast<uintptr_t>(dst)), src, bytes);
  return kSuccess;
}

FAKE_API CUresult cuMemcpyDtoH_v2(void* dst, CUdeviceptr src, size_t bytes) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  if (!dst || !inside_allocation(src, bytes)) return kInvalidValue;
  std::memcpy(dst, reinterpret_cast<const void*>(static_cast<uintptr_t>(src)), bytes);
  return kSuccess;
}

FAKE_API CUresult cuModuleLoadDataEx(void** module, const void* image, unsigned num_options,
                                     int* options, void** values) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  if (!image || (num_options > 0 && (!options || !values))) return kInvalidValue;
  const std::string text = static_cast<const char*>(image);
  // The first line that is neither blank nor a comment must declare the PTX version.
  size_t line_no = 0, pos = 0;
  std::string first;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    size_t s = line.find_first_not_of(" \t\r");
    if (s == std::string::npos || line.compare(s, 2, "//") == 0) continue;
    first = line.substr(s);
    break;
  }
  if (first.find(".version") == std::string::npos) {
    std::string log = "ptxas application ptx input, line " + std::to_string(line_no) +
                      "; fatal   : Parsing error near '" + first.substr(0, first.find(' ')) +
                      "': syntax error";
    if (first.empty()) log = "ptxas fatal   : PTX input is empty (no .version directive)";
    // CU_JIT_ERROR_LOG_BUFFER (5) and its size (6): the size goes in, the length comes out.
    char* buffer = nullptr;
    size_t capacity = 0;
    int size_index = -1;
    for (unsigned i = 0; i < num_options; ++i) {
      if (options[i] == 5) buffer = static_cast<char*>(values[i]);
      if (options[i] == 6) {
        capacity = reinterpret_cast<uintptr_t>(values[i]);
        size_index = static_cast<int>(i);
      }
    }
    if (buffer && capacity > 0) {
      size_t n = std::min(log.size(), capacity - 1);
      std::memcpy(buffer, log.data(), n);
      buffer[n] = '\0';
      values[size_index] = reinterpret_cast<void*>(uintptr_t{n + 1});
    }
    return kInvalidPtx;
  }
  auto m = std::make_unique<FakeModule>();
  for (size_t at = text.find(".entry"); at != std::string::npos; at = text.find(".entry", at + 1)) {
    size_t s = text.find_first_not_of(" \t", at + 6);
    size_t e = text.find_first_of(" \t\r\n(", s);
    if (s == std::string::npos || e == std::string::npos || e == s) continue;
    m->functions.push_back(std::make_unique<FakeFunction>(FakeFunction{text.substr(s, e - s)}));
  }
  *module = m.get();
  g_modules.insert(m.release());
  return kSuccess;
}

FAKE_API CUresult cuModuleGetFunction(void** function, void* module, const char* name) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  auto* m = static_cast<FakeModule*>(module);
  if (!g_modules.count(m)) return kInvalidHandle;
  for (const auto& f : m->functions) {
    if (f->name == name) {
      *function = f.get();
      return kSuccess;
    }
  }
  return kNotFound;
}

FAKE_API CUresult cuModuleUnload(void* module) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  auto* m = static_cast<FakeModule*>(module);
  if (!g_modules.erase(m)) return kInvalidHandle;
  delete m;
  return kSuccess;
}

FAKE_API CUresult cuLaunchKernel(void* function, unsigned grid_x, unsigned grid_y, unsigned grid_z,
                                 unsigned block_x, unsigned block_y, unsigned block_z,
                                 unsigned shared_bytes, void* stream, void** params, void** extra) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  if (!function) return kInvalidHandle;
  if (grid_x == 0 || grid_y == 0 || grid_z == 0 || block_x == 0 || block_y == 0 || block_z == 0 ||
      block_x * block_y * block_z > 1024 || !params || extra) {
    return kInvalidValue;
  }
  if (g_mode == "launch_fails") return kLaunchOutOfResources;
  ++g_launches;
  g_last_entry = static_cast<FakeFunction*>(function)->name;
  g_last_grid = grid_x;
  g_last_block = block_x;
  std::memcpy(&g_last_arg0, params[0], sizeof g_last_arg0);
  return kSuccess;
}

FAKE_API CUresult cuEventCreate(void** event, unsigned flags) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  auto* e = new FakeEvent;
  g_events.insert(e);
  *event = e;
  return kSuccess;
}

FAKE_API CUresult cuEventRecord(void* event, void* stream) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  auto* e = static_cast<FakeEvent*>(event);
  if (!g_events.count(e)) return kInvalidHandle;
  e->when = std::chrono::steady_clock::now();
  e->recorded = true;
  return kSuccess;
}

FAKE_API CUresult cuEventSynchronize(void* event) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  if (!g_events.count(static_cast<FakeEvent*>(event))) return kInvalidHandle;
  if (g_mode == "kernel_faults") return kIllegalAddress;
  return kSuccess;
}

FAKE_API CUresult cuEventElapsedTime(float* ms, void* start, void* stop) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  auto* a = static_cast<FakeEvent*>(start);
  auto* b = static_cast<FakeEvent*>(stop);
  if (!g_events.count(a) || !g_events.count(b)) return kInvalidHandle;
  if (!a->recorded || !b->recorded) return kInvalidHandle;
  *ms = std::chrono::duration<float, std::milli>(b->when - a->when).count();
  return kSuccess;
}

FAKE_API CUresult cuEventDestroy_v2(void* event) {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (CUresult r = need_context(); r != kSuccess) return r;
  auto* e = static_cast<FakeEvent*>(event);
  if (!g_events.erase(e)) return kInvalidHandle;
  delete e;
  return kSuccess;
}

// What the tests look at.
FAKE_API int hfrt_fake_cuda_launches() {
  return g_launches;
}
FAKE_API const char* hfrt_fake_cuda_last_entry() {
  return g_last_entry.c_str();
}
FAKE_API unsigned hfrt_fake_cuda_last_grid() {
  return g_last_grid;
}
FAKE_API unsigned hfrt_fake_cuda_last_block() {
  return g_last_block;
}
FAKE_API uint64_t hfrt_fake_cuda_last_arg0() {
  return g_last_arg0;
}
/// Allocations, modules and events not yet freed, and primary-context references held.
FAKE_API int hfrt_fake_cuda_live_objects() {
  return static_cast<int>(g_allocations.size() + g_modules.size() + g_events.size()) +
         g_context_refs;
}
