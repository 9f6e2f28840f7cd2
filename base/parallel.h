#pragma once
// The few parallel patterns hfrt uses (tiles, chunks, a reduction, two-way recursion, a sort,
// per-thread state), over oneTBB, or — when built with HFRT_STD_THREADS (the `tsan` preset) —
// over plain std::thread. ThreadSanitizer sees every hand-off of the std::thread backend,
// while Debian's libtbb.so is not instrumented: TSan then reports races inside TBB's inlined
// scheduler code that are not there (issue 21), and suppressing TBB's frames would hide the
// races of hfrt's own loop bodies, which run under them. So the sanitizer build runs hfrt's
// threads without TBB, and the release build keeps TBB's work stealing.
//
// Only the folders that link TBB (geom, render, mesher) include this header.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#ifndef HFRT_STD_THREADS
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_arena.h>
#endif

namespace hfrt::par {

#ifdef HFRT_STD_THREADS
namespace detail {
/// Workers of the parallel calls made by this thread (with_threads), and whether it is a
/// worker itself (nested calls then run in the calling thread: no thread explosion).
inline thread_local int t_threads = 0;
inline thread_local bool t_in_worker = false;

inline int hardware_threads() {
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

/// Runs work() on `n` threads (the caller and n - 1 new ones) and joins them.
inline void run_workers(int n, const std::function<void()>& work) {
  const int threads = n;
  std::vector<std::thread> pool;
  for (int i = 1; i < n; ++i) {
    pool.emplace_back([&work, threads] {
      t_in_worker = true;
      t_threads = threads;
      work();
    });
  }
  const bool was = t_in_worker;
  t_in_worker = true;
  work();
  t_in_worker = was;
  for (std::thread& t : pool) t.join();
}
}  // namespace detail
#endif

/// The number of worker threads the machine offers.
inline int default_concurrency() {
#ifdef HFRT_STD_THREADS
  return detail::hardware_threads();
#else
  return tbb::info::default_concurrency();
#endif
}

/// Runs f() so that the parallel calls inside it use exactly `threads` workers (0: all
/// cores; more than the cores is allowed: --threads N means N).
inline void with_threads(int threads, const std::function<void()>& f) {
  if (threads <= 0) threads = default_concurrency();
#ifdef HFRT_STD_THREADS
  const int saved = detail::t_threads;
  detail::t_threads = threads;
  f();
  detail::t_threads = saved;
#else
  // TBB caps workers at the core count unless told otherwise.
  tbb::global_control allow(tbb::global_control::max_allowed_parallelism,
                            std::max<size_t>(size_t(threads), size_t(default_concurrency())));
  tbb::task_arena arena(threads);
  arena.execute(f);
#endif
}

/// Starts the parallel runtime as with_threads(threads, ...) will use it (TBB's scheduler, its
/// allocator and worker threads, which stay for the process), so that the first parallel
/// call that matters does not pay for it: meant for a thread of its own while the caller is
/// busy elsewhere (a JIT compile). Why: TBB's first arena costs ~2.5 ms on the 2-core VM
/// (it reads the CPU topology, loads libtbbmalloc, probes for OpenMP), which the first
/// `hfrt mesh` of a process paid inside the mesher. Nothing to do for the std::thread backend.
inline void warm_up(int threads) {
#ifdef HFRT_STD_THREADS
  (void)threads;
#else
  if (threads <= 0) threads = default_concurrency();
  with_threads(threads, [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, threads, 1),
                      [](const tbb::blocked_range<int>&) {});
  });
#endif
}

/// body(begin, end) over the chunks [k grain, min(n, (k + 1) grain)) of [0, n), each once, in
/// any order and on any worker; returns when all are done.
template <typename Body>
void parallel_for(size_t n, size_t grain, Body&& body) {
  if (n == 0) return;
  grain = std::max<size_t>(grain, 1);
  const size_t chunks = (n + grain - 1) / grain;
#ifdef HFRT_STD_THREADS
  const int workers = detail::t_in_worker
                          ? 1
                          : int(std::min<size_t>(chunks, size_t(detail::t_threads > 0
                                                                    ? detail::t_threads
                                                                    : detail::hardware_threads())));
  std::atomic<size_t> next{0};
  detail::run_workers(workers, [&] {
    for (size_t c = next.fetch_add(1); c < chunks; c = next.fetch_add(1))
      body(c * grain, std::min(n, (c + 1) * grain));
  });
#else
  tbb::parallel_for(tbb::blocked_range<size_t>(0, chunks, 1),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t c = r.begin(); c != r.end(); ++c)
                        body(c * grain, std::min(n, (c + 1) * grain));
                    });
#endif
}

/// join over chunks of [begin, end) (at least `grain` elements each) of body(lo, hi, identity)
/// -> T. join must be associative and commutative: the chunks are joined in any order.
template <typename T, typename Body, typename Join>
T parallel_reduce(size_t begin, size_t end, size_t grain, T identity, Body&& body, Join&& join) {
#ifdef HFRT_STD_THREADS
  const size_t n = end > begin ? end - begin : 0;
  const size_t chunks = (n + grain - 1) / std::max<size_t>(grain, 1);
  std::vector<T> parts(chunks, identity);
  parallel_for(n, grain, [&](size_t lo, size_t hi) {
    parts[lo / std::max<size_t>(grain, 1)] = body(begin + lo, begin + hi, identity);
  });
  T r = identity;
  for (const T& p : parts) r = join(r, p);
  return r;
#else
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(begin, end, grain), identity,
      [&](const tbb::blocked_range<size_t>& r, T acc) { return body(r.begin(), r.end(), acc); },
      join);
#endif
}

/// f() and g(), possibly at the same time.
template <typename F, typename G>
void parallel_invoke(F&& f, G&& g) {
#ifdef HFRT_STD_THREADS
  if (detail::t_in_worker) {
    f();
    g();
    return;
  }
  std::thread other([&] {
    detail::t_in_worker = true;
    f();
  });
  const bool was = detail::t_in_worker;
  detail::t_in_worker = true;
  g();
  detail::t_in_worker = was;
  other.join();
#else
  tbb::parallel_invoke(std::forward<F>(f), std::forward<G>(g));
#endif
}

/// Sorts [first, last) with operator<.
template <typename It>
void parallel_sort(It first, It last) {
#ifdef HFRT_STD_THREADS
  std::sort(first, last);
#else
  tbb::parallel_sort(first, last);
#endif
}

/// One T per worker thread, made on first use by `make`; iterate over them (in no particular
/// order) when the parallel work is done.
template <typename T>
class ThreadLocal {
 public:
  explicit ThreadLocal(std::function<T()> make = [] { return T(); })
#ifdef HFRT_STD_THREADS
      : make_(std::move(make)){}
#else
      : ets_(std::move(make)) {
  }
#endif

        T
        &
        local() {
#ifdef HFRT_STD_THREADS
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = by_thread_.find(std::this_thread::get_id());
    if (it == by_thread_.end()) {
      items_.push_back(std::make_unique<T>(make_()));
      it = by_thread_.emplace(std::this_thread::get_id(), items_.back().get()).first;
    }
    return *it->second;
#else
    return ets_.local();
#endif
  }

  /// f(T&) for every thread's T.
  template <typename F>
  void for_each(F&& f) {
#ifdef HFRT_STD_THREADS
    for (auto& item : items_) f(*item);
#else
    for (T& item : ets_) f(item);
#endif
  }

 private:
#ifdef HFRT_STD_THREADS
  std::function<T()> make_;
  std::mutex mutex_;
  std::unordered_map<std::thread::id, T*> by_thread_;
  std::vector<std::unique_ptr<T>> items_;
#else
  tbb::enumerable_thread_specific<T> ets_;
#endif
};

}  // namespace hfrt::par
