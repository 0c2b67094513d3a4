// The hmdnode reference tracker protocol (version 1.0): the HID reports a headset maker's own
// tracker firmware sends so that hmdnode reads it without a driver. Byte-by-byte layout, units and
// the time-sync exchange are documented in docs/tracker-protocol.md; this header is the codec.
//
// Every report is little-endian, starts with its report id, then one version byte
// (major << 4 | minor). A decoder accepts any minor version of its major, reading the fields it
// knows and ignoring bytes appended by a newer minor version (decoded by length); an unknown major
// version, a short report or an out-of-range field is an error, never trusted.
//
// Pure functions over caller-owned bytes: no I/O, no allocation beyond the returned vectors of the
// encoders, no global state. Any thread.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode::refproto {

// pid.codes test ids, for development; a product ships with the maker's own VID:PID.
constexpr uint16_t kDevVendorId = 0x1209;
constexpr uint16_t kDevProductId = 0x0001;

constexpr uint8_t kVersionMajor = 1;
constexpr uint8_t kVersionMinor = 0;
constexpr uint8_t kVersionByte = (kVersionMajor << 4) | kVersionMinor;

enum ReportId : uint8_t {
    kPoseReport = 0x01,         // input: fused pose
    kImuReport = 0x02,          // input: raw IMU samples
    kDeviceInfoReport = 0x10,   // feature, get: identity, capabilities, rates
    kCalibrationReport = 0x11,  // feature, get/set: ranges, biases
    kReportRateReport = 0x12,   // feature, get/set: pose and IMU report rates
    kTimeSyncReport = 0x13,     // feature, set then get: NTP-like time exchange
};

// Sizes of the version-1.0 reports, report id included. Newer minor versions may be longer.
constexpr size_t kPoseReportSize = 64;
constexpr size_t kImuReportSize = 64;
constexpr size_t kDeviceInfoReportSize = 64;
constexpr size_t kCalibrationReportSize = 32;
constexpr size_t kReportRateReportSize = 8;
constexpr size_t kTimeSyncReportSize = 32;

// Pose report flags.
constexpr uint8_t kPoseFlagOrientationValid = 1u << 0;
constexpr uint8_t kPoseFlagPositionValid = 1u << 1;
constexpr uint8_t kPoseFlagAngularVelocityValid = 1u << 2;
constexpr uint8_t kPoseFlagClockReset = 1u << 3;  // device clock restarted (reboot, resync)

// Capability bits of the device-info report.
constexpr uint32_t kCapOrientation = 1u << 0;
constexpr uint32_t kCapPosition = 1u << 1;
constexpr uint32_t kCapImu = 1u << 2;
constexpr uint32_t kCapAngularVelocity = 1u << 3;
constexpr uint32_t kCapTimeSync = 1u << 4;
constexpr uint32_t kCapSettableRate = 1u << 5;

// Fixed-point units on the wire.
constexpr double kQuatScale = 1073741824.0;  // Q2.30: 1.0 = 2^30
constexpr double kPositionUnitM = 1e-6;      // position: int32 micrometres (+-2147 m)
constexpr double kAngVelUnitRadS = 1e-6;     // angular velocity: int32 micro-rad/s
constexpr double kBiasGyroUnitRadS = 1e-6;   // calibration gyro bias: int32 micro-rad/s
constexpr double kBiasAccelUnitMs2 = 1e-6;   // calibration accel bias: int32 micro-m/s^2
constexpr double kStandardGravity = 9.80665;

// 0x01, input. Orientation head-to-world (hmdnode frame: x right, y up, -z forward).
struct PoseReport {
    uint8_t version = kVersionByte;
    uint8_t flags = kPoseFlagOrientationValid;
    uint32_t sequence = 0;        // +1 per report; wraps at 2^32
    uint64_t device_time_us = 0;  // device clock at the measurement the pose describes
    glm::dquat orientation{1, 0, 0, 0};
    glm::dvec3 position_m{0.0};        // meaningful when kPoseFlagPositionValid
    glm::dvec3 angular_velocity{0.0};  // rad/s, head frame; when kPoseFlagAngularVelocityValid
};

// 0x02, input. Up to kMaxImuSamples consecutive samples; sample i has sequence first_sequence + i
// and time device_time_us + dt_us[i] (dt_us[0] = 0).
constexpr size_t kMaxImuSamples = 3;
struct ImuSample {
    uint16_t dt_us = 0;
    std::array<int16_t, 3> accel{};  // LSB = accel_range_g * g / 32768 m/s^2, head frame
    std::array<int16_t, 3> gyro{};   // LSB = gyro_range_dps / 32768 deg/s, head frame
};
struct ImuReport {
    uint8_t version = kVersionByte;
    uint8_t count = 0;               // 1..kMaxImuSamples
    uint8_t accel_range_g = 8;       // full scale, g
    uint16_t gyro_range_dps = 2000;  // full scale, deg/s
    uint32_t first_sequence = 0;
    uint64_t device_time_us = 0;  // time of samples[0]
    std::array<ImuSample, kMaxImuSamples> samples{};

    double accel_scale() const { return accel_range_g * kStandardGravity / 32768.0; }
    double gyro_scale() const;  // rad/s per LSB
};

// 0x10, feature (get).
struct DeviceInfoReport {
    uint8_t version = kVersionByte;
    uint8_t firmware_major = 0, firmware_minor = 0;
    uint16_t firmware_patch = 0;
    uint32_t capabilities = 0;
    uint16_t pose_rate_hz = 0;  // current nominal rates (0: report not sent)
    uint16_t imu_rate_hz = 0;
    std::string serial;   // <= 16 ASCII bytes on the wire (NUL-padded)
    std::string product;  // <= 32 ASCII bytes on the wire (NUL-padded)
};

// 0x11, feature (get; set where the firmware allows). Biases are subtracted by the host.
struct CalibrationReport {
    uint8_t version = kVersionByte;
    uint8_t accel_range_g = 8;
    uint16_t gyro_range_dps = 2000;
    glm::dvec3 gyro_bias{0.0};   // rad/s
    glm::dvec3 accel_bias{0.0};  // m/s^2
};

// 0x12, feature (get/set). 0 disables that report.
struct ReportRateReport {
    uint8_t version = kVersionByte;
    uint16_t pose_rate_hz = 0;
    uint16_t imu_rate_hz = 0;
};

// 0x13, feature. The host sets {nonce, host_send_ns}; the device stamps device_receive_us when the
// set arrives. The host then gets the report: the device echoes nonce and host_send_ns and stamps
// device_transmit_us as it answers. With host_receive_ns taken when the get returns:
//   offset (host - device) = ((t2 - t1) + (t3 - t4)) / 2 with t1 = host_send_ns,
//   t2 = device_receive_us, t3 = device_transmit_us, t4 = host_receive_ns (all in ns);
//   round-trip delay = (t4 - t1) - (t3 - t2).
struct TimeSyncReport {
    uint8_t version = kVersionByte;
    uint32_t nonce = 0;
    int64_t host_send_ns = 0;
    uint64_t device_receive_us = 0;   // 0 in the host's set
    uint64_t device_transmit_us = 0;  // 0 in the host's set
};

// One NTP-like exchange's estimate (see TimeSyncReport).
struct TimeSyncEstimate {
    int64_t offset_ns = 0;  // host_ns = device_us * 1000 + offset_ns
    int64_t round_trip_ns = 0;
};
TimeSyncEstimate time_sync_estimate(const TimeSyncReport& answer, int64_t host_receive_ns);

// The HID report descriptor a device of this protocol presents (vendor page 0xFF00, usage 0x01).
std::span<const uint8_t> report_descriptor();

// Encoders: the exact bytes of a version-1.0 report, report id first. Values out of range of the
// wire format are clamped (encoders assert on count > kMaxImuSamples).
std::vector<uint8_t> encode(const PoseReport& r);
std::vector<uint8_t> encode(const ImuReport& r);
std::vector<uint8_t> encode(const DeviceInfoReport& r);
std::vector<uint8_t> encode(const CalibrationReport& r);
std::vector<uint8_t> encode(const ReportRateReport& r);
std::vector<uint8_t> encode(const TimeSyncReport& r);

// Decoders: bytes as a transport gives them (report id first). Errors name the report and field.
Result<PoseReport> decode_pose(std::span<const uint8_t> bytes);
Result<ImuReport> decode_imu(std::span<const uint8_t> bytes);
Result<DeviceInfoReport> decode_device_info(std::span<const uint8_t> bytes);
Result<CalibrationReport> decode_calibration(std::span<const uint8_t> bytes);
Result<ReportRateReport> decode_report_rate(std::span<const uint8_t> bytes);
Result<TimeSyncReport> decode_time_sync(std::span<const uint8_t> bytes);

}  // namespace hmdnode::refproto
