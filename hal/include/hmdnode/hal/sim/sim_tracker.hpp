// A simulated tracker replaying a recorded trace through the tracker interface.
//
// On a simulated clock it has no thread: read() delivers every sample whose arrival time is at or
// before clock.now_ns(), so a replay is deterministic. On the system clock a reader thread sleeps
// until each sample's arrival time and pushes it into a single-producer ring, as a device would.
#pragma once

#include <cstdint>
#include <memory>

#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/tracker.hpp"

namespace hmdnode {

struct SimTrackerConfig {
    int64_t host_start_ns = 0;    // host time of trace time start_ns() (+ start_offset_ns)
    int64_t start_offset_ns = 0;  // skip this much of the trace
    int64_t duration_ns = 0;      // 0 = to the end of the trace
    double resample_hz = 0.0;     // 0 = the trace's own samples; else slerp-resampled at this rate
    double noise_deg = 0.0;       // std dev of gaussian orientation noise (per axis)
    int64_t latency_ns = 1'000'000;  // transport delay: arrival = time + latency (+ jitter)
    int64_t jitter_ns = 0;           // arrival jitter, uniform in [0, jitter_ns]
    uint64_t seed = 1;               // noise and jitter are deterministic for a seed
    size_t ring_capacity = 4096;     // real-time mode
};

// The trace must outlive the tracker. Fails when the trace has fewer than two samples in range.
Result<std::unique_ptr<Tracker>> create_sim_tracker(std::shared_ptr<const Trace> trace,
                                                    Clock& clock, const SimTrackerConfig& config);

}  // namespace hmdnode
