// Scratch blocks from the caller's SimplifyScratch, named by a ScratchScope; see scratch.hpp.
#include "scratch.hpp"

#include <bit>
#include <cstdint>

namespace hmdnode {

SimplifyScratch::SimplifyScratch() : cache_(std::make_unique<lod_detail::ScratchCache>()) {}
SimplifyScratch::~SimplifyScratch() = default;

size_t SimplifyScratch::cached_bytes() const {
    return cache_->bytes;
}

namespace lod_detail {
namespace {

constexpr size_t kMinCached = size_t(64) << 10;
constexpr std::align_val_t kAlign{64};  // note: a cache line, for the per-element arrays

// note: only a pointer to the caller's cache, set by ScratchScope for the length of a call.
thread_local ScratchCache* t_cache = nullptr;

size_t block_size(size_t bytes) {
    return bytes < kMinCached ? bytes : std::bit_ceil(bytes);
}

}  // namespace

ScratchCache::~ScratchCache() {
    for (const auto& [size, p] : blocks) ::operator delete(p, kAlign);
}

ScratchScope::ScratchScope(SimplifyScratch* scratch) : previous_(t_cache) {
    t_cache = scratch ? scratch->cache_.get() : nullptr;
}

ScratchScope::~ScratchScope() {
    t_cache = previous_;
}

void* scratch_allocate(size_t bytes) {
    const size_t size = block_size(bytes);
    if (ScratchCache* c = size >= kMinCached ? t_cache : nullptr) {
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
    ScratchCache* c = size >= kMinCached ? t_cache : nullptr;
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

}  // namespace lod_detail
}  // namespace hmdnode
