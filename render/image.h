#pragma once
// The rendered image (linear RGB plus per-pixel AOVs) and writing it: PNG with hfrt's own encoder
// (render/png_writer.h), other formats through OpenImageIO in the image I/O module.

#include <string>
#include <vector>

#include "base/color.h"
#include "base/result.h"
#include "render/vec.h"

namespace hfrt::render {

/// A rendered image, row-major from the top-left pixel. Colours are linear (not sRGB-encoded).
struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;     ///< 3 floats per pixel
  std::vector<float> alpha;   ///< fraction of the pixel's samples that hit the solid
  std::vector<float> depth;   ///< mean distance from the ray origin to the hit; +inf: no hit
  std::vector<float> normal;  ///< 3 floats per pixel: mean outward unit normal; 0 where no hit

  void resize(int w, int h);
  size_t pixels() const { return size_t(width) * size_t(height); }
};

/// Which extra images (AOVs) to write besides the colour.
struct AovSet {
  bool depth = false;
  bool normal = false;
};

/// How hard PNG writing compresses (render/png_writer.h). kSmall: zlib level 3 with adaptive
/// row filters, as libpng's (hfrt render). kFast: level 1 without row filters, for files about
/// a quarter larger: the REPL's edit-to-image latency.
enum class PngCompression { kSmall, kFast };

/// Writes `image` to `path`; the format follows the extension (.png, .exr, .tif/.tiff, .jpg/.jpeg,
/// anything else OpenImageIO knows). PNG (any case of the extension) is written by
/// render/png_writer.h without loading the image I/O module; the rest through that module. EXR
/// keeps linear float (and gets the AOVs as extra channels Z and N.X/N.Y/N.Z in the same file); 8-
/// and 16-bit formats are sRGB-encoded, and their AOVs go to sibling files `<stem>.depth.<ext>`
/// (depth normalised to the hit range, near = white) and `<stem>.normal.<ext>` (0.5 + 0.5 n).
/// Returns the paths written.
Result<std::vector<std::string>> write_image(const Image& image, const std::string& path,
                                             const AovSet& aovs = {},
                                             PngCompression png = PngCompression::kSmall);

/// Writes `channels` floats per pixel (row-major from the top-left). `encode_srgb` converts
/// linear values to sRGB for integer formats; EXR always stores the values as they are. A
/// 4-channel PNG stores the alpha straight, colour as given (OpenImageIO, which wrote PNGs
/// before render/png_writer.h, divided colour by alpha: it took the input as premultiplied).
Result<std::vector<std::string>> write_pixels(const std::string& path, int width, int height,
                                              int channels, const std::vector<float>& data,
                                              bool encode_srgb,
                                              const std::vector<std::string>& channel_names = {},
                                              PngCompression png = PngCompression::kSmall);

/// Reads an image as floats (used by tests and golden-image comparisons). Values of integer
/// formats come back in [0, 1] as stored (still sRGB-encoded).
Result<std::vector<float>> read_image(const std::string& path, int* width, int* height,
                                      int* channels);

/// Linear -> sRGB transfer function (base/color.h).
using ::hfrt::linear_to_srgb;

}  // namespace hfrt::render
