#include "render/image.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "base/check.h"
#include "base/module.h"
#include "base/parallel.h"
#include "render/image_io_module.h"
#include "render/png_writer.h"

namespace hfrt::render {

namespace {

std::string lower_extension(const std::string& path) {
  size_t dot = path.find_last_of('.');
  size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

std::string sibling(const std::string& path, const std::string& what) {
  size_t dot = path.find_last_of('.');
  size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash))
    return path + "." + what;
  return path.substr(0, dot) + "." + what + path.substr(dot);
}

/// 8-bit encoding of linear values without a pow per sample: thresholds[k] is the linear value
/// at which the rounded code (round(255 * srgb(v))) steps from k to k + 1, so the code of v is
/// the number of thresholds <= v. Gives the same codes as encoding then rounding (up to ties
/// within one float ulp of a threshold) and makes writing a 512x512 PNG about 3x faster.
class Srgb8Encoder {
 public:
  Srgb8Encoder() {
    for (int k = 0; k < 255; ++k) {
      double e = (k + 0.5) / 255.0;  // the encoded value halfway between codes k and k + 1
      double lin = e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4);
      thresholds_[k] = float(lin);
    }
    for (int b = 0; b < kBuckets; ++b) {
      const float start = float(b) / float(kBuckets);
      first_[b] = uint8_t(std::upper_bound(thresholds_, thresholds_ + 255, start) - thresholds_);
    }
  }
  /// The number of thresholds <= v (std::upper_bound's answer, which a binary search per value
  /// made 10 ns: most of the time of writing a PNG): v's bucket of [0, 1) says how many lie
  /// below it, and consecutive thresholds are further apart than a bucket (at least
  /// 1 / (12.92 * 255) > 1 / 4096), so at most one more lies inside it.
  uint8_t encode(float v) const {
    if (!(v > 0)) return 0;  // also NaN
    if (!(v < 1)) return 255;
    int k = first_[int(v * float(kBuckets))];  // exact: a power-of-two scale
    while (k < 255 && thresholds_[k] <= v) ++k;
    return uint8_t(k);
  }

 private:
  static constexpr int kBuckets = 4096;
  float thresholds_[255];
  uint8_t first_[kBuckets];
};

uint8_t linear_to_unorm8(float v) {
  if (!std::isfinite(v)) return 0;
  return uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

/// 8-bit codes of `data`: sRGB-encoded colour (channels 1-3 of RGBA) when `encode_srgb`, else
/// round(255 * v); clamped to [0, 1], NaN -> 0.
std::vector<uint8_t> encode8(const std::vector<float>& data, int channels, bool encode_srgb) {
  static const Srgb8Encoder srgb8;
  std::vector<uint8_t> bytes(data.size());
  // In chunks on all cores (a 512x512 RGB picture, the REPL's after each edit, took ~1.1 ms
  // on one); a chunk is a whole number of pixels.
  const size_t grain = size_t(channels) * 16384;
  par::parallel_for(data.size(), grain, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      bool colour = encode_srgb && (channels < 4 || int(i % channels) < 3);
      bytes[i] = colour ? srgb8.encode(data[i]) : linear_to_unorm8(data[i]);
    }
  });
  return bytes;
}

/// PNG without the image I/O module (render/png_writer.h): 8-bit, the sRGB chunks when
/// `encode_srgb`. kSmall: zlib level 3 with adaptive row filters (a fifth of the time of level
/// 6 for a few percent more bytes); kFast: level 1 without row filters.
Result<std::vector<std::string>> write_png_file(const std::string& path, int width, int height,
                                                int channels, const std::vector<float>& data,
                                                bool encode_srgb, PngCompression png) {
  if (channels < 1 || channels > 4) {
    return Error{"cannot write '" + path + "': a PNG holds 1 to 4 channels, not " +
                 std::to_string(channels)};
  }
  if (width < 1 || height < 1) return Error{"cannot write '" + path + "': an empty image"};
  HFRT_CHECK(data.size() == size_t(width) * size_t(height) * size_t(channels));
  const std::vector<uint8_t> bytes = encode8(data, channels, encode_srgb);
  PngImage image;
  image.width = width;
  image.height = height;
  image.channels = channels;
  image.bit_depth = 8;
  image.samples = bytes.data();
  image.srgb = encode_srgb;
  PngOptions options;
  options.zlib_level = png == PngCompression::kFast ? 1 : 3;
  options.filter_rows = png == PngCompression::kSmall;
  auto written = write_png(path, image, options);
  if (!written.ok()) return written.error();
  return std::vector<std::string>{path};
}

/// The image I/O module's table (loaded on first use), or why it cannot be loaded.
Result<const image_io::Module*> image_io_module() {
  return module_table<image_io::Module>("imageio", image_io::kEntrySymbol, image_io::kAbiVersion);
}

/// "cannot write 'x.png': " + why, keeping the loader's hint.
Error io_error(const char* verb, const std::string& path, const Error& why) {
  return Error{std::string("cannot ") + verb + " '" + path + "': " + why.message, why.hint};
}

}  // namespace

void Image::resize(int w, int h) {
  width = w;
  height = h;
  size_t n = size_t(w) * size_t(h);
  rgb.assign(3 * n, 0.0f);
  alpha.assign(n, 0.0f);
  depth.assign(n, std::numeric_limits<float>::infinity());
  normal.assign(3 * n, 0.0f);
}

Result<std::vector<std::string>> write_pixels(const std::string& path, int width, int height,
                                              int channels, const std::vector<float>& data,
                                              bool encode_srgb,
                                              const std::vector<std::string>& channel_names,
                                              PngCompression png) {
  std::string ext = lower_extension(path);
  if (ext == "png") return write_png_file(path, width, height, channels, data, encode_srgb, png);
  auto module = image_io_module();
  if (!module.ok()) return io_error("write", path, module.error());
  bool is_float = ext == "exr" || ext == "hdr";
  bool is_16 = ext == "tif" || ext == "tiff";
  image_io::WriteRequest request;
  request.path = path;
  request.width = width;
  request.height = height;
  request.channels = channels;
  request.type = is_float ? image_io::PixelType::kFloat
                          : (is_16 ? image_io::PixelType::kUint16 : image_io::PixelType::kUint8);
  request.channel_names = channel_names;
  auto text = [&](const char* name, const char* value) {
    request.attributes.push_back({name, true, value, 0});
  };
  if (is_float) {
    text("oiio:ColorSpace", "Linear");
  } else if (encode_srgb) {
    text("oiio:ColorSpace", "sRGB");
  }
  if (ext == "jpg" || ext == "jpeg") text("Compression", "jpeg:95");
  std::vector<uint8_t> bytes;
  std::vector<float> floats;
  if (request.type == image_io::PixelType::kUint8) {
    bytes = encode8(data, channels, encode_srgb);
    request.pixels = bytes.data();
  } else {
    floats.resize(data.size());
    for (size_t i = 0; i < data.size(); ++i) {
      float v = data[i];
      if (!is_float) {
        // 16 bits: sRGB-encode colour; clamp everything (OIIO maps [0, 1] to the range).
        if (encode_srgb && (channels < 4 || int(i % channels) < 3)) v = linear_to_srgb(v);
        v = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
      }
      floats[i] = v;
    }
    request.pixels = floats.data();
  }
  std::string err;
  switch ((*module)->write(request, &err)) {
    case image_io::WriteStatus::kOk:
      break;
    case image_io::WriteStatus::kNoFormat:
      return Error{"cannot write '" + path + "': no image format for the extension '." + ext +
                   "' (use .png, .exr, .tif or .jpg)"};
    case image_io::WriteStatus::kError:
      return Error{"cannot write '" + path + "': " + err};
  }
  return std::vector<std::string>{path};
}

Result<std::vector<std::string>> write_image(const Image& image, const std::string& path,
                                             const AovSet& aovs, PngCompression png) {
  std::string ext = lower_extension(path);
  size_t n = image.pixels();
  if (ext == "exr") {
    // One file: colour, alpha and the AOVs as extra channels.
    std::vector<std::string> names{"R", "G", "B", "A"};
    if (aovs.depth) names.push_back("Z");
    if (aovs.normal) names.insert(names.end(), {"N.X", "N.Y", "N.Z"});
    int c = int(names.size());
    std::vector<float> data(n * c);
    for (size_t i = 0; i < n; ++i) {
      float* p = &data[i * c];
      int k = 0;
      p[k++] = image.rgb[3 * i];
      p[k++] = image.rgb[3 * i + 1];
      p[k++] = image.rgb[3 * i + 2];
      p[k++] = image.alpha[i];
      if (aovs.depth) p[k++] = image.depth[i];
      if (aovs.normal) {
        for (int j = 0; j < 3; ++j) p[k++] = image.normal[3 * i + j];
      }
    }
    return write_pixels(path, image.width, image.height, c, data, false, names);
  }
  auto written = write_pixels(path, image.width, image.height, 3, image.rgb, true, {}, png);
  if (!written.ok()) return written;
  std::vector<std::string> paths = written.value();
  if (aovs.depth) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (float d : image.depth) {
      if (std::isfinite(d)) lo = std::min(lo, d), hi = std::max(hi, d);
    }
    std::vector<float> data(n, 0.0f);
    for (size_t i = 0; i < n; ++i) {
      float d = image.depth[i];
      if (std::isfinite(d)) data[i] = hi > lo ? 1.0f - 0.9f * (d - lo) / (hi - lo) : 1.0f;
    }
    auto w =
        write_pixels(sibling(path, "depth"), image.width, image.height, 1, data, false, {}, png);
    if (!w.ok()) return w;
    paths.push_back(w.value()[0]);
  }
  if (aovs.normal) {
    std::vector<float> data(3 * n);
    for (size_t i = 0; i < 3 * n; ++i) {
      data[i] = image.alpha[i / 3] > 0 ? 0.5f + 0.5f * image.normal[i] : 0.0f;
    }
    auto w =
        write_pixels(sibling(path, "normal"), image.width, image.height, 3, data, false, {}, png);
    if (!w.ok()) return w;
    paths.push_back(w.value()[0]);
  }
  return paths;
}

Result<std::vector<float>> read_image(const std::string& path, int* width, int* height,
                                      int* channels) {
  auto module = image_io_module();
  if (!module.ok()) return io_error("read", path, module.error());
  image_io::ReadResult read;
  std::string err;
  if (!(*module)->read(path, &read, &err)) return Error{"cannot read '" + path + "': " + err};
  *width = read.width;
  *height = read.height;
  *channels = read.channels;
  return std::move(read.data);
}

}  // namespace hfrt::render
