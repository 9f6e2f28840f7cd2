// The device check's cases: see gpu_cases.h. The format is the runner's (docs/gpu.md).

#include "app/gpu_cases.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>

#include "app/gpu_render.h"
#include "app/render_job.h"
#include "gpu/check_grid.h"
#include "hfrt/model.h"
#include "jit/nvptx.h"

namespace hfrt::app {

namespace {
namespace fs = std::filesystem;

bool write_bytes(const fs::path& path, const void* data, size_t bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(static_cast<const char*>(data), std::streamsize(bytes));
  return bool(f);
}

bool write_floats(const fs::path& path, const std::vector<float>& v) {
  return write_bytes(path, v.data(), v.size() * sizeof(float));
}

/// A case folder's name from a model path: the file stem, made unique.
std::string case_name(const std::string& path, std::vector<std::string>* used) {
  std::string stem = fs::path(path).stem().string();
  std::string name = stem;
  for (int k = 2; std::count(used->begin(), used->end(), name); ++k)
    name = stem + "_" + std::to_string(k);
  used->push_back(name);
  return name;
}

std::vector<std::string> model_files(const std::string& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec)) {
    const std::string p = e.path().string();
    // The parser stress tests (10^4 generated statements, NaN everywhere): not GPU material.
    if (e.path().extension() == ".hf" && p.find("historical_") == std::string::npos)
      out.push_back(p);
  }
  std::sort(out.begin(), out.end());
  return out;
}

/// The eval case of `model` at the points `xs` (num_inputs coordinates, structure of arrays).
Result<bool> write_eval_case(const fs::path& dir, const std::string& name, const Model& model,
                             const std::vector<float>& xs, int64_t n, const std::string& sm,
                             const std::string& grid = "") {
  std::string ptx, error;
  // The point evaluator alone: the ray caster and the interval kernel would only make the
  // carried PTX larger (Prospero's: 6.8 MB with them).
  if (!model.device_ptx(&ptx, &error, sm, /*eval_only=*/true)) return Error{error};
  auto kernels = model.device_kernels_on_host(&error);
  if (!kernels) return Error{error};
  const std::vector<float> a = model.code_params_f32();
  std::vector<float> jit(static_cast<size_t>(n)), host(static_cast<size_t>(n));
  model.eval_batch(n, xs.data(), jit.data());
  kernels->eval(n, xs.data(), a.data(), host.data(), nullptr);
  fs::create_directories(dir);
  std::ofstream meta(dir / "case.txt");
  meta << "kind=eval\nname=" << name << "\nn=" << n << "\nnum_inputs=" << model.num_inputs()
       << "\nnum_params=" << a.size() << "\nnum_s=0\n";
  // A grid's points are made by the runner (gpu::grid_points), not carried.
  if (!grid.empty()) meta << "grid=" << grid << "\n";
  const bool ok =
      bool(meta) && write_bytes(dir / "kernel.ptx", ptx.data(), ptx.size()) &&
      write_floats(dir / "a.f32", a) && (!grid.empty() || write_floats(dir / "xs.f32", xs)) &&
      write_floats(dir / "expect_jit.f32", jit) && write_floats(dir / "expect_host.f32", host);
  if (!ok) return Error{"cannot write " + dir.string()};
  return true;
}

/// The render case of `model`: the CPU renderer's image and the host-run kernel's.
Result<bool> write_render_case(const fs::path& dir, const std::string& name, const Model& model,
                               const std::string& file, int size, const std::string& sm) {
  RenderJob job;
  job.model = &model;
  job.file = file;
  job.setup.options.width = job.setup.options.height = size;
  job.setup.options.root = render::RootMode::kSign;  // the kernels' search
  render::RenderResult cpu;
  RenderJobResult done = run_render_job(job, &cpu);
  if (done.status != RenderJobStatus::kOk) return Error{done.error};
  auto params = make_render_params(done.options, model.time());
  if (!params.ok()) return params.error();
  std::string ptx, error;
  if (!model.device_ptx(&ptx, &error, sm)) return Error{error};
  auto kernels = model.device_kernels_on_host(&error);
  if (!kernels) return Error{error};
  const std::vector<float> a = model.code_params_f32();
  const int64_t pixels = int64_t(size) * size;
  const int k = gpu::kRenderFloatsPerPixel;
  std::vector<float> host(size_t(pixels) * k), want(size_t(pixels) * k);
  std::vector<uint8_t> host8(size_t(pixels) * 4), want8(size_t(pixels) * 4);
  kernels->render(params.value(), a.data(), host.data(), 0, pixels);
  for (int64_t i = 0; i < pixels; ++i) {
    float* px = &want[size_t(i) * k];
    for (int c = 0; c < 3; ++c) px[c] = cpu.image.rgb[3 * i + c];
    px[3] = cpu.image.alpha[i];
    px[4] = cpu.image.alpha[i] > 0 ? cpu.image.depth[i] : 0.0f;
    for (int c = 0; c < 3; ++c) px[5 + c] = cpu.image.normal[3 * i + c];
    gpu::quantize_rgba8(px, &want8[size_t(i) * 4]);
    gpu::quantize_rgba8(&host[size_t(i) * k], &host8[size_t(i) * 4]);
  }
  fs::create_directories(dir);
  std::ofstream meta(dir / "case.txt");
  meta << "kind=render\nname=" << name << "\nwidth=" << size << "\nheight=" << size
       << "\nnum_params=" << a.size() << "\nformat=rgba8\n";
  // 8-bit expectations: 4 MB for 1024x1024 instead of 32 (the check travels to the GPU).
  const bool ok = bool(meta) && write_bytes(dir / "kernel.ptx", ptx.data(), ptx.size()) &&
                  write_floats(dir / "a.f32", a) &&
                  write_bytes(dir / "params.bin", &params.value(), sizeof(gpu::RenderParams)) &&
                  write_bytes(dir / "expect_host.rgba8", host8.data(), host8.size()) &&
                  write_bytes(dir / "expect_cpu.rgba8", want8.data(), want8.size());
  if (!ok) return Error{"cannot write " + dir.string()};
  return true;
}
}  // namespace

Result<int> write_gpu_cases(const std::string& out_dir, const GpuCaseOptions& options,
                            const std::function<void(const std::string&)>& log) {
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) return Error{"cannot create " + out_dir + ": " + ec.message()};
  std::vector<std::string> used;
  int written = 0;
  auto compile = [&](const std::string& path) -> std::optional<Model> {
    ModelOptions mo;
    mo.eager_f64 = false;
    CompileResult c = Model::compile_file(path, mo);
    if (!c.ok()) {
      log("skip " + path + ": does not compile");
      return std::nullopt;
    }
    return std::move(c.model);
  };
  // Eval cases: every corpus model at random points of [-2, 2]^3.
  std::mt19937 rng(2026);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  for (const std::string& path : model_files(options.models_dir)) {
    std::optional<Model> model = compile(path);
    if (!model) continue;
    const int64_t n = options.eval_points;
    std::vector<float> xs(size_t(std::max(model->num_inputs(), 1)) * size_t(n));
    for (float& x : xs) x = u(rng);
    const std::string name = case_name(path, &used);
    auto ok = write_eval_case(fs::path(out_dir) / name, name, *model, xs, n, options.sm);
    if (!ok.ok()) {
      log("skip " + name + ": " + ok.error().message);
      continue;
    }
    log("eval case " + name + " (" + std::to_string(n) + " points)");
    ++written;
  }
  // Prospero's 1024x1024 slice at z = 0 over [-1, 1]^2 (the challenge's image).
  if (!options.prospero.empty()) {
    if (std::optional<Model> model = compile(options.prospero)) {
      const int side = 1024;
      const int64_t n = int64_t(side) * side;
      const std::vector<float> xs =
          gpu::grid_points(side, side, -1, 1, -1, 1, 0, std::max(model->num_inputs(), 1));
      auto ok = write_eval_case(fs::path(out_dir) / "prospero_1024", "prospero_1024", *model, xs, n,
                                options.sm, "1024,1024,-1,1,-1,1,0");
      if (!ok.ok()) return Error{"prospero: " + ok.error().message};
      log("eval case prospero_1024 (1024x1024 points)");
      ++written;
    }
  }
  for (const std::string& path : options.render_models) {
    std::optional<Model> model = compile(path);
    if (!model) continue;
    const std::string name = "render_" + case_name(path, &used);
    auto ok = write_render_case(fs::path(out_dir) / name, name, *model, path, options.render_size,
                                options.sm);
    if (!ok.ok()) return Error{name + ": " + ok.error().message};
    log("render case " + name + " (" + std::to_string(options.render_size) + "x" +
        std::to_string(options.render_size) + ")");
    ++written;
  }
  return written;
}

}  // namespace hfrt::app
