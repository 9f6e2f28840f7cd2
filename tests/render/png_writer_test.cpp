// The PNG writer (render/png_writer.h): every channel count and both bit depths read back
// exactly through the image I/O module (OpenImageIO's libpng reader) and through a decoder
// here, the colour chunks, and the errors of an unwritable path. (tests/tools/startup_cli_test.cpp
// checks that writing a PNG loads no OpenImageIO.)
#include "render/png_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "render/image.h"

namespace hfrt::render {
namespace {

/// A file name of this process only: CTest runs the tests of this file as separate processes
/// in parallel, and a name they shared made two of them read each other's files.
std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("hfrt_png_writer_test_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

/// Random samples with the edge values 0 and max in the first row and a smooth ramp in the
/// last (which the row filters compress differently from noise).
template <typename T>
std::vector<T> test_samples(int w, int h, int c, unsigned seed) {
  std::mt19937 rng(seed);
  const uint32_t max = (1u << (8 * sizeof(T))) - 1;
  std::vector<T> s(size_t(w) * h * c);
  for (auto& v : s) v = T(rng() & max);
  for (int i = 0; i < w * c; ++i) s[i] = (i / c) % 2 ? T(max) : T(0);
  for (int i = 0; i < w * c; ++i) s[size_t(h - 1) * w * c + i] = T(uint64_t(i) * max / (w * c));
  return s;
}

/// Reads `path` with read_image and returns the samples as integer codes.
std::vector<uint32_t> read_codes(const std::string& path, int bit_depth, int* w, int* h, int* c) {
  auto data = read_image(path, w, h, c);
  EXPECT_TRUE(data.ok()) << data.error().message;
  if (!data.ok()) return {};
  const float max = bit_depth == 8 ? 255.0f : 65535.0f;
  std::vector<uint32_t> codes;
  for (float v : data.value()) codes.push_back(uint32_t(std::lround(v * max)));
  return codes;
}

template <typename T>
void round_trip(int channels, bool filter_rows, int level) {
  const int w = 37, h = 23;  // odd sizes: no row is a multiple of anything
  const int depth = int(8 * sizeof(T));
  std::vector<T> samples = test_samples<T>(w, h, channels, unsigned(channels * 100 + depth));
  PngImage image{w, h, channels, depth, samples.data(), false};
  std::string path = temp_path("rt.png");
  auto written = write_png(path, image, {level, filter_rows});
  ASSERT_TRUE(written.ok()) << written.error().message;
  int rw, rh, rc;
  std::vector<uint32_t> back = read_codes(path, depth, &rw, &rh, &rc);
  EXPECT_EQ(rw, w);
  EXPECT_EQ(rh, h);
  ASSERT_EQ(rc, channels);
  ASSERT_EQ(back.size(), samples.size());
  int mismatches = 0;
  for (size_t i = 0; i < samples.size(); ++i) mismatches += back[i] != samples[i];
  EXPECT_EQ(mismatches, 0) << channels << " channels, " << depth << " bits";
  std::filesystem::remove(path);
}

TEST(PngWriter, EightBitGreyRgbReadBackExactly) {
  for (int channels : {1, 3}) {
    for (bool filter : {true, false}) round_trip<uint8_t>(channels, filter, filter ? 3 : 1);
  }
}

TEST(PngWriter, SixteenBitReadsBackExactly) {
  for (int channels : {1, 3}) round_trip<uint16_t>(channels, true, 6);
}

TEST(PngWriter, AlphaIsStoredStraight) {
  // OpenImageIO premultiplies colour by alpha when it reads a PNG, so the colour of an RGBA
  // file read back is round(c * a / max) (exact where alpha is opaque), the alpha as written.
  for (int depth : {8, 16}) {
    for (int channels : {2, 4}) {
      const int w = 29, h = 11;
      const uint32_t max = depth == 8 ? 255 : 65535;
      std::vector<uint8_t> s8 = test_samples<uint8_t>(w, h, channels, 7);
      std::vector<uint16_t> s16 = test_samples<uint16_t>(w, h, channels, 9);
      PngImage image{w, h, channels, depth, depth == 8 ? (const void*)s8.data() : s16.data()};
      std::string path = temp_path("alpha.png");
      ASSERT_TRUE(write_png(path, image).ok());
      int rw, rh, rc;
      std::vector<uint32_t> back = read_codes(path, depth, &rw, &rh, &rc);
      ASSERT_EQ(rc, channels);
      int mismatches = 0;
      for (size_t p = 0; p < size_t(w) * h; ++p) {
        auto sample = [&](int k) -> uint32_t {
          size_t i = p * channels + k;
          return depth == 8 ? s8[i] : s16[i];
        };
        const uint32_t a = sample(channels - 1);
        mismatches += back[p * channels + channels - 1] != a;
        for (int k = 0; k + 1 < channels; ++k) {
          const double want = double(sample(k)) * a / max;
          const double got = back[p * channels + k];
          mismatches += a == max ? got != sample(k) : std::abs(got - want) > 1.0;
        }
      }
      EXPECT_EQ(mismatches, 0) << channels << " channels, " << depth << " bits";
      std::filesystem::remove(path);
    }
  }
}

/// The chunk types of a PNG file, in order.
std::vector<std::string> chunk_types(const std::vector<uint8_t>& png) {
  std::vector<std::string> types;
  for (size_t p = 8; p + 8 <= png.size();) {
    const uint32_t n = uint32_t(png[p]) << 24 | uint32_t(png[p + 1]) << 16 |
                       uint32_t(png[p + 2]) << 8 | png[p + 3];
    types.emplace_back(reinterpret_cast<const char*>(&png[p + 4]), 4);
    p += 12 + n;
  }
  return types;
}

/// Samples in bands of rows for which the minimum-sum heuristic picks each filter: noise, then
/// x * y (Paeth), a plane (Up), and each value the mean of its left and upper neighbours plus
/// a little noise (Average); Sub starts the smooth bands.
template <typename T>
std::vector<T> banded_samples(int w, int h, int c, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<T> s(size_t(w) * h * c);
  const size_t n = size_t(w) * c;
  for (int y = 0; y < h; ++y) {
    for (size_t i = 0; i < n; ++i) {
      const int x = int(i) / c, k = int(i) % c;
      const uint32_t a = i >= size_t(c) ? s[y * n + i - c] : 0, b = y ? s[(y - 1) * n + i] : 0;
      uint32_t v = 0;
      if (y < 3) {
        v = rng();
      } else if (y < 6) {
        v = x * y / 3 + k;
      } else if (y < 9) {
        v = 7 * x + 5 * y + k;
      } else {
        v = ((a + b) >> 1) + rng() % 4;
      }
      s[y * n + i] = T(sizeof(T) == 1 ? v & 0xff : v & 0xffff);
    }
  }
  return s;
}

/// The samples of an 8-bit or 16-bit PNG written by encode_png, decoded here (inflate, undo
/// each row's filter) without OpenImageIO, whose reader premultiplies alpha.
std::vector<uint32_t> decode(const std::vector<uint8_t>& png, int w, int h, int c, int depth,
                             std::set<int>* filters) {
  std::vector<uint8_t> zdata;
  for (size_t p = 8; p + 8 <= png.size();) {
    const uint32_t n = uint32_t(png[p]) << 24 | uint32_t(png[p + 1]) << 16 |
                       uint32_t(png[p + 2]) << 8 | png[p + 3];
    if (std::memcmp(&png[p + 4], "IDAT", 4) == 0) {
      zdata.insert(zdata.end(), png.begin() + p + 8, png.begin() + p + 8 + n);
    }
    p += 12 + n;
  }
  const size_t bpp = size_t(c) * depth / 8, row_bytes = bpp * w;
  std::vector<uint8_t> raw(size_t(h) * (row_bytes + 1));
  uLongf raw_size = uLongf(raw.size());
  EXPECT_EQ(uncompress(raw.data(), &raw_size, zdata.data(), uLong(zdata.size())), Z_OK);
  EXPECT_EQ(raw_size, raw.size());
  std::vector<uint8_t> rows(size_t(h) * row_bytes, 0);
  for (int y = 0; y < h; ++y) {
    const uint8_t type = raw[y * (row_bytes + 1)];
    filters->insert(type);
    const uint8_t* f = &raw[y * (row_bytes + 1) + 1];
    uint8_t* r = &rows[y * row_bytes];
    const uint8_t* up = y ? r - row_bytes : nullptr;
    for (size_t i = 0; i < row_bytes; ++i) {
      const int a = i >= bpp ? r[i - bpp] : 0, b = up ? up[i] : 0;
      const int cc = up && i >= bpp ? up[i - bpp] : 0;
      const int p = a + b - cc, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - cc);
      const int paeth = pa <= pb && pa <= pc ? a : (pb <= pc ? b : cc);
      const int predicted[5] = {0, a, b, (a + b) / 2, paeth};
      EXPECT_LE(type, 4);
      r[i] = uint8_t(f[i] + predicted[std::min<int>(type, 4)]);
    }
  }
  std::vector<uint32_t> samples;
  for (size_t i = 0; i < rows.size(); i += depth / 8) {
    samples.push_back(depth == 8 ? rows[i] : uint32_t(rows[i]) << 8 | rows[i + 1]);
  }
  return samples;
}

TEST(PngWriter, EveryLayoutDecodesExactly) {
  // Independent of OpenImageIO's reader: grey, grey + alpha, RGB and RGBA at 8 and 16 bits,
  // with and without row filters, decoded sample for sample.
  for (int depth : {8, 16}) {
    for (int channels = 1; channels <= 4; ++channels) {
      for (bool filter : {true, false}) {
        const int w = 41, h = 13;
        std::vector<uint8_t> s8 = banded_samples<uint8_t>(w, h, channels, 3);
        std::vector<uint16_t> s16 = banded_samples<uint16_t>(w, h, channels, 5);
        PngImage image{w, h, channels, depth, depth == 8 ? (const void*)s8.data() : s16.data()};
        std::vector<uint32_t> want(s8.begin(), s8.end());
        if (depth == 16) want.assign(s16.begin(), s16.end());
        std::set<int> filters;
        std::vector<uint32_t> got =
            decode(encode_png(image, {6, filter}), w, h, channels, depth, &filters);
        EXPECT_EQ(got, want) << channels << " channels, " << depth << " bits, filter " << filter;
        if (!filter) {
          EXPECT_EQ(filters, std::set<int>{0});
        } else if (depth == 8) {  // every predictor was used, so each is checked
          for (int type : {1, 2, 3, 4}) EXPECT_TRUE(filters.count(type)) << type;
        }
      }
    }
  }
}

TEST(PngWriter, LargeImagesDeflatedInTwoHalvesDecodeExactly) {
  // From 256 KiB of filtered rows the two halves of the image are deflated at once into one
  // zlib stream (a sync flush between them, the Adler-32s combined): zlib's uncompress (which
  // checks the Adler-32) and OpenImageIO must both read every sample, with and without row
  // filters, at 8 and 16 bits, for odd heights (halves of unequal size) and every level class
  // of the zlib header.
  for (int depth : {8, 16}) {
    for (bool filter : {true, false}) {
      const int w = 301, h = 303, channels = 3;  // 8 bits: 274 KiB of filtered rows
      std::vector<uint8_t> s8 = banded_samples<uint8_t>(w, h, channels, 11);
      std::vector<uint16_t> s16 = banded_samples<uint16_t>(w, h, channels, 13);
      PngImage image{w, h, channels, depth, depth == 8 ? (const void*)s8.data() : s16.data()};
      std::vector<uint32_t> want(s8.begin(), s8.end());
      if (depth == 16) want.assign(s16.begin(), s16.end());
      for (int level : {1, 3, 6, 9}) {
        std::set<int> filters;
        EXPECT_EQ(decode(encode_png(image, {level, filter}), w, h, channels, depth, &filters), want)
            << depth << " bits, filter " << filter << ", level " << level;
      }
      std::string path = temp_path("large.png");
      ASSERT_TRUE(write_png(path, image, {1, filter}).ok());
      int rw, rh, rc;
      EXPECT_EQ(read_codes(path, depth, &rw, &rh, &rc), want) << depth << " bits";
      std::filesystem::remove(path);
    }
  }
}

TEST(PngWriter, SrgbImagesGetTheColourChunks) {
  const uint8_t pixel[3] = {1, 2, 3};
  PngImage image{1, 1, 3, 8, pixel, true};
  EXPECT_EQ(chunk_types(encode_png(image)),
            (std::vector<std::string>{"IHDR", "gAMA", "sRGB", "cHRM", "IDAT", "IEND"}));
  image.srgb = false;
  EXPECT_EQ(chunk_types(encode_png(image)), (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
}

TEST(PngWriter, WritePixelsUsesItForAnyCaseOfTheExtension) {
  // A linear render through write_pixels: the sRGB chunks, the rounded sRGB codes.
  std::vector<float> data = {0.0f, 0.5f, 1.0f, 0.25f, 2.0f, -1.0f};
  std::string path = temp_path("upper.PNG");
  auto written = write_pixels(path, 2, 1, 3, data, true);
  ASSERT_TRUE(written.ok()) << written.error().message;
  std::ifstream in(path, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), {});
  ASSERT_GT(bytes.size(), 8u);
  EXPECT_EQ(std::memcmp(bytes.data(), "\x89PNG\r\n\x1a\n", 8), 0);
  EXPECT_EQ(chunk_types(bytes)[1], "gAMA");
  int w, h, c;
  std::vector<uint32_t> back = read_codes(path, 8, &w, &h, &c);
  EXPECT_EQ(back, (std::vector<uint32_t>{0, 188, 255, 137, 255, 0}));
  std::filesystem::remove(path);
}

TEST(PngWriter, UnwritablePathIsAnErrorNamingIt) {
  const uint8_t pixel[1] = {0};
  auto written = write_png("/nonexistent-dir/x.png", {1, 1, 1, 8, pixel});
  ASSERT_FALSE(written.ok());
  EXPECT_EQ(written.error().message,
            "cannot write '/nonexistent-dir/x.png': No such file or directory");
  std::vector<float> data(4, 0.5f);
  auto via_image = write_pixels("/nonexistent-dir/y.png", 2, 2, 1, data, false);
  ASSERT_FALSE(via_image.ok());
  EXPECT_EQ(via_image.error().message,
            "cannot write '/nonexistent-dir/y.png': No such file or directory");
  auto empty = write_pixels(temp_path("empty.png"), 0, 0, 3, {}, false);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().message, "cannot write '" + temp_path("empty.png") + "': an empty image");
  auto channels = write_pixels(temp_path("five.png"), 1, 1, 5, {0, 0, 0, 0, 0}, false);
  ASSERT_FALSE(channels.ok());
  EXPECT_EQ(channels.error().message,
            "cannot write '" + temp_path("five.png") + "': a PNG holds 1 to 4 channels, not 5");
}

}  // namespace
}  // namespace hfrt::render
