// hmdnoded's cumulative metrics since start, in the Prometheus text exposition format (version
// 0.0.4: `# HELP`, `# TYPE`, counters `_total`, histograms with cumulative `le` buckets, `_sum`,
// `_count`), served by the control socket's `metrics` command. Updated once per presented frame
// from its FrameRecord: O(objects) for the LOD switches, no allocation.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {

// A histogram with fixed upper bounds (seconds).
struct Histogram {
    static constexpr std::array<double, 10> kBounds = {0.002, 0.005, 0.008, 0.011, 0.015,
                                                       0.020, 0.030, 0.050, 0.100, 0.250};
    std::array<uint64_t, kBounds.size()> counts{};  // per bucket, not cumulative
    uint64_t count = 0;
    double sum = 0.0;
    void observe(double seconds);
};

struct DaemonMetrics {
    uint64_t frames = 0, errors = 0, no_pose_frames = 0;
    uint64_t vsyncs = 0, missed_vsyncs = 0, late_frames = 0, rewarps = 0;
    uint64_t lod_switches = 0;
    // Visible LOD level changes without a cross-fade, and cross-fades begun
    // (docs/lod-selection.md, "No pops"); pops per minute over the presents' span.
    uint64_t lod_pops = 0, lod_transitions = 0;
    int64_t first_photon_ns = 0, last_photon_ns = 0;
    double lod_pops_per_min() const;
    uint64_t triangles = 0;  // of the last new frame
    // The pixel-cost ladder and the render rate (docs/latency.md): presents per ladder step
    // (index as NodeRuntime::ladder().steps(), at most kMaxLadderSteps), presents per render rate
    // (index d - 1), and the last present's.
    static constexpr size_t kMaxLadderSteps = 16, kMaxDivisor = 4;
    std::array<uint64_t, kMaxLadderSteps> presents_by_step{};
    std::array<uint64_t, kMaxDivisor> presents_by_divisor{};
    int ladder_step = 0, render_divisor = 1;
    double render_scale = 1.0;
    Histogram mtp, render;
    std::vector<int> last_levels;

    // One presented frame; `first` for the very first (no vsyncs before it to count).
    void add_frame(const FrameRecord& rec, bool first);
    // The text exposition; the tracker's figures when there is a device tracker.
    std::string prometheus(const DeviceTrackerStatus* tracker) const;
};

}  // namespace hmdnode
