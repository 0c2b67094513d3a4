// Base-station placement inside the tracker (docs/tracking.md §12): the still stretches of the
// device found online from its IMU, the light of the latest one kept, and the base stations it
// saw placed from it (base_station_placement.hpp) once their calibrations are known. The same
// stillness test as device_light_log.cpp's still_stretches (the offline setup step), on
// consecutive windows as the samples arrive. As libsurvive does at start-up without a stored
// configuration (its posers solve the base stations from the light of the device and hand them
// to PoserData_lighthouse_poses_func, poser.c, which puts the device at the origin and levels the
// world with the accelerometer); the code is this project's own.
// One thread. add_imu: O(1); add_light: O(1) per event kept; place: one placement per base
// station (O(events of the stretch) to gather, then as one pose solve).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/light_tracking.hpp"

namespace hmdnode {

class SelfPlacement {
  public:
    // `model_from_head`: the IMU's head axes into the sensor model's; `world_up`: the world's up
    // (a world defined here is the device's model frame levelled with its up there).
    SelfPlacement(const InTrackerPlacement& options, lighthouse::SensorLayout layout,
                  const glm::dmat3& model_from_head, const glm::dvec3& world_up,
                  bool require_calibration);

    // An IMU sample (head axes). True when a still window closed: a placement may be due.
    bool add_imu(int64_t device_time_ns, const glm::dvec3& gyro, const glm::dvec3& accel);
    // A light event of a base station the setup lacks (on the IMU's turn of the clock).
    void add_light(const lighthouse::LightEvent& e);
    // The device's pose in the setup's world at `device_time_ns` (a light solve): lets a
    // stretch that did not define the world place base stations.
    void note_solve(int64_t device_time_ns, const lighthouse::RigidPose& world_from_device);

    // The base stations of the kept stretch not in `setup`, placed where they can be (their
    // calibration known unless not required); `why` gets those tried and not placed.
    std::vector<lighthouse::BaseStationPlacement> place(
        std::span<const lighthouse::BaseStationPlacement> setup,
        const lighthouse::LightDecoder& decoder, std::string* why);
    uint64_t stretches() const { return stretches_; }

  private:
    struct Stretch {
        int64_t begin_ns = 0, end_ns = 0;
        glm::dvec3 accel_sum{0.0};
        double accel_n = 0;
        std::vector<lighthouse::LightEvent> events;
        // The device's pose in the world there: set by the placement that defined the world, or
        // by a solve inside the stretch.
        std::optional<lighthouse::RigidPose> world_from_device;
        double seconds() const { return double(end_ns - begin_ns) * 1e-9; }
    };
    void close_window(int64_t end_ns);

    InTrackerPlacement o_;
    lighthouse::SensorLayout layout_;
    glm::dmat3 model_from_head_;
    glm::dvec3 world_up_;
    bool require_calibration_;
    // The IMU window being filled.
    bool in_window_ = false;
    int64_t window_begin_ns_ = 0, window_last_ns_ = 0;
    double n_ = 0;
    glm::dvec3 g_sum_{0.0}, a_sum_{0.0};
    double g_sq_ = 0, a_sq_ = 0;
    std::vector<lighthouse::LightEvent> window_events_;  // light inside the window being filled
    std::optional<Stretch> open_;                        // the still stretch being extended
    std::optional<Stretch> kept_;  // the latest stretch of min_still_s, its light kept
    uint64_t stretches_ = 0;
    size_t kept_version_ = 0;
    std::array<size_t, 4> tried_{};  // what place() last tried with
};

}  // namespace hmdnode
