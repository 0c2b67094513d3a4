// The head-tracker interface of the hardware abstraction layer. Backends (simulated replay,
// hidapi, libusb, usbmon-capture replay) implement it; the node runtime only sees this.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

// One tracker measurement, already on the host clock (device ticks are converted at the HAL edge).
struct TrackerSample {
    int64_t time_ns = 0;     // host time the measurement describes
    int64_t arrival_ns = 0;  // host time it reached the host (>= time_ns)
    uint64_t sequence = 0;   // increments by one per sample the device produced
    bool has_orientation = false;
    glm::dquat orientation{1, 0, 0, 0};  // head-to-world
    std::optional<glm::dvec3> position;  // metres, world
    std::optional<glm::dvec3> gyro;      // rad/s, head frame
    std::optional<glm::dvec3> accel;     // m/s^2, head frame
};

struct TrackerInfo {
    std::string name;
    std::string serial;
    double nominal_rate_hz = 0.0;
    bool provides_orientation = false;
    bool provides_position = false;
    bool provides_imu = false;
};

struct TrackerCounters {
    uint64_t samples_delivered = 0;
    uint64_t samples_dropped = 0;  // ring overflow: the frame thread did not read in time
};

class Tracker {
  public:
    virtual ~Tracker() = default;

    // Any thread.
    virtual TrackerInfo info() const = 0;

    // Control thread. start() begins producing samples (a backend with a reader thread starts it);
    // stop() ends them and joins the thread. Both are idempotent.
    virtual Status start() = 0;
    virtual void stop() = 0;

    // Frame thread only. Moves the samples that have arrived by now (on the tracker's clock) into
    // out, oldest first, and returns how many. Never blocks, locks or allocates.
    virtual size_t read(std::span<TrackerSample> out) = 0;

    // Frame thread only. True once the source has no more samples (end of a replayed trace).
    virtual bool finished() const = 0;

    // Any thread.
    virtual TrackerCounters counters() const = 0;
};

}  // namespace hmdnode
