#pragma once
// The contract between the kernels hfrt generates for NVIDIA GPUs (jit/llvm_nvptx.cpp) and
// the code that launches them (gpu/cuda_driver, app/gpu_render, tools/hfrt_gpu_runner):
// entry names, parameter lists and the render parameter block. Plain C++: no LLVM, no CUDA
// headers, so the launcher side builds and runs without either.

#include <cstddef>
#include <cstdint>

namespace hfrt::gpu {

/// The point evaluator of a model, one point per thread:
///   hfrt_eval_f32(int64 n, const float* xs, const float* a, float* out_f, float* out_s)
/// Thread i = blockIdx.x * blockDim.x + threadIdx.x evaluates point i < n with the layout of
/// jit::BatchFn<float> (structure of arrays): x[k+1] = xs[k*n + i], a[k+1] = a[k],
/// F -> out_f[i], s[k+1] -> out_s[k*n + i] (out_s may be null). 1-D grid of any block size.
inline constexpr const char* kEvalEntry = "hfrt_eval_f32";

/// The interval evaluator of a model, one box per thread (double precision, as the CPU's):
///   hfrt_interval_f64(int64 n, const double* xlo, const double* xhi, const double* a,
///                     double* out_lo, double* out_hi, uint8* out_nan)
/// Thread i < n encloses F over the box x[k+1] in [xlo[k*n + i], xhi[k*n + i]] (a[k+1] = a[k])
/// in [out_lo[i], out_hi[i]], out_nan[i] = 1 when F may have no value there. Present only for
/// models whose interval code calls no host function (no libm-based op, no R-function node:
/// jit::interval_code_is_self_contained); the ray caster then uses it to skip the empty part
/// of each ray (kRenderCullSpans pieces of its range, proven F < 0 before any point is
/// evaluated).
inline constexpr const char* kIntervalEntry = "hfrt_interval_f64";
inline constexpr int kRenderCullSpans = 8;

/// The ray caster of a model, one pixel per thread:
///   hfrt_render_f32(const RenderParams* p, const float* a, float* out)
/// Thread i < width * height shades pixel (i % width, i / width) through its centre and
/// writes kRenderFloatsPerPixel floats at out[i * kRenderFloatsPerPixel]:
///   linear r, g, b (background where nothing is hit), coverage (1 hit, 0 miss),
///   distance along the ray to the hit, outward unit normal x, y, z (0 on a miss).
inline constexpr const char* kRenderEntry = "hfrt_render_f32";
inline constexpr int kRenderFloatsPerPixel = 8;

/// Threads per block the launchers use (any multiple of 32 works).
inline constexpr int kThreadsPerBlock = 128;

inline constexpr int kMaxLights = 4;
inline constexpr int32_t kLightDirectional = 0;  ///< light_v: the direction towards the light
inline constexpr int32_t kLightPoint = 1;        ///< light_v: the light's position

/// Everything the render kernel reads besides the model's parameters, in device memory.
/// Only 4-byte fields, so the layout is the same in C++ and in the generated code (which
/// reads each field at its offsetof).
struct RenderParams {
  // The camera, as render::CameraFrame holds it: the ray through pixel (px, py) (pixel
  // units, (0, 0) the top-left corner) is o + t d with
  //   u = (2 px / width - 1) * half_w,  v = (1 - 2 py / height) * half_h,
  //   perspective:  o = eye,                        d = forward + u right + v up
  //   orthographic: o = eye + u right + v up,       d = forward
  float eye[3];
  float forward[3];
  float right[3];
  float up[3];
  float half_w;
  float half_h;
  int32_t ortho;  ///< 0 perspective, 1 orthographic
  int32_t width;
  int32_t height;
  // The region searched; the solid is capped at its faces.
  float box_lo[3];
  float box_hi[3];
  // The sign-change search: march step, bisection tolerance (world units), shadow-ray origin
  // offset along the normal, and a bound on march steps per ray.
  float step;
  float eps;
  float shadow_bias;
  int32_t max_steps;
  // Shading: background, surface colour, the Blinn-Phong constants of render/renderer.cpp.
  float background[3];
  float albedo[3];
  float ambient;
  float specular;
  float shininess;
  int32_t shadows;  ///< 0: no shadow rays
  int32_t num_lights;
  int32_t light_kind[kMaxLights];
  float light_v[kMaxLights][3];
  float light_radiance[kMaxLights][3];  ///< colour * intensity
  float time;                           ///< x[4] of the evaluated points (Model::set_time)
};
static_assert(sizeof(RenderParams) % 4 == 0);

}  // namespace hfrt::gpu
