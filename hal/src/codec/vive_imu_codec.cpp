// Vive / Index IMU report codec (DESIGN.md §8; layout and axis conventions as read by the public
// drivers Monado `vive_device.c` and OpenHMD `vive.c`).
// Cost: O(1) time and memory per report (three slots).
// Departures: the first report of a stream emits only its newest slot (older slots cannot be told
// apart from stale repeats without a previous sequence number); a slot whose tick goes backwards
// keeps the previous unwrapped time instead of jumping forward by a whole wrap.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>

#include "hmdnode/hal/codec/vive_imu.hpp"

namespace hmdnode::vive {
namespace {

int16_t le_i16(const uint8_t* p) {
    return int16_t(uint16_t(p[0] | (p[1] << 8)));
}
uint32_t le_u32(const uint8_t* p) {
    return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

}  // namespace

glm::dvec3 to_head_frame(Variant v, const glm::dvec3& s) {
    if (v == Variant::Index) return {-s.y, -s.x, -s.z};
    return {s.x, -s.y, -s.z};
}
glm::dvec3 to_sensor_frame(Variant v, const glm::dvec3& h) {
    return to_head_frame(v, h);  // a signed permutation that is its own inverse
}

Result<ImuRanges> parse_range_report(std::span<const uint8_t> b) {
    if (b.size() < 3)
        return make_error("Vive range report 0x01: " + std::to_string(b.size()) +
                          " bytes, needs at least 3");
    if (b[0] != kRangeReportId)
        return make_error("Vive range report 0x01: byte 0 (report id) is " + std::to_string(b[0]));
    if (b[1] > 4)
        return make_error("Vive range report 0x01: byte 1 (gyro range code) is " +
                          std::to_string(b[1]) + ", above 4");
    if (b[2] > 4)
        return make_error("Vive range report 0x01: byte 2 (accel range code) is " +
                          std::to_string(b[2]) + ", above 4");
    ImuRanges r;
    r.gyro_rad_s = double(250 << b[1]) * 3.14159265358979323846 / 180.0;
    r.accel_m_s2 = double(2 << b[2]) * kStandardGravity;
    return r;
}

Result<std::array<RawSlot, 3>> parse_imu_report(std::span<const uint8_t> b) {
    if (b.empty() || b[0] != kImuReportId)
        return make_error("Vive IMU report: byte 0 (report id) is not 0x20");
    if (b.size() < kImuReportSize)
        return make_error("Vive IMU report 0x20: " + std::to_string(b.size()) + " bytes, needs 52");
    std::array<RawSlot, 3> slots;
    for (size_t i = 0; i < 3; ++i) {
        assert(1 + 17 * (i + 1) <= b.size());  // the slot's 17 bytes lie within the report
        const uint8_t* p = b.data() + 1 + 17 * i;
        for (int k = 0; k < 3; ++k) slots[i].accel[k] = le_i16(p + 2 * k);
        for (int k = 0; k < 3; ++k) slots[i].gyro[k] = le_i16(p + 6 + 2 * k);
        slots[i].ticks = le_u32(p + 12);
        slots[i].sequence = p[16];
    }
    return slots;
}

std::array<uint8_t, kImuReportSize> encode_imu_report(const std::array<RawSlot, 3>& slots) {
    std::array<uint8_t, kImuReportSize> b{};
    b[0] = kImuReportId;
    for (size_t i = 0; i < 3; ++i) {
        uint8_t* p = b.data() + 1 + 17 * i;
        auto put16 = [](uint8_t* q, int16_t v) {
            q[0] = uint8_t(uint16_t(v));
            q[1] = uint8_t(uint16_t(v) >> 8);
        };
        for (int k = 0; k < 3; ++k) put16(p + 2 * k, slots[i].accel[k]);
        for (int k = 0; k < 3; ++k) put16(p + 6 + 2 * k, slots[i].gyro[k]);
        for (int k = 0; k < 4; ++k) p[12 + k] = uint8_t(slots[i].ticks >> (8 * k));
        p[16] = slots[i].sequence;
    }
    return b;
}

Variant variant_for_product(uint16_t product_id) {
    return product_id == kIndexProductId ? Variant::Index : Variant::Vive;
}

ImuDecoder::ImuDecoder(Variant variant, const ImuRanges& ranges)
    : variant_(variant), ranges_(ranges) {
    assert(ranges.gyro_rad_s > 0.0 && ranges.accel_m_s2 > 0.0);  // full scales, LSB = range / 2^15
}

size_t ImuDecoder::decode(std::span<const uint8_t> report, std::span<ImuSample, 3> out) {
    if (report.empty() || report[0] != kImuReportId) {
        ++counters_.unknown;
        return 0;
    }
    auto parsed = parse_imu_report(report);
    if (!parsed) {
        ++counters_.malformed;
        return 0;
    }
    ++counters_.reports;
    const std::array<RawSlot, 3>& slots = *parsed;

    // Order the slots newer than the last emitted one by their (wrapping) sequence distance.
    struct Pick {
        int delta;
        size_t slot;
    };
    std::array<Pick, 3> picks;
    size_t n_picks = 0;
    if (!have_last_) {
        size_t newest = 0;
        for (size_t i = 1; i < 3; ++i)
            if (int8_t(uint8_t(slots[i].sequence - slots[newest].sequence)) > 0) newest = i;
        picks[n_picks++] = {1, newest};
        counters_.duplicate_slots += 2;
    } else {
        for (size_t i = 0; i < 3; ++i) {
            const int d = int8_t(uint8_t(slots[i].sequence - last_seq8_));
            if (d > 0 && std::none_of(picks.begin(), picks.begin() + n_picks,
                                      [&](const Pick& p) { return p.delta == d; }))
                picks[n_picks++] = {d, i};
            else
                ++counters_.duplicate_slots;
        }
        for (size_t i = 1; i < n_picks; ++i)  // insertion sort of at most three
            for (size_t j = i; j > 0 && picks[j].delta < picks[j - 1].delta; --j)
                std::swap(picks[j], picks[j - 1]);
    }
    assert(n_picks <= out.size());

    const double accel_scale = ranges_.accel_m_s2 / 32768.0;
    const double gyro_scale = ranges_.gyro_rad_s / 32768.0;
    int prev_delta = 0;
    for (size_t k = 0; k < n_picks; ++k) {
        const RawSlot& s = slots[picks[k].slot];
        // Picks are new slots in sequence order: each one past the last emitted and the previous.
        assert(picks[k].slot < 3 && picks[k].delta > prev_delta);
        [[maybe_unused]] const bool had_last = have_last_;
        [[maybe_unused]] const uint64_t prev_seq = last_seq_, prev_ticks = ticks_;
        if (have_last_ && picks[k].delta > prev_delta + 1) {
            ++counters_.sequence_gaps;
            counters_.missing_samples += uint64_t(picks[k].delta - prev_delta - 1);
        }
        prev_delta = picks[k].delta;
        if (!have_last_) {
            ticks_ = s.ticks;
            last_seq_ = s.sequence;
        } else {
            const int32_t dt = int32_t(s.ticks - last_ticks32_);
            if (dt > 0) ticks_ += uint64_t(dt);
            last_seq_ += uint64_t(uint8_t(s.sequence - last_seq8_));
        }
        // Each sample once, in order: the unwrapped sequence rises, the unwrapped clock never
        // goes back.
        assert(!had_last || (last_seq_ > prev_seq && ticks_ >= prev_ticks));
        have_last_ = true;
        last_ticks32_ = s.ticks;
        last_seq8_ = s.sequence;

        ImuSample& o = out[k];
        o.sequence = last_seq_;
        o.ticks = ticks_;
        o.device_time_ns = int64_t(ticks_ / 48 * 1000 + (ticks_ % 48) * 1000 / 48);
        o.accel =
            to_head_frame(variant_, glm::dvec3(s.accel[0], s.accel[1], s.accel[2]) * accel_scale);
        o.gyro = to_head_frame(variant_, glm::dvec3(s.gyro[0], s.gyro[1], s.gyro[2]) * gyro_scale);
        auto clipped = [](const std::array<int16_t, 3>& v) {
            return std::any_of(v.begin(), v.end(),
                               [](int16_t x) { return x == INT16_MIN || x == INT16_MAX; });
        };
        o.gyro_saturated = clipped(s.gyro);
        o.accel_saturated = clipped(s.accel);
        counters_.saturated_samples += o.gyro_saturated || o.accel_saturated;
    }
    counters_.samples += n_picks;
    return n_picks;
}

}  // namespace hmdnode::vive
