// The transport helpers (VID:PID parsing, filters, HID control setup packets) and what the real
// backends can show without hardware: an enumeration that finds nothing is not an error, and
// opening a missing device names it.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <string>

#include "hmdnode/hal/transport.hpp"

namespace hmdnode {
namespace {

TEST(Transport, ParsesVidPidInHex) {
    Result<DeviceFilter> f = parse_vid_pid(std::string_view("28de:2000"));
    ASSERT_TRUE(f.ok()) << f.error().message;
    EXPECT_EQ(f->vendor_id, 0x28de);
    EXPECT_EQ(f->product_id, 0x2000);
    EXPECT_TRUE(f->serial.empty());

    Result<DeviceFilter> g = parse_vid_pid(std::string_view("2833:31:WMHD123"));
    ASSERT_TRUE(g.ok()) << g.error().message;
    EXPECT_EQ(g->vendor_id, 0x2833);
    EXPECT_EQ(g->product_id, 0x0031);
    EXPECT_EQ(g->serial, "WMHD123");

    EXPECT_EQ(format_vid_pid(0x1209, 0x1), "1209:0001");
}

TEST(Transport, RejectsMalformedVidPidNamingThePart) {
    Result<DeviceFilter> a = parse_vid_pid(std::string_view("28de2000"));
    ASSERT_FALSE(a.ok());
    EXPECT_NE(a.error().message.find("28de2000"), std::string::npos);
    Result<DeviceFilter> b = parse_vid_pid(std::string_view("28dg:2000"));
    ASSERT_FALSE(b.ok());
    EXPECT_NE(b.error().message.find("'g'"), std::string::npos);
    EXPECT_NE(b.error().message.find("vendor id"), std::string::npos);
    Result<DeviceFilter> c = parse_vid_pid(std::string_view("28de:12345"));
    ASSERT_FALSE(c.ok());
    EXPECT_NE(c.error().message.find("product id"), std::string::npos);
    EXPECT_FALSE(parse_vid_pid(std::string_view("28de:2000:")).ok());
    EXPECT_FALSE(parse_vid_pid(std::string_view(":2000")).ok());
}

TEST(Transport, FilterMatchesZeroAsAny) {
    DeviceId id;
    id.vendor_id = 0x28de;
    id.product_id = 0x2300;
    id.serial = "LHR-1";
    EXPECT_TRUE(DeviceFilter{}.matches(id));
    EXPECT_TRUE((DeviceFilter{0x28de, 0, ""}.matches(id)));
    EXPECT_TRUE((DeviceFilter{0x28de, 0x2300, "LHR-1"}.matches(id)));
    EXPECT_FALSE((DeviceFilter{0x28de, 0x2000, ""}.matches(id)));
    EXPECT_FALSE((DeviceFilter{0x2833, 0, ""}.matches(id)));
    EXPECT_FALSE((DeviceFilter{0x28de, 0x2300, "LHR-2"}.matches(id)));
}

TEST(Transport, HidGetReportSetupPacketBytes) {
    // GET_REPORT(feature 0x10), interface 2, 64 bytes: A1 01 | 10 03 | 02 00 | 40 00.
    const UsbSetupPacket s = hid_get_report_setup(HidReportType::feature, 0x10, 2, 64);
    EXPECT_EQ(s.request_type, 0xA1);
    EXPECT_EQ(s.request, 0x01);
    EXPECT_EQ(s.value, 0x0310);
    const std::array<uint8_t, 8> want{0xA1, 0x01, 0x10, 0x03, 0x02, 0x00, 0x40, 0x00};
    EXPECT_EQ(s.bytes(), want);
}

TEST(Transport, HidSetReportSetupPacketBytes) {
    // SET_REPORT(output 0x05), interface 0, 300 bytes: 21 09 | 05 02 | 00 00 | 2C 01.
    const UsbSetupPacket s = hid_set_report_setup(HidReportType::output, 0x05, 0, 300);
    const std::array<uint8_t, 8> want{0x21, 0x09, 0x05, 0x02, 0x00, 0x00, 0x2C, 0x01};
    EXPECT_EQ(s.bytes(), want);
    EXPECT_EQ(hid_set_report_setup(HidReportType::feature, 0x13, 1, 32).value, 0x0313);
}

TEST(Transport, UnknownBackendNameIsAnError) {
    auto b = create_transport_backend("bluetooth");
    ASSERT_FALSE(b.ok());
    EXPECT_NE(b.error().message.find("bluetooth"), std::string::npos);
}

// A VID:PID from the pid.codes test range nobody ships.
constexpr uint16_t kAbsentVid = 0x1209;
constexpr uint16_t kAbsentPid = 0xfff7;

TEST(HidapiBackend, EnumeratingAnAbsentDeviceIsEmptyNotAnError) {
    auto b = create_hidapi_backend();
    ASSERT_TRUE(b.ok()) << b.error().message;
    EXPECT_EQ((*b)->name(), "hidapi");
    auto list = (*b)->enumerate(DeviceFilter{kAbsentVid, kAbsentPid, ""});
    ASSERT_TRUE(list.ok()) << list.error().message;
    EXPECT_TRUE(list->empty());
}

TEST(HidapiBackend, OpeningAMissingDeviceNamesIt) {
    auto b = create_hidapi_backend();
    ASSERT_TRUE(b.ok()) << b.error().message;
    DeviceId id;
    id.vendor_id = kAbsentVid;
    id.product_id = kAbsentPid;
    id.path = "/dev/hidraw-hmdnode-missing";
    auto t = (*b)->open(id);
    ASSERT_FALSE(t.ok());
    EXPECT_NE(t.error().message.find("/dev/hidraw-hmdnode-missing"), std::string::npos);
    EXPECT_NE(t.error().message.find("1209:fff7"), std::string::npos);
    id.path.clear();
    auto u = (*b)->open(id);
    ASSERT_FALSE(u.ok());
    EXPECT_NE(u.error().message.find("1209:fff7"), std::string::npos);
}

TEST(LibusbBackend, EnumeratingAndOpeningAnAbsentDevice) {
    auto b = create_libusb_backend();
    if (!b.ok()) {
        // note: libusb_init fails where no usbfs exists (containers); that must be said clearly.
        EXPECT_NE(b.error().message.find("libusb_init"), std::string::npos);
        GTEST_SKIP() << b.error().message;
    }
    auto list = (*b)->enumerate(DeviceFilter{kAbsentVid, kAbsentPid, ""});
    ASSERT_TRUE(list.ok()) << list.error().message;
    EXPECT_TRUE(list->empty());
    DeviceId id;
    id.vendor_id = kAbsentVid;
    id.product_id = kAbsentPid;
    id.serial = "NOPE";
    auto t = (*b)->open(id);
    ASSERT_FALSE(t.ok());
    EXPECT_NE(t.error().message.find("1209:fff7"), std::string::npos);
    EXPECT_NE(t.error().message.find("NOPE"), std::string::npos);
}

}  // namespace
}  // namespace hmdnode

// ---- udev rules (hal/udev/70-hmdnode.rules, docs/udev.md) ----

namespace hmdnode {
namespace {

TEST(UdevRules, EverySupportedDeviceHasGroupAccessAndNothingIsWorldWritable) {
    std::ifstream in(std::string(HMDNODE_SOURCE_DIR) + "/hal/udev/70-hmdnode.rules");
    ASSERT_TRUE(in) << "hal/udev/70-hmdnode.rules missing";
    std::set<std::string> hidraw, usb;
    std::string line;
    int rules = 0;
    const std::regex hid_re(
        R"re(SUBSYSTEM=="hidraw", ATTRS\{idVendor\}=="([0-9a-f]{4})", ATTRS\{idProduct\}=="([0-9a-f]{4})")re");
    const std::regex usb_re(
        R"re(SUBSYSTEM=="usb", ATTR\{idVendor\}=="([0-9a-f]{4})", ATTR\{idProduct\}=="([0-9a-f]{4})")re");
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        ++rules;
        EXPECT_NE(line.find("MODE=\"0660\""), std::string::npos) << line;
        EXPECT_NE(line.find("GROUP=\"plugdev\""), std::string::npos) << line;
        EXPECT_NE(line.find("TAG+=\"uaccess\""), std::string::npos) << line;
        EXPECT_EQ(line.find("0666"), std::string::npos) << line;
        EXPECT_EQ(line.find("0664"), std::string::npos) << line;
        std::smatch m;
        if (std::regex_search(line, m, hid_re))
            hidraw.insert(m[1].str() + ":" + m[2].str());
        else if (std::regex_search(line, m, usb_re))
            usb.insert(m[1].str() + ":" + m[2].str());
        else
            ADD_FAILURE() << "rule matches neither hidraw nor usb ids: " << line;
    }
    const std::set<std::string> want{"28de:2000", "28de:2300", "2833:0021", "2833:0031",
                                     "1209:0001"};
    EXPECT_EQ(hidraw, want);
    EXPECT_EQ(usb, want);
    EXPECT_EQ(rules, 10);
}

}  // namespace
}  // namespace hmdnode
