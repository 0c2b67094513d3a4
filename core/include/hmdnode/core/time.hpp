// Time: every time in hmdnode is int64_t nanoseconds of one monotonic host clock, named *_ns.
#pragma once

#include <atomic>
#include <cstdint>

namespace hmdnode {

constexpr int64_t kNsPerSecond = 1'000'000'000;
constexpr int64_t kNsPerMs = 1'000'000;
constexpr int64_t kNsPerUs = 1'000;

constexpr double ns_to_s(int64_t ns) {
    return static_cast<double>(ns) * 1e-9;
}
constexpr double ns_to_ms(int64_t ns) {
    return static_cast<double>(ns) * 1e-6;
}
constexpr int64_t s_to_ns(double s) {
    return static_cast<int64_t>(s * 1e9 + (s >= 0 ? 0.5 : -0.5));
}
constexpr int64_t ms_to_ns(double ms) {
    return s_to_ns(ms * 1e-3);
}

// The host clock. Implementations are thread-safe: any thread may call any method.
class Clock {
  public:
    virtual ~Clock() = default;
    // Current time in ns on the host's monotonic timeline.
    virtual int64_t now_ns() const = 0;
    // Blocks (system clock) or advances time (simulated clock) until now_ns() >= t_ns.
    virtual void sleep_until_ns(int64_t t_ns) = 0;
    // True when time only moves when someone calls sleep_until_ns/advance (deterministic replay).
    virtual bool is_simulated() const = 0;
};

// CLOCK_MONOTONIC.
class SystemClock final : public Clock {
  public:
    int64_t now_ns() const override;
    void sleep_until_ns(int64_t t_ns) override;
    bool is_simulated() const override { return false; }
};

// A clock that only moves when told to. sleep_until_ns() jumps forward instantly; time never goes
// backwards (a request for an earlier time is a no-op).
class SimulatedClock final : public Clock {
  public:
    explicit SimulatedClock(int64_t start_ns = 0) : now_ns_(start_ns) {}
    int64_t now_ns() const override { return now_ns_.load(std::memory_order_acquire); }
    void sleep_until_ns(int64_t t_ns) override;
    bool is_simulated() const override { return true; }
    void advance_ns(int64_t dt_ns) { sleep_until_ns(now_ns() + dt_ns); }

  private:
    std::atomic<int64_t> now_ns_;
};

}  // namespace hmdnode
