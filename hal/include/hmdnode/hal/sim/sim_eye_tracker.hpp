// A simulated eye tracker replaying a trace's gaze columns (docs/trace-format.md) through the
// eye-tracker interface, on the same host timeline as the simulated head tracker replaying the
// same trace (SimTrackerConfig's host_start_ns / start_offset_ns / duration_ns).
//
// No thread: read() delivers every sample whose arrival time is at or before clock.now_ns(), on a
// simulated clock (deterministic) and on the system clock alike.
#pragma once

#include <cstdint>
#include <memory>

#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/eye_tracker.hpp"

namespace hmdnode {

struct SimEyeTrackerConfig {
    int64_t host_start_ns = 0;       // host time of trace time start_ns() + start_offset_ns
    int64_t start_offset_ns = 0;     // skip this much of the trace
    int64_t duration_ns = 0;         // 0 = to the end of the trace
    int64_t latency_ns = 5'000'000;  // arrival = time + latency (eye trackers: a few ms)
};

// The trace must have the gaze group; errors say so, naming nothing else (the caller prefixes the
// file). Fails when no sample lies in range.
Result<std::unique_ptr<EyeTracker>> create_sim_eye_tracker(std::shared_ptr<const Trace> trace,
                                                           Clock& clock,
                                                           const SimEyeTrackerConfig& config);

}  // namespace hmdnode
