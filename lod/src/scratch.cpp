// Per-thread cache of large scratch blocks; see scratch.hpp.
#include "scratch.hpp"

#include <bit>
#include <cstdint>
#include <utility>

namespace hmdnode::lod_detail {
namespace {

constexpr size_t kMinCached = size_t(64) << 10;
constexpr std::align_val_t kAlign{64};  // note: a cache line, for the per-element arrays

// note: trivially destructible, so it stays readable after the thread's Cache is gone (a scratch
// array freed later in that thread's exit then bypasses the cache).
thread_local bool t_cache_gone = false;

struct Cache {
    std::vector<std::pair<size_t, void*>> blocks;  // (size, block)
    size_t bytes = 0;
    ~Cache() {
        for (const auto& [size, p] : blocks) ::operator delete(p, kAlign);
        t_cache_gone = true;
    }
};

// nullptr once the calling thread's cache was destroyed.
Cache* cache() {
    if (t_cache_gone) return nullptr;
    thread_local Cache c;
    return &c;
}

size_t block_size(size_t bytes) {
    return bytes < kMinCached ? bytes : std::bit_ceil(bytes);
}

}  // namespace

void* scratch_allocate(size_t bytes) {
    const size_t size = block_size(bytes);
    if (Cache* c = size >= kMinCached ? cache() : nullptr) {
        for (size_t i = 0; i < c->blocks.size(); ++i) {
            if (c->blocks[i].first != size) continue;
            void* p = c->blocks[i].second;
            c->blocks[i] = c->blocks.back();
            c->blocks.pop_back();
            c->bytes -= size;
            return p;
        }
    }
    return ::operator new(size, kAlign);
}

void scratch_free(void* p, size_t bytes) noexcept {
    if (!p) return;
    const size_t size = block_size(bytes);
    Cache* c = size >= kMinCached ? cache() : nullptr;
    if (c && c->bytes + size <= kScratchKeepBytes) {
        try {
            c->blocks.emplace_back(size, p);
            c->bytes += size;
            return;
        } catch (const std::bad_alloc&) {
            // note: no room to remember it: free it below
        }
    }
    ::operator delete(p, kAlign);
}

size_t scratch_cached_bytes() noexcept {
    const Cache* c = cache();
    return c ? c->bytes : 0;
}

}  // namespace hmdnode::lod_detail
