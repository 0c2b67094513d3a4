// The camera observer (docs/latency.md, "The observer"): motion-to-photon latency measured from
// the panel's own light. Each captured frame's latency marker (core/latency_marker.hpp) names the
// tracker sample that shaped the image and the present; the observed latency is the middle of the
// exposure of the camera row where the marker was seen (exposure_middle_ns: the stamp's meaning,
// exposure and line time accounted) minus that sample's host time; beside it the node's own
// figure for the same present at the vsync whose light the camera caught (a repeated frame ages
// a period per vsync, as the node counts it) and the marker's row (FrameRecord::
// marker_photon_time_ns). Cost: O(camera pixels) per frame (the decode), O(log presents) to
// match.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hmdnode/core/latency_marker.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/camera.hpp"

namespace hmdnode {

struct ObservedFrame {
    uint64_t camera_sequence = 0;
    bool decoded = false;
    std::string reason;          // why not decoded, or why not matched
    bool matched = false;        // decoded, and the id is one the node presented
    uint64_t present = 0;        // FrameRecord::index
    int64_t vsync_ns = 0;        // the vsync whose light the camera caught
    int64_t capture_ns = 0;      // middle of the exposure at the marker's camera row
    int64_t sample_time_ns = 0;  // from the marker (microseconds, unwrapped against capture_ns)
    double observed_ms = 0.0;    // capture - sample
    double node_ms = 0.0;  // the node's photon time of the marker's row at that vsync - sample
    double difference_ms = 0.0;  // observed - node
    bool repeat = false;         // the same present as the previous decoded frame
};

struct ObserverSummary {
    size_t frames = 0, decoded = 0, undecoded = 0;
    size_t unmatched = 0;  // decoded ids the node never presented (none, unless a decode lied)
    size_t repeats = 0;    // decoded frames showing the present the one before showed
    size_t skipped = 0;    // presents between two decoded ones that no frame showed
    Percentiles observed_ms, node_ms, difference_ms;
};

struct ObserverResult {
    std::vector<ObservedFrame> frames;
    ObserverSummary summary;
};

// One camera frame decoded, before it is matched: all a capture thread keeps of a frame (the
// pixels go as soon as the marker is read).
struct CameraSighting {
    uint64_t camera_sequence = 0;
    bool decoded = false;
    std::string reason;  // why not decoded
    LatencyMarkerPayload payload;
    // The middle of the exposure at the marker's camera row (undecoded: at the frame's middle row).
    int64_t capture_ns = 0;
};

// Decodes one frame: GREY, or YUYV (its luma); any other format is reported undecoded.
CameraSighting sight_camera_frame(const CameraFrame& frame);

// Matches sightings (in capture order) against the node's presents (in present order, with the
// marker on) of a display whose period is period_ns.
ObserverResult match_camera_sightings(const std::vector<CameraSighting>& sightings,
                                      const std::vector<FrameRecord>& presents, int64_t period_ns);

// sight_camera_frame on each frame, then match_camera_sightings.
ObserverResult observe_camera_frames(const std::vector<CameraFrame>& frames,
                                     const std::vector<FrameRecord>& presents, int64_t period_ns);

}  // namespace hmdnode
