#pragma once
// hfrt's public C++ render entry point, beside hfrt/model.h: ray trace a compiled Model into
// a caller's RGBA float buffer, as `hfrt render` does (the same render job, app/render_job.h),
// and write such a buffer to an image file.
//
//   hfrt::RenderSettings settings;
//   settings.width = settings.height = 256;
//   std::vector<float> rgba(4 * 256 * 256);
//   hfrt::RenderOutcome r = hfrt::render_model(model, settings, rgba.data(), rgba.size());
//   if (!r.ok()) std::cerr << r.error;
//
// Self-contained like hfrt/model.h: the standard library only.

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "hfrt/model.h"

namespace hfrt {

/// How a ray finds the surface (`hfrt render --root`).
enum class RootSearch { kAuto, kSign, kInterval, kAnalytic };

/// What to render. Camera fields left empty are found as `hfrt render` finds them: the
/// solid's extent inside `bbox` is searched and framed from a three-quarter view.
struct RenderSettings {
  int width = 512, height = 512;
  std::optional<std::array<double, 3>> eye, look_at, up;
  std::optional<double> fov_deg;      ///< vertical field of view (default 35)
  std::optional<double> ortho_width;  ///< set: orthographic with this view width
  std::array<double, 6> bbox{-10, -10, -10, 10, 10, 10};  ///< xmin, ymin, zmin, xmax, ymax, zmax
  RootSearch root = RootSearch::kAuto;
  int spp = 1;      ///< samples per pixel, 1..4096
  int threads = 0;  ///< 0: all cores
  bool shadows = true;
  std::array<double, 3> background{0.18, 0.2, 0.24};
};

/// How a render ended.
struct RenderOutcome {
  enum class Status {
    kOk,
    kInvalidSettings,  ///< a size, box, camera or count out of range (`error` says which)
    kSourceError,      ///< kAnalytic on a model that does not qualify (`error`: located text)
    kRenderError,      ///< a degenerate camera (eye = look-at, up parallel to the view)
  };
  Status status = Status::kOk;
  std::string error;
  std::vector<std::string> warnings;  ///< JIT failures (the interpreters took over)
  bool ok() const { return status == Status::kOk; }
};

/// Renders `model` into `rgba` (width * height pixels row-major from the top-left, 4 floats
/// each: linear RGB and the fraction of the pixel's samples that hit the solid);
/// `rgba_len` >= 4 * width * height. `file` names the model in messages. Thread-safe for
/// concurrent renders of one model (the model must not be changed meanwhile); never throws.
RenderOutcome render_model(const Model& model, const RenderSettings& settings, float* rgba,
                           size_t rgba_len, const std::string& file = "<model>");

/// Traces a scene file (docs/scenes.md: several placed models with materials and lights,
/// reflection, refraction, soft shadows, depth of field) into `rgba` as render_model does, with
/// the scene's own settings except the image size (width x height, which the caller allocated)
/// and `threads` (0: all cores). A bad scene file or a model that does not compile is
/// kSourceError with the located message; never throws.
RenderOutcome render_scene_file(const std::string& path, int width, int height, float* rgba,
                                size_t rgba_len, int threads = 0);

/// Writes an RGBA buffer as render_model fills it to `path`; the format follows the extension
/// (PNG, EXR, TIFF, JPEG; 8- and 16-bit formats get sRGB-encoded colour, EXR keeps linear
/// floats and alpha). Returns "" on success, else the message.
std::string write_rgba_image(const std::string& path, int width, int height, const float* rgba);

}  // namespace hfrt
