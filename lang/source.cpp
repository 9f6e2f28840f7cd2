// SourceFile: line table and offset -> line/column mapping.
#include "lang/source.h"

#include <algorithm>

#include "base/check.h"

namespace hfrt::lang {

SourceFile::SourceFile(std::string name, std::string text)
    : name_(std::move(name)), text_(std::move(text)) {
  // Offsets are 32-bit; the front end refuses larger files before they get here, and
  // this check keeps that promise honest.
  HFRT_CHECK_LT(text_.size(), size_t{0xFFFFFFF0u});
  line_starts_.push_back(0);
  for (size_t i = 0; i < text_.size(); ++i) {
    if (text_[i] == '\n') line_starts_.push_back(static_cast<uint32_t>(i + 1));
  }
}

std::string_view SourceFile::line_text(uint32_t line) const {
  if (line == 0 || line > line_starts_.size()) return {};
  uint32_t begin = line_starts_[line - 1];
  uint32_t end =
      line < line_starts_.size() ? line_starts_[line] - 1 : static_cast<uint32_t>(text_.size());
  // CRLF files (an hfrt deviation accepts them): the '\r' is not part of the line.
  if (end > begin && text_[end - 1] == '\r') --end;
  return std::string_view(text_).substr(begin, end - begin);
}

SourceLoc SourceFile::loc_at(uint32_t offset) const {
  offset = std::min<uint32_t>(offset, static_cast<uint32_t>(text_.size()));
  auto it = std::upper_bound(line_starts_.begin(), line_starts_.end(), offset);
  uint32_t line = static_cast<uint32_t>(it - line_starts_.begin());  // >= 1
  SourceLoc loc;
  loc.offset = offset;
  loc.line = line;
  loc.col = offset - line_starts_[line - 1] + 1;
  return loc;
}

}  // namespace hfrt::lang
