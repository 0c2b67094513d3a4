// libsurvive recordings (`.rec` / `.rec.gz`): the raw IMU samples, factory IMU calibration and
// lighthouse-solved poses of one device, and a transport backend that replays its IMU samples as
// the device's own USB reports, so they pass through the same codec, calibration, clock tracking
// and fusion as a live device (docs/tracking.md §8).
//
// The format is libsurvive's text log, one event a line, `TIME DEVICE KIND ...` (TIME in seconds
// on the recording host's clock). What is read (libsurvive documents it nowhere formally; this is
// what its recorder writes):
//   TIME DEV i MASK TICK ax ay az gx gy gz mx my mz SEQ   raw IMU counts, 48 MHz tick, sequence
//   TIME DEV CONFIG {json}                                  the device's factory configuration
//   TIME DEV POSE x y z qw qx qy qz                          lighthouse-solved pose (libsurvive's
//                                                           world, z up; the object's frame)
// Every other line is counted and skipped. A malformed line of a kind read is an error naming the
// file and line, except a cut last line (a recorder stopped mid-write), which is skipped with a
// warning. Cost: O(file) time and memory.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

struct SurviveImuLine {
    int64_t host_time_ns = 0;        // the line's TIME
    uint32_t ticks = 0;              // 48 MHz device clock (wraps every 89 s)
    uint8_t sequence = 0;            // the device's 8-bit sample counter
    std::array<int16_t, 3> accel{};  // raw counts, IMU axes
    std::array<int16_t, 3> gyro{};
};

struct SurvivePose {
    int64_t host_time_ns = 0;
    glm::dvec3 position{0.0};            // metres, libsurvive world
    glm::dquat orientation{1, 0, 0, 0};  // object-to-world
};

struct SurviveRecording {
    std::string device;  // e.g. "T20"
    std::vector<SurviveImuLine> imu;
    std::vector<SurvivePose> poses;
    bool has_config = false;
    ImuCalibration calibration;        // from the device's CONFIG (identity when none)
    std::string model;                 // CONFIG's model_number, when present
    uint64_t lines = 0;                // lines read
    uint64_t other_lines = 0;          // lines of other kinds or devices, skipped
    std::vector<std::string> devices;  // every device name with i/POSE/CONFIG lines, in order
    std::vector<std::string> warnings;
};

// Reads `device`'s lines of a recording (gzip'd or not). A device with no IMU line is an error
// naming the devices the file holds.
Result<SurviveRecording> read_survive_recording(const std::filesystem::path& path,
                                                const std::string& device);
// The same over text; `source` names it in errors.
Result<SurviveRecording> parse_survive_recording(const std::string& text, const std::string& source,
                                                 const std::string& device);

// The factory IMU calibration of a device configuration JSON (OpenVR/lighthouse `imu` object:
// acc_bias in m/s^2, acc_scale, gyro_bias in rad/s, gyro_scale, plus_x / plus_z of the IMU in the
// device frame; the `head` object's plus_x / plus_z give the head frame in the same device frame).
Result<ImuCalibration> parse_imu_calibration_json(const std::string& json,
                                                  const std::string& source);

// A backend with one device (28de:2300, product "Valve Index (libsurvive recording DEV)") whose
// input reports are Vive/Index reports 0x20 built from the recording's IMU lines, one new sample
// each, arriving at the lines' TIME.
std::unique_ptr<TransportBackend> create_survive_backend(
    std::shared_ptr<const SurviveRecording> rec);

// `hmdnode record --backend rec`: a device tracker over the recording's IMU (Index codec with the
// recording's calibration, clock sync, fusion), its first report arriving at first_report_host_ns.
Result<std::unique_ptr<DeviceTracker>> create_survive_tracker(
    std::shared_ptr<const SurviveRecording> rec, Clock& clock, int64_t first_report_host_ns,
    const ImuFusionConfig& fusion = {});

}  // namespace hmdnode
