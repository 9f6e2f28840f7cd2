// The image I/O module (libhfrt_imageio.so): the only code of hfrt that sees OpenImageIO.
// render/image_io_module.h says why it is a module and what the table means.

#include <OpenImageIO/imageio.h>

#include "render/image_io_module.h"

namespace hfrt::render::image_io {
namespace {

OIIO::TypeDesc type_desc(PixelType type) {
  switch (type) {
    case PixelType::kUint8:
      return OIIO::TypeDesc::UINT8;
    case PixelType::kUint16:
      return OIIO::TypeDesc::UINT16;
    case PixelType::kFloat:
      return OIIO::TypeDesc::FLOAT;
  }
  return OIIO::TypeDesc::UNKNOWN;
}

WriteStatus write(const WriteRequest& r, std::string* error) {
  auto out = OIIO::ImageOutput::create(r.path);
  if (!out) return WriteStatus::kNoFormat;
  // The file's type is the buffer's except that 16-bit files are written from float
  // (OpenImageIO maps [0, 1] to the integer range).
  const OIIO::TypeDesc file_type = type_desc(r.type);
  OIIO::ImageSpec spec(r.width, r.height, r.channels, file_type);
  if (!r.channel_names.empty()) spec.channelnames = r.channel_names;
  for (const Attribute& a : r.attributes) {
    if (a.is_text) {
      spec.attribute(a.name, a.text);
    } else {
      spec.attribute(a.name, a.number);
    }
  }
  if (!out->open(r.path, spec)) {
    *error = out->geterror();
    return WriteStatus::kError;
  }
  const OIIO::TypeDesc buffer_type =
      r.type == PixelType::kUint8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT;
  bool ok = out->write_image(buffer_type, r.pixels);
  if (!ok) *error = out->geterror();
  if (!out->close() && ok) {
    ok = false;
    *error = out->geterror();
  }
  return ok ? WriteStatus::kOk : WriteStatus::kError;
}

bool read(const std::string& path, ReadResult* result, std::string* error) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    *error = OIIO::geterror();
    return false;
  }
  const OIIO::ImageSpec& spec = in->spec();
  result->data.resize(size_t(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, result->data.data())) {
    *error = in->geterror();
    return false;
  }
  result->width = spec.width;
  result->height = spec.height;
  result->channels = spec.nchannels;
  in->close();
  return true;
}

const Module kModule{kAbiVersion, &write, &read};

}  // namespace
}  // namespace hfrt::render::image_io

extern "C" __attribute__((visibility("default"))) const hfrt::render::image_io::Module*
hfrt_image_io_module() {
  return &hfrt::render::image_io::kModule;
}
