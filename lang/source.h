#pragma once
// Source text and locations. Every diagnostic and every IR instruction points back here.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace hfrt::lang {

/// A position in a source file: byte offset and 1-based line and column (columns count bytes).
struct SourceLoc {
  uint32_t offset = 0;
  uint32_t line = 0;  ///< 0 means "no location" (synthesised code).
  uint32_t col = 0;
  bool valid() const { return line != 0; }
};

/// A located span of source text; `length` is in bytes and may be 0 (a point).
struct SourceRange {
  SourceLoc begin;
  uint32_t length = 0;
};

/// One source buffer with its display name. Immutable after construction so that locations
/// and string_views into it stay valid for the lifetime of the program that refers to it.
class SourceFile {
 public:
  SourceFile(std::string name, std::string text);

  const std::string& name() const { return name_; }
  std::string_view text() const { return text_; }
  /// The text of 1-based line `line` without its line terminator ("" when out of range).
  std::string_view line_text(uint32_t line) const;
  /// Line and column of a byte offset.
  SourceLoc loc_at(uint32_t offset) const;
  uint32_t line_count() const { return static_cast<uint32_t>(line_starts_.size()); }

 private:
  std::string name_;
  std::string text_;
  std::vector<uint32_t> line_starts_;
};

}  // namespace hfrt::lang
