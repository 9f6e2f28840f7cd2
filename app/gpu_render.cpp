// The GPU path's renders and evaluations: see gpu_render.h.

#include "app/gpu_render.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "base/parallel.h"
#include "base/timer.h"
#include "gpu/check_grid.h"
#include "gpu/cuda_driver.h"
#include "jit/nvptx.h"
#include "render/camera.h"

namespace hfrt::app {

namespace {
void copy3(float* dst, render::Vec3 v) {
  dst[0] = v.x, dst[1] = v.y, dst[2] = v.z;
}

/// The kernels compiled for this CPU, with the time it took in `info`.
Result<std::shared_ptr<const jit::HostKernels>> host_kernels(const Model& model,
                                                             DeviceRunInfo* info) {
  const auto t0 = std::chrono::steady_clock::now();
  std::string error;
  auto kernels = model.device_kernels_on_host(&error);
  if (!kernels) return Error{error};
  info->compile_ms = ms_since(t0);
  info->device = "this CPU (the CUDA kernels compiled for it)";
  return kernels;
}

/// The driver, a device and the model's module, loaded.
struct CudaSession {
  std::unique_ptr<gpu::CudaDevice> device;
  std::unique_ptr<gpu::CudaModule> module;
  DeviceRunInfo info;
};

Result<CudaSession> open_cuda(const Model& model) {
  CudaSession s;
  const auto t0 = std::chrono::steady_clock::now();
  auto device = gpu::CudaDevice::open();
  if (!device.ok()) return device.error();
  s.device = std::move(device).value();
  std::string ptx, error;
  if (!model.device_ptx(&ptx, &error)) return Error{error};
  auto module = s.device->load_ptx(ptx);
  if (!module.ok()) return module.error();
  s.module = std::move(module).value();
  s.info.device = s.device->name() + " (compute " + std::to_string(s.device->compute_major()) +
                  "." + std::to_string(s.device->compute_minor()) + ")";
  s.info.compile_ms = ms_since(t0);
  return s;
}

/// A device buffer holding `bytes` bytes of `src` (or uninitialised when src is null).
Result<gpu::DeviceBuffer> upload(gpu::CudaDevice& device, const void* src, size_t bytes) {
  auto buffer = gpu::DeviceBuffer::allocate(device, std::max<size_t>(bytes, 4));
  if (!buffer.ok()) return buffer.error();
  if (src && bytes > 0) {
    auto done = buffer.value().upload(src, bytes);
    if (!done.ok()) return done.error();
  }
  return std::move(buffer).value();
}
}  // namespace

bool parse_device(std::string_view text, Device* device) {
  for (Device d : {Device::kCpu, Device::kCuda, Device::kCudaHost}) {
    if (text == device_name(d)) {
      *device = d;
      return true;
    }
  }
  return false;
}

const char* device_name(Device device) {
  switch (device) {
    case Device::kCpu:
      return "cpu";
    case Device::kCuda:
      return "cuda";
    case Device::kCudaHost:
      return "cuda-host";
  }
  return "?";
}

Result<gpu::RenderParams> make_render_params(const render::RenderOptions& opt, double time) {
  if (opt.spp != 1) {
    return Error{"--device cuda renders one sample per pixel so far (leave out --spp)"};
  }
  render::CameraFrame frame(opt.camera, opt.width, opt.height);
  std::vector<render::Light> lights =
      opt.lights.empty() ? render::default_lights(frame) : opt.lights;
  if (lights.size() > size_t(gpu::kMaxLights)) {
    return Error{"--device cuda takes up to " + std::to_string(gpu::kMaxLights) + " lights"};
  }
  gpu::RenderParams p{};
  copy3(p.eye, frame.eye());
  copy3(p.forward, frame.forward());
  copy3(p.right, frame.right());
  copy3(p.up, frame.up());
  p.half_w = frame.half_width();
  p.half_h = frame.half_height();
  p.ortho = frame.orthographic() ? 1 : 0;
  p.width = opt.width;
  p.height = opt.height;
  copy3(p.box_lo, opt.bbox.lo);
  copy3(p.box_hi, opt.bbox.hi);
  p.step = render::effective_step(opt);
  p.eps = render::effective_epsilon(opt);
  p.shadow_bias = render::shadow_bias(opt);
  p.max_steps = 1 << 26;
  copy3(p.background, opt.background);
  copy3(p.albedo, opt.albedo);
  p.ambient = render::kAmbient;
  p.specular = render::kSpecular;
  p.shininess = render::kShininess;
  p.shadows = opt.shadows ? 1 : 0;
  p.num_lights = int32_t(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) {
    const render::Light& l = lights[i];
    if (l.kind == render::Light::Kind::kSphere) {
      return Error{
          "--device cuda has no sphere (area) lights yet: use point or directional lights"};
    }
    p.light_kind[i] =
        l.kind == render::Light::Kind::kPoint ? gpu::kLightPoint : gpu::kLightDirectional;
    copy3(p.light_v[i], l.v);
    copy3(p.light_radiance[i], l.color * l.intensity);
  }
  p.time = float(time);
  return p;
}

void image_from_kernel_output(const std::vector<float>& out, int width, int height,
                              render::Image* image) {
  image->resize(width, height);
  const size_t n = size_t(width) * size_t(height);
  for (size_t i = 0; i < n; ++i) {
    const float* px = &out[i * gpu::kRenderFloatsPerPixel];
    for (int c = 0; c < 3; ++c) image->rgb[3 * i + c] = px[c];
    image->alpha[i] = px[3];
    image->depth[i] = px[3] > 0 ? px[4] : INFINITY;
    for (int c = 0; c < 3; ++c) image->normal[3 * i + c] = px[5 + c];
  }
}

Result<DeviceRunInfo> render_on_device(const Model& model, const render::RenderOptions& opt,
                                       Device device, render::RenderResult* out) {
  auto params = make_render_params(opt, model.time());
  if (!params.ok()) return params.error();
  const gpu::RenderParams& p = params.value();
  const std::vector<float> a = model.code_params_f32();
  const int64_t pixels = int64_t(opt.width) * opt.height;
  std::vector<float> result(size_t(pixels) * gpu::kRenderFloatsPerPixel);
  DeviceRunInfo info;
  if (device == Device::kCudaHost) {
    auto kernels = host_kernels(model, &info);
    if (!kernels.ok()) return kernels.error();
    const auto t1 = std::chrono::steady_clock::now();
    par::with_threads(opt.threads, [&] {
      par::parallel_for(size_t(pixels), 256, [&](size_t b, size_t e) {
        kernels.value()->render(p, a.data(), result.data(), int64_t(b), int64_t(e));
      });
    });
    info.kernel_ms = ms_since(t1);
  } else {
    auto session = open_cuda(model);
    if (!session.ok()) return session.error();
    CudaSession& s = session.value();
    info = s.info;
    const auto t1 = std::chrono::steady_clock::now();
    auto dp = upload(*s.device, &p, sizeof p);
    if (!dp.ok()) return dp.error();
    auto da = upload(*s.device, a.data(), a.size() * sizeof(float));
    if (!da.ok()) return da.error();
    auto dout = upload(*s.device, nullptr, result.size() * sizeof(float));
    if (!dout.ok()) return dout.error();
    uint64_t ap = dp.value().address(), aa = da.value().address(), ao = dout.value().address();
    const double upload_ms = ms_since(t1);
    auto ran = s.module->launch(gpu::kRenderEntry, pixels, {&ap, &aa, &ao});
    if (!ran.ok()) return ran.error();
    info.kernel_ms = ran.value();
    const auto t2 = std::chrono::steady_clock::now();
    auto got = dout.value().download(result.data(), result.size() * sizeof(float));
    if (!got.ok()) return got.error();
    info.transfer_ms = upload_ms + ms_since(t2);
  }
  image_from_kernel_output(result, opt.width, opt.height, &out->image);
  out->stats = render::RenderStats{};
  out->stats.seconds = info.kernel_ms / 1000.0;
  out->stats.primary_rays = uint64_t(pixels);
  return info;
}

DeviceJobResult run_device_render_job(const RenderJob& job, Device device,
                                      render::RenderResult* out) {
  DeviceJobResult r;
  const Model& model = *job.model;
  ModelField model_field(model, job.file);
  WithoutIntervals sampled(model_field);
  r.options = job.setup.options;
  const render::Field& field = render_field(model, model_field, sampled, r.options.root);
  if (!frame_camera(field, job.setup.camera, &r.options, &r.framing, &r.error)) {
    r.status = RenderJobStatus::kUsageError;
    return r;
  }
  if (auto params = make_render_params(r.options, model.time()); !params.ok()) {
    r.status = RenderJobStatus::kUsageError;
    r.error = params.error().message;
    return r;
  }
  auto ran = render_on_device(model, r.options, device, out);
  if (!ran.ok()) {
    r.status = RenderJobStatus::kUsageError;
    r.environment = true;
    r.error = ran.error().message;
    return r;
  }
  r.run = ran.value();
  return r;
}

Result<DeviceRunInfo> eval_on_device(const Model& model, int64_t n, const float* xs, Device device,
                                     float* out_f) {
  const std::vector<float> a = model.code_params_f32();
  DeviceRunInfo info;
  if (device == Device::kCudaHost) {
    auto kernels = host_kernels(model, &info);
    if (!kernels.ok()) return kernels.error();
    const auto t1 = std::chrono::steady_clock::now();
    kernels.value()->eval(n, xs, a.data(), out_f, nullptr);
    info.kernel_ms = ms_since(t1);
    return info;
  }
  auto session = open_cuda(model);
  if (!session.ok()) return session.error();
  CudaSession& s = session.value();
  info = s.info;
  const auto t1 = std::chrono::steady_clock::now();
  const size_t nin = size_t(std::max(model.num_inputs(), 1));
  auto dx = upload(*s.device, xs, nin * size_t(n) * sizeof(float));
  if (!dx.ok()) return dx.error();
  auto da = upload(*s.device, a.data(), a.size() * sizeof(float));
  if (!da.ok()) return da.error();
  auto df = upload(*s.device, nullptr, size_t(n) * sizeof(float));
  if (!df.ok()) return df.error();
  int64_t count = n;
  uint64_t ax = dx.value().address(), aa = da.value().address(), af = df.value().address(), as = 0;
  const double upload_ms = ms_since(t1);
  auto ran = s.module->launch(gpu::kEvalEntry, n, {&count, &ax, &aa, &af, &as});
  if (!ran.ok()) return ran.error();
  info.kernel_ms = ran.value();
  const auto t2 = std::chrono::steady_clock::now();
  auto got = df.value().download(out_f, size_t(n) * sizeof(float));
  if (!got.ok()) return got.error();
  info.transfer_ms = upload_ms + ms_since(t2);
  return info;
}

Result<DeviceRunInfo> slice_on_device(const Model& model, const render::SliceOptions& opt,
                                      Device device, render::SliceResult* out) {
  const int64_t n = int64_t(opt.width) * opt.height;
  // render_slice's pixel centres, x[4] the model's time.
  const std::vector<float> xs =
      gpu::grid_points(opt.width, opt.height, opt.x0, opt.x1, opt.y0, opt.y1, opt.z,
                       std::max(model.num_inputs(), 1), float(model.time()));
  std::vector<float> f(static_cast<size_t>(n));
  auto ran = eval_on_device(model, n, xs.data(), device, f.data());
  if (!ran.ok()) return ran.error();
  out->width = opt.width;
  out->height = opt.height;
  out->inside.assign(size_t(n), 0);
  out->stats = render::SliceStats{};
  for (int64_t k = 0; k < n; ++k) {
    if (f[size_t(k)] >= 0) {
      out->inside[size_t(k)] = 1;
      out->stats.pixels_inside++;
    } else if (std::isnan(f[size_t(k)])) {
      out->stats.evals.nan_samples++;
    }
  }
  out->stats.evals.eval_calls = 1;
  out->stats.evals.eval_points = uint64_t(n);
  out->stats.seconds = ran.value().kernel_ms / 1000.0;
  return ran.value();
}

}  // namespace hfrt::app
