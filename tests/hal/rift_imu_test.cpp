// Rift DK2/CV1 IMU codec: the 21-bit packing against hand-computed bytes, golden report fields,
// scaling, de-duplication by the running sample count, 16-bit wrap, malformed reports.
#include <gtest/gtest.h>

#include <vector>

#include "hmdnode/hal/codec/rift_imu.hpp"

namespace hmdnode::rift {
namespace {

TEST(RiftImu, Unpacks21BitTriplesLikeOpenHmd) {
    // x = 1, y = -1, z = 0x0FFFFF (largest positive): bits 0x20 1 | 1x21 | 0 1x20 | 0.
    uint8_t b[8];
    pack21({1, -1, 0x0FFFFF}, b);
    const std::vector<uint8_t> golden = {0x00, 0x00, 0x0F, 0xFF, 0xFF, 0xDF, 0xFF, 0xFE};
    EXPECT_EQ(std::vector<uint8_t>(b, b + 8), golden);
    EXPECT_EQ(unpack21(golden.data()), (std::array<int32_t, 3>{1, -1, 0x0FFFFF}));
    const uint8_t neg[8] = {0x80, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};  // x = -2^20
    EXPECT_EQ(unpack21(neg)[0], -(1 << 20));
}

SensorReport report(uint16_t count, uint32_t ts, uint8_t n = 2) {
    SensorReport r;
    r.num_samples = n;
    r.sample_count = count;
    r.timestamp_us = ts;
    r.temperature_cdeg = 3550;
    r.samples[0].accel = {0, 98066, 0};  // 9.8066 m/s^2 up
    r.samples[0].gyro = {1000, 0, -1000};
    r.samples[1] = r.samples[0];
    r.mag = {1, 2, 3};
    return r;
}

TEST(RiftImu, GoldenReportRoundTripsAndScales) {
    const auto b = encode_report(report(500, 123456));
    EXPECT_EQ(b[0], 0x0B);
    EXPECT_EQ(b[3], 2);
    EXPECT_EQ(b[4], 0xF4);  // 500
    EXPECT_EQ(b[5], 0x01);
    EXPECT_EQ(b[8], 0x40);  // 123456 = 0x0001E240
    EXPECT_EQ(b[9], 0xE2);
    EXPECT_EQ(b[10], 0x01);
    auto r = parse_report(b);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->temperature_cdeg, 3550);
    EXPECT_EQ(r->samples[1].accel[1], 98066);
    EXPECT_EQ(r->mag[2], 3);

    ImuDecoder dec;
    std::array<ImuSample, 2> out;
    ASSERT_EQ(dec.decode(b, out), 2u);
    EXPECT_EQ(out[0].sequence, 500u);
    EXPECT_EQ(out[1].sequence, 501u);
    EXPECT_EQ(out[0].device_time_ns, (123456 - 1000) * 1000);
    EXPECT_EQ(out[1].device_time_ns, 123456 * 1000);
    EXPECT_NEAR(out[0].accel.y, 9.8066, 1e-12);
    EXPECT_NEAR(out[0].gyro.z, -0.1, 1e-12);
}

TEST(RiftImu, DeduplicatesCountsGapsAndWraps) {
    ImuDecoder dec;
    std::array<ImuSample, 2> out;
    uint16_t count = 65530;
    uint32_t ts = 0xFFFFF000u;
    ASSERT_EQ(dec.decode(encode_report(report(count, ts)), out), 2u);
    EXPECT_EQ(dec.decode(encode_report(report(count, ts)), out), 0u);  // repeat
    for (int i = 0; i < 10; ++i) {  // crosses the 16-bit count and the 32-bit µs wrap
        count = uint16_t(count + 2);
        ts += 2000;
        ASSERT_EQ(dec.decode(encode_report(report(count, ts)), out), 2u);
        EXPECT_EQ(out[1].sequence, 65530u + 2 * (i + 1) + 1);
        EXPECT_EQ(out[1].device_time_ns, (int64_t(0xFFFFF000u) + 2000 * (i + 1)) * 1000);
    }
    count = uint16_t(count + 6);  // four samples lost
    ts += 6000;
    ASSERT_EQ(dec.decode(encode_report(report(count, ts)), out), 2u);
    EXPECT_EQ(dec.counters().sequence_gaps, 1u);
    EXPECT_EQ(dec.counters().missing_samples, 4u);
    EXPECT_EQ(dec.counters().repeated, 2u);
}

TEST(RiftImu, CountsMalformedAndUnknown) {
    ImuDecoder dec;
    std::array<ImuSample, 2> out;
    auto b = encode_report(report(1, 1));
    EXPECT_EQ(dec.decode(std::span<const uint8_t>(b.data(), 62), out), 0u);
    b[3] = 0;  // no samples
    EXPECT_EQ(dec.decode(b, out), 0u);
    EXPECT_EQ(dec.decode(std::vector<uint8_t>{0x20, 0}, out), 0u);
    EXPECT_EQ(dec.counters().malformed, 2u);
    EXPECT_EQ(dec.counters().unknown, 1u);
}

}  // namespace
}  // namespace hmdnode::rift
