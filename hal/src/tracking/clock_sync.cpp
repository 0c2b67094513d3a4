// Clock tracking by the windowed minimum of host - device: the one-way-delay minimum filter of
// V. Paxson, "On Calibrating Measurements of Packet Transit Times", SIGMETRICS 1998 (§4, skew
// estimation from minimum delays), with the skew found by least squares through per-sub-window
// minima rather than Paxson's convex-hull / median-slope methods.
// Cost: O(kBuckets) time per sample, O(kBuckets) memory.
// Departures: least-squares through bucket minima instead of the lower convex hull (simpler, and
// with 1 kHz samples each bucket's minimum is already close to the floor); the constant part of the
// delay is unobservable and is left in unless config.fixed_latency_ns says it; a difference below
// the floor by more than the jump threshold, or a whole bucket above it, resets the estimate.
#include "hmdnode/hal/tracking/clock_sync.hpp"

#include <algorithm>
#include <cmath>

namespace hmdnode {

uint64_t TickUnwrapper::unwrap(uint64_t raw) {
    raw %= modulus_;
    if (!have_) {
        have_ = true;
        last_raw_ = raw;
        value_ = raw;
        return value_;
    }
    const uint64_t fwd = (raw + modulus_ - last_raw_) % modulus_;
    if (fwd > modulus_ / 2) {  // a step backwards: keep the value
        ++backward_;
        return value_;
    }
    if (raw < last_raw_) ++wraps_;
    value_ += fwd;
    last_raw_ = raw;
    return value_;
}

ClockSync::ClockSync(const ClockSyncConfig& config)
    : config_(config), bucket_ns_(std::max<int64_t>(1, config.window_ns / kBuckets)) {}

void ClockSync::reset(int64_t device_ns, int64_t arrival_ns) {
    if (have_) ++resets_;
    have_ = true;
    ref_device_ = device_ns;
    base_diff_ = arrival_ns - device_ns;
    buckets_ = {};
    intercept_ = 0.0;
    slope_ = 0.0;
    jitter_ns_ = 0.0;
}

void ClockSync::refit(int64_t current_index) {
    // Least squares through the minima of the completed buckets (the current one has seen too few
    // samples for its minimum to be near the floor).
    int n = 0;
    double sx = 0, sy = 0, sxx = 0, sxy = 0, lo_x = 1e300, hi_x = -1e300;
    for (const Bucket& b : buckets_) {
        if (!b.used || b.index == current_index) continue;
        ++n;
        sx += b.at_device;
        sy += b.min_diff;
        sxx += b.at_device * b.at_device;
        sxy += b.at_device * b.min_diff;
        lo_x = std::min(lo_x, b.at_device);
        hi_x = std::max(hi_x, b.at_device);
    }
    const double det = n * sxx - sx * sx;
    if (!config_.estimate_drift || n < 3 || hi_x - lo_x < double(bucket_ns_) || det <= 0.0) {
        // Too little span for a slope: keep the current slope, through the lowest minimum.
        if (!config_.estimate_drift) slope_ = 0.0;
        double lowest = 1e300;
        for (const Bucket& b : buckets_)
            if (b.used) lowest = std::min(lowest, b.min_diff - slope_ * b.at_device);
        intercept_ = lowest;
        return;
    }
    slope_ = (n * sxy - sx * sy) / det;
    intercept_ = (sy - slope_ * sx) / n;
}

int64_t ClockSync::update(int64_t device_ns, int64_t arrival_ns) {
    if (!have_) reset(device_ns, arrival_ns);
    const double x = double(device_ns - ref_device_);
    const double diff = double(arrival_ns - device_ns - base_diff_);
    const double thr = double(config_.jump_threshold_ns);

    // A sample can't arrive before it was measured: far below the floor is a jump of a clock.
    // So is going back in device time by more than a bucket.
    const bool fitted =
        std::any_of(buckets_.begin(), buckets_.end(), [](const Bucket& b) { return b.used; });
    if (fitted && (diff < predicted_diff(x) - thr || device_ns < last_device_ - bucket_ns_)) {
        reset(device_ns, arrival_ns);
        return update(device_ns, arrival_ns);
    }
    last_device_ = device_ns;

    const int64_t idx = (device_ns - ref_device_) / bucket_ns_;
    Bucket& b = buckets_[size_t(((idx % kBuckets) + kBuckets) % kBuckets)];
    if (!b.used || b.index != idx) {
        // A completed bucket whose floor is far above the estimate: the device clock jumped back.
        if (fitted) {
            const Bucket* prev = nullptr;
            for (const Bucket& c : buckets_)
                if (c.used && c.index == idx - 1) prev = &c;
            if (prev && prev->min_diff > predicted_diff(prev->at_device) + thr) {
                reset(device_ns, arrival_ns);
                return update(device_ns, arrival_ns);
            }
        }
        b = Bucket{true, idx, diff, x};
        // Drop buckets that left the window.
        for (Bucket& c : buckets_)
            if (c.used && c.index <= idx - kBuckets) c.used = false;
        refit(idx);
    } else if (diff < b.min_diff) {
        b.min_diff = diff;
        b.at_device = x;
        refit(idx);
    }
    const double above = diff - predicted_diff(x);
    jitter_ns_ += (above - jitter_ns_) * 0.01;
    return std::min(arrival_ns, to_host(device_ns));
}

int64_t ClockSync::to_host(int64_t device_ns) const {
    const double x = double(device_ns - ref_device_);
    return device_ns + base_diff_ + int64_t(std::llround(predicted_diff(x))) -
           config_.fixed_latency_ns;
}

int64_t ClockSync::offset_ns() const {
    return to_host(last_device_) - last_device_;
}

}  // namespace hmdnode
