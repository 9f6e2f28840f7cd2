// base/memory.h: the huge-page hint changes nothing a program can see.
#include "base/memory.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <numeric>
#include <vector>

#if defined(__linux__) && defined(__GLIBC__)
#include <malloc.h>
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
#endif

}  // namespace
}  // namespace hfrt
