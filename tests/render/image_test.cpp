#include "render/image.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <vector>

namespace hfrt::render {
namespace {

Image test_image() {
  Image img;
  img.resize(8, 4);
  for (size_t i = 0; i < img.pixels(); ++i) {
    img.rgb[3 * i] = float(i) / 32.0f;
    img.rgb[3 * i + 1] = 0.5f;
    img.rgb[3 * i + 2] = 2.0f;  // over 1: clamps in 8-bit, kept in EXR
    img.alpha[i] = i % 2;
    if (i % 2) {
      img.depth[i] = 10.0f + float(i);
      img.normal[3 * i + 2] = 1;
    }
  }
  return img;
}

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("hfrt_image_test_" + name)).string();
}

TEST(Image, ExrKeepsLinearFloatAndAovChannels) {
  Image img = test_image();
  std::string path = temp_path("a.exr");
  auto written = write_image(img, path, {true, true});
  ASSERT_TRUE(written.ok()) << written.error().message;
  EXPECT_EQ(written.value().size(), 1u);
  int w, h, c;
  auto data = read_image(path, &w, &h, &c);
  ASSERT_TRUE(data.ok()) << data.error().message;
  EXPECT_EQ(w, 8);
  EXPECT_EQ(h, 4);
  ASSERT_EQ(c, 8);  // RGBA Z N.X N.Y N.Z
  const auto& d = data.value();
  EXPECT_FLOAT_EQ(d[5 * c + 0], 5.0f / 32.0f);
  EXPECT_FLOAT_EQ(d[5 * c + 2], 2.0f);
  EXPECT_FLOAT_EQ(d[5 * c + 4], 15.0f);
  EXPECT_FLOAT_EQ(d[5 * c + 7], 1.0f);
  std::filesystem::remove(path);
}

TEST(Image, PngIsSrgbEncodedAndAovsGoToSiblingFiles) {
  Image img = test_image();
  std::string path = temp_path("b.png");
  auto written = write_image(img, path, {true, true});
  ASSERT_TRUE(written.ok()) << written.error().message;
  ASSERT_EQ(written.value().size(), 3u);
  EXPECT_EQ(written.value()[1], temp_path("b.depth.png"));
  EXPECT_EQ(written.value()[2], temp_path("b.normal.png"));
  int w, h, c;
  auto data = read_image(path, &w, &h, &c);
  ASSERT_TRUE(data.ok());
  ASSERT_EQ(c, 3);
  // 0.5 linear is 0.735 in sRGB; 2.0 clamps to 1.
  EXPECT_NEAR(data.value()[1], linear_to_srgb(0.5f), 1.0 / 255);
  EXPECT_NEAR(data.value()[1], 0.735f, 0.003);
  EXPECT_FLOAT_EQ(data.value()[2], 1.0f);
  for (const auto& p : written.value()) {
    EXPECT_TRUE(std::filesystem::exists(p));
    std::filesystem::remove(p);
  }
}

TEST(Image, EightBitCodesAreTheRoundedEncoding) {
  // Every value gets the code round(255 * srgb(v)) for colour (the writer finds it by
  // thresholds, not by pow) and round(255 * v) for other data: a ramp over [0, 1] that crosses
  // every code several times, plus values off the range and NaN. (RGB and grey files: OIIO
  // associates colour with alpha in RGBA PNGs, which would hide the encoding.)
  const int w = 1024, h = 3;
  for (int channels : {3, 1}) {
    const bool srgb = channels == 3;
    std::vector<float> data(size_t(w) * h * channels);
    for (size_t i = 0; i < data.size(); ++i) data[i] = float(i) / float(data.size() - 1);
    data[0] = -0.5f;
    data[1] = std::nanf("");
    data[2] = 7.0f;
    data[3] = std::numeric_limits<float>::infinity();
    std::string path = temp_path("codes.png");
    ASSERT_TRUE(write_pixels(path, w, h, channels, data, srgb).ok());
    int rw, rh, c;
    auto back = read_image(path, &rw, &rh, &c);
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_EQ(c, channels);
    int mismatches = 0;
    for (size_t i = 0; i < data.size(); ++i) {
      float v = data[i];
      float clamped = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
      long want = std::lround(255.0f * (srgb ? linear_to_srgb(clamped) : clamped));
      if (std::isinf(v)) want = srgb ? 255 : 0;  // colour clamps; other data: not a value
      long got = std::lround(255.0f * back.value()[i]);
      if (got != want) ++mismatches;
    }
    EXPECT_EQ(mismatches, 0) << channels << " channels";
    EXPECT_EQ(std::lround(255.0f * back.value()[2]), 255);  // 7.0 clamps
    std::filesystem::remove(path);
  }
}

TEST(Image, FastPngHoldsTheSamePixels) {
  // The REPL's fast settings (no row filters, zlib level 1) change the bytes, not the image.
  Image img;
  img.resize(64, 48);
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = float((i * 37) % 101) / 100.0f;
  std::vector<float> pixels[2];
  int k = 0;
  for (PngCompression png : {PngCompression::kSmall, PngCompression::kFast}) {
    std::string path = temp_path(k == 0 ? "small.png" : "fast.png");
    ASSERT_TRUE(write_image(img, path, {}, png).ok());
    int w, h, c;
    auto back = read_image(path, &w, &h, &c);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(w, 64);
    EXPECT_EQ(h, 48);
    pixels[k++] = back.value();
    std::filesystem::remove(path);
  }
  EXPECT_EQ(pixels[0], pixels[1]);
}

TEST(Image, UnknownExtensionIsAnError) {
  Image img = test_image();
  auto written = write_image(img, temp_path("c.notaformat"));
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.error().message.find("notaformat"), std::string::npos);
}

TEST(Image, TiffAndJpegAreWritten) {
  Image img = test_image();
  for (const char* name : {"d.tif", "e.jpg"}) {
    std::string path = temp_path(name);
    auto written = write_image(img, path);
    ASSERT_TRUE(written.ok()) << written.error().message;
    int w, h, c;
    ASSERT_TRUE(read_image(path, &w, &h, &c).ok());
    EXPECT_EQ(w, 8);
    std::filesystem::remove(path);
  }
}

}  // namespace
}  // namespace hfrt::render
