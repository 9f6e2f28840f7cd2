// Diagnostic collection and gcc/clang-style rendering.
#include "lang/diagnostics.h"

#include <algorithm>

namespace hfrt::lang {
namespace {

// Lines longer than this are shown as a window around the diagnostic so that a
// one-line 10 MB file does not print 10 MB per message.
constexpr uint32_t kMaxShownLine = 160;
constexpr uint32_t kWindowBefore = 80;

const char* severity_name(Severity s) {
  switch (s) {
    case Severity::kError:
      return "error";
    case Severity::kWarning:
      return "warning";
    case Severity::kNote:
      return "note";
  }
  return "error";
}

const char* severity_color(Severity s) {
  switch (s) {
    case Severity::kError:
      return "\033[1;31m";
    case Severity::kWarning:
      return "\033[1;35m";
    case Severity::kNote:
      return "\033[1;36m";
  }
  return "";
}

bool is_utf8_continuation(char c) {
  return (static_cast<unsigned char>(c) & 0xC0) == 0x80;
}

}  // namespace

void DiagnosticSink::error(SourceRange range, std::string message, std::string hint) {
  if (error_count_ >= kMaxErrors) {
    if (!truncated_) {
      truncated_ = true;
      diags_.push_back(
          {Severity::kNote,
           range,
           "too many errors (" + std::to_string(kMaxErrors) + "); stopping here — fix these first",
           {}});
    }
    return;
  }
  ++error_count_;
  diags_.push_back({Severity::kError, range, std::move(message), std::move(hint)});
}

void DiagnosticSink::warning(SourceRange range, std::string message, std::string hint) {
  if (warning_count_ >= kMaxWarnings || truncated_) return;
  ++warning_count_;
  diags_.push_back({Severity::kWarning, range, std::move(message), std::move(hint)});
}

void DiagnosticSink::note(SourceRange range, std::string message) {
  if (truncated_) return;
  diags_.push_back({Severity::kNote, range, std::move(message), {}});
}

std::string DiagnosticSink::render(bool color) const {
  std::string out;
  for (const Diagnostic& d : diags_) out += render_diagnostic(*file_, d, color);
  return out;
}

std::string render_brief(std::string_view where, Severity severity, std::string_view message,
                         std::string_view hint) {
  std::string out;
  out += where;
  out += ": ";
  out += severity_name(severity);
  out += ": ";
  out += message;
  out += '\n';
  if (!hint.empty()) {
    out += "  hint: ";
    out += hint;
    out += '\n';
  }
  return out;
}

std::string render_diagnostic(const SourceFile& file, const Diagnostic& diag, bool color) {
  const char* bold = color ? "\033[1m" : "";
  const char* reset = color ? "\033[0m" : "";
  std::string out;
  out += bold;
  out += file.name();
  if (diag.range.begin.valid()) {
    out += ':' + std::to_string(diag.range.begin.line) + ':' + std::to_string(diag.range.begin.col);
  }
  out += ": ";
  out += reset;
  if (color) out += severity_color(diag.severity);
  out += severity_name(diag.severity);
  out += ": ";
  out += reset;
  out += bold;
  out += diag.message;
  out += reset;
  out += '\n';

  if (diag.range.begin.valid()) {
    std::string_view line = file.line_text(diag.range.begin.line);
    uint32_t col0 =
        std::min<uint32_t>(diag.range.begin.col - 1, static_cast<uint32_t>(line.size()));
    // Show at most kMaxShownLine bytes around the caret.
    uint32_t first = 0, last = static_cast<uint32_t>(line.size());
    if (line.size() > kMaxShownLine) {
      first = col0 > kWindowBefore ? col0 - kWindowBefore : 0;
      last = std::min<uint32_t>(last, first + kMaxShownLine);
      while (first > 0 && is_utf8_continuation(line[first])) --first;
    }
    std::string shown, caret;
    if (first > 0) {
      shown += "...";
      caret += "   ";
    }
    for (uint32_t i = first; i < last; ++i) {
      char c = line[i];
      // Control bytes (binary input) must not reach the terminal.
      bool control = (static_cast<unsigned char>(c) < 0x20 && c != '\t') || c == 0x7F;
      shown += control ? ' ' : c;
      if (i < col0 && !is_utf8_continuation(c)) caret += c == '\t' ? '\t' : ' ';
    }
    if (last < line.size()) shown += "...";
    uint32_t len = std::max<uint32_t>(diag.range.length, 1);
    uint32_t underline_end = std::min<uint32_t>(col0 + len, std::max(last, col0 + 1));
    if (color) caret += "\033[1;32m";
    caret += '^';
    for (uint32_t i = col0 + 1; i < underline_end; ++i) {
      if (i < line.size() && is_utf8_continuation(line[i])) continue;
      caret += '~';
    }
    caret += reset;
    out += ' ';
    out += shown;
    out += "\n ";
    out += caret;
    out += '\n';
  }
  if (!diag.hint.empty()) {
    if (color) out += "\033[1;36m";
    out += "hint: ";
    out += reset;
    out += diag.hint;
    out += '\n';
  }
  return out;
}

}  // namespace hfrt::lang
