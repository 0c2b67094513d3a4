// Scratch memory for the simplifiers' working arrays (Scratch<T>, a std::vector on it). Where the
// caller passed a SimplifyScratch (SimplifyOptions::scratch), a ScratchScope names its cache for
// the calling thread for the duration of the call, and large blocks come from that cache and go
// back to it, so simplifying mesh after mesh (the levels of a LOD chain, a scene's meshes, a
// benchmark's runs) reuses pages already mapped instead of faulting tens of megabytes in again
// (the C library returns freed large blocks to the system). Without a scope (no SimplifyScratch,
// or another thread: the helper) the blocks come from operator new and go back to operator
// delete: the library keeps no memory between calls of its own accord.
//
// Blocks of 64 KiB and more are rounded up to a power of two and, when freed within a scope,
// kept for the next request of the same size while the cache holds at most kScratchKeepBytes;
// smaller requests and what does not fit go to operator new / delete as usual.
// Cost: O(cached blocks) per large allocation (a few dozen at most), nothing per element.
#pragma once

#include <cstddef>
#include <new>
#include <utility>
#include <vector>

#include "hmdnode/lod/simplify.hpp"

namespace hmdnode::lod_detail {

inline constexpr size_t kScratchKeepBytes = size_t(64) << 20;

// The blocks a SimplifyScratch keeps.
struct ScratchCache {
    std::vector<std::pair<size_t, void*>> blocks;  // (size, block)
    size_t bytes = 0;
    ScratchCache() = default;
    ScratchCache(const ScratchCache&) = delete;
    ScratchCache& operator=(const ScratchCache&) = delete;
    ~ScratchCache();
};

// For its lifetime, scratch blocks allocated or freed on this thread use `scratch`'s cache
// (nullptr: none). Scopes nest; the innermost wins.
class ScratchScope {
  public:
    explicit ScratchScope(SimplifyScratch* scratch);
    ~ScratchScope();
    ScratchScope(const ScratchScope&) = delete;
    ScratchScope& operator=(const ScratchScope&) = delete;

  private:
    ScratchCache* previous_;
};

void* scratch_allocate(size_t bytes);
void scratch_free(void* p, size_t bytes) noexcept;

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
