#pragma once
// Renders and point evaluations on the GPU path (docs/gpu.md): the kernels of
// gpu/kernel_abi.h, generated from the model (Model::device_ptx), run either on an NVIDIA GPU
// through the driver loaded at run time (gpu/cuda_driver.h) or, the same LLVM code compiled
// for this CPU, on the host (Model::device_kernels_on_host: what the GPU computes, without
// one). The camera, box, lights and steps are the CPU renderer's, resolved beforehand (a
// framed camera, default lights), so the images agree within the stated tolerance.

#include <string>
#include <string_view>
#include <vector>

#include "app/render_job.h"
#include "base/result.h"
#include "gpu/kernel_abi.h"
#include "hfrt/model.h"
#include "render/renderer.h"
#include "render/slice.h"

namespace hfrt::app {

/// Where `--device` runs a render or a slice.
enum class Device {
  kCpu,       ///< the CPU renderer (default)
  kCuda,      ///< the generated kernels on an NVIDIA GPU
  kCudaHost,  ///< the generated kernels compiled for this CPU (one thread per core)
};
/// "cpu", "cuda", "cuda-host"; false for anything else.
bool parse_device(std::string_view text, Device* device);
const char* device_name(Device device);

/// The kernels' parameter block for `opt` (camera resolved; lights empty = the default
/// lights of the camera; up to gpu::kMaxLights directional or point lights) at time `time`.
/// Fails for what the kernels cannot do yet (sphere lights, more than kMaxLights lights,
/// more than one sample per pixel), with the option to change.
Result<gpu::RenderParams> make_render_params(const render::RenderOptions& opt, double time);

/// The kernel output (gpu::kRenderFloatsPerPixel floats a pixel) as an image.
void image_from_kernel_output(const std::vector<float>& out, int width, int height,
                              render::Image* image);

struct DeviceRunInfo {
  std::string device;      ///< e.g. "NVIDIA H200 (compute 9.0)" or "this CPU (cuda-host)"
  double compile_ms = 0;   ///< PTX generation and the driver's load, or the host compile
  double kernel_ms = 0;    ///< the kernel alone
  double transfer_ms = 0;  ///< uploads and downloads
};

/// Renders `model` (its parameters and time as set) with `opt` (camera resolved) on `device`
/// (kCuda or kCudaHost) into `out`. Environment failures (no driver, no device, a model the
/// GPU cannot run) are errors with their reason.
Result<DeviceRunInfo> render_on_device(const Model& model, const render::RenderOptions& opt,
                                       Device device, render::RenderResult* out);

/// How run_device_render_job ended: kOk, kUsageError (a degenerate camera, or an option the
/// kernels cannot do: `error`), or an environment failure (`error`, `environment` true).
struct DeviceJobResult {
  RenderJobStatus status = RenderJobStatus::kOk;
  bool environment = false;
  std::string error;
  render::RenderOptions options;  ///< as rendered: the camera resolved
  FramingInfo framing;
  DeviceRunInfo run;
};

/// `job` (as run_render_job takes it) on `device`: the camera framed exactly as the CPU job
/// frames it (same field, same extent search), then render_on_device.
DeviceJobResult run_device_render_job(const RenderJob& job, Device device,
                                      render::RenderResult* out);

/// F at n points (structure of arrays, model.num_inputs() coordinates, the model's time in
/// x[4] when it has one) on `device`, into out_f.
Result<DeviceRunInfo> eval_on_device(const Model& model, int64_t n, const float* xs, Device device,
                                     float* out_f);

/// `hfrt slice --device`: F at every pixel centre of `opt` (render/slice.h's pixel mapping,
/// x[4] the model's time) by the point-evaluator kernel, inside where F >= 0. Every pixel is
/// evaluated (no interval pruning); stats count the points.
Result<DeviceRunInfo> slice_on_device(const Model& model, const render::SliceOptions& opt,
                                      Device device, render::SliceResult* out);

}  // namespace hfrt::app
