#pragma once
// The interface between render/image.cpp and the image I/O module (libhfrt_imageio.so,
// render/image_io_oiio.cpp), which alone links OpenImageIO. The module is loaded when an image is
// first read, or written in a format other than PNG (render/png_writer.h writes PNGs on zlib),
// by base/module.h: OpenImageIO's ~250 shared libraries cost ~0.3 s of CPU at load, which a
// process that never touches such a file must not pay.
//
// Both sides are built from one tree by one compiler, so the entry table passes C++ types; the
// ABI number guards against a module left over from another build.

#include <string>
#include <vector>

namespace hfrt::render::image_io {

inline constexpr int kAbiVersion = 1;
/// The entry point the module exports (extern "C", returns `const Module*`).
inline constexpr const char* kEntrySymbol = "hfrt_image_io_module";

enum class PixelType : int { kUint8, kUint16, kFloat };

/// A format attribute of the written file (OpenImageIO's ImageSpec::attribute).
struct Attribute {
  std::string name;
  bool is_text = true;
  std::string text;
  int number = 0;
};

struct WriteRequest {
  std::string path;
  int width = 0, height = 0, channels = 0;
  PixelType type = PixelType::kUint8;  ///< the file's sample type
  /// width * height * channels samples, interleaved, row-major from the top-left: uint8_t for
  /// kUint8, else float (in [0, 1] for kUint16, which the module maps to the integer range).
  const void* pixels = nullptr;
  std::vector<std::string> channel_names;  ///< empty: the format's defaults
  std::vector<Attribute> attributes;
};

enum class WriteStatus : int { kOk, kNoFormat, kError };

struct ReadResult {
  int width = 0, height = 0, channels = 0;
  std::vector<float> data;  ///< interleaved float, as OpenImageIO converts it
};

/// The module's table. Each function is thread-safe and never throws.
struct Module {
  int abi_version;
  /// Writes one image; on kError `*error` says why (the library's text).
  WriteStatus (*write)(const WriteRequest& request, std::string* error);
  /// Reads the first subimage as float; false with `*error` on failure.
  bool (*read)(const std::string& path, ReadResult* out, std::string* error);
};

}  // namespace hfrt::render::image_io
