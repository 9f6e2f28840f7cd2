// hfrt::render_model: the public C++ render entry point (hfrt/render.h) over the render job
// that `hfrt render` runs (app/render_job.h).

#include "hfrt/render.h"

#include <cmath>
#include <exception>

#include "app/render_job.h"
#include "app/scene_job.h"
#include "render/image.h"
#include "render/renderer.h"
#include "scene/scene_file.h"

namespace hfrt {
namespace {

render::Vec3 to_vec3(const std::array<double, 3>& v) {
  return {float(v[0]), float(v[1]), float(v[2])};
}

bool finite3(const std::array<double, 3>& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

/// Validates `s` like `hfrt render` validates its options; "" when they are usable.
std::string check_settings(const RenderSettings& s) {
  if (s.width < 1 || s.height < 1 || s.width > 65536 || s.height > 65536) {
    return "width and height must be 1..65536 (got " + std::to_string(s.width) + "x" +
           std::to_string(s.height) + ")";
  }
  const auto& b = s.bbox;
  for (double v : b) {
    if (!std::isfinite(v)) return "bbox must be finite";
  }
  if (!(b[0] < b[3] && b[1] < b[4] && b[2] < b[5])) {
    return "bbox: each min must be below its max";
  }
  if ((s.eye && !finite3(*s.eye)) || (s.look_at && !finite3(*s.look_at)) ||
      (s.up && !finite3(*s.up))) {
    return "eye, look_at and up must be finite";
  }
  if (s.up && (*s.up)[0] == 0 && (*s.up)[1] == 0 && (*s.up)[2] == 0) return "up must be non-zero";
  if (s.fov_deg && !(*s.fov_deg > 0 && *s.fov_deg < 180)) {
    return "fov_deg must be between 0 and 180 degrees";
  }
  if (s.ortho_width && !(*s.ortho_width > 0 && std::isfinite(*s.ortho_width))) {
    return "ortho_width must be positive";
  }
  if (s.spp < 1 || s.spp > 4096) return "spp must be 1..4096";
  if (s.threads < 0) return "threads must be >= 0 (0: all cores)";
  if (!finite3(s.background)) return "background must be finite";
  return "";
}

render::RootMode to_root(RootSearch r) {
  switch (r) {
    case RootSearch::kSign:
      return render::RootMode::kSign;
    case RootSearch::kInterval:
      return render::RootMode::kInterval;
    case RootSearch::kAnalytic:
      return render::RootMode::kAnalytic;
    case RootSearch::kAuto:
      break;
  }
  return render::RootMode::kAuto;
}

/// "" when `rgba` holds a width x height RGBA image (4 floats a pixel), else why not.
std::string check_rgba(int width, int height, const float* rgba, size_t rgba_len) {
  const size_t pixels = size_t(width) * size_t(height);
  if (rgba == nullptr) return "rgba is null";
  if (rgba_len < 4 * pixels) {
    return "rgba has " + std::to_string(rgba_len) + " floats, a " + std::to_string(width) + "x" +
           std::to_string(height) + " image needs " + std::to_string(4 * pixels);
  }
  return "";
}

/// The image's linear RGB and alpha coverage into `rgba`, 4 floats a pixel.
void copy_rgba(const render::Image& img, float* rgba) {
  for (size_t i = 0; i < img.pixels(); ++i) {
    rgba[4 * i] = img.rgb[3 * i];
    rgba[4 * i + 1] = img.rgb[3 * i + 1];
    rgba[4 * i + 2] = img.rgb[3 * i + 2];
    rgba[4 * i + 3] = img.alpha[i];
  }
}

}  // namespace

RenderOutcome render_model(const Model& model, const RenderSettings& settings, float* rgba,
                           size_t rgba_len, const std::string& file) {
  RenderOutcome outcome;
  auto fail = [&](RenderOutcome::Status status, std::string message) {
    outcome.status = status;
    outcome.error = std::move(message);
    return outcome;
  };
  std::string bad = check_settings(settings);
  if (!bad.empty()) return fail(RenderOutcome::Status::kInvalidSettings, bad);
  bad = check_rgba(settings.width, settings.height, rgba, rgba_len);
  if (!bad.empty()) return fail(RenderOutcome::Status::kInvalidSettings, bad);
  try {
    app::RenderJob job;
    job.model = &model;
    job.file = file;
    render::RenderOptions& opt = job.setup.options;
    opt.width = settings.width;
    opt.height = settings.height;
    const auto& b = settings.bbox;
    opt.bbox = {{float(b[0]), float(b[1]), float(b[2])}, {float(b[3]), float(b[4]), float(b[5])}};
    opt.root = to_root(settings.root);
    opt.spp = settings.spp;
    opt.threads = settings.threads;
    opt.shadows = settings.shadows;
    opt.background = to_vec3(settings.background);
    render::CameraRequest& cam = job.setup.camera;
    if (settings.eye) cam.eye = to_vec3(*settings.eye);
    if (settings.look_at) cam.look_at = to_vec3(*settings.look_at);
    if (settings.up) cam.up = to_vec3(*settings.up);
    if (settings.fov_deg) cam.fov_deg = float(*settings.fov_deg);
    if (settings.ortho_width) cam.ortho_width = float(*settings.ortho_width);

    render::RenderResult result;
    app::RenderJobResult done = app::run_render_job(job, &result);
    outcome.warnings = done.warnings;
    switch (done.status) {
      case app::RenderJobStatus::kOk:
        break;
      case app::RenderJobStatus::kSourceError:
        return fail(RenderOutcome::Status::kSourceError, done.error);
      case app::RenderJobStatus::kUsageError:
      case app::RenderJobStatus::kCancelled:
        return fail(RenderOutcome::Status::kRenderError, done.error);
    }
    copy_rgba(result.image, rgba);
  } catch (const std::exception& e) {
    return fail(RenderOutcome::Status::kRenderError, std::string("render failed: ") + e.what());
  }
  return outcome;
}

RenderOutcome render_scene_file(const std::string& path, int width, int height, float* rgba,
                                size_t rgba_len, int threads) {
  RenderOutcome outcome;
  auto fail = [&](RenderOutcome::Status status, std::string message) {
    outcome.status = status;
    outcome.error = std::move(message);
    return outcome;
  };
  if (width < 1 || height < 1 || width > 32768 || height > 32768) {
    return fail(RenderOutcome::Status::kInvalidSettings, "width and height must be 1..32768");
  }
  if (threads < 0) return fail(RenderOutcome::Status::kInvalidSettings, "threads is negative");
  std::string bad = check_rgba(width, height, rgba, rgba_len);
  if (!bad.empty()) return fail(RenderOutcome::Status::kInvalidSettings, bad);
  try {
    scene::SceneDesc desc;
    scene::SceneError err;
    if (!scene::read_scene_file(path, &desc, &err)) {
      return fail(RenderOutcome::Status::kSourceError, err.render());
    }
    app::SceneOverrides ov;
    ov.size = std::array<int, 2>{width, height};
    ov.threads = threads;
    render::TraceResult result;
    app::SceneJobResult done = app::run_scene_job(desc, ov, nullptr, nullptr, &result);
    outcome.warnings = done.warnings;
    switch (done.status) {
      case app::SceneJobStatus::kOk:
        break;
      case app::SceneJobStatus::kSourceError:
        return fail(RenderOutcome::Status::kSourceError, done.error);
      case app::SceneJobStatus::kEnvironment:
      case app::SceneJobStatus::kUsageError:
      case app::SceneJobStatus::kCancelled:
        return fail(RenderOutcome::Status::kRenderError, done.error);
    }
    copy_rgba(result.image, rgba);
  } catch (const std::exception& e) {
    return fail(RenderOutcome::Status::kRenderError, std::string("render failed: ") + e.what());
  }
  return outcome;
}

std::string write_rgba_image(const std::string& path, int width, int height, const float* rgba) {
  if (width < 1 || height < 1 || rgba == nullptr) return "write_rgba_image: empty image";
  try {
    render::Image img;
    img.resize(width, height);
    const size_t pixels = img.pixels();
    for (size_t i = 0; i < pixels; ++i) {
      for (int c = 0; c < 3; ++c) img.rgb[3 * i + c] = rgba[4 * i + c];
      img.alpha[i] = rgba[4 * i + 3];
    }
    auto written = render::write_image(img, path);
    if (!written.ok()) return written.error().message;
  } catch (const std::exception& e) {
    return std::string("cannot write '") + path + "': " + e.what();
  }
  return "";
}

}  // namespace hfrt
