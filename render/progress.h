#pragma once
// A progress bar on stderr for long renders: tiles done, percentage and ETA. It stays silent
// for the first second (short renders print nothing) and when disabled (stderr not a terminal).

#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace hfrt::render {

class ProgressBar {
 public:
  /// `enabled` is normally isatty(STDERR_FILENO).
  ProgressBar(std::string label, bool enabled);
  ~ProgressBar() { finish(); }

  /// Thread-safe; redraws at most about ten times a second.
  void update(size_t done, size_t total);
  /// Clears the bar (if one was drawn). Idempotent.
  void finish();

 private:
  std::string label_;
  bool enabled_;
  bool drawn_ = false;
  std::mutex mutex_;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace hfrt::render
