#include "render/png_writer.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

#include "base/check.h"

namespace hfrt::render {

namespace {

void put32(std::vector<uint8_t>& out, uint32_t v) {
  out.push_back(uint8_t(v >> 24));
  out.push_back(uint8_t(v >> 16));
  out.push_back(uint8_t(v >> 8));
  out.push_back(uint8_t(v));
}

/// Appends a chunk: length, type, data, CRC of type and data.
void put_chunk(std::vector<uint8_t>& out, const char type[4], const uint8_t* data, size_t size) {
  put32(out, uint32_t(size));
  const size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  if (size) out.insert(out.end(), data, data + size);
  put32(out, uint32_t(crc32(0, out.data() + start, uInt(out.size() - start))));
}

void put_chunk(std::vector<uint8_t>& out, const char type[4], const std::vector<uint8_t>& data) {
  put_chunk(out, type, data.data(), data.size());
}

std::vector<uint8_t> be32s(std::initializer_list<uint32_t> values) {
  std::vector<uint8_t> out;
  for (uint32_t v : values) put32(out, v);
  return out;
}

/// The Paeth predictor, without branches (the filter loop vectorises).
int paeth(int a, int b, int c) {
  const int pa = std::abs(b - c), pb = std::abs(a - c), pc = std::abs(a + b - 2 * c);
  const int bc = pb <= pc ? b : c;
  return pa <= pb && pa <= pc ? a : bc;
}

/// The byte that filter `Type` (0 None, 1 Sub, 2 Up, 3 Average, 4 Paeth) stores for `x` with
/// left neighbour `a`, upper `b` and upper-left `c`.
template <int Type>
uint8_t filtered_byte(int x, int a, int b, int c) {
  if constexpr (Type == 0) return uint8_t(x);
  if constexpr (Type == 1) return uint8_t(x - a);
  if constexpr (Type == 2) return uint8_t(x - b);
  if constexpr (Type == 3) return uint8_t(x - ((a + b) >> 1));
  if constexpr (Type == 4) return uint8_t(x - paeth(a, b, c));
}

/// Filters `row` (with `prev`, the previous raw row, zeros for the first) into out[0] (the
/// filter type) and out[1..n]; returns the sum of |signed byte| of the filtered bytes (the
/// minimum-sum heuristic's cost). The first pixel (no left neighbour) is split off so that the
/// main loop has no branch and vectorises.
template <int Type>
uint64_t filter_row(const uint8_t* __restrict row, const uint8_t* __restrict prev, size_t n,
                    size_t bpp, uint8_t* __restrict out) {
  out[0] = uint8_t(Type);
  uint8_t* __restrict f = out + 1;
  const size_t head = std::min(bpp, n);
  for (size_t i = 0; i < head; ++i) f[i] = filtered_byte<Type>(row[i], 0, prev[i], 0);
  for (size_t i = head; i < n; ++i) {
    f[i] = filtered_byte<Type>(row[i], row[i - bpp], prev[i], prev[i - bpp]);
  }
  uint64_t cost = 0;
  for (size_t i = 0; i < n; ++i) cost += uint64_t(std::abs(int(int8_t(f[i]))));
  return cost;
}

uint64_t filter_row(int type, const uint8_t* row, const uint8_t* prev, size_t n, size_t bpp,
                    uint8_t* out) {
  switch (type) {
    case 1:
      return filter_row<1>(row, prev, n, bpp, out);
    case 2:
      return filter_row<2>(row, prev, n, bpp, out);
    case 3:
      return filter_row<3>(row, prev, n, bpp, out);
    case 4:
      return filter_row<4>(row, prev, n, bpp, out);
    default:
      return filter_row<0>(row, prev, n, bpp, out);
  }
}

}  // namespace

std::vector<uint8_t> encode_png(const PngImage& image, const PngOptions& options) {
  HFRT_CHECK(image.width > 0 && image.height > 0);
  HFRT_CHECK(image.channels >= 1 && image.channels <= 4);
  HFRT_CHECK(image.bit_depth == 8 || image.bit_depth == 16);
  const size_t bpp = size_t(image.channels) * size_t(image.bit_depth / 8);
  const size_t row_bytes = bpp * size_t(image.width);
  const size_t samples_per_row = size_t(image.width) * size_t(image.channels);

  // One zlib stream with libpng's window and memory settings, and its Z_FILTERED strategy for
  // filtered rows, of the filtered rows (each the filter type byte and row_bytes bytes).
  z_stream z{};
  HFRT_CHECK(deflateInit2(&z, options.zlib_level, Z_DEFLATED, 15, 8,
                          options.filter_rows ? Z_FILTERED : Z_DEFAULT_STRATEGY) == Z_OK);
  const size_t raw_size = size_t(image.height) * (row_bytes + 1);
  std::vector<uint8_t> idat(deflateBound(&z, uLong(raw_size)));
  z.next_out = idat.data();
  z.avail_out = uInt(idat.size());

  const std::vector<uint8_t> zeros(row_bytes, 0);  // the row above the first
  std::vector<uint8_t> wide[2];                    // 16 bits: big-endian copies of two rows
  if (image.bit_depth == 16) wide[0].resize(row_bytes), wide[1].resize(row_bytes);
  std::vector<uint8_t> best(row_bytes + 1), trial(row_bytes + 1);
  constexpr size_t kBatch = size_t(1) << 16;
  std::vector<uint8_t> staged;
  staged.reserve(kBatch + row_bytes + 1);
  const uint8_t* prev = zeros.data();
  for (int y = 0; y < image.height; ++y) {
    const uint8_t* row;
    if (image.bit_depth == 8) {
      row = static_cast<const uint8_t*>(image.samples) + size_t(y) * samples_per_row;
    } else {
      const auto* src = static_cast<const uint16_t*>(image.samples) + size_t(y) * samples_per_row;
      uint8_t* dst = wide[y % 2].data();
      for (size_t i = 0; i < samples_per_row; ++i) {  // PNG's samples are big-endian
        dst[2 * i] = uint8_t(src[i] >> 8);
        dst[2 * i + 1] = uint8_t(src[i]);
      }
      row = dst;
    }
    if (!options.filter_rows) {
      best[0] = 0;
      std::memcpy(best.data() + 1, row, row_bytes);
    } else {
      uint64_t best_cost = filter_row(0, row, prev, row_bytes, bpp, best.data());
      for (int type = 1; type <= 4; ++type) {
        const uint64_t cost = filter_row(type, row, prev, row_bytes, bpp, trial.data());
        if (cost < best_cost) best_cost = cost, best.swap(trial);
      }
    }
    prev = row;
    // Rows go to zlib in batches of >= 64 KiB rather than one deflate call each.
    staged.insert(staged.end(), best.begin(), best.end());
    const bool last = y + 1 == image.height;
    if (staged.size() < kBatch && !last) continue;
    z.next_in = staged.data();
    z.avail_in = uInt(staged.size());
    for (;;) {  // deflateBound is enough in practice; grow the buffer if it is not
      const int status = deflate(&z, last ? Z_FINISH : Z_NO_FLUSH);
      HFRT_CHECK(status == Z_OK || status == Z_STREAM_END || status == Z_BUF_ERROR);
      if (last ? status == Z_STREAM_END : z.avail_in == 0) break;
      if (z.avail_out == 0) {
        const size_t used = z.total_out;
        idat.resize(2 * idat.size());
        z.next_out = idat.data() + used;
        z.avail_out = uInt(idat.size() - used);
      }
    }
    staged.clear();
  }
  idat.resize(z.total_out);
  deflateEnd(&z);

  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  png.reserve(idat.size() + 128);
  static constexpr uint8_t kColourType[5] = {0, 0, 4, 2, 6};  // grey, grey+alpha, RGB, RGBA
  std::vector<uint8_t> ihdr = be32s({uint32_t(image.width), uint32_t(image.height)});
  ihdr.insert(ihdr.end(), {uint8_t(image.bit_depth), kColourType[image.channels], 0, 0, 0});
  put_chunk(png, "IHDR", ihdr);
  if (image.srgb) {
    // The chunks OpenImageIO wrote for an sRGB image: gamma 1/2.2, the sRGB chunk with
    // rendering intent 3 (absolute colorimetric), the BT.709 primaries and D65 white. (Not its
    // oFFs chunk of a zero offset, nor its tEXt "oiio:ColorSpace", which its reader infers from
    // the sRGB chunk.)
    put_chunk(png, "gAMA", be32s({45455}));
    const uint8_t intent = 3;
    put_chunk(png, "sRGB", &intent, 1);
    put_chunk(png, "cHRM", be32s({31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000}));
  }
  constexpr size_t kMaxChunk = size_t(1) << 30;  // a chunk's length is below 2^31
  for (size_t at = 0; at < idat.size(); at += kMaxChunk) {
    put_chunk(png, "IDAT", idat.data() + at, std::min(kMaxChunk, idat.size() - at));
  }
  put_chunk(png, "IEND", nullptr, 0);
  return png;
}

Result<bool> write_png(const std::string& path, const PngImage& image, const PngOptions& options) {
  const std::vector<uint8_t> png = encode_png(image, options);
  auto fail = [&](int err) { return Error{"cannot write '" + path + "': " + std::strerror(err)}; };
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) return fail(errno);
  if (std::fwrite(png.data(), 1, png.size(), file.get()) != png.size()) return fail(errno);
  FILE* f = file.release();
  if (std::fclose(f) != 0) return fail(errno);
  return true;
}

}  // namespace hfrt::render
