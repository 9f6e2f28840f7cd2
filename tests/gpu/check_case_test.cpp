// The comparisons of hfrt_gpu_runner (tools/gpu_runner/check_case.h): ulps over the ordered
// floats, NaN patterns, and image coverage and colour.
#include "tools/gpu_runner/check_case.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "gpu/kernel_abi.h"

namespace hfrt::gpu_runner {
namespace {

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kTiny = std::numeric_limits<float>::denorm_min();

TEST(GpuCheckCompare, UlpDistanceOverOrderedIntegers) {
  EXPECT_EQ(ulp_distance(1.0f, 1.0f), 0);
  EXPECT_EQ(ulp_distance(0.0f, -0.0f), 0);
  EXPECT_EQ(ulp_distance(kTiny, 0.0f), 1);
  EXPECT_EQ(ulp_distance(-kTiny, kTiny), 2);  // across zero
  EXPECT_EQ(ulp_distance(1.0f, std::nextafter(1.0f, 2.0f)), 1);
  EXPECT_EQ(ulp_distance(-1.0f, std::nextafter(-1.0f, -2.0f)), 1);
  EXPECT_EQ(ulp_distance(2.0f, 1.0f), 1 << 23);  // one binade
  EXPECT_EQ(ulp_distance(std::numeric_limits<float>::max(), kInf), 1);
  EXPECT_EQ(ulp_distance(-kInf, kInf), 2 * int64_t{0x7f800000});
  EXPECT_EQ(ulp_distance(kNan, -kNan), 0);  // both NaN: agree
  EXPECT_EQ(ulp_distance(kNan, 1.0f), -1);  // a NaN-pattern mismatch
  EXPECT_EQ(ulp_distance(kInf, kNan), -1);
}

TEST(GpuCheckCompare, UlpsLargestFirstAndNanMismatches) {
  const std::vector<float> gpu = {1.0f, 2.0f, kNan, 3.0f, kNan, 5.0f};
  const std::vector<float> ref = {1.0f, std::nextafter(2.0f, 3.0f), 7.0f, 3.0f, kNan, 4.0f};
  const UlpStats s = compare_ulps(gpu, ref);
  EXPECT_EQ(s.nan_mismatch, 1);
  EXPECT_EQ(s.max_ulp, ulp_distance(5.0f, 4.0f));
  EXPECT_EQ(s.worst, 5u);
  const UlpStats same = compare_ulps(gpu, gpu);
  EXPECT_EQ(same.max_ulp, 0);
  EXPECT_EQ(same.worst, 0u);
  EXPECT_EQ(same.nan_mismatch, 0);
}

TEST(GpuCheckCompare, ImagesCoverageAndColourOverPixelsCoveredInBoth) {
  constexpr int k = gpu::kRenderFloatsPerPixel;
  std::vector<float> gpu(4 * k, 0.0f), ref(4 * k, 0.0f);
  auto pixel = [&](std::vector<float>& img, int p, float r, float g, float b, float cover) {
    img[p * k + 0] = r;
    img[p * k + 1] = g;
    img[p * k + 2] = b;
    img[p * k + 3] = cover;
  };
  pixel(gpu, 0, 0.5f, 0.5f, 0.5f, 1);  // covered in both: differences 0.25, 0, 0.5
  pixel(ref, 0, 0.25f, 0.5f, 1.0f, 1);
  pixel(gpu, 1, 0.1f, 0.1f, 0.1f, 1);  // covered in both, equal
  pixel(ref, 1, 0.1f, 0.1f, 0.1f, 1);
  pixel(gpu, 2, 0.9f, 0.9f, 0.9f, 1);  // covered only on the GPU: not in the colour figures
  pixel(ref, 3, 0, 0, 0, 0);           // a miss in both
  ref[3 * k + 4] = kNan;               // distance NaN on one side only
  const ImageStats s = compare_images(gpu, ref, 4);
  EXPECT_DOUBLE_EQ(s.cover_diff, 0.25);
  EXPECT_EQ(s.both, 2);
  EXPECT_DOUBLE_EQ(s.max_rgb, 0.5);
  EXPECT_DOUBLE_EQ(s.mean_rgb, 0.75 / 6.0);
  EXPECT_EQ(s.nan_mismatch, 1);
}

}  // namespace
}  // namespace hfrt::gpu_runner
