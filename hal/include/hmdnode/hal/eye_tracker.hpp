// The eye-tracker interface of the hardware abstraction layer: where the eyes look, in the head
// frame. Backends (today the simulated one replaying a trace's gaze columns; a real tracker's
// driver implements the same class) deliver samples; the node runtime measures LOD eccentricity
// from the newest valid gaze (docs/lod-selection.md, "Gaze").
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

// One eye-tracker measurement, on the host clock (device time converted at the HAL edge).
// Directions are unit vectors in the head frame (+X right, +Y up, -Z forward: (0,0,-1) is the lens
// centre). `direction` is the cyclopean gaze (both eyes combined, from the midpoint between them);
// a tracker that measures each eye also fills left/right.
struct GazeSample {
    int64_t time_ns = 0;     // host time the measurement describes
    int64_t arrival_ns = 0;  // host time it reached the host (>= time_ns)
    uint64_t sequence = 0;
    glm::dvec3 direction{0.0, 0.0, -1.0};
    std::optional<glm::dvec3> left, right;
    // 0..1; 0: no gaze (blink, track lost), the direction is meaningless. Trackers that only say
    // valid/invalid report 1 or 0.
    double confidence = 0.0;
    bool valid() const { return confidence > 0.0; }
};

struct EyeTrackerInfo {
    std::string name;
    double nominal_rate_hz = 0.0;
    bool per_eye = false;  // fills GazeSample::left/right
};

struct EyeTrackerCounters {
    uint64_t samples_delivered = 0;
    uint64_t samples_invalid = 0;  // delivered with confidence 0
};

class EyeTracker {
  public:
    virtual ~EyeTracker() = default;

    // Any thread.
    virtual EyeTrackerInfo info() const = 0;

    // Control thread; idempotent.
    virtual Status start() = 0;
    virtual void stop() = 0;

    // Frame thread only. Moves the samples that have arrived by now into out, oldest first, and
    // returns how many. Never blocks, locks or allocates.
    virtual size_t read(std::span<GazeSample> out) = 0;

    // Frame thread only. True once the source has no more samples.
    virtual bool finished() const = 0;

    // Frame thread (or after stop()).
    virtual EyeTrackerCounters counters() const = 0;
};

}  // namespace hmdnode
