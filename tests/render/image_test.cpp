#include "render/image.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

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
