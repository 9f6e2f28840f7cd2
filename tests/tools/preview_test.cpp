// The REPL's inline previews (tools/hfrt/preview.h): the escape sequences of the kitty
// graphics protocol and of sixel are decoded here and compared, pixel by pixel, with the image;
// terminal detection from a fake environment.
#include "tools/hfrt/preview.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace hfrt::tools {
namespace {

/// A test image with distinct colours: a gradient in x (red), y (green) and a blue checker.
render::Image test_image(int w, int h) {
  render::Image img;
  img.resize(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float* p = &img.rgb[(size_t(y) * w + x) * 3];
      p[0] = float(x) / float(w);
      p[1] = float(y) / float(h);
      p[2] = ((x / 3 + y / 2) % 2) ? 0.8f : 0.05f;
    }
  }
  return img;
}

std::vector<uint8_t> base64_decode(const std::string& s) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::vector<uint8_t> out;
  uint32_t acc = 0;
  int bits = 0;
  for (char c : s) {
    if (c == '=') break;
    int v = value(c);
    EXPECT_GE(v, 0) << "not base64: " << int(c);
    acc = acc << 6 | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(uint8_t(acc >> bits));
    }
  }
  return out;
}

TEST(Preview, Base64KnownVectors) {
  auto enc = [](const std::string& s) {
    return base64_encode(reinterpret_cast<const uint8_t*>(s.data()), s.size());
  };
  // RFC 4648, section 10.
  EXPECT_EQ(enc(""), "");
  EXPECT_EQ(enc("f"), "Zg==");
  EXPECT_EQ(enc("fo"), "Zm8=");
  EXPECT_EQ(enc("foo"), "Zm9v");
  EXPECT_EQ(enc("foob"), "Zm9vYg==");
  EXPECT_EQ(enc("fooba"), "Zm9vYmE=");
  EXPECT_EQ(enc("foobar"), "Zm9vYmFy");
}

TEST(Preview, DownscaleKeepsAspectAndNeverUpscales) {
  render::Image img = test_image(100, 50);
  Rgb8Image a = to_srgb8(img, 40);
  EXPECT_EQ(a.width, 40);
  EXPECT_EQ(a.height, 20);
  EXPECT_EQ(a.rgb.size(), size_t(40 * 20 * 3));
  Rgb8Image b = to_srgb8(img, 1000);
  EXPECT_EQ(b.width, 100);
  EXPECT_EQ(b.height, 50);
  // Unscaled: each byte is the pixel through the sRGB curve.
  EXPECT_EQ(b.rgb[0], 0);                             // x = 0: no red
  EXPECT_EQ(b.rgb[(size_t(0) * 100 + 50) * 3], 188);  // 0.5 linear is 188 in sRGB
}

/// The kitty escapes: APC "ESC _ G keys ; payload ESC \".
struct KittyChunk {
  std::map<std::string, std::string> keys;
  std::string payload;
};

std::vector<KittyChunk> parse_kitty(const std::string& s, std::string* rest) {
  std::vector<KittyChunk> chunks;
  size_t pos = 0;
  while (s.compare(pos, 3, "\x1b_G") == 0) {
    size_t semi = s.find(';', pos);
    size_t end = s.find("\x1b\\", pos);
    EXPECT_NE(semi, std::string::npos);
    EXPECT_NE(end, std::string::npos);
    if (semi == std::string::npos || end == std::string::npos || semi > end) break;
    KittyChunk c;
    std::string keys = s.substr(pos + 3, semi - pos - 3);
    size_t k = 0;
    while (k < keys.size()) {
      size_t comma = keys.find(',', k);
      std::string kv = keys.substr(k, comma == std::string::npos ? std::string::npos : comma - k);
      size_t eq = kv.find('=');
      EXPECT_NE(eq, std::string::npos) << kv;
      c.keys[kv.substr(0, eq)] = kv.substr(eq + 1);
      if (comma == std::string::npos) break;
      k = comma + 1;
    }
    c.payload = s.substr(semi + 1, end - semi - 1);
    chunks.push_back(c);
    pos = end + 2;
  }
  *rest = s.substr(pos);
  return chunks;
}

TEST(Preview, KittyProtocolStructureAndPixels) {
  render::Image img = test_image(90, 60);  // 90x60x3 bytes: 21600 base64 chars, 6 chunks
  std::string out = kitty_preview(img, 1000);
  std::string rest;
  std::vector<KittyChunk> chunks = parse_kitty(out, &rest);
  EXPECT_EQ(rest, "\n");
  ASSERT_GE(chunks.size(), 2u);
  EXPECT_EQ(chunks.size(), (size_t(90 * 60 * 3 / 3 * 4) + 4095) / 4096);
  // The first chunk carries the image's keys; every chunk says whether more follow.
  EXPECT_EQ(chunks[0].keys["a"], "T");
  EXPECT_EQ(chunks[0].keys["f"], "24");
  EXPECT_EQ(chunks[0].keys["q"], "2");
  EXPECT_EQ(chunks[0].keys["s"], "90");
  EXPECT_EQ(chunks[0].keys["v"], "60");
  std::string payload;
  for (size_t i = 0; i < chunks.size(); ++i) {
    EXPECT_EQ(chunks[i].keys["m"], i + 1 < chunks.size() ? "1" : "0") << i;
    EXPECT_LE(chunks[i].payload.size(), 4096u);
    if (i + 1 < chunks.size()) {
      EXPECT_EQ(chunks[i].payload.size() % 4, 0u);
    }
    if (i > 0) {
      EXPECT_EQ(chunks[i].keys.count("s"), 0u);
    }
    payload += chunks[i].payload;
  }
  std::vector<uint8_t> pixels = base64_decode(payload);
  Rgb8Image expect = to_srgb8(img, 1000);
  EXPECT_EQ(pixels, expect.rgb);
}

TEST(Preview, KittyKeepCursorPlacesWithoutMoving) {
  std::string out = kitty_preview(test_image(20, 10), 100, /*keep_cursor=*/true);
  EXPECT_NE(out.find("C=1,"), std::string::npos);
  EXPECT_NE(out.back(), '\n');
  EXPECT_EQ(kitty_preview(test_image(20, 10), 100).find("C=1"), std::string::npos);
}

TEST(Preview, ResizeNearest) {
  render::Image small = test_image(4, 2);
  render::Image big = resize_nearest(small, 8, 6);
  ASSERT_EQ(big.width, 8);
  ASSERT_EQ(big.height, 6);
  for (int y = 0; y < 6; ++y) {
    for (int x = 0; x < 8; ++x) {
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(big.rgb[(size_t(y) * 8 + x) * 3 + c],
                  small.rgb[(size_t(y / 3) * 4 + x / 2) * 3 + c]);
      }
    }
  }
}

TEST(Preview, KittyScalesDownToTheWidth) {
  std::string out = kitty_preview(test_image(200, 100), 50);
  EXPECT_NE(out.find("s=50,v=25,"), std::string::npos);
}

/// A sixel decoder: the register of each pixel (-1 where nothing was painted), the raster
/// attributes and the defined registers.
struct SixelImage {
  int width = 0, height = 0;  // from the raster attributes
  std::vector<int> reg;       // painted size (width x painted rows)
  int painted_rows = 0;
  std::map<int, std::vector<int>> defined;  // register -> {2, r%, g%, b%}
};

SixelImage decode_sixel(const std::string& s) {
  SixelImage img;
  EXPECT_EQ(s.compare(0, 2, "\x1bP"), 0);
  size_t q = s.find('q');
  EXPECT_NE(q, std::string::npos);
  size_t end = s.find("\x1b\\");
  EXPECT_NE(end, std::string::npos);
  size_t i = q + 1;
  auto number = [&]() {
    int v = 0;
    while (i < end && std::isdigit(static_cast<unsigned char>(s[i]))) v = v * 10 + (s[i++] - '0');
    return v;
  };
  EXPECT_EQ(s[i], '"');
  ++i;
  int pan = number();
  ++i;
  int pad = number();
  ++i;
  img.width = number();
  ++i;
  img.height = number();
  EXPECT_EQ(pan, 1);
  EXPECT_EQ(pad, 1);
  img.reg.assign(size_t(img.width) * ((img.height + 5) / 6 * 6), -1);
  int band = 0, x = 0, color = -1;
  while (i < end) {
    char c = s[i];
    if (c == '#') {
      ++i;
      int k = number();
      if (i < end && s[i] == ';') {
        std::vector<int> def;
        while (i < end && s[i] == ';') {
          ++i;
          def.push_back(number());
        }
        img.defined[k] = def;
      } else {
        color = k;
      }
    } else if (c == '$') {
      x = 0;
      ++i;
    } else if (c == '-') {
      x = 0;
      ++band;
      ++i;
    } else if (c == '!' || (c >= 63 && c <= 126)) {
      int run = 1;
      if (c == '!') {
        ++i;
        run = number();
        c = s[i];
      }
      ++i;
      int bits = c - 63;
      for (int r = 0; r < run; ++r, ++x) {
        for (int b = 0; b < 6; ++b) {
          if (!(bits & (1 << b))) continue;
          int y = band * 6 + b;
          EXPECT_LT(x, img.width);
          if (x >= img.width || size_t(y) * img.width + x >= img.reg.size()) continue;
          img.reg[size_t(y) * img.width + x] = color;
        }
      }
    } else {
      ADD_FAILURE() << "unexpected sixel byte " << int(c);
      ++i;
    }
  }
  img.painted_rows = (band + 1) * 6;
  return img;
}

TEST(Preview, SixelStructureAndPixels) {
  render::Image img = test_image(37, 23);  // not a multiple of 6 rows
  std::string out = sixel_preview(img, 1000);
  ASSERT_GE(out.size(), 4u);
  EXPECT_EQ(out.substr(out.size() - 3), "\x1b\\\n");
  SixelImage dec = decode_sixel(out);
  EXPECT_EQ(dec.width, 37);
  EXPECT_EQ(dec.height, 23);
  EXPECT_EQ(dec.painted_rows, 24);  // 4 bands
  Rgb8Image expect = to_srgb8(img, 1000);
  for (int y = 0; y < 23; ++y) {
    for (int x = 0; x < 37; ++x) {
      const uint8_t* p = &expect.rgb[(size_t(y) * 37 + x) * 3];
      int want = sixel_palette_index(p[0], p[1], p[2]);
      ASSERT_EQ(dec.reg[size_t(y) * 37 + x], want) << x << "," << y;
      // Each register used is defined, in RGB percent, as the palette says.
      ASSERT_EQ(dec.defined.count(want), 1u);
      uint8_t c[3];
      sixel_palette_color(want, c);
      const std::vector<int>& d = dec.defined[want];
      ASSERT_EQ(d.size(), 4u);
      EXPECT_EQ(d[0], 2);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(d[1 + k], c[k] * 100.0 / 255.0, 0.5);
    }
  }
  // Nothing painted below the image.
  for (int x = 0; x < 37; ++x) EXPECT_EQ(dec.reg[size_t(23) * 37 + x], -1);
}

TEST(Preview, SixelRunLengthOnFlatImages) {
  render::Image img;
  img.resize(64, 6);
  for (float& v : img.rgb) v = 0.5f;
  std::string out = sixel_preview(img, 1000);
  // One band, one colour, one run: "#k!64~".
  EXPECT_NE(out.find("!64~"), std::string::npos) << out;
  EXPECT_EQ(out.find('-'), std::string::npos);
  EXPECT_EQ(out.find('$'), std::string::npos);
}

TEST(Preview, SixelPaletteIndexIsTheNearestColour) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> byte(0, 255);
  for (int t = 0; t < 2000; ++t) {
    uint8_t want[3] = {uint8_t(byte(rng)), uint8_t(byte(rng)), uint8_t(byte(rng))};
    if (t % 4 == 0) want[1] = want[2] = want[0];  // greys too
    auto d2 = [&](int k) {
      uint8_t c[3];
      sixel_palette_color(k, c);
      int d = 0;
      for (int i = 0; i < 3; ++i) d += (int(c[i]) - want[i]) * (int(c[i]) - want[i]);
      return d;
    };
    int best = 0;
    for (int k = 1; k < 256; ++k) {
      if (d2(k) < d2(best)) best = k;
    }
    int got = sixel_palette_index(want[0], want[1], want[2]);
    ASSERT_EQ(d2(got), d2(best)) << int(want[0]) << "," << int(want[1]) << "," << int(want[2]);
  }
}

TEST(Preview, AnsiHalfBlocks) {
  render::Image img = test_image(8, 6);
  std::string p = ansi_preview(img, 4);  // 4 columns: 2 source pixels each; 3 pixel rows
  size_t blocks = 0, resets = 0;
  for (size_t i = p.find("\xe2\x96\x80"); i != std::string::npos; i = p.find("\xe2\x96\x80", i + 1))
    ++blocks;
  for (size_t i = p.find("\x1b[0m\n"); i != std::string::npos; i = p.find("\x1b[0m\n", i + 1))
    ++resets;
  EXPECT_EQ(resets, 2u);       // ceil(3 / 2) text rows
  EXPECT_EQ(blocks, 4u * 2u);  // 4 per row
}

TEST(Preview, DetectionFromTheEnvironment) {
  auto detect = [](std::map<std::string, std::string> env) {
    return detect_preview([&env](const char* name) -> const char* {
      auto it = env.find(name);
      return it == env.end() ? nullptr : it->second.c_str();
    });
  };
  EXPECT_EQ(detect({{"TERM", "xterm-kitty"}}), PreviewMode::kKitty);
  EXPECT_EQ(detect({{"TERM", "xterm-256color"}, {"KITTY_WINDOW_ID", "3"}}), PreviewMode::kKitty);
  EXPECT_EQ(detect({{"TERM", "xterm-256color"}, {"TERM_PROGRAM", "WezTerm"}}), PreviewMode::kKitty);
  EXPECT_EQ(detect({{"TERM", "xterm-256color"}, {"TERM_PROGRAM", "iTerm.app"}}),
            PreviewMode::kSixel);
  EXPECT_EQ(detect({{"TERM", "foot"}}), PreviewMode::kSixel);
  EXPECT_EQ(detect({{"TERM", "mlterm"}}), PreviewMode::kSixel);
  EXPECT_EQ(detect({{"TERM", "xterm-256color"}, {"COLORTERM", "truecolor"}}), PreviewMode::kAnsi);
  EXPECT_EQ(detect({}), PreviewMode::kAnsi);
  EXPECT_EQ(detect({{"TERM", "dumb"}, {"KITTY_WINDOW_ID", "1"}}), PreviewMode::kOff);
  // HFRT_PREVIEW decides over everything; an unknown value is ignored.
  EXPECT_EQ(detect({{"TERM", "xterm-kitty"}, {"HFRT_PREVIEW", "sixel"}}), PreviewMode::kSixel);
  EXPECT_EQ(detect({{"TERM", "dumb"}, {"HFRT_PREVIEW", "ansi"}}), PreviewMode::kAnsi);
  EXPECT_EQ(detect({{"TERM", "foot"}, {"HFRT_PREVIEW", "bogus"}}), PreviewMode::kSixel);
  PreviewMode m;
  EXPECT_TRUE(parse_preview_mode("kitty", &m));
  EXPECT_EQ(m, PreviewMode::kKitty);
  EXPECT_FALSE(parse_preview_mode("iterm", &m));
  EXPECT_STREQ(preview_mode_name(PreviewMode::kSixel), "sixel");
}

}  // namespace
}  // namespace hfrt::tools
