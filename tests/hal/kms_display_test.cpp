// The KMS display's parsers (EDID identity, display.mode) and its errors where no KMS device is
// usable. Page flips on a real kernel's display are proven in the kernel lane (tests/kernel_lane).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hmdnode/hal/display/kms_display.hpp"

using namespace hmdnode;

namespace {

// A base block with the fixed header, vendor "VLV", product 0x91A8, a monitor name descriptor
// and a correct checksum.
std::vector<uint8_t> edid_block(const char* vendor = "VLV", uint16_t product = 0x91a8) {
    std::vector<uint8_t> e(128, 0);
    const uint8_t header[8] = {0x00, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x00};
    std::copy(header, header + 8, e.begin());
    const unsigned v = (unsigned(vendor[0] - 'A' + 1) << 10) |
                       (unsigned(vendor[1] - 'A' + 1) << 5) | unsigned(vendor[2] - 'A' + 1);
    e[8] = uint8_t(v >> 8);
    e[9] = uint8_t(v);
    e[10] = uint8_t(product);
    e[11] = uint8_t(product >> 8);
    const std::string name = "Index HMD\n";
    e[72 + 3] = 0xfc;  // the second descriptor: monitor name
    for (size_t i = 0; i < name.size(); ++i) e[72 + 5 + i] = uint8_t(name[i]);
    uint8_t sum = 0;
    for (int i = 0; i < 127; ++i) sum = uint8_t(sum + e[size_t(i)]);
    e[127] = uint8_t(256 - sum);
    return e;
}

}  // namespace

TEST(KmsDisplay, ParsesEdidVendorProductAndName) {
    const std::vector<uint8_t> e = edid_block();
    Result<EdidIdentity> id = parse_edid_identity(e.data(), e.size());
    ASSERT_TRUE(id.ok()) << id.error().message;
    EXPECT_EQ(id->vendor, "VLV");
    EXPECT_EQ(id->product, 0x91a8);
    EXPECT_EQ(id->monitor_name, "Index HMD");
}

// Found by tests/fuzz/edid_fuzz.cpp: names from several descriptors were run together.
TEST(KmsDisplay, TakesTheFirstMonitorNameDescriptorOnly) {
    std::vector<uint8_t> e = edid_block();
    const std::string other = "Second name\n";
    e[90 + 3] = 0xfc;  // the third descriptor: another monitor name
    for (size_t i = 0; i < other.size(); ++i) e[90 + 5 + i] = uint8_t(other[i]);
    uint8_t sum = 0;
    for (int i = 0; i < 127; ++i) sum = uint8_t(sum + e[size_t(i)]);
    e[127] = uint8_t(256 - sum);
    Result<EdidIdentity> id = parse_edid_identity(e.data(), e.size());
    ASSERT_TRUE(id.ok()) << id.error().message;
    EXPECT_EQ(id->monitor_name, "Index HMD");
}

TEST(KmsDisplay, RefusesBrokenEdidNamingTheByte) {
    std::vector<uint8_t> e = edid_block();
    EXPECT_NE(parse_edid_identity(e.data(), 100).error().message.find("100 bytes"),
              std::string::npos);
    std::vector<uint8_t> bad_header = e;
    bad_header[3] = 0;
    EXPECT_NE(parse_edid_identity(bad_header.data(), 128).error().message.find("byte 3"),
              std::string::npos);
    std::vector<uint8_t> bad_sum = e;
    bad_sum[20] ^= 1;
    EXPECT_NE(parse_edid_identity(bad_sum.data(), 128).error().message.find("checksum (byte 127)"),
              std::string::npos);
    std::vector<uint8_t> bad_letter = e;
    bad_letter[8] = 0x7c;  // first letter 31
    bad_letter[127] = uint8_t(bad_letter[127] - (0x7c - e[8]));
    EXPECT_NE(parse_edid_identity(bad_letter.data(), 128).error().message.find("bytes 8-9"),
              std::string::npos);
}

TEST(KmsDisplay, ParsesModeRequests) {
    Result<KmsModeRequest> m = parse_kms_mode("2880x1600@90");
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(m->width, 2880);
    EXPECT_EQ(m->height, 1600);
    EXPECT_DOUBLE_EQ(m->refresh_hz, 90.0);
    Result<KmsModeRequest> any = parse_kms_mode("1920x1080");
    ASSERT_TRUE(any.ok());
    EXPECT_EQ(any->refresh_hz, 0.0);
    for (const char* bad : {"", "2880", "2880x", "2880x1600@", "2880x1600@90x", "0x10@60",
                            "2880x1600@0", "-1x5", "1920x1080 "}) {
        Result<KmsModeRequest> r = parse_kms_mode(bad);
        ASSERT_FALSE(r.ok()) << bad;
        EXPECT_NE(r.error().message.find(std::string("\"") + bad + "\""), std::string::npos)
            << r.error().message;
    }
}

TEST(KmsDisplay, MissingDeviceIsAnErrorNamingIt) {
    SystemClock clock;
    KmsDisplayConfig cfg;
    cfg.device = "/dev/dri/card-hmdnode-missing";
    auto d = create_kms_display(clock, cfg);
    ASSERT_FALSE(d.ok());
    EXPECT_NE(d.error().message.find("/dev/dri/card-hmdnode-missing"), std::string::npos)
        << d.error().message;
    auto list = list_kms_connectors(cfg.device);
    ASSERT_FALSE(list.ok());
    EXPECT_NE(list.error().message.find("/dev/dri/card-hmdnode-missing"), std::string::npos);
}

TEST(KmsDisplay, RefusesTheSimulatedClockAndABadMode) {
    SimulatedClock sim;
    auto d = create_kms_display(sim, KmsDisplayConfig{});
    ASSERT_FALSE(d.ok());
    EXPECT_NE(d.error().message.find("system clock"), std::string::npos);
    SystemClock clock;
    KmsDisplayConfig cfg;
    cfg.mode = "90Hz";
    auto m = create_kms_display(clock, cfg);
    ASSERT_FALSE(m.ok());
    EXPECT_NE(m.error().message.find("display.mode"), std::string::npos) << m.error().message;
}
