#pragma once
// Large arrays and the kernel's pages: asking for transparent huge pages where a big array is
// about to be filled once.

#include <cstddef>
#include <memory>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace hfrt {

/// Asks the kernel to back [p, p + bytes) with transparent huge pages (Linux MADV_HUGEPAGE;
/// nothing elsewhere, for ranges under 4 MiB, or where the kernel says no). Why: a fresh
/// 32 MiB array written once takes ~8000 page faults of 4 KiB, each zeroing a page and
/// charging it to the memory cgroup; on the 2-core VM that was ~15 % of a 512^3 mesh. With
/// huge pages it is ~16. Only a hint: the contents and the program's meaning do not change.
void advise_huge_pages(void* p, size_t bytes);

/// The GLIBC_TUNABLES value that puts glibc's malloc on transparent huge pages
/// (`glibc.malloc.hugetlb=1`, glibc >= 2.35: its heaps and its mmap'ed chunks are advised
/// MADV_HUGEPAGE), serves blocks up to 32 MiB from its heaps (`glibc.malloc.mmap_threshold`,
/// unless the user set one: a block mmap'ed on its own below 2 MiB cannot get a huge page)
/// and grows its main heap 16 MiB at a time (`glibc.malloc.top_pad`, unless the user set it: a
/// heap grown by small steps keeps 4 KiB pages at its top),
/// given the variable's current value (nullptr: unset) and the kernel's THP mode (the contents
/// of /sys/kernel/mm/transparent_hugepage/enabled, e.g. "always [madvise] never").
/// std::nullopt when nothing is to change: THP is not in madvise mode (with "always" malloc gets
/// huge pages anyway, with "never" it cannot), or glibc.malloc.hugetlb is already set, by the
/// user or by an earlier exec. Other tunables in the value are kept.
/// `one_arena`: also one malloc arena for all threads (`glibc.malloc.arena_max=1`, unless the
/// user set a maximum), for processes whose threads allocate little while they run (`hfrt
/// render`: tools/hfrt/main.cpp): each further arena is a heap of its own, whose memory
/// other threads never reuse and which its trims hand back to the kernel, so that it is faulted
/// in (and, in huge pages, zeroed 2 MiB at a time) again.
std::optional<std::string> huge_page_malloc_tunables(const char* current, std::string_view thp_mode,
                                                     bool one_arena = false);

/// Re-executes this program (/proc/self/exe, the same arguments and environment) with
/// GLIBC_TUNABLES from huge_page_malloc_tunables, so that every allocation of the process
/// touches 2 MiB pages instead of 4 KiB ones. Returns (and the program goes on as it is) where
/// that is not possible or not wanted: not Linux with glibc, HFRT_MALLOC_HUGEPAGES=0 in the
/// environment, nothing to change, or the exec failed. Why: on the 2-core VM a page fault costs
/// several microseconds; `hfrt mesh` of the 512^3 gyroid spent 1.0-1.4 s of its 2.2-2.8 s in
/// the kernel, faulting in the mesher's arrays, the aiScene and Assimp's copy of it; with this,
/// 1.3-1.8 s in all (bench/README.md, "Memory"). The variable stays set for child processes,
/// where it only gives the same advice.
/// Call first thing in main(), before any thread starts.
void reexec_with_huge_page_malloc(char** argv, bool one_arena = false);

/// Keeps malloc's large blocks (up to 32 MiB) on its heap, and the heap's freed top (16 MiB of
/// padding) mapped, for the rest of the process (glibc's mallopt M_MMAP_THRESHOLD and
/// M_TOP_PAD; nothing elsewhere, or where GLIBC_TUNABLES already set them). For long-running
/// processes that allocate and free the same large buffers again and again (the REPL's
/// renders and PNG writes): by default each such block is a fresh mmap whose pages are faulted
/// in and zeroed anew, several microseconds a page on the 2-core VM (a 512x512 PNG write took
/// 7-8 ms of a c1_gear edit, ~4 ms with this).
void keep_large_blocks_on_heap();

/// Faults in a block of malloc's heap ahead of a phase that will fill fresh large arrays, so
/// that they land on pages the kernel has already mapped: the constructor allocates the block
/// (from the calling thread's arena: call it on the thread that will allocate the arrays),
/// touch() writes one byte per 4 KiB page (from any thread: one that is otherwise idle, while
/// the caller compiles), and the destructor hands the block back with malloc's trim
/// threshold raised, so that malloc keeps its pages for the next allocations. Why: a fresh
/// process's 512^3 mesh of the blend faulted in ~24 MB of new arrays inside its own time (huge
/// pages when the kernel has them free, 4 KiB ones otherwise): 0.046-0.049 s, and
/// 0.042-0.046 s with this beside the compile (bench/README.md). Does nothing (and touch()
/// nothing) unless malloc is on huge pages (malloc_on_huge_pages(): hfrt's tunables serve
/// blocks up to 32 MiB from the heap; otherwise the block would be mmap'ed on its own and
/// unmapped when freed) and glibc on Linux; `bytes` is cut to 31 MiB. The trim threshold
/// is left as the user set it in GLIBC_TUNABLES, if they did. For processes of their own
/// (hfrt mesh): it changes the process's malloc settings.
class HeapPrefault {
 public:
  explicit HeapPrefault(size_t bytes);
  ~HeapPrefault();
  HeapPrefault(const HeapPrefault&) = delete;
  HeapPrefault& operator=(const HeapPrefault&) = delete;
  void touch() const;
  /// The bytes held (0 where nothing is done).
  size_t size() const { return bytes_; }

 private:
  char* block_ = nullptr;
  size_t bytes_ = 0;
};

/// Whether this process's malloc was started on huge pages (GLIBC_TUNABLES has
/// glibc.malloc.hugetlb=1), for --stats.
bool malloc_on_huge_pages();

/// The --stats line that says which pages malloc uses: "stats: memory: malloc on transparent
/// huge pages (GLIBC_TUNABLES=...)" or "stats: memory: malloc on the kernel's default pages",
/// with its newline.
std::string malloc_pages_stats_line();

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
