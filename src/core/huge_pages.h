// Large arrays asked for in transparent huge pages (madvise), where the kernel offers them on
// request. A page fault costs microseconds under virtualisation; an array of tens of MB (a
// film, a 1M-triangle build's arrays) faulted in 4 KiB pages spent a visible part of a render
// or a build in the kernel. The advice is a hint: refused, the pages are small ones.
#pragma once

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>

namespace cierzo {

inline constexpr size_t kHugePage = size_t(2) << 20;

// From this size up an array is given whole huge pages (the last one partly unused): one
// fault clears 2 MiB where small pages fault 512 times, at some 10 µs each on the virtual
// machines measured here (a 160x160 render's 1.2 MB splat sums alone cost 3 ms in faults).
inline constexpr size_t kHugePageFrom = size_t(1) << 20;

// `bytes` of memory, uninitialised; from kHugePageFrom up, 2 MiB-aligned and advised into
// huge pages. Freed with free_large(p, bytes).
inline void* allocate_large(size_t bytes) {
    if (bytes < kHugePageFrom) return ::operator new(bytes);
    const size_t rounded = (bytes + kHugePage - 1) / kHugePage * kHugePage;
    void* p = std::aligned_alloc(kHugePage, rounded);
    if (!p) throw std::bad_alloc();
    ::madvise(p, rounded, MADV_HUGEPAGE);
    return p;
}

inline void free_large(void* p, size_t bytes) {
    if (bytes < kHugePageFrom)
        ::operator delete(p);
    else
        std::free(p);
}

// The same request for memory already allocated and not yet touched (a vector reserved): the
// whole 2 MiB pages within [p, p + bytes).
inline void advise_huge_pages(const void* p, size_t bytes) {
    const uintptr_t lo = (reinterpret_cast<uintptr_t>(p) + kHugePage - 1) & ~(kHugePage - 1);
    const uintptr_t hi = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kHugePage - 1);
    if (hi > lo) ::madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
}

// An allocator for large arrays of plain structs whose elements are written before they
// are read: a vector grows without writing its new elements (resize() constructs nothing;
// construction from a value still copies), in huge pages from kHugePageFrom up.
template <class T>
struct Uninitialised {
    using value_type = T;
    template <class U>
    struct rebind {
        using other = Uninitialised<U>;
    };
    Uninitialised() = default;
    template <class U>
    Uninitialised(const Uninitialised<U>&) noexcept {}
    T* allocate(size_t n) { return static_cast<T*>(allocate_large(n * sizeof(T))); }
    void deallocate(T* p, size_t n) noexcept { free_large(p, n * sizeof(T)); }
    template <class U>
    bool operator==(const Uninitialised<U>&) const noexcept {
        return true;
    }
    template <class U>
    void construct(U*) noexcept {
        static_assert(std::is_trivially_copyable_v<U> && std::is_trivially_destructible_v<U>);
    }
    template <class U, class... Args>
    void construct(U* p, Args&&... args) {
        ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
    }
};

}  // namespace cierzo
