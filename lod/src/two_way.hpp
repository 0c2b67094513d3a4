// A second thread for two-way splits of the simplifiers' work: run(f) calls f(1) on the helper
// thread and f(0) on the calling thread, and returns when both are done; without a helper it calls
// f(0) then f(1) on the calling thread. Work split this way writes disjoint data in its two halves,
// so the result is the same bit for bit with or without the helper.
//
// Cost: one thread start per object; per run(), a wake-up and a wait on a futex (libstdc++'s
// std::atomic wait spins briefly first): tens of microseconds at worst on this machine.
#pragma once

#include <atomic>
#include <cstdint>
#include <new>
#include <thread>
#include <type_traits>

namespace hmdnode::lod_detail {

class TwoWay {
  public:
    explicit TwoWay(bool helper) {
        if (helper) thread_ = std::thread([this] { serve(); });
    }
    ~TwoWay() {
        if (!thread_.joinable()) return;
        stop_.store(true, std::memory_order_relaxed);
        go_.fetch_add(1, std::memory_order_release);
        go_.notify_one();
        thread_.join();
    }
    TwoWay(const TwoWay&) = delete;
    TwoWay& operator=(const TwoWay&) = delete;

    bool has_helper() const { return thread_.joinable(); }

    // f(int half) must not throw (an exception on the helper thread ends the process). f is copied
    // into this object first and both threads call the copy: a closure left on the caller's stack
    // shares cache lines with the caller's locals, which the caller writes while the helper reads
    // the closure (a collect of the bunny's candidates ran 1.6x slower than on one thread so).
    // The same goes for what f captures by reference: capture by value what the loops read.
    template <class F>
    void run(const F& f) {
        static_assert(std::is_trivially_copyable_v<F> && sizeof(F) <= sizeof(job_) &&
                          alignof(F) <= alignof(Job),
                      "TwoWay::run takes a small lambda that captures by value or reference");
        if (!thread_.joinable()) {
            f(0);
            f(1);
            return;
        }
        const F& job = *::new (static_cast<void*>(job_.bytes)) F(f);
        call_ = [](const void* j, int half) { (*static_cast<const F*>(j))(half); };
        const uint32_t round = go_.fetch_add(1, std::memory_order_release) + 1;
        go_.notify_one();
        job(0);
        for (uint32_t d = done_.load(std::memory_order_acquire); d != round;
             d = done_.load(std::memory_order_acquire)) {
            done_.wait(d, std::memory_order_acquire);
        }
    }

  private:
    void serve() {
        uint32_t seen = 0;
        for (;;) {
            go_.wait(seen, std::memory_order_acquire);
            seen = go_.load(std::memory_order_acquire);
            if (stop_.load(std::memory_order_relaxed)) return;
            call_(job_.bytes, 1);
            done_.store(seen, std::memory_order_release);
            done_.notify_one();
        }
    }

    // note: the job's copy on lines of its own, written only before the helper is woken.
    struct alignas(64) Job {
        unsigned char bytes[128];
    };
    std::atomic<uint32_t> go_{0}, done_{0};
    std::atomic<bool> stop_{false};
    void (*call_)(const void*, int) = nullptr;
    Job job_;
    std::thread thread_;  // note: last, started once the rest is set up
};

}  // namespace hmdnode::lod_detail
