// Clock tracking by the lower envelope of host - device: the one-way-delay skew estimation of
// V. Paxson, "On Calibrating Measurements of Packet Transit Times", SIGMETRICS 1998 (§4: the
// lower convex hull of the (device time, delay) points; the skew is the hull edge under the
// points' mean time, which minimises the summed distance of the points above a line that lies
// under all of them), as NTP-style estimators do. The points are the minima of 250 ms
// sub-windows (buckets) over a 16 s window.
// Cost: O(1) per sample; O(kBuckets) for the hull when a bucket's minimum changes; O(kBuckets)
// memory.
// Why the hull and not least squares through the minima (the former method): a 1 kHz device
// polled every 1 ms frame beats against the frames, so host - device is a sawtooth whose phase
// drifts slowly; least squares followed the sawtooth (229 ppm read on an Index whose crystal is
// ~33 ppm off); a line under every minimum cannot follow it.
// Departures: the constant part of the delay is unobservable and is left in unless
// config.fixed_latency_ns says it; a difference below the line by more than the jump threshold,
// or a whole bucket above it, resets the estimate; outputs are clamped to be monotonic and at
// least half the device interval apart (refits move the line by microseconds).
#include "hmdnode/hal/tracking/clock_sync.hpp"

#include <algorithm>
#include <cassert>
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
    assert(fwd <= modulus_ / 2 && value_ + fwd >= value_);  // forward only, by under half a wrap
    value_ += fwd;
    last_raw_ = raw;
    return value_;
}

ClockSync::ClockSync(const ClockSyncConfig& config)
    : config_(config), bucket_ns_(std::max<int64_t>(1, config.window_ns / kBuckets)) {
    assert(config.window_ns > 0 && config.jump_threshold_ns >= 0 && config.fixed_latency_ns >= 0);
}

void ClockSync::reset(int64_t device_ns, int64_t arrival_ns) {
    if (have_) ++resets_;
    have_ = true;
    ref_device_ = device_ns;
    base_diff_ = arrival_ns - device_ns;
    buckets_ = {};
    intercept_ = 0.0;
    slope_ = 0.0;
    jitter_ns_ = 0.0;
    have_out_ = false;
}

void ClockSync::refit(int64_t current_index) {
    // The completed buckets in time order (the current one has seen too few samples for its
    // minimum to be near the floor; it only lowers the intercept below).
    std::array<const Bucket*, kBuckets> pts;
    int n = 0;
    int64_t first_index = current_index - kBuckets + 1;
    for (int64_t k = first_index; k < current_index; ++k) {
        const Bucket& b = buckets_[size_t(((k % kBuckets) + kBuckets) % kBuckets)];
        if (b.used && b.index == k) pts[size_t(n++)] = &b;
    }
    assert(n < kBuckets);        // the completed buckets of the window, the current one left out
    for (int i = 1; i < n; ++i)  // in time order: the hull's x increases
        assert(pts[size_t(i)]->index > pts[size_t(i - 1)]->index);
    const bool can_fit =
        config_.estimate_drift && n >= 2 &&
        pts[size_t(n - 1)]->at_device - pts[0]->at_device >= 2.0 * double(bucket_ns_);
    if (can_fit) {
        // Lower convex hull (Andrew's monotone chain; x increases with the bucket index).
        std::array<const Bucket*, kBuckets> hull;
        int h = 0;
        auto cross = [](const Bucket* o, const Bucket* a, const Bucket* b) {
            return (a->at_device - o->at_device) * (b->min_diff - o->min_diff) -
                   (a->min_diff - o->min_diff) * (b->at_device - o->at_device);
        };
        for (int i = 0; i < n; ++i) {
            while (h >= 2 && cross(hull[size_t(h - 2)], hull[size_t(h - 1)], pts[size_t(i)]) <= 0)
                --h;
            hull[size_t(h++)] = pts[size_t(i)];
        }
        double mean_x = 0.0;
        for (int i = 0; i < n; ++i) mean_x += pts[size_t(i)]->at_device;
        mean_x /= n;
        assert(h >= 2 && h <= n);  // the two ends of the points are always on the hull
        int e = 0;                 // the edge [hull[e], hull[e + 1]] under the mean time
        while (e + 2 < h && hull[size_t(e + 1)]->at_device < mean_x) ++e;
        assert(e + 1 < h);
        const Bucket* a = hull[size_t(e)];
        const Bucket* b = hull[size_t(e + 1)];
        slope_ = (b->min_diff - a->min_diff) / (b->at_device - a->at_device);
    } else if (!config_.estimate_drift) {
        slope_ = 0.0;
    }
    // Through the lowest point under this slope, the current bucket included: a lower bound.
    double lowest = 1e300;
    for (const Bucket& b : buckets_)
        if (b.used) lowest = std::min(lowest, b.min_diff - slope_ * b.at_device);
    assert(lowest < 1e300);  // refit runs after a bucket was filled: some bucket is in use
    intercept_ = lowest;
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
        // The hull uses completed buckets only: the slope stands, the line may only go down.
        intercept_ = std::min(intercept_, diff - slope_ * x);
    }
    const double above = diff - predicted_diff(x);
    jitter_ns_ += (above - jitter_ns_) * 0.01;
    int64_t out = std::min(arrival_ns, to_host(device_ns));
    // Monotonic, and at least half the device interval after the previous output: a refit or a
    // new floor moves the line by microseconds, which must not reorder or crowd the samples.
    if (have_out_ && device_ns > last_out_device_)
        out = std::max(out, last_out_ + (device_ns - last_out_device_) / 2);
    else if (have_out_)
        out = std::max(out, last_out_);
    // Output times are monotonic between resets (a reset clears have_out_).
    assert(!have_out_ || out >= last_out_);
    have_out_ = true;
    last_out_ = out;
    last_out_device_ = device_ns;
    return out;
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
