// Reference tracker protocol: golden bytes of every report, round trips, the descriptor, version
// handling (newer minor decoded by length, unknown major rejected) and malformed reports.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "hmdnode/hal/codec/reference_protocol.hpp"

namespace hmdnode::refproto {
namespace {

std::vector<uint8_t> hex(const char* s) {
    std::vector<uint8_t> b;
    for (; s[0] && s[1]; s += 2) {
        if (s[0] == ' ') {
            --s;
            continue;
        }
        b.push_back(uint8_t(std::stoi(std::string(s, 2), nullptr, 16)));
    }
    return b;
}

TEST(ReferenceProtocol, PoseReportGoldenBytes) {
    PoseReport r;
    r.flags = kPoseFlagOrientationValid | kPoseFlagPositionValid | kPoseFlagAngularVelocityValid;
    r.sequence = 0x01020304;
    r.device_time_us = 0x1122334455667788ull;
    r.orientation = glm::dquat(1, 0, 0, 0);
    r.position_m = {0.001, -0.002, 1.5};
    r.angular_velocity = {0.5, 0.0, -1.0};
    const auto b = encode(r);
    std::vector<uint8_t> golden =
        hex("01 10 07 00 04030201 8877665544332211"
            " 00000040 00000000 00000000 00000000"
            " e8030000 30f8ffff 60e31600"
            " 20a10700 00000000 c0bdf0ff"
            " 0000000000000000");
    ASSERT_EQ(golden.size(), kPoseReportSize);
    EXPECT_EQ(b, golden);
    auto d = decode_pose(golden);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ(d->sequence, r.sequence);
    EXPECT_EQ(d->device_time_us, r.device_time_us);
    EXPECT_EQ(d->flags, r.flags);
    EXPECT_NEAR(d->position_m.z, 1.5, 1e-9);
    EXPECT_NEAR(d->position_m.y, -0.002, 1e-9);
    EXPECT_NEAR(d->angular_velocity.z, -1.0, 1e-9);
    EXPECT_DOUBLE_EQ(d->orientation.w, 1.0);
}

TEST(ReferenceProtocol, PoseRoundTripWithinQuantisation) {
    PoseReport r;
    r.flags = kPoseFlagOrientationValid | kPoseFlagAngularVelocityValid;
    r.orientation = glm::normalize(glm::dquat(0.3, -0.5, 0.7, 0.1));
    r.angular_velocity = {1.234567, -2.5, 0.000001};
    auto d = decode_pose(encode(r));
    ASSERT_TRUE(d.ok());
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(d->orientation[i], r.orientation[i], 2.0 / kQuatScale);
    EXPECT_NEAR(d->angular_velocity.x, 1.234567, 1e-6);
    EXPECT_EQ(d->position_m, glm::dvec3(0.0));  // not valid: not sent
}

TEST(ReferenceProtocol, ImuReportGoldenBytesAndScale) {
    ImuReport r;
    r.count = 2;
    r.accel_range_g = 8;
    r.gyro_range_dps = 2000;
    r.first_sequence = 7;
    r.device_time_us = 1000;
    r.samples[0] = {0, {4096, 0, -4096}, {1, 2, 3}};
    r.samples[1] = {1000, {0, 4096, 0}, {-1, -2, -3}};
    const auto b = encode(r);
    std::vector<uint8_t> golden =
        hex("02 10 02 08 d007 0000 07000000 e803000000000000"
            " 0000 0010 0000 00f0 0100 0200 0300"
            " e803 0000 0010 0000 ffff feff fdff"
            " 0000000000000000000000000000 0000");
    ASSERT_EQ(golden.size(), kImuReportSize);
    EXPECT_EQ(b, golden);
    auto d = decode_imu(b);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ(d->count, 2);
    EXPECT_EQ(d->samples[1].dt_us, 1000);
    EXPECT_EQ(d->samples[1].gyro[2], -3);
    EXPECT_NEAR(d->samples[0].accel[0] * d->accel_scale(), 9.80665, 1e-9);  // 4096 of 8 g = 1 g
    EXPECT_NEAR(32768 * d->gyro_scale(), 2000 * M_PI / 180, 1e-9);
    // dt must increase and the first must be 0.
    auto bad = golden;
    bad[34] = 0;
    bad[35] = 0;
    EXPECT_FALSE(decode_imu(bad).ok());
    bad = golden;
    bad[2] = 4;
    EXPECT_FALSE(decode_imu(bad).ok());
}

TEST(ReferenceProtocol, FeatureReportsGoldenBytesAndRoundTrip) {
    DeviceInfoReport info;
    info.firmware_major = 1;
    info.firmware_minor = 2;
    info.firmware_patch = 3;
    info.capabilities = kCapOrientation | kCapImu | kCapTimeSync;
    info.pose_rate_hz = 1000;
    info.imu_rate_hz = 1000;
    info.serial = "SN42";
    info.product = "hmdnode ref";
    auto ib = encode(info);
    EXPECT_EQ(std::vector<uint8_t>(ib.begin(), ib.begin() + 20),
              hex("10 10 01 02 0300 15000000 e803 e803 0000 534e3432"));
    auto id = decode_device_info(ib);
    ASSERT_TRUE(id.ok());
    EXPECT_EQ(id->serial, "SN42");
    EXPECT_EQ(id->product, "hmdnode ref");
    EXPECT_EQ(id->capabilities, info.capabilities);
    ib[20] = 0x01;  // control character in the serial
    EXPECT_FALSE(decode_device_info(ib).ok());

    CalibrationReport cal;
    cal.accel_range_g = 16;
    cal.gyro_range_dps = 1000;
    cal.gyro_bias = {0.001, -0.002, 0.0};
    cal.accel_bias = {0.0, 0.05, 0.0};
    auto cb = encode(cal);
    EXPECT_EQ(cb, hex("11 10 10 00 e803 0000 e8030000 30f8ffff 00000000"
                      " 00000000 50c30000 00000000"));
    auto cd = decode_calibration(cb);
    ASSERT_TRUE(cd.ok());
    EXPECT_NEAR(cd->gyro_bias.y, -0.002, 1e-9);
    EXPECT_NEAR(cd->accel_bias.y, 0.05, 1e-9);

    ReportRateReport rate;
    rate.pose_rate_hz = 500;
    rate.imu_rate_hz = 1000;
    EXPECT_EQ(encode(rate), hex("12 10 f401 e803 0000"));
    auto rd = decode_report_rate(encode(rate));
    ASSERT_TRUE(rd.ok());
    EXPECT_EQ(rd->pose_rate_hz, 500);

    TimeSyncReport ts;
    ts.nonce = 0xdeadbeef;
    ts.host_send_ns = 1'000'000'000;
    ts.device_receive_us = 2'000;
    ts.device_transmit_us = 2'010;
    EXPECT_EQ(encode(ts), hex("13 10 0000 efbeadde 00ca9a3b00000000 d007000000000000"
                              " da07000000000000"));
    auto td = decode_time_sync(encode(ts));
    ASSERT_TRUE(td.ok());
    EXPECT_EQ(td->nonce, 0xdeadbeefu);
    EXPECT_EQ(td->device_transmit_us, 2010u);
}

TEST(ReferenceProtocol, TimeSyncEstimateIsNtpOffset) {
    // Device clock = host - 999,000 µs... : host sends at 1.000000 s, 100 µs one-way each way,
    // device stamps receive at 1100 µs and transmits at 1110 µs device time.
    TimeSyncReport a;
    a.host_send_ns = 1'000'000'000;
    a.device_receive_us = 1100;
    a.device_transmit_us = 1110;
    const int64_t host_receive = 1'000'000'000 + 100'000 + 10'000 + 100'000;
    auto e = time_sync_estimate(a, host_receive);
    // True offset: host = device + (1e9 - 1e6) ns.
    EXPECT_EQ(e.offset_ns, 1'000'000'000 - 1'000'000);
    EXPECT_EQ(e.round_trip_ns, 200'000);
}

// Found by the fuzzer: device stamps near 2^64 µs overflowed the ns arithmetic.
TEST(ReferenceProtocol, TimeSyncEstimateSaturatesOnAbsurdDeviceStamps) {
    TimeSyncReport a;
    a.device_receive_us = uint64_t(1) << 57;
    a.device_transmit_us = ~uint64_t(0);
    const TimeSyncEstimate e = time_sync_estimate(a, 0);
    EXPECT_EQ(e.offset_ns, std::numeric_limits<int64_t>::min());
    EXPECT_EQ(e.round_trip_ns, std::numeric_limits<int64_t>::min());
}

TEST(ReferenceProtocol, DescriptorDeclaresEveryReportWithItsSize) {
    auto d = report_descriptor();
    ASSERT_GE(d.size(), 10u);
    EXPECT_EQ(d[0], 0x06);  // usage page
    EXPECT_EQ(d[1], 0x00);
    EXPECT_EQ(d[2], 0xFF);
    EXPECT_EQ(d.back(), 0xC0);
    // Walk the short items: each Report ID is followed by its count; check sizes.
    struct Want {
        uint8_t id;
        size_t size;
        uint8_t main;
    };
    const Want want[] = {{kPoseReport, kPoseReportSize, 0x81},
                         {kImuReport, kImuReportSize, 0x81},
                         {kDeviceInfoReport, kDeviceInfoReportSize, 0xB1},
                         {kCalibrationReport, kCalibrationReportSize, 0xB1},
                         {kReportRateReport, kReportRateReportSize, 0xB1},
                         {kTimeSyncReport, kTimeSyncReportSize, 0xB1}};
    size_t found = 0;
    int current = -1, count = -1;
    for (size_t i = 0; i < d.size();) {
        const uint8_t prefix = d[i];
        const size_t n = (prefix & 3) == 3 ? 4 : (prefix & 3);
        ASSERT_LE(i + 1 + n, d.size());
        const uint32_t v = n >= 1 ? d[i + 1] | (n >= 2 ? d[i + 2] << 8 : 0) : 0;
        if ((prefix & 0xFC) == 0x84) current = int(v);
        if ((prefix & 0xFC) == 0x94) count = int(v);
        if ((prefix & 0xFC) == 0x80 || (prefix & 0xFC) == 0xB0) {
            for (const Want& w : want)
                if (w.id == current) {
                    EXPECT_EQ(size_t(count) + 1, w.size) << int(w.id);
                    EXPECT_EQ(prefix, w.main) << int(w.id);
                    ++found;
                }
        }
        i += 1 + n;
    }
    EXPECT_EQ(found, 6u);
}

TEST(ReferenceProtocol, VersionsAndMalformedReports) {
    PoseReport r;
    auto b = encode(r);
    // Newer minor version with 8 more bytes: decoded by length.
    auto newer = b;
    newer[1] = 0x13;
    newer.resize(72, 0xAB);
    auto d = decode_pose(newer);
    ASSERT_TRUE(d.ok()) << d.error().message;
    EXPECT_EQ(d->version, 0x13);
    // Unknown major version.
    auto v2 = b;
    v2[1] = 0x20;
    auto e = decode_pose(v2);
    ASSERT_FALSE(e.ok());
    EXPECT_NE(e.error().message.find("major version 2"), std::string::npos);
    // Short, wrong id, empty, not a unit quaternion.
    EXPECT_FALSE(decode_pose(std::span<const uint8_t>(b.data(), 63)).ok());
    EXPECT_FALSE(decode_imu(b).ok());
    EXPECT_FALSE(decode_pose(std::span<const uint8_t>()).ok());
    auto zero_q = b;
    for (int i = 16; i < 32; ++i) zero_q[i] = 0;
    EXPECT_FALSE(decode_pose(zero_q).ok());
    EXPECT_FALSE(decode_time_sync(std::vector<uint8_t>{0x13, 0x10, 0}).ok());
}

}  // namespace
}  // namespace hmdnode::refproto
