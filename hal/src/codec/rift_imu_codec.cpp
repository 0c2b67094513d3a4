// Rift DK2/CV1 IMU report codec (DESIGN.md §8; layout as read by OpenHMD's packet.c
// decode_tracker_sensor_msg_dk2 and decode_sample: id, u16 command id, u8 sample count, u16
// samples-since-start, i16 temperature, u32 µs timestamp, 2 x (accel 8 bytes, gyro 8 bytes),
// 3 x i16 magnetometer, then camera-frame fields).
// Cost: O(1) per report.
// Departures: samples are numbered by the running count (unwrapped from 16 bits) so repeats are
// dropped and gaps counted; sample i's time is the report timestamp minus (n - 1 - i) ms, as
// OpenHMD assumes a 1 kHz IMU.
#include "hmdnode/hal/codec/rift_imu.hpp"

#include <algorithm>
#include <cassert>

namespace hmdnode::rift {

std::array<int32_t, 3> unpack21(const uint8_t* b) {
    assert(b != nullptr);
    const uint32_t x =
        (uint32_t(b[0]) << 24) | (uint32_t(b[1]) << 16) | (uint32_t(b[2] & 0xF8) << 8);
    const uint32_t y = (uint32_t(b[2] & 0x07) << 29) | (uint32_t(b[3]) << 21) |
                       (uint32_t(b[4]) << 13) | (uint32_t(b[5] & 0xC0) << 5);
    const uint32_t z =
        (uint32_t(b[5] & 0x3F) << 26) | (uint32_t(b[6]) << 18) | (uint32_t(b[7]) << 10);
    return {int32_t(x) >> 11, int32_t(y) >> 11, int32_t(z) >> 11};
}

void pack21(const std::array<int32_t, 3>& v, uint8_t* p) {
    assert(p != nullptr);
    // 63 bits: x (21) y (21) z (21), big-endian, then one zero bit.
    const uint64_t m = (uint64_t(1) << 21) - 1;
    const uint64_t bits = ((uint64_t(uint32_t(v[0])) & m) << 43) |
                          ((uint64_t(uint32_t(v[1])) & m) << 22) |
                          ((uint64_t(uint32_t(v[2])) & m) << 1);
    for (int i = 0; i < 8; ++i) p[i] = uint8_t(bits >> (56 - 8 * i));
}

Result<SensorReport> parse_report(std::span<const uint8_t> b) {
    if (b.empty() || b[0] != kSensorReportId)
        return make_error("Rift sensor report: byte 0 (report id) is not 11");
    if (b.size() != kSensorReportSize)
        return make_error("Rift sensor report 11: " + std::to_string(b.size()) +
                          " bytes, needs 64");
    auto u16 = [&](size_t i) { return uint16_t(b[i] | (b[i + 1] << 8)); };
    SensorReport r;
    r.command_id = u16(1);
    r.num_samples = b[3];
    r.sample_count = u16(4);
    r.temperature_cdeg = int16_t(u16(6));
    r.timestamp_us = uint32_t(u16(8)) | (uint32_t(u16(10)) << 16);
    if (r.num_samples == 0) return make_error("Rift sensor report 11: byte 3 (samples) is 0");
    for (size_t i = 0; i < 2; ++i) {
        r.samples[i].accel = unpack21(&b[12 + 16 * i]);
        r.samples[i].gyro = unpack21(&b[20 + 16 * i]);
    }
    for (size_t k = 0; k < 3; ++k) r.mag[k] = int16_t(u16(44 + 2 * k));
    return r;
}

std::array<uint8_t, kSensorReportSize> encode_report(const SensorReport& r) {
    std::array<uint8_t, kSensorReportSize> b{};
    auto put16 = [&](size_t i, uint16_t v) {
        b[i] = uint8_t(v);
        b[i + 1] = uint8_t(v >> 8);
    };
    b[0] = kSensorReportId;
    put16(1, r.command_id);
    b[3] = r.num_samples;
    put16(4, r.sample_count);
    put16(6, uint16_t(r.temperature_cdeg));
    put16(8, uint16_t(r.timestamp_us));
    put16(10, uint16_t(r.timestamp_us >> 16));
    for (size_t i = 0; i < 2; ++i) {
        pack21(r.samples[i].accel, &b[12 + 16 * i]);
        pack21(r.samples[i].gyro, &b[20 + 16 * i]);
    }
    for (size_t k = 0; k < 3; ++k) put16(44 + 2 * k, uint16_t(r.mag[k]));
    return b;
}

size_t ImuDecoder::decode(std::span<const uint8_t> report, std::span<ImuSample, 2> out) {
    if (report.empty() || report[0] != kSensorReportId) {
        ++counters_.unknown;
        return 0;
    }
    auto r = parse_report(report);
    if (!r) {
        ++counters_.malformed;
        return 0;
    }
    ++counters_.reports;
    const size_t n = std::min<size_t>(r->num_samples, 2);
    // Unwrap the 16-bit count and the 32-bit timestamp.
    uint64_t first_seq;
    if (!have_) {
        first_seq = r->sample_count;
        ts_us_ = r->timestamp_us;
    } else {
        // The count relative to the next expected one, wrapping at 16 bits.
        const int16_t d = int16_t(uint16_t(r->sample_count - uint16_t(next_seq_)));
        first_seq = int64_t(next_seq_) + d < 0 ? 0 : uint64_t(int64_t(next_seq_) + d);
        const int32_t dt = int32_t(r->timestamp_us - last_ts32_);
        if (dt > 0) ts_us_ += uint64_t(dt);
    }
    last_ts32_ = r->timestamp_us;
    size_t k = 0;
    for (size_t i = 0; i < n; ++i) {
        const uint64_t seq = first_seq + i;
        if (have_ && seq < next_seq_) {
            ++counters_.repeated;
            continue;
        }
        assert(k < out.size() && (!have_ || seq >= next_seq_));  // each sample once, in order
        if (have_ && seq > next_seq_) {
            ++counters_.sequence_gaps;
            counters_.missing_samples += seq - next_seq_;
        }
        have_ = true;
        next_seq_ = seq + 1;
        ImuSample& s = out[k++];
        s.sequence = seq;
        s.device_time_ns = (int64_t(ts_us_) - int64_t(n - 1 - i) * kSamplePeriodUs) * 1000;
        const RawSample& raw = r->samples[i];
        s.accel = glm::dvec3(raw.accel[0], raw.accel[1], raw.accel[2]) * kLsb;
        s.gyro = glm::dvec3(raw.gyro[0], raw.gyro[1], raw.gyro[2]) * kLsb;
    }
    counters_.samples += k;
    return k;
}

}  // namespace hmdnode::rift
