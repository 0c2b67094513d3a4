#include "hmdnode/core/time.hpp"

#include <cerrno>
#include <ctime>

namespace hmdnode {

int64_t SystemClock::now_ns() const {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return int64_t(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

void SystemClock::sleep_until_ns(int64_t t_ns) {
    timespec ts{};
    ts.tv_sec = t_ns / kNsPerSecond;
    ts.tv_nsec = t_ns % kNsPerSecond;
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
}

void SimulatedClock::sleep_until_ns(int64_t t_ns) {
    int64_t cur = now_ns_.load(std::memory_order_acquire);
    while (cur < t_ns && !now_ns_.compare_exchange_weak(cur, t_ns, std::memory_order_acq_rel)) {
    }
}

}  // namespace hmdnode
