#include "base/memory.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>

#if defined(__linux__)
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace hfrt {

void advise_huge_pages(void* p, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr size_t kMin = size_t(4) << 20;  // below this the faults are few anyway
  constexpr uintptr_t kPage = 4096;
  if (p == nullptr || bytes < kMin) return;
  // madvise wants page-aligned ranges: the whole pages inside [p, p + bytes).
  const uintptr_t lo = (reinterpret_cast<uintptr_t>(p) + kPage - 1) & ~(kPage - 1);
  const uintptr_t hi = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kPage - 1);
  if (hi > lo) (void)madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#else
  (void)p;
  (void)bytes;
#endif
}

namespace {
constexpr std::string_view kHugetlbTunable = "glibc.malloc.hugetlb";
constexpr std::string_view kMmapThresholdTunable = "glibc.malloc.mmap_threshold";
constexpr std::string_view kArenaMaxTunable = "glibc.malloc.arena_max";
constexpr std::string_view kTopPadTunable = "glibc.malloc.top_pad";
constexpr std::string_view kTrimThresholdTunable = "glibc.malloc.trim_threshold";
/// The largest block served from malloc's heaps (32 MiB is glibc's own ceiling for its moving
/// threshold), and the heap's growth step and kept top: for GLIBC_TUNABLES and for mallopt.
constexpr int kHeapBlockMax = 32 << 20;
constexpr int kHeapTopPad = 16 << 20;

/// Whether GLIBC_TUNABLES (the user's, or reexec_with_huge_page_malloc's) sets `name`: such a
/// setting is kept, not overridden by mallopt.
[[maybe_unused]] bool tunable_set(std::string_view name) {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  return tunables && std::string_view(tunables).find(name) != std::string_view::npos;
}
}  // namespace

std::optional<std::string> huge_page_malloc_tunables(const char* current, std::string_view thp_mode,
                                                     bool one_arena) {
  if (thp_mode.find("[madvise]") == std::string_view::npos) return std::nullopt;
  const std::string_view now = current ? current : "";
  if (now.find(kHugetlbTunable) != std::string_view::npos) return std::nullopt;
  std::string value(now);
  auto add = [&](std::string_view name, std::string_view v) {
    if (!value.empty()) value += ':';
    value += name;
    value += '=';
    value += v;
  };
  add(kHugetlbTunable, "1");
  // Blocks up to 32 MiB from malloc's heaps, which hugetlb=1 grows in huge pages, instead of
  // an mmap of their own each (the default above 128 KiB), whose 4 KiB pages a block of 1 MiB
  // must fault in one by one (32 MiB is glibc's own ceiling for its moving threshold).
  if (now.find(kMmapThresholdTunable) == std::string_view::npos)
    add(kMmapThresholdTunable, std::to_string(kHeapBlockMax));
  // The main heap grown 16 MiB at a time instead of by what each request needs plus 128 KiB:
  // the kernel backs a madvised range with a huge page only where a whole aligned 2 MiB lies
  // inside the mapping, so a heap that creeps up by small steps gets 4 KiB pages at its top.
  // The 512^3 blend's mesher took ~550 faults of 4 KiB in its octree (its level arrays of
  // ~1 MiB), ~11 ms of its 0.075 s, and 336 more in its blocks; with this, ~200 and ~10
  // (getrusage). Only address space: pages are still faulted in when first touched.
  if (now.find(kTopPadTunable) == std::string_view::npos) {
    add(kTopPadTunable, std::to_string(kHeapTopPad));
  }
  if (one_arena && now.find(kArenaMaxTunable) == std::string_view::npos) add(kArenaMaxTunable, "1");
  return value;
}

void reexec_with_huge_page_malloc(char** argv, bool one_arena) {
#if defined(__linux__) && defined(__GLIBC__) && \
    (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 35))
  const char* opt = std::getenv("HFRT_MALLOC_HUGEPAGES");
  if (opt && std::strcmp(opt, "0") == 0) return;
  std::ifstream mode_file("/sys/kernel/mm/transparent_hugepage/enabled");
  if (!mode_file) return;
  const std::string mode((std::istreambuf_iterator<char>(mode_file)),
                         std::istreambuf_iterator<char>());
  const char* current = std::getenv("GLIBC_TUNABLES");
  const std::optional<std::string> previous =
      current ? std::optional<std::string>(current) : std::nullopt;
  const std::optional<std::string> value = huge_page_malloc_tunables(current, mode, one_arena);
  if (!value) return;
  if (setenv("GLIBC_TUNABLES", value->c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // The exec failed (no /proc, say): go on as before, with the environment as it was.
  if (previous) {
    setenv("GLIBC_TUNABLES", previous->c_str(), 1);
  } else {
    unsetenv("GLIBC_TUNABLES");
  }
#else
  (void)argv;
  (void)one_arena;
#endif
}

void keep_large_blocks_on_heap() {
#if defined(__linux__) && defined(__GLIBC__)
  if (!tunable_set(kMmapThresholdTunable)) mallopt(M_MMAP_THRESHOLD, kHeapBlockMax);
  if (!tunable_set(kTopPadTunable)) mallopt(M_TOP_PAD, kHeapTopPad);
#endif
}

HeapPrefault::HeapPrefault(size_t bytes) {
#if defined(__linux__) && defined(__GLIBC__)
  if (bytes == 0 || !malloc_on_huge_pages()) return;
  bytes = std::min(bytes, size_t(kHeapBlockMax - (1 << 20)));  // served from the heap
  // Kept when handed back: by default malloc trims its heap's top down to the top pad as soon
  // as the top exceeds 128 KiB.
  if (!tunable_set(kTrimThresholdTunable))
    mallopt(M_TRIM_THRESHOLD, int(bytes) + kHeapTopPad + kHeapBlockMax);
  block_ = static_cast<char*>(std::malloc(bytes));
  if (block_) bytes_ = bytes;
#else
  (void)bytes;
#endif
}

void HeapPrefault::touch() const {
  // (Volatile: the writes are there for the pages they fault in, never read.)
  volatile char* p = block_;
  for (size_t at = 0; at < bytes_; at += 4096) p[at] = 0;
}

HeapPrefault::~HeapPrefault() {
  std::free(block_);
}

bool malloc_on_huge_pages() {
  const char* v = std::getenv("GLIBC_TUNABLES");
  if (!v) return false;
  const std::string_view s = v;
  const std::string key = std::string(kHugetlbTunable) + "=1";
  for (size_t at = s.find(key); at != std::string_view::npos; at = s.find(key, at + 1)) {
    const size_t end = at + key.size();
    if ((at == 0 || s[at - 1] == ':') && (end == s.size() || s[end] == ':')) return true;
  }
  return false;
}

std::string malloc_pages_stats_line() {
  if (!malloc_on_huge_pages()) return "stats: memory: malloc on the kernel's default pages\n";
  return "stats: memory: malloc on transparent huge pages (GLIBC_TUNABLES=" +
         std::string(std::getenv("GLIBC_TUNABLES")) + ")\n";
}

}  // namespace hfrt
