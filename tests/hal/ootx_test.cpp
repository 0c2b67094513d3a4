// The base-station calibration frame (OOTX): a frame decodes after its preamble whatever came
// before, unknown bits (missed syncs) are resolved by the CRC up to eight, a bad CRC is reported
// naming the base station and the frame and never used ("no calibration yet" stays), a bad sync
// bit or an overlong length abandons the frame, and the lighthouse-1 and lighthouse-2 payload
// layouts give each field.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/ootx.hpp"

namespace hmdnode {
namespace {

using namespace lighthouse;

std::vector<uint8_t> sample_payload(size_t n) {
    std::vector<uint8_t> p(n);
    for (size_t i = 0; i < n; ++i) p[i] = uint8_t(i * 73 + 5);
    return p;
}

// The index in a frame's bits of payload bit `k` (after the 18 preamble bits, a sync bit after
// every 16 data bits; the length word is data bits 0..15).
size_t data_bit_index(size_t k) {
    return 18 + k + k / 16;
}

TEST(Ootx, HalfFloatsDecodeAsIeeeBinary16) {
    EXPECT_EQ(half_to_double(0x3c00), 1.0);
    EXPECT_EQ(half_to_double(0xc000), -2.0);
    EXPECT_EQ(half_to_double(0x0001), std::ldexp(1.0, -24));  // the smallest subnormal
    EXPECT_EQ(half_to_double(0x0400), std::ldexp(1.0, -14));
    EXPECT_EQ(half_to_double(0x7bff), 65504.0);
    EXPECT_TRUE(std::isinf(half_to_double(0x7c00)));
    EXPECT_TRUE(std::isnan(half_to_double(0x7e00)));
    EXPECT_EQ(half_to_double(0x8000), -0.0);
    EXPECT_NEAR(half_to_double(0x3555), 1.0 / 3.0, 1e-4);
}

TEST(Ootx, AFrameDecodesAfterItsPreambleWhateverCameBefore) {
    const auto payload = sample_payload(kLh2PayloadBytes);
    const auto bits = encode_ootx_frame(payload);
    OotxDecoder dec;
    // Noise first: runs of at most 16 zeros, a cut frame, and unknown bits.
    for (int i = 0; i < 200; ++i) EXPECT_FALSE(dec.push(i % 17 == 0 ? 1 : (i % 5 == 0 ? -1 : 0)));
    for (size_t i = 0; i < 100; ++i) EXPECT_FALSE(dec.push(bits[i]));
    std::vector<OotxFrame> frames;
    for (int rep = 0; rep < 2; ++rep)
        for (uint8_t b : bits)
            if (auto f = dec.push(b)) frames.push_back(*f);
    ASSERT_EQ(frames.size(), 2u);
    for (const OotxFrame& f : frames) {
        EXPECT_TRUE(f.crc_ok);
        EXPECT_EQ(f.payload, payload);
        EXPECT_EQ(f.unknown_bits, 0);
    }
    EXPECT_EQ(frames[0].end_bit,
              300 + bits.size() - 1);  // the last data bit; its sync bit unneeded
    EXPECT_EQ(dec.counters().good_frames, 2u);
    EXPECT_EQ(dec.counters().bad_crc, 0u);
}

TEST(Ootx, UnknownBitsAreResolvedByTheCrcUpToEight) {
    const auto payload = sample_payload(kLh1PayloadBytes);
    const auto bits = encode_ootx_frame(payload);
    for (int unknown : {1, 8, 9}) {
        OotxDecoder dec;
        std::vector<int> b(bits.begin(), bits.end());
        for (int u = 0; u < unknown; ++u) b[data_bit_index(16 + 8 + 29 * size_t(u))] = -1;
        std::optional<OotxFrame> got;
        for (int x : b)
            if (auto f = dec.push(x)) got = f;
        if (unknown <= kMaxUnknownBits) {
            ASSERT_TRUE(got) << unknown;
            EXPECT_TRUE(got->crc_ok);
            EXPECT_EQ(got->unknown_bits, unknown);
            EXPECT_EQ(got->payload, payload);
        } else {
            EXPECT_FALSE(got);
            EXPECT_EQ(dec.counters().too_many_unknown, 1u);
        }
    }
}

TEST(Ootx, ABadSyncBitOrAnOverlongLengthAbandonsTheFrame) {
    const auto bits = encode_ootx_frame(sample_payload(kLh2PayloadBytes));
    OotxDecoder sync;
    std::vector<uint8_t> b = bits;
    b[18 + 16] = 0;  // the sync bit after the length word
    for (uint8_t x : b) EXPECT_FALSE(sync.push(x));
    EXPECT_EQ(sync.counters().bad_sync_bits, 1u);
    OotxDecoder length;
    const auto overlong = encode_ootx_frame(sample_payload(kMaxPayload + 2));
    for (uint8_t x : overlong) EXPECT_FALSE(length.push(x));
    EXPECT_EQ(length.counters().too_long, 1u);
}

TEST(Ootx, ABadCrcIsAWarningNamingTheBaseStationAndFrameAndIsNeverUsed) {
    const auto payload = sample_payload(kLh2PayloadBytes);
    const auto good = encode_ootx_frame(payload);
    auto bad = good;
    bad[data_bit_index(16 + 8 * 3 + 3)] ^= 1;  // a bit of the id
    LightDecoder dec;
    const uint8_t ch = 5;
    const double period = kTickHz / lh2_rotor_hz(ch);
    double t = 1e6;
    auto push = [&](const std::vector<uint8_t>& bits) {
        for (uint8_t b : bits) {
            ASSERT_TRUE(dec.add_lh2_sync(ch, uint32_t(std::llround(t)), b != 0, false).ok());
            t += period;
        }
    };
    push(bad);
    const auto warnings = dec.take_warnings();
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_EQ(
        warnings[0].rfind("lighthouse 2 channel 5: OOTX frame 1 (ending at bit " +
                              std::to_string(bad.size() - 1) + "): bad CRC-32 (the frame says 0x",
                          0),
        0u)
        << warnings[0];
    EXPECT_NE(warnings[0].find("); not used"), std::string::npos);
    const BaseStationState* s = dec.base_station(Generation::lh2, ch);
    ASSERT_NE(s, nullptr);
    EXPECT_FALSE(s->calibration);
    EXPECT_EQ(
        dec.calibration_status(Generation::lh2, ch),
        "no calibration yet (" + std::to_string(bad.size()) + " OOTX bits, 1 with a bad CRC)");
    push(good);
    ASSERT_TRUE(s->calibration);
    EXPECT_EQ(s->calibration->payload, payload);
    EXPECT_EQ(dec.calibration_status(Generation::lh2, ch).rfind("calibration: id 0x", 0), 0u);
    EXPECT_TRUE(dec.take_warnings().empty());
}

TEST(Ootx, ThePayloadLayoutsGiveEachField) {
    std::vector<uint8_t> p(kLh2PayloadBytes, 0);
    auto u16 = [&](size_t at, uint16_t v) {
        p[at] = uint8_t(v);
        p[at + 1] = uint8_t(v >> 8);
    };
    u16(0, 0x0888);
    p[2] = 0xa0, p[3] = 0xb5, p[4] = 0x96, p[5] = 0x40;  // id 0x4096b5a0
    u16(6, 0x3c00), u16(8, 0xbc00);                      // phase 1, -1
    u16(10, 0x3800), u16(12, 0xb800);                    // tilt 0.5, -0.5
    p[14] = 7, p[15] = 9;
    u16(16, 0x3400), u16(18, 0x3000);  // curve 0.25, 0.125
    p[20] = 1, p[21] = 0x80, p[22] = 127;
    u16(23, 0x4000), u16(25, 0x4200);  // gibbous phase 2, 3
    u16(27, 0x4400), u16(29, 0x4500);  // gibbous mag 4, 5
    p[31] = 0x83, p[32] = 0;
    u16(33, 0x4600), u16(35, 0x4700);  // ogee phase 6, 7
    u16(37, 0x4800), u16(39, 0x4880);  // ogee mag 8, 9
    u16(41, 0x1234);
    auto c2 = parse_ootx_payload(Generation::lh2, p);
    ASSERT_TRUE(c2.ok()) << c2.error().message;
    EXPECT_EQ(c2->firmware_version, 0x0888);
    EXPECT_EQ(c2->id, 0x4096b5a0u);
    EXPECT_EQ(c2->plane[0].phase, 1.0);
    EXPECT_EQ(c2->plane[1].phase, -1.0);
    EXPECT_EQ(c2->plane[0].tilt, 0.5);
    EXPECT_EQ(c2->plane[1].curve, 0.125);
    EXPECT_EQ(c2->plane[0].gibbous_phase, 2.0);
    EXPECT_EQ(c2->plane[1].gibbous_mag, 5.0);
    EXPECT_EQ(c2->plane[0].ogee_phase, 6.0);
    EXPECT_EQ(c2->plane[1].ogee_mag, 9.0);
    EXPECT_EQ(c2->accel_dir, (std::array<int8_t, 3>{1, -128, 127}));
    EXPECT_EQ(c2->sys_unlock_count, 7);
    EXPECT_EQ(c2->hw_version, 9);
    EXPECT_EQ(c2->mode_current, 0x83);
    EXPECT_EQ(c2->nonce, 0x1234);
    // The lighthouse-1 layout is the same up to its 33rd byte, without ogee terms and nonce.
    auto c1 = parse_ootx_payload(Generation::lh1, std::span(p).first(kLh1PayloadBytes));
    ASSERT_TRUE(c1.ok());
    EXPECT_EQ(c1->plane[1].gibbous_mag, 5.0);
    EXPECT_EQ(c1->plane[0].ogee_phase, 0.0);
    EXPECT_EQ(c1->nonce, 0);
    auto short_one = parse_ootx_payload(Generation::lh2, std::span(p).first(kLh1PayloadBytes));
    ASSERT_FALSE(short_one.ok());
    EXPECT_EQ(short_one.error().message,
              "OOTX payload of 33 bytes, shorter than the lighthouse 2 layout's 43");
}

}  // namespace
}  // namespace hmdnode
