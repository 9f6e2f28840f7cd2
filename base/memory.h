#pragma once
// Large arrays and the kernel's pages: asking for transparent huge pages where a big array is
// about to be filled once.

#include <cstddef>
#include <memory>
#include <new>
#include <type_traits>
#include <utility>

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

/// An allocator whose value-less construct default-initialises (a trivial element is left as
/// it is): resize() of a vector about to be overwritten element by element writes nothing.
/// Why: a 512^3 mesh's 32 MiB of triangles were zeroed by one thread before the threads
/// wrote them; now the threads that write them are the first to touch them.
template <typename T, typename Base = std::allocator<T>>
struct DefaultInitAllocator : Base {
  using Base::Base;
  template <typename U>
  struct rebind {
    using other =
        DefaultInitAllocator<U, typename std::allocator_traits<Base>::template rebind_alloc<U>>;
  };
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    std::allocator_traits<Base>::construct(static_cast<Base&>(*this), p,
                                           std::forward<Args>(args)...);
  }
};

}  // namespace hfrt
