// The usbmon pcap writer and the tee backend (hal/transport/usbmon_pcap_writer.hpp), read back by
// hal's own capture reader: the events, their times and bytes, and the device's ids from the
// synthetic descriptor exchange.
#include "hmdnode/hal/transport/usbmon_pcap_writer.hpp"

#include <gtest/gtest.h>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

namespace hmdnode {
namespace {

Result<UsbCapture> read_back(const UsbmonPcapWriter& w) {
    const std::string& b = w.bytes();
    return parse_usbmon_capture(
        std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(b.data()), b.size()));
}

TEST(UsbmonPcapWriter, EventsReadBackWithTheirTimesBytesAndIds) {
    UsbmonPcapWriter w;
    w.device_descriptor(5 * kNsPerSecond, 0x28de, 0x2000);
    const uint8_t report[4] = {0x20, 1, 2, 3};
    w.interrupt_in(5 * kNsPerSecond + 1'500'000, report);
    EXPECT_EQ(w.events(), 3u);
    Result<UsbCapture> cap = read_back(w);
    ASSERT_TRUE(cap.ok()) << cap.error().message;
    EXPECT_EQ(cap->link_type, 220);
    EXPECT_TRUE(cap->warnings.empty());
    ASSERT_EQ(cap->packets.size(), 3u);
    EXPECT_EQ(cap->packets[0].event, 'S');
    EXPECT_TRUE(cap->packets[0].setup_present);
    const UsbPacket& in = cap->packets[2];
    EXPECT_EQ(in.event, 'C');
    EXPECT_EQ(in.transfer_type, 1);
    EXPECT_EQ(in.endpoint, 0x81);
    EXPECT_EQ(in.time_ns, 5 * kNsPerSecond + 1'500'000);
    EXPECT_EQ(in.data, std::vector<uint8_t>(report, report + 4));
    const CaptureSummary s = summarize_capture(*cap);
    ASSERT_EQ(s.devices.size(), 1u);
    EXPECT_EQ(s.devices[0].vendor_id, 0x28de);
    EXPECT_EQ(s.devices[0].product_id, 0x2000);
    EXPECT_EQ(s.devices[0].id_source, "descriptor");
}

// The tee hands everything through and writes what passed: the descriptor on open, the
// feature report read, each input report at its arrival time.
TEST(UsbmonPcapWriter, TeeBackendWritesWhatPassesThrough) {
    SimulatedClock clock(kNsPerSecond);
    SimReferenceDeviceConfig sc;
    auto pcap = std::make_shared<UsbmonPcapWriter>();
    auto tee = create_pcap_tee_backend(create_sim_reference_backend(clock, sc, sinusoidal_motion()),
                                       pcap, clock, 0);
    DeviceFilter f;
    f.vendor_id = sc.vendor_id;
    f.product_id = sc.product_id;
    auto ids = tee->enumerate(f);
    ASSERT_TRUE(ids.ok() && !ids->empty());
    auto t = tee->open(ids->front());
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_TRUE(
        (*t)->get_feature(refproto::kDeviceInfoReport, refproto::kDeviceInfoReportSize).ok());
    clock.advance_ns(10 * kNsPerMs);
    size_t reports = 0;
    for (;;) {
        auto r = (*t)->read_input(0);
        ASSERT_TRUE(r.ok()) << r.error().message;
        if (!r->has_value()) break;
        ++reports;
    }
    EXPECT_GT(reports, 0u);
    EXPECT_EQ(pcap->events(), 4u + reports);  // descriptor S/C, feature S/C, the reports
    Result<UsbCapture> cap = read_back(*pcap);
    ASSERT_TRUE(cap.ok()) << cap.error().message;
    EXPECT_EQ(summarize_capture(*cap).devices.at(0).vendor_id, sc.vendor_id);
}

}  // namespace
}  // namespace hmdnode
