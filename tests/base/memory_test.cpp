// base/memory.h: the huge-page hint changes nothing a program can see.
#include "base/memory.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <vector>

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

}  // namespace
}  // namespace hfrt
