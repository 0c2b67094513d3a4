// Scratch memory for the simplifiers' working arrays: a per-thread cache of large blocks, so that
// simplifying mesh after mesh (the levels of a LOD chain, a scene's meshes, a benchmark's runs)
// reuses pages already mapped instead of faulting tens of megabytes in again on every call (the
// C library returns freed large blocks to the system).
//
// Blocks of 64 KiB and more are rounded up to a power of two and, when freed, kept for the next
// request of the same size while the thread keeps at most kScratchKeepBytes; smaller requests and
// what does not fit go to operator new / delete as usual. The cache is freed when its thread ends
// (a block freed after that, during the thread's exit, goes straight back to operator delete).
// Cost: O(cached blocks) per large allocation (a few dozen at most), nothing per element.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

namespace hmdnode::lod_detail {

inline constexpr size_t kScratchKeepBytes = size_t(64) << 20;

void* scratch_allocate(size_t bytes);
void scratch_free(void* p, size_t bytes) noexcept;
// Bytes the calling thread keeps cached (for tests).
size_t scratch_cached_bytes() noexcept;

template <class T>
struct ScratchAllocator {
    using value_type = T;
    ScratchAllocator() = default;
    template <class U>
    ScratchAllocator(const ScratchAllocator<U>&) noexcept {}
    T* allocate(size_t n) {
        if (n > size_t(-1) / sizeof(T)) throw std::bad_array_new_length();
        return static_cast<T*>(scratch_allocate(n * sizeof(T)));
    }
    void deallocate(T* p, size_t n) noexcept { scratch_free(p, n * sizeof(T)); }
    template <class U>
    bool operator==(const ScratchAllocator<U>&) const noexcept {
        return true;
    }
};

// A std::vector on scratch memory.
template <class T>
using Scratch = std::vector<T, ScratchAllocator<T>>;

}  // namespace hmdnode::lod_detail
