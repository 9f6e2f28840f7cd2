#include "tools/hfrt/preview.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace hfrt::tools {
namespace {

uint8_t to_srgb_byte(float v) {
  v = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(std::max(v, 0.0f), 1 / 2.4f) - 0.055f;
  return uint8_t(std::clamp(int(std::lround(v * 255)), 0, 255));
}

bool starts_with(const char* s, const char* prefix) {
  return s && std::strncmp(s, prefix, std::strlen(prefix)) == 0;
}

bool equals(const char* s, const char* t) {
  return s && std::strcmp(s, t) == 0;
}

constexpr int kCubeLevels = 6;
constexpr int kCubeSize = kCubeLevels * kCubeLevels * kCubeLevels;  // 216
constexpr int kGreys = 256 - kCubeSize;                             // 40

int cube_level(uint8_t v) {
  return (int(v) * (kCubeLevels - 1) + 127) / 255;
}
uint8_t cube_value(int level) {
  return uint8_t(level * 255 / (kCubeLevels - 1));
}
uint8_t grey_value(int i) {
  return uint8_t((i + 1) * 255 / (kGreys + 1));
}

int dist2(const uint8_t a[3], const uint8_t b[3]) {
  int d = 0;
  for (int c = 0; c < 3; ++c) d += (int(a[c]) - int(b[c])) * (int(a[c]) - int(b[c]));
  return d;
}

}  // namespace

const char* preview_mode_name(PreviewMode mode) {
  switch (mode) {
    case PreviewMode::kOff:
      return "off";
    case PreviewMode::kAnsi:
      return "ansi";
    case PreviewMode::kSixel:
      return "sixel";
    case PreviewMode::kKitty:
      return "kitty";
  }
  return "off";
}

bool parse_preview_mode(const std::string& text, PreviewMode* mode) {
  for (PreviewMode m :
       {PreviewMode::kOff, PreviewMode::kAnsi, PreviewMode::kSixel, PreviewMode::kKitty}) {
    if (text == preview_mode_name(m)) {
      *mode = m;
      return true;
    }
  }
  return false;
}

PreviewMode detect_preview(const std::function<const char*(const char*)>& getenv) {
  PreviewMode forced;
  if (const char* p = getenv("HFRT_PREVIEW"); p && parse_preview_mode(p, &forced)) return forced;
  const char* term = getenv("TERM");
  const char* program = getenv("TERM_PROGRAM");
  if (equals(term, "dumb")) return PreviewMode::kOff;
  if (equals(term, "xterm-kitty") || getenv("KITTY_WINDOW_ID") || equals(program, "WezTerm") ||
      equals(program, "ghostty") || equals(term, "xterm-ghostty") ||
      getenv("GHOSTTY_RESOURCES_DIR")) {
    return PreviewMode::kKitty;
  }
  if (equals(program, "iTerm.app") || equals(program, "mlterm") || starts_with(term, "foot") ||
      starts_with(term, "mlterm") || starts_with(term, "yaft") || equals(term, "contour") ||
      (term && std::strstr(term, "sixel")) || getenv("WT_SESSION") || getenv("KONSOLE_VERSION")) {
    return PreviewMode::kSixel;
  }
  return PreviewMode::kAnsi;
}

Rgb8Image to_srgb8(const render::Image& image, int max_width) {
  Rgb8Image out;
  if (image.width <= 0 || image.height <= 0 || image.rgb.empty()) return out;
  const int w = std::max(1, std::min(max_width, image.width));
  const double scale = double(image.width) / w;  // >= 1: source pixels per output pixel
  const int h = std::max(1, int(std::lround(image.height / scale)));
  out.width = w;
  out.height = h;
  out.rgb.resize(size_t(w) * h * 3);
  for (int y = 0; y < h; ++y) {
    const int y0 = std::min(image.height - 1, int(y * scale));
    const int y1 = std::clamp(int((y + 1) * scale), y0 + 1, image.height);
    for (int x = 0; x < w; ++x) {
      const int x0 = std::min(image.width - 1, int(x * scale));
      const int x1 = std::clamp(int((x + 1) * scale), x0 + 1, image.width);
      // A box filter in linear light, then the sRGB curve.
      float sum[3] = {0, 0, 0};
      for (int sy = y0; sy < y1; ++sy) {
        for (int sx = x0; sx < x1; ++sx) {
          const float* p = &image.rgb[(size_t(sy) * image.width + sx) * 3];
          for (int c = 0; c < 3; ++c) sum[c] += p[c];
        }
      }
      const float n = float((y1 - y0) * (x1 - x0));
      for (int c = 0; c < 3; ++c) out.rgb[(size_t(y) * w + x) * 3 + c] = to_srgb_byte(sum[c] / n);
    }
  }
  return out;
}

std::string ansi_preview(const render::Image& image, int max_cols) {
  if (image.width <= 0 || image.height <= 0 || image.rgb.empty()) return "";
  const int cols = std::max(1, std::min(max_cols, image.width));
  const double scale = double(image.width) / cols;
  const int rows = std::max(1, int(image.height / scale));  // pixel rows after scaling
  auto pixel = [&](int col, int row, int c) {
    int x = std::min(image.width - 1, int(col * scale));
    int y = std::min(image.height - 1, int(row * scale));
    return int(to_srgb_byte(image.rgb[(size_t(y) * image.width + x) * 3 + c]));
  };
  std::string out;
  char buf[64];
  for (int r = 0; r < rows; r += 2) {
    for (int c = 0; c < cols; ++c) {
      int lower = std::min(r + 1, rows - 1);
      std::snprintf(buf, sizeof buf, "\x1b[38;2;%d;%d;%dm\x1b[48;2;%d;%d;%dm", pixel(c, r, 0),
                    pixel(c, r, 1), pixel(c, r, 2), pixel(c, lower, 0), pixel(c, lower, 1),
                    pixel(c, lower, 2));
      out += buf;
      out += "\xe2\x96\x80";  // U+2580 upper half block: fg = upper pixel, bg = lower pixel
    }
    out += "\x1b[0m\n";
  }
  return out;
}

std::string base64_encode(const uint8_t* data, size_t n) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((n + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < n; i += 3) {
    uint32_t v = uint32_t(data[i]) << 16 | uint32_t(data[i + 1]) << 8 | data[i + 2];
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < n) {
    uint32_t v = uint32_t(data[i]) << 16 | (i + 1 < n ? uint32_t(data[i + 1]) << 8 : 0);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < n ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

render::Image resize_nearest(const render::Image& image, int width, int height) {
  render::Image out;
  out.resize(width, height);
  if (image.width <= 0 || image.height <= 0) return out;
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(image.height - 1, int(int64_t(y) * image.height / height));
    for (int x = 0; x < width; ++x) {
      const int sx = std::min(image.width - 1, int(int64_t(x) * image.width / width));
      const size_t d = size_t(y) * width + x, src = size_t(sy) * image.width + sx;
      for (int c = 0; c < 3; ++c) out.rgb[d * 3 + c] = image.rgb[src * 3 + c];
      if (!out.alpha.empty() && !image.alpha.empty()) out.alpha[d] = image.alpha[src];
    }
  }
  return out;
}

std::string kitty_preview(const render::Image& image, int max_width, bool keep_cursor) {
  Rgb8Image img = to_srgb8(image, max_width);
  if (img.width == 0) return "";
  const std::string payload = base64_encode(img.rgb.data(), img.rgb.size());
  // The protocol's limit for one escape's payload; every chunk but the last is a multiple of 4.
  constexpr size_t kChunk = 4096;
  std::string out;
  for (size_t pos = 0; pos < payload.size(); pos += kChunk) {
    const bool last = pos + kChunk >= payload.size();
    out += "\x1b_G";
    if (pos == 0) {
      out +=
          "a=T,f=24,q=2,s=" + std::to_string(img.width) + ",v=" + std::to_string(img.height) + ",";
      if (keep_cursor) out += "C=1,";
    }
    out += last ? "m=0;" : "m=1;";
    out.append(payload, pos, kChunk);
    out += "\x1b\\";
  }
  if (!keep_cursor) out += '\n';
  return out;
}

void sixel_palette_color(int index, uint8_t rgb[3]) {
  if (index < kCubeSize) {
    rgb[0] = cube_value(index / (kCubeLevels * kCubeLevels));
    rgb[1] = cube_value(index / kCubeLevels % kCubeLevels);
    rgb[2] = cube_value(index % kCubeLevels);
  } else {
    rgb[0] = rgb[1] = rgb[2] = grey_value(std::min(index - kCubeSize, kGreys - 1));
  }
}

int sixel_palette_index(uint8_t r, uint8_t g, uint8_t b) {
  const uint8_t want[3] = {r, g, b};
  const int cube =
      cube_level(r) * kCubeLevels * kCubeLevels + cube_level(g) * kCubeLevels + cube_level(b);
  uint8_t c[3];
  sixel_palette_color(cube, c);
  // The nearest grey by the mean, then whichever of the two is nearer.
  const int mean = (int(r) + int(g) + int(b)) / 3;
  const int guess = std::clamp((mean * (kGreys + 1) + 127) / 255 - 1, 0, kGreys - 1);
  int best = cube, best_d = dist2(c, want);
  for (int i = std::max(0, guess - 1); i <= std::min(kGreys - 1, guess + 1); ++i) {
    uint8_t gc[3];
    sixel_palette_color(kCubeSize + i, gc);
    if (dist2(gc, want) < best_d) {
      best = kCubeSize + i;
      best_d = dist2(gc, want);
    }
  }
  return best;
}

std::string sixel_preview(const render::Image& image, int max_width) {
  Rgb8Image img = to_srgb8(image, max_width);
  if (img.width == 0) return "";
  const int w = img.width, h = img.height;
  std::vector<uint8_t> index(size_t(w) * h);
  bool used[256] = {};
  for (size_t i = 0; i < index.size(); ++i) {
    index[i] = uint8_t(sixel_palette_index(img.rgb[i * 3], img.rgb[i * 3 + 1], img.rgb[i * 3 + 2]));
    used[index[i]] = true;
  }
  std::string out = "\x1bP0;1;0q\"1;1;" + std::to_string(w) + ";" + std::to_string(h);
  char buf[48];
  for (int k = 0; k < 256; ++k) {
    if (!used[k]) continue;  // only the registers the image uses
    uint8_t c[3];
    sixel_palette_color(k, c);
    std::snprintf(buf, sizeof buf, "#%d;2;%d;%d;%d", k, (c[0] * 100 + 127) / 255,
                  (c[1] * 100 + 127) / 255, (c[2] * 100 + 127) / 255);
    out += buf;
  }
  std::vector<uint8_t> bits(static_cast<size_t>(w));
  for (int band = 0; band * 6 < h; ++band) {
    const int y0 = band * 6, y1 = std::min(h, y0 + 6);
    bool in_band[256] = {};
    for (int y = y0; y < y1; ++y) {
      for (int x = 0; x < w; ++x) in_band[index[size_t(y) * w + x]] = true;
    }
    bool first = true;
    for (int k = 0; k < 256; ++k) {
      if (!in_band[k]) continue;
      std::fill(bits.begin(), bits.end(), uint8_t(0));
      for (int y = y0; y < y1; ++y) {
        for (int x = 0; x < w; ++x) {
          if (index[size_t(y) * w + x] == k) bits[size_t(x)] |= uint8_t(1 << (y - y0));
        }
      }
      if (!first) out += '$';  // back to the band's start: the next colour overprints
      first = false;
      out += '#' + std::to_string(k);
      for (int x = 0; x < w;) {
        int run = 1;
        while (x + run < w && bits[size_t(x + run)] == bits[size_t(x)]) ++run;
        const char ch = char(63 + bits[size_t(x)]);
        if (ch == '?' && x + run == w) break;  // nothing more of this colour in the band
        if (run > 3) {
          out += '!' + std::to_string(run) + ch;
        } else {
          out.append(size_t(run), ch);
        }
        x += run;
      }
    }
    if (y1 < h) out += '-';  // next band
  }
  out += "\x1b\\\n";
  return out;
}

}  // namespace hfrt::tools
