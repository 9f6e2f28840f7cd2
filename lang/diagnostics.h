#pragma once
// User source errors and warnings: collected, located, each with a message that says what to do.
// (Environment failures use Result types; broken invariants are HFRT_CHECK aborts.)

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "lang/source.h"

namespace hfrt::lang {

enum class Severity { kError, kWarning, kNote };

/// One diagnostic. `message` is one line; `hint` (optional) says how to fix it.
struct Diagnostic {
  Severity severity = Severity::kError;
  SourceRange range;
  std::string message;
  std::string hint;
};

/// Collects the diagnostics of one compilation. Errors stop being recorded after
/// `kMaxErrors` (the 21st error records a single "too many errors" note) so that a garbage
/// file cannot produce megabytes of output.
class DiagnosticSink {
 public:
  static constexpr int kMaxErrors = 20;
  /// Warnings beyond this many are dropped silently (a generated file can repeat one
  /// warning thousands of times; the first ones say all there is to say).
  static constexpr int kMaxWarnings = 100;

  explicit DiagnosticSink(std::shared_ptr<const SourceFile> file) : file_(std::move(file)) {}

  void error(SourceRange range, std::string message, std::string hint = {});
  void warning(SourceRange range, std::string message, std::string hint = {});
  void note(SourceRange range, std::string message);

  bool has_errors() const { return error_count_ > 0; }
  int error_count() const { return error_count_; }
  int warning_count() const { return warning_count_; }
  /// True once the error limit is reached: the parser uses it to stop early.
  bool saturated() const { return error_count_ >= kMaxErrors; }
  /// True once an error beyond the limit was dropped (and the "too many errors" note
  /// recorded): nothing more will be shown, so producers can stop.
  bool truncated() const { return truncated_; }
  const std::vector<Diagnostic>& diagnostics() const { return diags_; }
  const std::shared_ptr<const SourceFile>& file() const { return file_; }

  /// Renders all diagnostics as `file:line:col: error: message`, the source line, a caret
  /// line underlining the range and the hint. `color` adds ANSI colours (for terminals).
  std::string render(bool color = false) const;

 private:
  std::shared_ptr<const SourceFile> file_;
  std::vector<Diagnostic> diags_;
  int error_count_ = 0;
  int warning_count_ = 0;
  bool truncated_ = false;
};

/// The brief form of a diagnostic, without the source excerpt: `where: severity: message` and,
/// when there is a hint, `  hint: hint` on the next line (each line ends with a newline).
/// `where` is `file`, `file:line:col` or any other location text. For diagnostics whose
/// source is not at hand (the REPL's re-located ones, a missing object).
std::string render_brief(std::string_view where, Severity severity, std::string_view message,
                         std::string_view hint = {});

/// Renders one diagnostic against `file` (shared by the sink and by run-time error reports).
std::string render_diagnostic(const SourceFile& file, const Diagnostic& diag, bool color);

}  // namespace hfrt::lang
