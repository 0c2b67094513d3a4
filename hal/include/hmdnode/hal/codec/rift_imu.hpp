// Oculus Rift DK2 (2833:0021) and CV1 (2833:0031) IMU report codec (DESIGN.md §8): input report
// 11 (0x0B), 64 bytes, up to two samples of accelerometer and gyro, each three signed 21-bit
// values packed in 8 bytes at 1e-4 per LSB (m/s^2, rad/s), a 16-bit running sample count and a
// 32-bit µs timestamp of the newest sample.
//
// parse_report is pure; ImuDecoder keeps the sample-count and timestamp unwrappers and emits each
// sample once, in the hmdnode head frame (the Rift's HMD frame is already x right, y up,
// z backward). One thread. Not done: the keep-alive feature report a live DK2/CV1 needs.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode::rift {

constexpr uint16_t kVendorId = 0x2833;
constexpr uint16_t kDk2ProductId = 0x0021;
constexpr uint16_t kCv1ProductId = 0x0031;
constexpr uint8_t kSensorReportId = 0x0B;
constexpr size_t kSensorReportSize = 64;
constexpr double kLsb = 1e-4;
constexpr int64_t kSamplePeriodUs = 1000;

struct RawSample {
    std::array<int32_t, 3> accel{};  // 21-bit signed
    std::array<int32_t, 3> gyro{};
};
struct SensorReport {
    uint16_t command_id = 0;
    uint8_t num_samples = 0;       // as sent (the decoder uses at most 2)
    uint16_t sample_count = 0;     // samples since start, excluding this report's
    int16_t temperature_cdeg = 0;  // 1/100 °C
    uint32_t timestamp_us = 0;     // newest sample
    std::array<RawSample, 2> samples{};
    std::array<int16_t, 3> mag{};
};

// Three signed 21-bit values, big-endian bit order, packed in 8 bytes (OpenHMD packet.c).
std::array<int32_t, 3> unpack21(const uint8_t* p);
void pack21(const std::array<int32_t, 3>& v, uint8_t* p);

Result<SensorReport> parse_report(std::span<const uint8_t> bytes);
std::array<uint8_t, kSensorReportSize> encode_report(const SensorReport& r);

struct ImuSample {
    uint64_t sequence = 0;
    int64_t device_time_ns = 0;  // unwrapped µs clock, in ns
    glm::dvec3 accel{0.0};       // m/s^2
    glm::dvec3 gyro{0.0};        // rad/s
};

struct ImuDecoderCounters {
    uint64_t reports = 0, samples = 0, malformed = 0, unknown = 0, repeated = 0;
    uint64_t sequence_gaps = 0, missing_samples = 0;
};

class ImuDecoder {
  public:
    // Decodes one report; writes its new samples (0..2) oldest first into out.
    size_t decode(std::span<const uint8_t> report, std::span<ImuSample, 2> out);
    const ImuDecoderCounters& counters() const { return counters_; }

  private:
    ImuDecoderCounters counters_;
    bool have_ = false;
    uint64_t next_seq_ = 0;  // unwrapped sequence of the next expected sample
    uint32_t last_ts32_ = 0;
    uint64_t ts_us_ = 0;  // unwrapped timestamp of the last report
};

}  // namespace hmdnode::rift
