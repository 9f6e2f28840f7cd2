#pragma once
// Inline previews of a rendered image in a terminal, for `hfrt repl`: three encoders (the kitty
// graphics protocol, sixel, and 24-bit colour half blocks, the fallback every modern terminal
// shows) and the detection of which one the terminal understands. The encoders are pure
// functions of the image (no terminal I/O), so tests check their output byte by byte.

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "render/image.h"

namespace hfrt::tools {

/// How the REPL shows a rendered image (`:preview off|ansi|sixel|kitty`).
enum class PreviewMode { kOff, kAnsi, kSixel, kKitty };

/// "off", "ansi", "sixel", "kitty".
const char* preview_mode_name(PreviewMode mode);
/// Parses a mode name; false when unknown.
bool parse_preview_mode(const std::string& text, PreviewMode* mode);

/// The preview the terminal described by the environment understands, `getenv` answering for
/// the environment (tests pass their own). In order: HFRT_PREVIEW (a mode name) decides;
/// TERM=dumb: off; kitty (TERM=xterm-kitty, KITTY_WINDOW_ID, TERM_PROGRAM=WezTerm or ghostty,
/// GHOSTTY_RESOURCES_DIR): the kitty protocol; sixel terminals (TERM_PROGRAM=iTerm.app or
/// mlterm, TERM foot*/mlterm*/yaft*/contour or containing "sixel", WT_SESSION for Windows
/// Terminal, KONSOLE_VERSION): sixel; otherwise the half blocks. Terminals are not queried
/// (a DA1 query would read the reply from the same stdin that libedit reads).
PreviewMode detect_preview(const std::function<const char*(const char*)>& getenv);

/// The image downscaled (box filter) to at most `max_width` pixels wide, aspect kept, as 8-bit
/// sRGB, 3 bytes per pixel, rows top to bottom. Never upscales.
struct Rgb8Image {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
};
Rgb8Image to_srgb8(const render::Image& image, int max_width);

/// The image as 24-bit colour ANSI half blocks (two pixel rows per text row), scaled down to
/// at most `max_cols` columns. Ends with a colour reset and a newline.
std::string ansi_preview(const render::Image& image, int max_cols);

/// The kitty graphics protocol: raw 24-bit RGB (f=24), transmitted and shown at the cursor
/// (a=T), quiet (q=2: the terminal sends no reply into stdin), base64 in chunks of at most
/// 4096 bytes, each an APC "ESC _ G <keys>;<data> ESC \" with m=1 on all but the last.
/// The image is scaled down to at most `max_width` pixels wide. Ends with a newline.
/// With `keep_cursor` the picture is placed with C=1 (the cursor stays at its top left, no
/// newline follows), so that a later picture of the same size replaces it.
std::string kitty_preview(const render::Image& image, int max_width, bool keep_cursor = false);

/// `image` scaled to width x height by nearest neighbour (for showing a coarse render in the
/// place of the full one).
render::Image resize_nearest(const render::Image& image, int width, int height);

/// Sixel (DEC VT340 graphics, as xterm -ti vt340, foot, mlterm, WezTerm, iTerm2 show it):
/// "ESC P 0;1;0 q", raster attributes "1;1;W;H, a fixed 256-colour palette (the 6x6x6 cube
/// and 40 greys, nearest colour, no dithering), bands of six pixel rows separated by '-',
/// run-length coded ("!N"), and "ESC \". At most `max_width` pixels wide. Ends with a newline.
std::string sixel_preview(const render::Image& image, int max_width);

/// The sixel palette: register `index` (0..255) as 8-bit sRGB, for tests and the encoder.
void sixel_palette_color(int index, uint8_t rgb[3]);
/// The nearest palette register of an sRGB colour.
int sixel_palette_index(uint8_t r, uint8_t g, uint8_t b);

/// Base64 (RFC 4648, with padding).
std::string base64_encode(const uint8_t* data, size_t n);

}  // namespace hfrt::tools
