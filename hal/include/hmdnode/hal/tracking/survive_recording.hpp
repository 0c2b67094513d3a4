// libsurvive recordings (`.rec` / `.rec.gz`): the raw IMU samples, factory IMU calibration and
// lighthouse-solved poses of one device, and a transport backend that replays its IMU samples as
// the device's own USB reports, so they pass through the same codec, calibration, clock tracking
// and fusion as a live device (docs/tracking.md §8).
//
// The format is libsurvive's text log, one event a line, `TIME DEVICE KIND ...` (TIME in seconds
// on the recording host's clock). What is read (libsurvive documents it nowhere formally; this is
// what its recorder writes):
//   TIME DEV i MASK TICK ax ay az gx gy gz mx my mz SEQ   raw IMU counts, 48 MHz tick, sequence
//   TIME DEV i MASK TICK ax ay az gx gy gz SEQ             the same, older recorders (no
//   magnetometer) TIME DEV IMU_SCALES GYRO ACC                            the IMU's range codes
//   (feature report
//                                                           0x01: 250 << GYRO deg/s, 2 << ACC g)
//   TIME DEV CONFIG {json}                                  the device's factory configuration
//   TIME DEV POSE x y z qw qx qy qz                          lighthouse-solved pose (libsurvive's
//                                                           world, z up; the object's frame)
//   TIME NAME EXTERNAL_POSE x y z qw qx qy qz                a pose named NAME (libsurvive's replay
//                                                           writes a device's POSE lines back as
//                                                           replay_DEV; any name is read)
//   TIME DEV W CHANNEL SENSOR TIMECODE FLAG                 lighthouse-2 sweep hit (SENSOR: the
//                                                           model's index; FLAG: a half tick)
//   TIME DEV B CHANNEL SENSOR TIMECODE PLANE ANGLE          libsurvive's angle of that hit (rad)
//   TIME DEV Y CHANNEL TIMECODE OOTX GEN                    lighthouse-2 sync, one per rotor turn
//   TIME DEV C SENSOR TIMECODE LENGTH                       lighthouse-1 pulse (raw channel)
//   TIME DEV A SENSOR ACODE TIMECODE LENGTH_S ANGLE LH      libsurvive's lighthouse-1 angle (rad)
//   TIME CH LH_POSE x y z qw qx qy qz [ID]                  a base station's pose (any device
//                                                           field: the channel / number)
// The light lines feed lighthouse::LightDecoder (codec/light_codec.hpp) in file order.
// Every other line is counted and skipped. A malformed line of a kind read is an error naming the
// file and line, except a cut last line (a recorder stopped mid-write), which is skipped with a
// warning. Cost: O(file) time and memory.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/light_tracking.hpp"
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

// One light line of the device (see above), in file order.
struct SurviveLightLine {
    enum class Kind : uint8_t { sweep, angle, sync, pulse, lh1_angle };  // W B Y C A
    Kind kind = Kind::sweep;
    uint32_t line = 0;  // 1-based line number in the file
    int64_t host_time_ns = 0;
    uint8_t channel = 0;    // W B Y: lighthouse-2 channel; A: base station (LH)
    uint8_t sensor = 0;     // W B A: model index; C: raw channel
    uint32_t timecode = 0;  // 48 MHz, the device's 32-bit clock
    uint8_t flag = 0;       // W: half tick; B: plane; Y: OOTX bit; A: ACODE
    uint8_t gen = 0;        // Y
    uint32_t length = 0;    // C: ticks
    double angle = 0;       // B A: radians
    double length_s = 0;    // A
};

struct SurviveBaseStationPose {
    int64_t host_time_ns = 0;
    int number = 0;  // libsurvive's: the lighthouse-2 channel, or the lighthouse-1 index
    glm::dvec3 position{0.0};
    glm::dquat orientation{1, 0, 0, 0};  // base station to world
    std::optional<uint32_t> id;          // its OOTX id, when the line carries it
};

// The EXTERNAL_POSE lines of one name, in file order.
struct SurviveNamedPoses {
    std::string name;
    std::vector<SurvivePose> poses;
};

struct SurviveRecording {
    std::string device;  // e.g. "T20"
    std::vector<SurviveImuLine> imu;
    std::vector<SurvivePose> poses;                 // the device's POSE lines
    std::vector<SurviveNamedPoses> external_poses;  // every EXTERNAL_POSE line, by name
    // IMU_SCALES of the device (libsurvive's range modes: gyro 250 << g deg/s, accel 2 << a g),
    // when the recording has one with modes 0..3 (what libsurvive applies); else the device's
    // defaults (survive_imu_scales).
    std::optional<std::array<uint8_t, 2>> imu_scales;
    // The IMU lines carry no sequence number (every SEQ the same: a controller's, through its
    // radio): they were numbered in the order of their ticks (SurviveImuLine::sequence).
    bool imu_sequence_numbered = false;
    std::vector<SurviveLightLine> light;
    std::vector<SurviveBaseStationPose> base_station_poses;  // every LH_POSE line
    LighthouseSensors sensors;  // CONFIG's lighthouse_config (empty when none)
    bool has_config = false;
    ImuCalibration calibration;        // from the device's CONFIG (identity when none)
    std::string model;                 // CONFIG's model_number, when present
    std::string device_class;          // CONFIG's device_class ("hmd", "controller"), when present
    uint64_t lines = 0;                // lines read
    uint64_t other_lines = 0;          // lines of other kinds or devices, skipped
    std::vector<std::string> devices;  // every device name with lines of a kind read, in order
    std::vector<std::string> warnings;
    std::vector<std::string> notes;  // what the reader did that is not a fault (numbering, scales)
};

// The device's lighthouse-solved poses as a reference: its POSE lines; when it has none, the
// EXTERNAL_POSE lines named replay_DEV (libsurvive's replay of its POSE lines), else named DEV.
// `what` says which ("POSE lines of T20", "EXTERNAL_POSE lines named replay_T20"); null with no
// such line, and `what` then lists the EXTERNAL_POSE names the recording holds.
const std::vector<SurvivePose>* survive_device_poses(const SurviveRecording& rec,
                                                     std::string* what);

// The IMU range modes the device's samples are decoded with ({gyro, accel}, as IMU_SCALES): the
// recording's IMU_SCALES line when it has one, else libsurvive's defaults by device
// (survive_default_devices.c, handle_config): a headset 500 deg/s and 4 g ({1, 1}); every other
// device (controllers, trackers) 2000 deg/s and 8 g ({3, 2}). A headset: the CONFIG's
// device_class "hmd", or without one the codename "HMD" (libsurvive's own test).
std::array<uint8_t, 2> survive_imu_scales(const SurviveRecording& rec);
// What survive_imu_scales gives and where it comes from: "IMU_SCALES: 2000 deg/s, 8 g", or
// "2000 deg/s, 8 g (no IMU_SCALES line: libsurvive's default for a device that is not a headset,
// by its CONFIG device_class "controller")".
std::string describe_survive_imu_scales(const SurviveRecording& rec);

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

// The recording's device model for the light decoder (CONFIG's lighthouse_config; without one, 32
// sensors, raw channel = index).
lighthouse::SensorModel survive_sensor_model(const SurviveRecording& rec);

// Feeds the recording's light input, in file order, to `decoder`: W (sweeps) and Y (syncs) lines
// as lighthouse-2 events, C lines as lighthouse-1 pulses; B and A lines are libsurvive's own
// angles, not input. Then finish(). A line the decoder refuses (a sensor beyond the model) is an
// error naming the line.
Status replay_survive_light(const SurviveRecording& rec, lighthouse::LightDecoder& decoder);

// A backend with one device (28de:2300, product "Valve Index (libsurvive recording DEV)") whose
// input reports are Vive/Index reports 0x20 built from the recording's IMU lines, one new sample
// each, arriving at the lines' TIME. `with_light`: its light lines too, interleaved by TIME (a
// light line first on a tie), as the device's light reports: a W or Y line a report 0x28 of one
// word (the sensor as its raw channel, the low 24 bits of the time), a C line a report 0x25 of
// one pulse; B and A lines (libsurvive's angles) are not sent.
std::unique_ptr<TransportBackend> create_survive_backend(
    std::shared_ptr<const SurviveRecording> rec, bool with_light = false);

// `hmdnode record --backend rec`: a device tracker over the recording's IMU (Index codec with the
// recording's calibration, clock sync, fusion), its first report arriving at first_report_host_ns.
// `light` with a setup, on a recording with light lines: its light too, through the light path
// (DeviceTrackerConfig::light: 6DoF poses), the first IMU report still at first_report_host_ns
// (light reports before it as much earlier as in the recording); else IMU only.
Result<std::unique_ptr<DeviceTracker>> create_survive_tracker(
    std::shared_ptr<const SurviveRecording> rec, Clock& clock, int64_t first_report_host_ns,
    const ImuFusionConfig& fusion = {}, std::shared_ptr<const LightTrackingConfig> light = nullptr);

// The light path's configuration for a recording's device: its sensor model and head frame
// (CONFIG's lighthouse_config), the IMU's lever arm, `setup` in a world whose up is `world_up`
// (libsurvive's: +z). An error when the recording has no light lines or no sensor model.
Result<LightTrackingConfig> survive_light_tracking_config(
    const SurviveRecording& rec, std::vector<lighthouse::BaseStationPlacement> setup,
    const glm::dvec3& world_up = glm::dvec3(0, 0, 1));

}  // namespace hmdnode
