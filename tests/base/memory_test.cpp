// base/memory.h: the huge-page hint changes nothing a program can see.
#include "base/memory.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <numeric>
#include <vector>

#if defined(__linux__) && defined(__GLIBC__)
#include <malloc.h>
#include <sys/resource.h>
#endif

namespace hfrt {
namespace {

TEST(Memory, ReserveHugeReservesAndKeepsTheContents) {
  // 8 MiB: above the 4 MiB threshold, so madvise is asked on Linux.
  const size_t n = size_t(2) << 20;
  std::vector<uint32_t> v = {7, 8, 9};
  reserve_huge(v, n);
  EXPECT_GE(v.capacity(), n);
  ASSERT_EQ(v.size(), 3u);
  EXPECT_EQ(v[0], 7u);
  EXPECT_EQ(v[2], 9u);
  v.resize(n);
  std::iota(v.begin(), v.end(), 0u);
  EXPECT_EQ(v[n - 1], uint32_t(n - 1));
}

TEST(Memory, AdviceOnSmallOddOrNoRangesIsHarmless) {
  std::vector<char> small(100, 'a');
  advise_huge_pages(small.data(), small.size());
  advise_huge_pages(nullptr, size_t(64) << 20);
  std::vector<char> big((size_t(5) << 20) + 3, 'b');
  advise_huge_pages(big.data() + 1, big.size() - 1);  // not page aligned
  EXPECT_EQ(small[99], 'a');
  EXPECT_EQ(big[big.size() - 1], 'b');
}

/// The kernel's THP mode where malloc needs the advice, and the tunables hfrt then adds.
constexpr const char* kMadvise = "always [madvise] never\n";
const std::string kBoth =
    "glibc.malloc.hugetlb=1:glibc.malloc.mmap_threshold=33554432:glibc.malloc.top_pad=16777216";

TEST(Memory, HugePageTunablesOnlyInMadviseModeAndOnlyOnce) {
  EXPECT_EQ(huge_page_malloc_tunables(nullptr, kMadvise), kBoth);
  EXPECT_EQ(huge_page_malloc_tunables("", kMadvise), kBoth);
  // The user's other tunables are kept, and their own mmap threshold too.
  EXPECT_EQ(huge_page_malloc_tunables("glibc.malloc.arena_max=2", kMadvise),
            "glibc.malloc.arena_max=2:" + kBoth);
  EXPECT_EQ(
      huge_page_malloc_tunables("glibc.malloc.mmap_threshold=65536", kMadvise),
      "glibc.malloc.mmap_threshold=65536:glibc.malloc.hugetlb=1:glibc.malloc.top_pad=16777216");
  EXPECT_EQ(huge_page_malloc_tunables("glibc.malloc.top_pad=0", kMadvise),
            "glibc.malloc.top_pad=0:glibc.malloc.hugetlb=1:glibc.malloc.mmap_threshold=33554432");
  // Already set (by the user, or by the exec before): no change, so no second exec.
  EXPECT_EQ(huge_page_malloc_tunables(kBoth.c_str(), kMadvise), std::nullopt);
  EXPECT_EQ(huge_page_malloc_tunables("glibc.malloc.hugetlb=0", kMadvise), std::nullopt);
  // "always": malloc gets huge pages without advice; "never": it cannot; unreadable: unknown.
  EXPECT_EQ(huge_page_malloc_tunables(nullptr, "[always] madvise never\n"), std::nullopt);
  EXPECT_EQ(huge_page_malloc_tunables(nullptr, "always madvise [never]\n"), std::nullopt);
  EXPECT_EQ(huge_page_malloc_tunables(nullptr, ""), std::nullopt);
}

TEST(Memory, OneArenaUnlessTheUserSetAMaximum) {
  EXPECT_EQ(huge_page_malloc_tunables(nullptr, kMadvise, true),
            kBoth + ":glibc.malloc.arena_max=1");
  EXPECT_EQ(huge_page_malloc_tunables("glibc.malloc.arena_max=4", kMadvise, true),
            "glibc.malloc.arena_max=4:" + kBoth);
  EXPECT_EQ(huge_page_malloc_tunables(nullptr, kMadvise, false), kBoth);
  // Nothing changes where huge pages are already asked for: no exec only for the arena.
  EXPECT_EQ(huge_page_malloc_tunables(kBoth.c_str(), kMadvise, true), std::nullopt);
}

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define HFRT_TEST_OWN_MALLOC 1  // the sanitizer's allocator, which mallinfo2 does not describe
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define HFRT_TEST_OWN_MALLOC 1
#endif
#if defined(__linux__) && defined(__GLIBC__) && !defined(HFRT_TEST_OWN_MALLOC)
/// keep_large_blocks_on_heap: a block of a few MiB then comes from malloc's heap, not from a
/// mmap of its own (mallinfo2's hblks counts those). Without the call glibc maps it (above its
/// threshold: 128 KiB at first, raised to a freed mapped block's size).
TEST(Memory, LargeBlocksStayOnTheHeap) {
  if (const char* t = std::getenv("GLIBC_TUNABLES");
      t && std::string(t).find("mmap_threshold") != std::string::npos) {
    GTEST_SKIP() << "GLIBC_TUNABLES sets the threshold: " << t;
  }
  const size_t before = mallinfo2().hblks;
  void* mapped = std::malloc(size_t(4) << 20);
  ASSERT_NE(mapped, nullptr);
  EXPECT_EQ(mallinfo2().hblks, before + 1);  // the default: a mmap of its own
  std::free(mapped);
  keep_large_blocks_on_heap();
  // 16 MiB: above the 4 MiB to which freeing the mapped block raised glibc's own threshold.
  const size_t after = mallinfo2().hblks;
  void* kept = std::malloc(size_t(16) << 20);
  ASSERT_NE(kept, nullptr);
  EXPECT_EQ(mallinfo2().hblks, after);
  std::free(kept);
}

#if !defined(HFRT_TEST_OWN_MALLOC)
long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}
/// The page faults of writing one byte per 4 KiB page of [p, p + n).
long touch_faults(char* p, size_t n) {
  const long before = minor_faults();
  volatile char* v = p;
  for (size_t at = 0; at < n; at += 4096) v[at] = 1;
  return minor_faults() - before;
}

/// HeapPrefault: with malloc on huge pages (hfrt's tunables, as `hfrt mesh` runs), the next
/// block of its size lands on the pages it faulted in (no fault), where one past it still
/// faults; without them it does nothing. CTest runs this test both ways
/// (hfrt_base_test.HeapPrefaultWithHugePageMalloc sets the tunables and
/// HFRT_TEST_EXPECT_HUGE_MALLOC=1).
TEST(Memory, HeapPrefaultKeepsItsPagesForTheNextBlock) {
  constexpr size_t kBytes = size_t(24) << 20;  // more than the top pad malloc keeps anyway
  if (std::getenv("HFRT_TEST_EXPECT_HUGE_MALLOC")) {
    ASSERT_TRUE(malloc_on_huge_pages());
  }
  if (!malloc_on_huge_pages()) {
    HeapPrefault none(kBytes);
    none.touch();
    EXPECT_EQ(none.size(), 0u);
    return;
  }
  {
    HeapPrefault pre(kBytes);
    ASSERT_EQ(pre.size(), kBytes);
    pre.touch();
  }
  char* kept = static_cast<char*>(std::malloc(kBytes));  // where the prefault's block was
  ASSERT_NE(kept, nullptr);
  const long kept_faults = touch_faults(kept, kBytes);
  char* fresh = static_cast<char*>(std::malloc(kBytes));  // past it: pages never touched
  ASSERT_NE(fresh, nullptr);
  const long fresh_faults = touch_faults(fresh, kBytes);
  std::free(fresh);
  std::free(kept);
  EXPECT_EQ(kept_faults, 0);
  EXPECT_GT(fresh_faults, 0);
  // More than the heap serves: cut to 31 MiB, not refused.
  HeapPrefault big(size_t(64) << 20);
  EXPECT_EQ(big.size(), size_t(31) << 20);
}
#endif
#endif

}  // namespace
}  // namespace hfrt
