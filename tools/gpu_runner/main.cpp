// hfrt_gpu_runner: runs the device check cases that `hfrt gpu-cases` prepares, on the first
// CUDA device, and prints one line of key=value pairs per case and a summary line
// (docs/gpu.md, "Device check cases" and "Running the device check"). It links only gpu/ and
// base/ (no LLVM, no image library) and carries its C++ run time, so that it can be copied to
// a GPU machine on its own.
//
// Exit status: 0 every case loaded and ran (and no NaN pattern differs from expect_host),
// 1 a case failed or there is no driver or device, 2 usage errors.
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "gpu/cuda_driver.h"
#include "tools/gpu_runner/check_case.h"

namespace fs = std::filesystem;

namespace {

constexpr const char* kUsage = "usage: hfrt_gpu_runner CASES_DIR [--out DIR] [--repeat N]";

int usage_error(const std::string& why) {
  std::fprintf(stderr, "hfrt_gpu_runner: %s\n%s\n", why.c_str(), kUsage);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string cases_arg;
  hfrt::gpu_runner::RunOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help") {
      std::printf(
          "%s\n"
          "Runs each case (a subdirectory of CASES_DIR with case.txt, kernel.ptx and its data)\n"
          "on the first CUDA device; prints one line per case and a summary line.\n"
          "  --out DIR     write the render cases' images there (DIR/NAME.ppm)\n"
          "  --repeat N    launches timed per case (default 20)\n",
          kUsage);
      return 0;
    }
    if (arg == "--out" || arg == "--repeat") {
      if (i + 1 >= argc) return usage_error(arg + " needs a value");
      const std::string value = argv[++i];
      if (arg == "--out") {
        options.out_dir = value;
      } else {
        int n = 0;
        auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), n);
        if (ec != std::errc() || end != value.data() + value.size() || n < 1) {
          return usage_error("--repeat " + value + ": expected a positive integer");
        }
        options.repeat = n;
      }
      continue;
    }
    if (arg.size() > 1 && arg[0] == '-') return usage_error("unknown option " + arg);
    if (!cases_arg.empty()) return usage_error("more than one CASES_DIR (" + arg + ")");
    cases_arg = arg;
  }
  if (cases_arg.empty()) return usage_error("no CASES_DIR given");
  std::error_code ec;
  if (!fs::is_directory(cases_arg, ec)) {
    return usage_error("CASES_DIR " + cases_arg + " is not a directory");
  }

  std::vector<fs::path> cases;
  for (const auto& entry : fs::directory_iterator(cases_arg, ec)) {
    if (entry.is_directory()) cases.push_back(entry.path());
  }
  if (ec) {
    std::fprintf(stderr, "hfrt_gpu_runner: cannot list %s: %s\n", cases_arg.c_str(),
                 ec.message().c_str());
    return 1;
  }
  std::sort(cases.begin(), cases.end());
  if (cases.empty()) {
    std::fprintf(stderr, "hfrt_gpu_runner: no cases in %s (a case is a subdirectory)\n",
                 cases_arg.c_str());
    return 1;
  }
  if (!options.out_dir.empty()) {
    fs::create_directories(options.out_dir, ec);
    if (ec) {
      std::fprintf(stderr, "hfrt_gpu_runner: cannot create %s: %s\n",
                   options.out_dir.string().c_str(), ec.message().c_str());
      return 1;
    }
  }

  auto device = hfrt::gpu::CudaDevice::open();
  if (!device) {
    std::fprintf(stderr, "hfrt_gpu_runner: %s\n", device.error().message.c_str());
    return 1;
  }
  const auto& dev = *device.value();
  std::printf("device compute=%d.%d memory_mib=%zu name=%s\n", dev.compute_major(),
              dev.compute_minor(), dev.total_memory() >> 20, dev.name().c_str());
  std::fflush(stdout);

  int ok = 0, failed = 0;
  for (const fs::path& dir : cases) {
    const auto outcome = hfrt::gpu_runner::run_case(*device.value(), dir, options);
    std::printf("%s\n", outcome.line.c_str());
    std::fflush(stdout);  // a kernel that hangs until the timeout leaves the lines before it
    ++(outcome.ok ? ok : failed);
  }
  std::printf("summary cases=%zu ok=%d failed=%d\n", cases.size(), ok, failed);
  return failed ? 1 : 0;
}
