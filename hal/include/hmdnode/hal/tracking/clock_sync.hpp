// Device clock -> host clock. A device stamps each sample with its own clock (µs, 48 MHz ticks);
// the host knows only when the report arrived. USB delay is only ever positive, so the offset and
// the drift between the two crystals come from the lower envelope of host - device: the lower
// convex hull of 250 ms sub-window minima over a 16 s window, whose edge under the window's
// centre gives the line (USB polling quantisation cannot bend a line that lies under every
// point). Output times are monotonic and, for samples 1 ms apart on the device, at least 0.5 ms
// apart. Jumps (device reboot, host suspend) reset the estimate; TickUnwrapper turns a wrapping
// counter into a 64-bit one.
//
// One thread; update() is O(1) per sample and O(buckets) per completed bucket, allocation-free.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>

namespace hmdnode {

// Unwraps a counter that wraps at `modulus` (e.g. 2^32 for a u32 µs or 48 MHz tick counter).
// A step backwards by less than half the modulus is a reordering or a jump, not a wrap: it returns
// the previous value (and counts it) rather than adding a whole period.
class TickUnwrapper {
  public:
    explicit TickUnwrapper(uint64_t modulus) : modulus_(modulus) { assert(modulus >= 2); }
    uint64_t unwrap(uint64_t raw);
    uint64_t wraps() const { return wraps_; }
    uint64_t backward_steps() const { return backward_; }

  private:
    uint64_t modulus_;
    bool have_ = false;
    uint64_t last_raw_ = 0;
    uint64_t value_ = 0;
    uint64_t wraps_ = 0;
    uint64_t backward_ = 0;
};

struct ClockSyncConfig {
    int64_t window_ns = 16'000'000'000;      // span of the lower envelope (device time)
    int64_t jump_threshold_ns = 20'000'000;  // a difference this far off the estimate: reset
    bool estimate_drift = true;              // fit the slope, else a constant offset
    int64_t fixed_latency_ns = 0;            // known minimum transport delay, subtracted
};

class ClockSync {
  public:
    explicit ClockSync(const ClockSyncConfig& config = {});

    // One sample: its device time (ns, unwrapped) and the host time it arrived. Returns the host
    // time the sample describes (never later than arrival_ns).
    int64_t update(int64_t device_ns, int64_t arrival_ns);

    // Host time of a device time under the current estimate.
    int64_t to_host(int64_t device_ns) const;

    bool valid() const { return have_; }
    int64_t offset_ns() const;  // host - device at the latest sample
    double drift_ppm() const { return slope_ * 1e6; }
    double jitter_ns() const { return jitter_ns_; }  // mean delay above the minimum (EWMA)
    uint64_t resets() const { return resets_; }      // jumps detected

  private:
    static constexpr int kBuckets = 64;
    struct Bucket {
        bool used = false;
        int64_t index = 0;       // device_ns / bucket_ns
        double min_diff = 0.0;   // min(host - device) in the bucket (ns, relative to base_)
        double at_device = 0.0;  // device time of that minimum (ns, relative to ref_)
    };
    void reset(int64_t device_ns, int64_t arrival_ns);
    void refit(int64_t current_index);
    double predicted_diff(double rel_device) const { return intercept_ + slope_ * rel_device; }

    ClockSyncConfig config_;
    int64_t bucket_ns_;
    bool have_ = false;
    int64_t ref_device_ = 0;  // device time origin of the fit
    int64_t base_diff_ = 0;   // host - device at the first sample (keeps doubles small)
    std::array<Bucket, kBuckets> buckets_{};
    double intercept_ = 0.0, slope_ = 0.0;
    double jitter_ns_ = 0.0;
    int64_t last_device_ = 0;
    bool have_out_ = false;
    int64_t last_out_ = 0;         // the last time returned (monotonic)
    int64_t last_out_device_ = 0;  // its device time
    uint64_t resets_ = 0;
};

}  // namespace hmdnode
