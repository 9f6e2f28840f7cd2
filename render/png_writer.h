#pragma once
// A PNG encoder on zlib alone: hfrt writes its PNGs (renders, AOV previews, slices) without
// loading the image I/O module, whose OpenImageIO tree costs ~0.3-0.5 s of CPU in the dynamic
// loader at every process start that writes an image (render/image_io_module.h). Everything
// else (EXR, TIFF, JPEG, reading) still goes through that module.

#include <cstdint>
#include <string>
#include <vector>

#include "base/result.h"

namespace hfrt::render {

/// An image to encode: width * height * channels samples, interleaved, row-major from the top
/// left, as uint8_t (bit_depth 8) or uint16_t in host order (bit_depth 16). Channels 1: grey,
/// 2: grey + alpha, 3: RGB, 4: RGBA (alpha straight, not premultiplied: PNG's convention).
struct PngImage {
  int width = 0, height = 0, channels = 0;
  int bit_depth = 8;  ///< 8 or 16
  const void* samples = nullptr;
  /// The samples are sRGB-encoded: writes the gAMA (1/2.2), sRGB and cHRM chunks that
  /// OpenImageIO wrote for an sRGB image, so viewers apply no further transfer. Otherwise no
  /// colour chunk (the values are data: depth, normals, slices).
  bool srgb = false;
};

/// How hard to compress (render/image.h's PngCompression picks one).
struct PngOptions {
  int zlib_level = 3;  ///< 0-9
  /// Per row, the filter (None, Sub, Up, Average, Paeth) whose output has the smallest sum of
  /// absolute signed bytes, as libpng's adaptive filtering; false: filter None on every row.
  bool filter_rows = true;
};

/// The PNG file's bytes. `image` must be valid (1-4 channels, depth 8 or 16, positive size).
std::vector<uint8_t> encode_png(const PngImage& image, const PngOptions& options = {});

/// Encodes `image` and writes it to `path`. An unwritable path is an Error "cannot write
/// 'PATH': " + the system's reason.
Result<bool> write_png(const std::string& path, const PngImage& image,
                       const PngOptions& options = {});

}  // namespace hfrt::render
