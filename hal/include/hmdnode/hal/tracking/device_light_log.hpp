// A lighthouse device's light and IMU gathered offline from its report stream, for placing the
// base stations (`hmdnode tracking place`, docs/tracking.md §10): a usbmon capture of the device
// (its configuration read, IMU reports 0x20 and light reports 0x25 / 0x28, on whichever
// endpoints) or a libsurvive recording replayed as the device's own reports
// (create_survive_backend), both through the codec the device tracker uses (factory
// calibration, head axes) and the light decoder; then the stretches in which the device lay
// still, found from its IMU, and the base stations placed from the light of one of them.
//
// Still: over every `window_s` of IMU samples the gyro's standard deviation and the
// accelerometer's stay under their bounds and the gyro's mean (a bias, after the factory
// calibration) under max_gyro_mean; consecutive still windows join into a stretch. A device that
// turns at a steady rate below max_gyro_mean would pass for still; the placement's residual then
// shows it (the angles of a moving device do not fit one pose).
//
// Pure functions but for the file reads. Cost: O(reports) to gather, O(IMU samples) to find the
// stretches, one placement (base_station_placement.hpp) per stretch placed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {

// One IMU sample as the device tracker's codec gives it: head axes, factory calibration applied.
struct ImuReading {
    int64_t device_time_ns = 0;
    glm::dvec3 gyro{0.0};   // rad/s
    glm::dvec3 accel{0.0};  // m/s^2 (specific force: at rest it points up)
};

struct DeviceLightLog {
    std::string source;  // "capture vive_cal.pcap.gz 28de:2000", "recording X.rec.gz T20"
    LighthouseSensors sensors;
    bool has_calibration = false;  // the factory IMU calibration was read (else the codec's axes)
    ImuCalibration calibration;
    std::vector<ImuReading> imu;
    // Every light event, on the IMU's turn of the device's 32-bit clock (the two unwrap from
    // their own first ticks), in decoding order.
    std::vector<lighthouse::LightEvent> events;
    // After the whole stream: every base station seen, with its calibration if a frame decoded.
    std::vector<lighthouse::BaseStationState> base_stations;
    lighthouse::LightCounters light;
    uint64_t imu_reports = 0, light_reports = 0, rejected_light_reports = 0;
    std::string first_rejection;        // the first refused light report's error
    std::vector<std::string> warnings;  // the reader's and the decoder's (bad CRC, ...)
};

// Device VID:PID of a usbmon capture (found as create_capture_tracker finds it: descriptors, the
// ".usbdevs" sidecar, or the one unidentified device with reports). An error names the file
// and the devices it holds; a capture without the device's configuration read (the sensor
// model) is an error saying so.
Result<DeviceLightLog> device_light_log_from_capture(const std::filesystem::path& capture,
                                                     const std::string& vid_pid);
// Device `device` of a libsurvive recording (its CONFIG gives the sensor model and calibration;
// its W / Y / C lines the light). An error when it has no light line or no sensor model.
Result<DeviceLightLog> device_light_log_from_recording(const std::filesystem::path& recording,
                                                       const std::string& device);

struct StillOptions {
    double window_s = 0.25;                        // the IMU samples judged together
    double max_gyro_sd_rad_s = 0.6 * 0.0174533;    // per window (a still Index: ~0.1 deg/s)
    double max_gyro_mean_rad_s = 3.0 * 0.0174533;  // a bias left by the factory calibration
    double max_accel_sd_m_s2 = 0.06;               // per window (a still Index: ~0.02)
    double min_duration_s = 1.0;                   // a shorter still stretch is not reported
};

struct StillStretch {
    int64_t begin_ns = 0, end_ns = 0;  // device clock
    glm::dvec3 mean_accel{0.0};        // head axes: "up" times g
    double gyro_sd_rad_s = 0;          // the largest window's
    size_t light_events = 0;           // events of the log inside it
    size_t base_stations = 0;          // base stations with events inside it
    double seconds() const { return double(end_ns - begin_ns) * 1e-9; }
};

// The still stretches of a log's IMU, in time order.
std::vector<StillStretch> still_stretches(const DeviceLightLog& log,
                                          const StillOptions& options = {});

// The stretch to place from: the one seeing the most base stations, then the most light.
// nullopt when `stretches` is empty.
std::optional<StillStretch> best_still_stretch(std::span<const StillStretch> stretches);

// The base stations placed from the log's light inside [begin_ns, end_ns] (the device still
// there), the device's model frame defining the world at its origin; with `mean_accel` (head
// axes) the world is levelled, its +Z up as in libsurvive's worlds and the setup file's
// convention (LightTrackingConfig::filter.world_up (0, 0, 1)), the device's heading kept.
lighthouse::PlacementResult place_from_log(const DeviceLightLog& log, int64_t begin_ns,
                                           int64_t end_ns,
                                           const std::optional<glm::dvec3>& mean_accel,
                                           const lighthouse::PlacementOptions& options = {});

}  // namespace hmdnode
