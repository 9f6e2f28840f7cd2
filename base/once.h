#pragma once
// A once-only action whose settled state costs one atomic load.

#include <atomic>
#include <mutex>
#include <utility>

namespace hfrt {

/// std::call_once with a fast path once settled: call() runs its action exactly once, on the
/// first caller's thread (callers meanwhile wait for it), and afterwards returns after one
/// acquire load. Why not std::call_once alone: libstdc++'s sets two thread-local variables on
/// every call, each a __tls_get_addr in a shared library, also when the flag is long settled;
/// on hot paths (every evaluator call, every ray of the analytic search) that was 1-2 % of a
/// patch render's instructions. An action that throws leaves it unsettled, as call_once does.
class SettledOnce {
 public:
  template <typename F>
  void call(F&& action) {
    if (done()) return;
    std::call_once(once_, [&] {
      std::forward<F>(action)();
      done_.store(true, std::memory_order_release);
    });
  }
  /// Whether the action has run to its end (never runs it).
  bool done() const { return done_.load(std::memory_order_acquire); }

 private:
  std::once_flag once_;
  std::atomic<bool> done_{false};
};

}  // namespace hfrt
