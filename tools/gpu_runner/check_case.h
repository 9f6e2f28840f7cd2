#pragma once
// One device check case of hfrt_gpu_runner (docs/gpu.md, "Device check cases"): read from its
// folder, run on the device, compared with the expectations that came with it, and reported
// as one line of key=value pairs.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "gpu/cuda_driver.h"

namespace hfrt::gpu_runner {

struct RunOptions {
  std::filesystem::path out_dir;  ///< where render cases write <name>.ppm; empty: no images
  int repeat = 20;                ///< launches timed per case (>= 1)
};

struct CaseOutcome {
  bool ok = false;   ///< loaded and ran, and no NaN pattern differs from expect_host
  std::string line;  ///< "case=NAME kind=... status=ok|fail ...", no newline
};

/// Runs the case in folder `dir`. Never aborts on bad input: every problem with the case's
/// files, the module or the launch is a failed outcome whose line ends with error=TEXT.
CaseOutcome run_case(gpu::CudaDevice& device, const std::filesystem::path& dir,
                     const RunOptions& options);

/// The distance in units in the last place between two floats, over the floats ordered as
/// integers (so -0 and +0 are 0 apart and the smallest subnormals 1 from 0). Both NaN: 0.
/// One NaN: -1 (a NaN-pattern mismatch).
int64_t ulp_distance(float a, float b);

/// The largest ulp distance and the NaN-pattern mismatches of `gpu` against `expect` (same
/// sizes).
struct UlpStats {
  int64_t max_ulp = 0;
  size_t worst = 0;  ///< index of the first value at max_ulp (0 when all agree)
  int64_t nan_mismatch = 0;
};
UlpStats compare_ulps(const std::vector<float>& gpu, const std::vector<float>& expect);

/// A GPU image against an expected one, both `pixels` * kRenderFloatsPerPixel floats (r, g,
/// b, coverage, ...); a pixel is covered when its coverage is above 0.5.
struct ImageStats {
  double cover_diff = 0;             ///< fraction of the pixels whose coverage differs
  int64_t both = 0;                  ///< pixels covered in both
  double max_rgb = 0, mean_rgb = 0;  ///< |r, g, b difference| over the pixels covered in both
  int64_t nan_mismatch = 0;          ///< floats (all of each pixel's) whose NaN-ness differs
};
ImageStats compare_images(const std::vector<float>& gpu, const std::vector<float>& expect,
                          int64_t pixels);

}  // namespace hfrt::gpu_runner
