#pragma once
// Wall-clock timing for statistics (`--stats`, the REPL's `:stats`, benchmarks): one clock,
// milliseconds as double, so every figure hfrt prints is measured the same way.

#include <chrono>

namespace hfrt {

using Clock = std::chrono::steady_clock;

/// Milliseconds elapsed since t0 on the steady clock.
inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace hfrt
