// A second thread for two-way splits of the simplifiers' work: run(f) calls f(0) on the calling
// thread and f(1) on the helper thread, and returns when both are done; without a helper it calls
// f(0) then f(1) on the calling thread. Work split this way writes disjoint data in its two halves,
// so the result is the same bit for bit with or without the helper. Half 1 goes to whichever
// thread claims it first: a caller done with f(0) before the helper has started f(1) runs it
// itself, so a helper that waits for its core (a busy machine: another process on it) or is slow
// to wake costs at most its own half, not a scheduler time slice per run().
//
// Only a caller that asked for a second thread gets one (SimplifyOptions::threads >= 2, see the
// pass schedule in pass_schedule.cpp); the object starts it and joins it in its destructor.
//
// Cost: one thread start per object (on a core other than the caller's, see start()); per run(),
// a futex wake-up of the helper (it sleeps between runs: after a run it waits for the next one
// for at most kIdleSpin, 0: it blocks at once, so an idle helper uses no CPU), and the caller waits
// for the helper's half spinning for up to kResultSpin, then blocking. The measurements behind
// these choices: docs/simplification.md ("Measurements behind the engine's choices").
#pragma once

#include <pthread.h>
#include <atomic>
#ifdef __linux__
#include <sched.h>
#endif
#include <chrono>
#include <cstdint>
#include <new>
#include <thread>
#include <type_traits>

namespace hmdnode::lod_detail {

class TwoWay {
  public:
    explicit TwoWay(bool helper) {
        if (helper) start();
    }
    ~TwoWay() {
        if (!has_helper()) return;
        stop_.store(true, std::memory_order_relaxed);
        go_.fetch_add(1, std::memory_order_release);
        go_.notify_one();
        pthread_join(thread_, nullptr);
    }
    TwoWay(const TwoWay&) = delete;
    TwoWay& operator=(const TwoWay&) = delete;

    bool has_helper() const { return started_; }

    // f(int half) must not throw (an exception on the helper thread ends the process). f is copied
    // into this object first and both threads call the copy: a closure left on the caller's stack
    // shares cache lines with the caller's locals, which the caller writes while the helper reads
    // the closure (false sharing: slower than one thread).
    // The same goes for what f captures by reference: capture by value what the loops read.
    template <class F>
    void run(const F& f) {
        static_assert(std::is_trivially_copyable_v<F> && sizeof(F) <= sizeof(job_) &&
                          alignof(F) <= alignof(Job),
                      "TwoWay::run takes a small lambda that captures by value or reference");
        if (!started_) {
            f(0);
            f(1);
            return;
        }
        const F& job = *::new (static_cast<void*>(job_.bytes)) F(f);
        call_ = [](const void* j, int half) { (*static_cast<const F*>(j))(half); };
        const uint32_t round = go_.fetch_add(1, std::memory_order_release) + 1;
        go_.notify_one();
        job(0);
        uint32_t unclaimed = round - 1;
        if (claimed_.compare_exchange_strong(unclaimed, round, std::memory_order_acq_rel)) {
            job(1);  // note: the helper has not started it; it will find the round claimed
            return;
        }
        for (uint32_t done = done_.load(std::memory_order_acquire); done != round;) {
            done = wait_change(done_, done, kResultSpin);
        }
    }

  private:
    // note: a new thread starts on its creator's core. With the other core idle (halted, as a
    // VM's idle vCPU is), the scheduler took milliseconds to move it there, and work started after
    // an idle moment ran on one thread meanwhile. Started with an affinity that leaves out the
    // caller's core of the moment, it starts promptly. For short work the scheduler would also have
    // left it there: every split would then run its halves one after the other on one core. The
    // caller is not pinned; no mask is set where the process may use one core only. Without a
    // thread (none could be created) the work runs on the caller.
    void start() {
        pthread_attr_t attr;
        if (pthread_attr_init(&attr) != 0) return;
        bool masked = false;
#ifdef __linux__
        cpu_set_t set;
        CPU_ZERO(&set);
        const int cpu = sched_getcpu();
        if (cpu >= 0 && cpu < CPU_SETSIZE && sched_getaffinity(0, sizeof set, &set) == 0 &&
            CPU_ISSET(cpu, &set) && CPU_COUNT(&set) >= 2) {
            CPU_CLR(cpu, &set);
            masked = pthread_attr_setaffinity_np(&attr, sizeof set, &set) == 0;
        }
#endif
        started_ = pthread_create(&thread_, &attr, &TwoWay::serve_entry, this) == 0;
        pthread_attr_destroy(&attr);
        // note: a mask the kernel refuses (a core gone offline meanwhile): start it unmasked.
        if (!started_ && masked) {
            started_ = pthread_create(&thread_, nullptr, &TwoWay::serve_entry, this) == 0;
        }
    }
    static void* serve_entry(void* self) {
        static_cast<TwoWay*>(self)->serve();
        return nullptr;
    }

    // Waits until a changes from old and returns the new value: spinning for up to `spin` first,
    // then asleep on the futex.
    static uint32_t wait_change(const std::atomic<uint32_t>& a, uint32_t old,
                                std::chrono::microseconds spin) {
        const auto start = std::chrono::steady_clock::now();
        for (uint32_t i = 1; spin.count() > 0; ++i) {
            const uint32_t v = a.load(std::memory_order_acquire);
            if (v != old) return v;
#if defined(__x86_64__) || defined(__i386__)
            __builtin_ia32_pause();
#endif
            if (i % 64 == 0) {
                if (std::chrono::steady_clock::now() - start > spin) break;
                // note: should the two threads share a core for a while (the caller is not
                // pinned, and may move to the helper's), spinning without yielding would hold
                // the other off for the whole spin.
                std::this_thread::yield();
            }
        }
        for (;;) {
            a.wait(old, std::memory_order_acquire);
            const uint32_t v = a.load(std::memory_order_acquire);
            if (v != old) return v;
        }
    }

    void serve() {
        uint32_t seen = 0;
        for (;;) {
            seen = wait_change(go_, seen, kIdleSpin);
            if (stop_.load(std::memory_order_relaxed)) return;
            // note: the latest round only (the caller may have run earlier ones' halves itself);
            // while this round is unclaimed the caller waits for it, so job_ is this round's.
            uint32_t unclaimed = seen - 1;
            if (!claimed_.compare_exchange_strong(unclaimed, seen, std::memory_order_acq_rel)) {
                continue;
            }
            call_(job_.bytes, 1);
            done_.store(seen, std::memory_order_release);
            done_.notify_one();
        }
    }

    // note: the job's copy on lines of its own, written only before the helper is woken.
    struct alignas(64) Job {
        unsigned char bytes[128];
    };
    // note: the helper's wait between runs is idle time: it blocks at once (kIdleSpin 0). The
    // caller's wait for the helper's half is part of the call (both cores are at work on it):
    // it spins for up to kResultSpin, which covers most halves, before it blocks.
    static constexpr std::chrono::microseconds kIdleSpin{0};
    static constexpr std::chrono::microseconds kResultSpin{1000};
    // go_: the rounds started; claimed_: the last round whose half 1 a thread took; done_: the
    // last round whose half 1 the helper finished.
    std::atomic<uint32_t> go_{0}, claimed_{0}, done_{0};
    std::atomic<bool> stop_{false};
    void (*call_)(const void*, int) = nullptr;
    Job job_;
    pthread_t thread_{};  // note: last, started once the rest is set up
    bool started_ = false;
};

}  // namespace hmdnode::lod_detail
