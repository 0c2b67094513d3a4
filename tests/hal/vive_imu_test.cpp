// Vive / Index IMU codec: golden bytes, range report, de-duplication of the rotating slots, gaps,
// tick unwrap, malformed and unknown reports.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode::vive {
namespace {

constexpr double kPi = 3.14159265358979323846;

RawSlot slot(uint8_t seq, uint32_t ticks, int16_t ax = 0, int16_t ay = 0, int16_t az = 0,
             int16_t gx = 0, int16_t gy = 0, int16_t gz = 0) {
    RawSlot s;
    s.accel = {ax, ay, az};
    s.gyro = {gx, gy, gz};
    s.ticks = ticks;
    s.sequence = seq;
    return s;
}

TEST(ViveImu, GoldenBytesDecodeToTheWireFields) {
    // Slot 0: accel (100, -200, 16384), gyro (1, -1, 32767), ticks 0x01020304, seq 5.
    std::vector<uint8_t> b = {0x20,                                // report id
                              0x64, 0x00, 0x38, 0xff, 0x00, 0x40,  // accel
                              0x01, 0x00, 0xff, 0xff, 0xff, 0x7f,  // gyro
                              0x04, 0x03, 0x02, 0x01,              // ticks
                              0x05};                               // seq
    b.resize(52, 0);
    auto slots = parse_imu_report(b);
    ASSERT_TRUE(slots.ok()) << slots.error().message;
    EXPECT_EQ((*slots)[0].accel, (std::array<int16_t, 3>{100, -200, 16384}));
    EXPECT_EQ((*slots)[0].gyro, (std::array<int16_t, 3>{1, -1, 32767}));
    EXPECT_EQ((*slots)[0].ticks, 0x01020304u);
    EXPECT_EQ((*slots)[0].sequence, 5);
    const auto again = encode_imu_report(*slots);
    EXPECT_TRUE(std::equal(again.begin(), again.end(), b.begin()));
}

TEST(ViveImu, ScalesWithDefaultRangesIntoTheHeadFrame) {
    ImuDecoder dec(Variant::Vive);
    std::array<ImuSample, 3> out;
    auto r = encode_imu_report(
        {slot(10, 1000, 8192, -8192, 4096, 16384, 0, -16384), slot(8, 900), slot(9, 950)});
    ASSERT_EQ(dec.decode(r, out), 1u);  // a first report gives its newest slot only
    const double g4 = 4 * 9.80665, w500 = 500 * kPi / 180;
    // Vive: x kept, y and z flipped.
    EXPECT_NEAR(out[0].accel.x, g4 / 4, 1e-12);
    EXPECT_NEAR(out[0].accel.y, g4 / 4, 1e-12);
    EXPECT_NEAR(out[0].accel.z, -g4 / 8, 1e-12);
    EXPECT_NEAR(out[0].gyro.x, w500 / 2, 1e-12);
    EXPECT_NEAR(out[0].gyro.z, w500 / 2, 1e-12);
    EXPECT_EQ(out[0].ticks, 1000u);
    EXPECT_EQ(out[0].device_time_ns, 20833);  // 1000 ticks at 48 MHz

    ImuDecoder index(Variant::Index);
    ASSERT_EQ(index.decode(r, out), 1u);
    // Index: x' = -y, y' = -x, z' = -z.
    EXPECT_NEAR(out[0].accel.x, g4 / 4, 1e-12);
    EXPECT_NEAR(out[0].accel.y, -g4 / 4, 1e-12);
    EXPECT_NEAR(out[0].accel.z, -g4 / 8, 1e-12);
}

TEST(ViveImu, RangeReportSetsTheScale) {
    const std::vector<uint8_t> feature = {0x01, 2, 3, 0, 0};  // 1000 deg/s, 16 g
    auto ranges = parse_range_report(feature);
    ASSERT_TRUE(ranges.ok());
    EXPECT_NEAR(ranges->gyro_rad_s, 1000 * kPi / 180, 1e-12);
    EXPECT_NEAR(ranges->accel_m_s2, 16 * 9.80665, 1e-12);
    EXPECT_FALSE(parse_range_report(std::vector<uint8_t>{0x01, 5, 0}).ok());
    EXPECT_FALSE(parse_range_report(std::vector<uint8_t>{0x02, 0, 0}).ok());
    EXPECT_FALSE(parse_range_report(std::vector<uint8_t>{0x01, 0}).ok());

    ImuDecoder dec(Variant::Vive, *ranges);
    std::array<ImuSample, 3> out;
    ASSERT_EQ(dec.decode(encode_imu_report({slot(1, 0, 32767), slot(0, 0), slot(0, 0)}), out), 1u);
    EXPECT_NEAR(out[0].accel.x, 16 * 9.80665 * 32767 / 32768, 1e-9);
}

TEST(ViveImu, DeduplicatesRotatingSlotsAndCountsGaps) {
    ImuDecoder dec;
    std::array<ImuSample, 3> out;
    // Rotation as the device sends it: each report refreshes one slot.
    ASSERT_EQ(dec.decode(encode_imu_report({slot(3, 3000), slot(1, 1000), slot(2, 2000)}), out),
              1u);
    EXPECT_EQ(out[0].sequence, 3u);
    ASSERT_EQ(dec.decode(encode_imu_report({slot(3, 3000), slot(4, 4000), slot(2, 2000)}), out),
              1u);
    EXPECT_EQ(out[0].sequence, 4u);
    // Same report again: nothing new.
    EXPECT_EQ(dec.decode(encode_imu_report({slot(3, 3000), slot(4, 4000), slot(2, 2000)}), out),
              0u);
    // Two new slots at once, out of slot order: emitted oldest first.
    ASSERT_EQ(dec.decode(encode_imu_report({slot(6, 6000), slot(4, 4000), slot(5, 5000)}), out),
              2u);
    EXPECT_EQ(out[0].sequence, 5u);
    EXPECT_EQ(out[1].sequence, 6u);
    EXPECT_EQ(dec.counters().sequence_gaps, 0u);
    // A gap: 7 and 8 never seen.
    ASSERT_EQ(dec.decode(encode_imu_report({slot(6, 6000), slot(9, 9000), slot(6, 6000)}), out),
              1u);
    EXPECT_EQ(out[0].sequence, 9u);
    EXPECT_EQ(dec.counters().sequence_gaps, 1u);
    EXPECT_EQ(dec.counters().missing_samples, 2u);
    EXPECT_EQ(dec.counters().samples, 5u);
}

TEST(ViveImu, UnwrapsSequenceAndTicks) {
    ImuDecoder dec;
    std::array<ImuSample, 3> out;
    uint32_t ticks = 0xffffffffu - 48000 * 2;  // wraps after two samples
    uint64_t expected_ticks = ticks;
    uint8_t seq = 254;
    ASSERT_EQ(dec.decode(encode_imu_report({slot(seq, ticks), slot(253, ticks - 48000),
                                            slot(252, ticks - 96000)}),
                         out),
              1u);
    for (int i = 1; i <= 600; ++i) {
        ticks += 48000;  // 1 ms
        expected_ticks += 48000;
        ++seq;
        ASSERT_EQ(
            dec.decode(encode_imu_report({slot(seq, ticks), slot(uint8_t(seq - 1), ticks - 48000),
                                          slot(uint8_t(seq - 2), ticks - 96000)}),
                       out),
            1u);
        EXPECT_EQ(out[0].sequence, 254u + uint64_t(i));
        EXPECT_EQ(out[0].ticks, expected_ticks);
    }
    EXPECT_EQ(dec.counters().sequence_gaps, 0u);
}

TEST(ViveImu, CountsMalformedAndUnknownReports) {
    ImuDecoder dec;
    std::array<ImuSample, 3> out;
    std::vector<uint8_t> shortr(30, 0);
    shortr[0] = 0x20;
    EXPECT_EQ(dec.decode(shortr, out), 0u);
    EXPECT_EQ(dec.decode(std::vector<uint8_t>{0x23, 1, 2}, out), 0u);
    EXPECT_EQ(dec.decode(std::vector<uint8_t>{}, out), 0u);
    EXPECT_EQ(dec.counters().malformed, 1u);
    EXPECT_EQ(dec.counters().unknown, 2u);
    EXPECT_EQ(dec.counters().samples, 0u);
}

// Full-scale counts flag the sample as saturated (its true value may be beyond), and count it.
TEST(ViveImu, FlagsAndCountsSaturatedSamples) {
    ImuDecoder dec(Variant::Index);
    std::array<ImuSample, 3> out;
    ASSERT_EQ(dec.decode(encode_imu_report({slot(1, 48000), slot(0, 0), slot(0, 0)}), out), 1u);
    EXPECT_FALSE(out[0].gyro_saturated);
    ASSERT_EQ(dec.decode(encode_imu_report({slot(1, 48000), slot(2, 96000, 0, 0, 0, 0, -32768, 0),
                                            slot(3, 144000, 32767, 0, 0)}),
                         out),
              2u);
    EXPECT_TRUE(out[0].gyro_saturated);
    EXPECT_FALSE(out[0].accel_saturated);
    EXPECT_TRUE(out[1].accel_saturated);
    EXPECT_FALSE(out[1].gyro_saturated);
    EXPECT_EQ(dec.counters().saturated_samples, 2u);
}

// The codec (make_codec_for) holds the first sample after an open until the next report: a
// continuous one emits both; a stale one (sequence and tick from ~100 samples before) is dropped
// and counted, with no phantom gap.
TEST(ViveCodec, DropsAndCountsAStaleFirstReport) {
    auto run = [](uint8_t first_seq, uint32_t first_ticks) {
        auto codec = make_codec_for(kVendorId, kIndexProductId);
        std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> out;
        std::vector<DeviceSample> got;
        auto feed = [&](std::array<RawSlot, 3> slots) {
            const size_t n = codec->decode(encode_imu_report(slots), out);
            got.insert(got.end(), out.begin(), out.begin() + long(n));
        };
        const std::array<RawSlot, 3> first = {slot(first_seq, first_ticks),
                                              slot(uint8_t(first_seq - 1), first_ticks - 48000),
                                              slot(uint8_t(first_seq - 2), first_ticks - 96000)};
        feed(first);
        feed(first);               // a repeat (no new slot) does not judge the held sample
        EXPECT_TRUE(got.empty());  // held until the next report
        uint8_t seq = 200;
        uint32_t ticks = 48'000'000;
        for (int r = 0; r < 10; ++r, seq += 3, ticks += 3 * 48000)
            feed({slot(seq, ticks), slot(uint8_t(seq + 1), ticks + 48000),
                  slot(uint8_t(seq + 2), ticks + 96000)});
        return std::make_pair(got, codec->counters());
    };
    // Continuous: seq 199 one tick period before 200.
    auto [ok, okc] = run(199, 48'000'000 - 48000);
    ASSERT_EQ(ok.size(), 31u);
    EXPECT_EQ(ok.front().sequence + 1, ok[1].sequence);
    EXPECT_EQ(okc.stale_first_dropped, 0u);
    EXPECT_EQ(okc.missing_samples, 0u);
    EXPECT_EQ(okc.samples, 31u);
    // Stale: seq 100 and a tick 100 ms older; dropped, the stream restarts at the next report's
    // newest slot, no gap is counted.
    auto [st, stc] = run(100, 48'000'000 - 4'800'000);
    EXPECT_EQ(stc.stale_first_dropped, 1u);
    EXPECT_EQ(stc.sequence_gaps, 0u);
    EXPECT_EQ(stc.missing_samples, 0u);
    ASSERT_EQ(st.size(), 28u);  // 30 of the stream less the next report's two older slots
    EXPECT_EQ(st.front().sequence + 1, st[1].sequence);
    EXPECT_EQ(stc.samples, 28u);
    for (size_t i = 1; i < st.size(); ++i)
        EXPECT_EQ(st[i].device_time_ns - st[i - 1].device_time_ns, 1'000'000);
    // Stale with a sequence ahead of the stream's (the decoder takes the stream's slots for old
    // repeats): judged stale after three reports without a new slot, then the stream flows.
    auto [ah, ahc] = run(250, 48'000'000 - 4'800'000);
    EXPECT_EQ(ahc.stale_first_dropped, 1u);
    EXPECT_EQ(ahc.missing_samples, 0u);
    EXPECT_EQ(ahc.samples, ah.size());
    ASSERT_GT(ah.size(), 15u);
    for (size_t i = 1; i < ah.size(); ++i) EXPECT_EQ(ah[i].sequence, ah[i - 1].sequence + 1);
}

// 28de:2300 is shared by the Index and a Vive Pro (other IMU axes, not supported): unless the
// product string says Index, the codec warns instead of decoding silently with the wrong axes.
TEST(ViveCodec, WarnsWhenA2300DeviceIsNotKnownToBeAnIndex) {
    struct NamedTransport final : Transport {
        std::string product;
        DeviceId id() const override {
            DeviceId d;
            d.vendor_id = kVendorId;
            d.product_id = kIndexProductId;
            d.product = product;
            return d;
        }
        Result<std::optional<InputReport>> read_input(int) override {
            return std::optional<InputReport>();
        }
        Result<std::vector<uint8_t>> get_feature(uint8_t, size_t) override {
            return make_error("no feature reports");
        }
        Status set_feature(std::span<const uint8_t>) override { return {}; }
        Status write_output(std::span<const uint8_t>) override { return {}; }
    };
    auto codec = make_codec_for(kVendorId, kIndexProductId);
    NamedTransport t;
    t.product = "Index HMD";
    codec->configure(t);
    EXPECT_TRUE(codec->warning().empty()) << codec->warning();
    t.product = "VIVE Pro MV";
    codec->configure(t);
    EXPECT_NE(codec->warning().find("Vive Pro"), std::string::npos) << codec->warning();
    EXPECT_NE(codec->warning().find("VIVE Pro MV"), std::string::npos) << codec->warning();
    t.product = "";  // a capture without a label: cannot be told
    codec->configure(t);
    EXPECT_FALSE(codec->warning().empty());
    auto vive = make_codec_for(kVendorId, kViveProductId);
    vive->configure(t);
    EXPECT_TRUE(vive->warning().empty());
}

}  // namespace
}  // namespace hmdnode::vive
