// HTC Vive (28de:2000) and Valve Index (28de:2300) IMU report codec (DESIGN.md §8): input report
// 0x20 carries three rotating 17-byte slots {int16 accel[3], int16 gyro[3], uint32 time in 48 MHz
// ticks, uint8 sequence}; feature report 0x01 carries the gyro and accelerometer ranges.
//
// parse_* are pure functions over bytes. ImuDecoder keeps the state a stream needs (the last
// sequence number, the 64-bit tick unwrapper, the ranges) and emits each sample once, in order,
// scaled to m/s^2 and rad/s in the hmdnode head frame (x right, y up, z backward). One thread.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode::vive {

constexpr uint16_t kVendorId = 0x28de;
constexpr uint16_t kViveProductId = 0x2000;
constexpr uint16_t kIndexProductId = 0x2300;
constexpr uint8_t kImuReportId = 0x20;
constexpr size_t kImuReportSize = 52;
constexpr uint8_t kRangeReportId = 0x01;
constexpr size_t kRangeReportSize = 64;  // hidraw returns 64 bytes; 3 are enough to parse
constexpr double kTickHz = 48e6;
constexpr double kStandardGravity = 9.80665;

// Full-scale ranges: LSB = range / 32768.
struct ImuRanges {
    double gyro_rad_s = 500.0 * 3.14159265358979323846 / 180.0;  // default 500 deg/s
    double accel_m_s2 = 4.0 * kStandardGravity;                  // default 4 g
};

// Feature report 0x01: byte 1 = gyro range code g (250 << g deg/s), byte 2 = accel range code a
// (2 << a g); codes above 4 are rejected.
Result<ImuRanges> parse_range_report(std::span<const uint8_t> bytes);

struct RawSlot {
    std::array<int16_t, 3> accel{};
    std::array<int16_t, 3> gyro{};
    uint32_t ticks = 0;
    uint8_t sequence = 0;
};
// The three slots of report 0x20 as they are on the wire (the report may be longer than 52 bytes,
// as some transports pad; the extra bytes are ignored).
Result<std::array<RawSlot, 3>> parse_imu_report(std::span<const uint8_t> bytes);

// Encodes a report 0x20 (for tests, fuzz seeds and simulated devices).
std::array<uint8_t, kImuReportSize> encode_imu_report(const std::array<RawSlot, 3>& slots);

enum class Variant { Vive, Index };
// 28de:2000 -> Vive, 28de:2300 -> Index; anything else -> Vive.
Variant variant_for_product(uint16_t product_id);
// Sensor axes -> hmdnode head frame (x right, y up, z backward) as Monado maps them: Vive
// (x, -y, -z), Index (-y, -x, -z); and back (each mapping is its own inverse).
glm::dvec3 to_head_frame(Variant v, const glm::dvec3& sensor);
glm::dvec3 to_sensor_frame(Variant v, const glm::dvec3& head);

struct ImuSample {
    uint64_t sequence = 0;       // unwrapped: first sample's 8-bit sequence, +1 per device sample
    uint64_t ticks = 0;          // unwrapped 48 MHz device clock
    int64_t device_time_ns = 0;  // ticks converted to ns (device clock, arbitrary origin)
    glm::dvec3 accel{0.0};       // m/s^2, hmdnode head frame
    glm::dvec3 gyro{0.0};        // rad/s, hmdnode head frame
    // A raw count at full scale (-32768 or 32767) on any axis: the true value may be beyond it.
    bool gyro_saturated = false;
    bool accel_saturated = false;
};

struct ImuDecoderCounters {
    uint64_t reports = 0;            // reports with id 0x20 seen
    uint64_t samples = 0;            // unique samples emitted
    uint64_t duplicate_slots = 0;    // slots already emitted (the rotation repeats them)
    uint64_t malformed = 0;          // id 0x20 but too short
    uint64_t unknown = 0;            // other report ids
    uint64_t sequence_gaps = 0;      // times the sequence jumped by more than one
    uint64_t missing_samples = 0;    // samples those jumps skipped
    uint64_t saturated_samples = 0;  // samples with a gyro or accel axis at full scale
};

class ImuDecoder {
  public:
    explicit ImuDecoder(Variant variant = Variant::Vive, const ImuRanges& ranges = {});
    void set_ranges(const ImuRanges& ranges) { ranges_ = ranges; }
    const ImuRanges& ranges() const { return ranges_; }

    // Decodes one input report; writes the samples not seen before, oldest first, into out and
    // returns how many (0..3). Malformed or unknown reports are counted and return 0.
    size_t decode(std::span<const uint8_t> report, std::span<ImuSample, 3> out);

    const ImuDecoderCounters& counters() const { return counters_; }

  private:
    Variant variant_;
    ImuRanges ranges_;
    ImuDecoderCounters counters_;
    bool have_last_ = false;
    uint8_t last_seq8_ = 0;
    uint64_t last_seq_ = 0;
    uint32_t last_ticks32_ = 0;
    uint64_t ticks_ = 0;
};

}  // namespace hmdnode::vive
