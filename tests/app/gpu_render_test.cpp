// Tests of app/gpu_render (issue 22) without a GPU: the generated ray caster compiled for the
// host against hfrt's CPU renderer (the same camera, box, lights and steps; the kernels search
// by the sign-change march and take normals by central differences, the CPU by its gradient
// JIT), a sphere against its closed-form silhouette, the parameter block, the options the
// kernels refuse, and --device cuda through the driver loader without a driver and with the
// fake driver of tests/gpu.
#include "app/gpu_render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include "app/model_field.h"
#include "app/render_job.h"
#include "gpu/cuda_driver.h"
#include "hfrt/model.h"

namespace hfrt::app {
namespace {

Model compile(const std::string& text) {
  ModelOptions mo;
  CompileResult c = Model::compile(text, mo);
  EXPECT_TRUE(c.ok()) << c.rendered;
  return std::move(*c.model);
}

std::string read(const std::string& path) {
  FILE* f = std::fopen(path.c_str(), "rb");
  EXPECT_NE(f, nullptr) << path;
  std::string s;
  char buf[4096];
  for (size_t n; f && (n = std::fread(buf, 1, sizeof buf, f)) > 0;) s.append(buf, n);
  if (f) std::fclose(f);
  return s;
}

struct Agreement {
  double coverage_differs = 0;  ///< fraction of pixels
  double color_differs = 0;     ///< fraction of pixels covered in both with |rgb diff| > 2/255
  int covered = 0;
};

Agreement compare(const render::Image& a, const render::Image& b) {
  Agreement r;
  const size_t n = a.pixels();
  size_t cov = 0, col = 0;
  for (size_t i = 0; i < n; ++i) {
    const bool ca = a.alpha[i] > 0.5f, cb = b.alpha[i] > 0.5f;
    if (ca != cb) ++cov;
    if (ca && cb) {
      ++r.covered;
      for (int c = 0; c < 3; ++c) {
        if (std::fabs(a.rgb[3 * i + c] - b.rgb[3 * i + c]) > 2.0f / 255) {
          ++col;
          break;
        }
      }
    }
  }
  r.coverage_differs = double(cov) / double(n);
  r.color_differs = double(col) / double(n);
  return r;
}

/// The CPU render (root search sign, as the kernels search) and the host-run kernels' render.
void render_both(const Model& model, const std::string& file, int size, render::RenderResult* cpu,
                 render::RenderResult* dev) {
  RenderJob job;
  job.model = &model;
  job.file = file;
  job.setup.options.width = job.setup.options.height = size;
  job.setup.options.root = render::RootMode::kSign;
  RenderJobResult done = run_render_job(job, cpu);
  ASSERT_EQ(done.status, RenderJobStatus::kOk) << done.error;
  DeviceJobResult d = run_device_render_job(job, Device::kCudaHost, dev);
  ASSERT_EQ(d.status, RenderJobStatus::kOk) << d.error;
  // The same camera: framing is the CPU job's.
  EXPECT_EQ(d.options.camera.eye.x, done.options.camera.eye.x);
  EXPECT_EQ(d.options.camera.look_at.z, done.options.camera.look_at.z);
}

TEST(GpuRender, HostKernelsAgreeWithTheCpuRendererOnCorpusModels) {
  // Stated tolerance (docs/gpu.md): at most 0.5% of the pixels differ in coverage and at most
  // 1% differ by more than 2/255 in a colour channel (silhouette and shadow-edge pixels).
  const std::string base = std::string(HFRT_CORPUS_DIR) + "/models/github/";
  for (const char* rel : {"pmur002__hyperfun-report/csg.hf", "adda-team__adda/example.hf"}) {
    const std::string path = base + rel;
    Model model = compile(read(path));
    render::RenderResult cpu, dev;
    render_both(model, path, 256, &cpu, &dev);
    Agreement a = compare(cpu.image, dev.image);
    EXPECT_GT(a.covered, 256 * 256 / 20) << rel;  // the solid is in the picture
    EXPECT_LE(a.coverage_differs, 0.005) << rel;
    EXPECT_LE(a.color_differs, 0.01) << rel;
  }
}

TEST(GpuRender, SphereSilhouetteIsTheClosedForm) {
  // A sphere of radius 4 seen by an orthographic camera of width 12 along -z: the covered
  // pixels are those whose centre is within 4 of the axis (up to the pixels the disk's edge
  // crosses).
  Model model =
      compile("my_model(x[3], a[1]) { my_model = 16 - x[1]*x[1] - x[2]*x[2] - x[3]*x[3]; }");
  RenderJob job;
  job.model = &model;
  job.file = "sphere.hf";
  const int size = 128;
  job.setup.options.width = job.setup.options.height = size;
  job.setup.options.root = render::RootMode::kSign;
  job.setup.camera.eye = render::Vec3{0, 0, 30};
  job.setup.camera.look_at = render::Vec3{0, 0, 0};
  job.setup.camera.ortho_width = 12.0f;
  render::RenderResult dev;
  DeviceJobResult d = run_device_render_job(job, Device::kCudaHost, &dev);
  ASSERT_EQ(d.status, RenderJobStatus::kOk) << d.error;
  const float pixel = 12.0f / size;
  int wrong = 0, edge = 0;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const float u = -6 + (x + 0.5f) * pixel, v = 6 - (y + 0.5f) * pixel;
      const float r = std::sqrt(u * u + v * v);
      const bool inside = r < 4;
      const float alpha = dev.image.alpha[size_t(y) * size + x];
      if (std::fabs(r - 4) < pixel) {
        ++edge;
        continue;
      }
      if ((alpha > 0.5f) != inside) ++wrong;
      if (inside) {
        // Depth: the eye plane is z = 30, the sphere's front at z = sqrt(16 - r^2).
        const float depth = dev.image.depth[size_t(y) * size + x];
        EXPECT_NEAR(depth, 30 - std::sqrt(16 - r * r), 0.01f) << x << "," << y;
        // The normal is the sphere's: (u, v, z) / 4.
        EXPECT_NEAR(dev.image.normal[3 * (size_t(y) * size + x) + 2], std::sqrt(16 - r * r) / 4,
                    0.01f);
      }
    }
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_GT(edge, 0);
}

TEST(GpuRender, ParameterBlockFollowsTheCameraFrame) {
  render::RenderOptions opt;
  opt.width = 64;
  opt.height = 32;
  opt.camera.eye = render::Vec3{0, 0, 10};
  opt.camera.look_at = render::Vec3{0, 0, 0};
  auto p = make_render_params(opt, 0.25);
  ASSERT_TRUE(p.ok()) << p.error().message;
  const gpu::RenderParams& r = p.value();
  // The ray through pixel (px, py) as CameraFrame::ray computes it.
  render::CameraFrame frame(opt.camera, opt.width, opt.height);
  const render::Ray ray = frame.ray(10.5f, 20.5f);
  const float sx = (2.0f * 10.5f / 64 - 1.0f) * r.half_w;
  const float sy = (1.0f - 2.0f * 20.5f / 32) * r.half_h;
  EXPECT_NEAR(r.forward[0] + sx * r.right[0] + sy * r.up[0], ray.d.x, 1e-6f);
  EXPECT_NEAR(r.forward[1] + sx * r.right[1] + sy * r.up[1], ray.d.y, 1e-6f);
  EXPECT_NEAR(r.forward[2] + sx * r.right[2] + sy * r.up[2], ray.d.z, 1e-6f);
  EXPECT_EQ(r.num_lights, 2);  // the default key and fill lights
  EXPECT_EQ(r.time, 0.25f);
  EXPECT_EQ(r.width, 64);
  EXPECT_EQ(r.height, 32);
}

TEST(GpuRender, OptionsTheKernelsCannotDoAreRefusedWithTheOptionToChange) {
  render::RenderOptions opt;
  opt.spp = 4;
  auto p = make_render_params(opt, 0);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("one sample per pixel"), std::string::npos);
  opt.spp = 1;
  opt.lights.assign(5, render::Light{});
  p = make_render_params(opt, 0);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("up to 4 lights"), std::string::npos);
  opt.lights.assign(1, render::Light{render::Light::Kind::kSphere, {0, 5, 0}, {1, 1, 1}, 1, 1});
  p = make_render_params(opt, 0);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("sphere (area) lights"), std::string::npos);
}

TEST(GpuRender, DeviceNames) {
  Device d = Device::kCpu;
  EXPECT_TRUE(parse_device("cuda", &d));
  EXPECT_EQ(d, Device::kCuda);
  EXPECT_TRUE(parse_device("cuda-host", &d));
  EXPECT_EQ(d, Device::kCudaHost);
  EXPECT_FALSE(parse_device("gpu", &d));
  EXPECT_STREQ(device_name(Device::kCpu), "cpu");
}

TEST(GpuRender, MeshLeavesAreRefusedOnTheDevice) {
  // hfTriangles: one triangle given inline needs no file.
  Model model = compile(
      "my_model(x[3], a[1]) { array v[9], t[3]; v = [0,0,0, 1,0,0, 0,1,0]; t = [1, 2, 3]; "
      "my_model = hfTriangles(x, v, t); }");
  float xs[3] = {0, 0, 0}, f = 0;
  auto r = eval_on_device(model, 1, xs, Device::kCudaHost, &f);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("not on the GPU yet"), std::string::npos);
}

TEST(GpuRender, CudaWithoutADriverSaysSo) {
  gpu::unload_driver_for_testing();
  ::setenv("HFRT_LIBCUDA", "/nonexistent/libcuda.so.1", 1);
  Model model = compile("my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1]; }");
  float xs[3] = {0, 0, 0}, f = 0;
  auto r = eval_on_device(model, 1, xs, Device::kCuda, &f);
  ::unsetenv("HFRT_LIBCUDA");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no CUDA driver"), std::string::npos) << r.error().message;
}

TEST(GpuRender, CudaLaunchesThroughTheDriver) {
  // The fake driver (tests/gpu/fake_cuda.cpp) accepts the PTX, records the launch and writes
  // nothing: the plumbing (PTX load, buffers, argument list, download) runs end to end.
  gpu::unload_driver_for_testing();
  ::setenv("HFRT_LIBCUDA", HFRT_FAKE_CUDA_LIB, 1);
  ::setenv("HFRT_FAKE_CUDA", "ok", 1);
  Model model = compile("my_model(x[3], a[1]) { my_model = 1 - x[1]*x[1]; }");
  std::vector<float> xs(3 * 100, 0.5f), f(100, -7.0f);
  auto r = eval_on_device(model, 100, xs.data(), Device::kCuda, f.data());
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_NE(r.value().device.find("Fake GPU"), std::string::npos);
  EXPECT_NE(r.value().device.find("compute 9.0"), std::string::npos);
  ::unsetenv("HFRT_FAKE_CUDA");
  ::unsetenv("HFRT_LIBCUDA");
  gpu::unload_driver_for_testing();
}

TEST(GpuRender, SliceOnTheHostKernelsIsTheCpuSlice) {
  const std::string path =
      std::string(HFRT_CORPUS_DIR) + "/models/github/pmur002__hyperfun-report/csg.hf";
  Model model = compile(read(path));
  ModelField field(model, path);
  render::SliceOptions opt;
  opt.width = opt.height = 200;
  opt.x0 = opt.y0 = -8;  // the corners of the 12-cube outside the sphere of radius 7
  opt.x1 = opt.y1 = 8;
  opt.z = 0.5f;
  opt.use_interval = false;
  render::SliceResult cpu = render::render_slice(field, opt), dev;
  auto ran = slice_on_device(model, opt, Device::kCudaHost, &dev);
  ASSERT_TRUE(ran.ok()) << ran.error().message;
  ASSERT_EQ(dev.inside.size(), cpu.inside.size());
  size_t differ = 0;
  for (size_t i = 0; i < cpu.inside.size(); ++i) differ += cpu.inside[i] != dev.inside[i];
  // Only where F is within a few ulps of 0 may the device math flip a pixel.
  EXPECT_LE(differ, cpu.inside.size() / 1000);
  const auto inside = size_t(std::count(cpu.inside.begin(), cpu.inside.end(), 1));
  EXPECT_GT(inside, cpu.inside.size() / 50);
  EXPECT_LT(inside, cpu.inside.size() * 19 / 20);
  EXPECT_EQ(dev.stats.pixels_inside, std::count(dev.inside.begin(), dev.inside.end(), 1));
}

}  // namespace
}  // namespace hfrt::app
