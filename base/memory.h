#pragma once
// Large arrays and the kernel's pages: asking for transparent huge pages where a big array is
// about to be filled once.

#include <cstddef>

namespace hfrt {

/// Asks the kernel to back [p, p + bytes) with transparent huge pages (Linux MADV_HUGEPAGE;
/// nothing elsewhere, for ranges under 4 MiB, or where the kernel says no). Why: a fresh
/// 32 MiB array written once takes ~8000 page faults of 4 KiB, each zeroing a page and
/// charging it to the memory cgroup; on the 2-core VM that was ~15 % of a 512^3 mesh. With
/// huge pages it is ~16. Only a hint: the contents and the program's meaning do not change.
void advise_huge_pages(void* p, size_t bytes);

/// v.reserve(n), then advise_huge_pages on its storage: call before the first fill of a
/// large vector (resize, push_back, insert), so that the fill touches huge pages.
template <typename Vector>
void reserve_huge(Vector& v, size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(*v.data()));
}

}  // namespace hfrt
