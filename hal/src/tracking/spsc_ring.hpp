// A bounded single-producer single-consumer ring (Lamport queue with cached indices). The device's
// reader thread is the only producer and the frame thread the only consumer; neither locks nor
// allocates after construction. When full, push() fails and the producer counts a drop.
#pragma once

#include <atomic>
#include <cassert>
#include <cstddef>
#include <memory>
#include <new>

namespace hmdnode {

template <class T>
class SpscRing {
  public:
    // capacity >= 2; rounded up to a power of two.
    explicit SpscRing(size_t capacity) {
        assert(capacity >= 2);
        size_t c = 1;
        while (c < capacity) c <<= 1;
        mask_ = c - 1;
        slots_ = std::make_unique<T[]>(c);
    }

    size_t capacity() const { return mask_ + 1; }

    // Producer thread only.
    bool push(const T& value) {
        const size_t head = head_.load(std::memory_order_relaxed);
        if (head - tail_cache_ > mask_) {
            tail_cache_ = tail_.load(std::memory_order_acquire);
            if (head - tail_cache_ > mask_) return false;
        }
        // The producer's view of the tail lags the consumer's (never passes the head); the ring
        // has a free slot.
        assert(head - tail_cache_ <= mask_);
        slots_[head & mask_] = value;
        head_.store(head + 1, std::memory_order_release);
        return true;
    }

    // Consumer thread only.
    bool pop(T* out_value) {
        assert(out_value != nullptr);
        const size_t tail = tail_.load(std::memory_order_relaxed);
        if (tail == head_cache_) {
            head_cache_ = head_.load(std::memory_order_acquire);
            if (tail == head_cache_) return false;
        }
        // The consumer's view of the head is ahead of the tail by at most the capacity.
        assert(head_cache_ - tail >= 1 && head_cache_ - tail <= mask_ + 1);
        *out_value = slots_[tail & mask_];
        tail_.store(tail + 1, std::memory_order_release);
        return true;
    }

  private:
    static constexpr size_t kLine = 64;
    alignas(kLine) std::atomic<size_t> head_{0};
    size_t tail_cache_ = 0;  // producer's view of tail_
    alignas(kLine) std::atomic<size_t> tail_{0};
    size_t head_cache_ = 0;  // consumer's view of head_
    alignas(kLine) size_t mask_ = 0;
    std::unique_ptr<T[]> slots_;
};

}  // namespace hmdnode
