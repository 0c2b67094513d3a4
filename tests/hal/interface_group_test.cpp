// A device's HID interfaces as one transport (hal/transport/interface_group.hpp): the merge by
// host time, polled and on reader threads; the backend decorator grouping interfaces by USB
// device; the hidraw node -> USB device resolution on a made-up sysfs tree; and the live light
// path end to end: the Vive HMD of data/traces/vive_cal.pcap.gz served as a two-interface device
// (IMU reports of endpoint 0x81 on interface 0, with its configuration read; light reports of
// endpoint 0x82 on interface 1), grouped and merged, through the device tracker whose sensor
// model comes from the configuration read at the open -- the same poses as the capture path.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/tracking/device_light_log.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/transport.hpp"
#include "hmdnode/hal/transport/interface_group.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

// What the mock parts did, shared with the test.
struct PartLog {
    std::mutex mutex;
    std::vector<uint8_t> features_asked;
    int writes = 0;
};

// One interface: its reports in order (returned at once, whatever the timeout), then finished;
// or an error after `fail_after` reports. Feature reports answer recorded replies per id in order.
class MockPart final : public Transport {
  public:
    MockPart(DeviceId id, std::vector<InputReport> reports, std::shared_ptr<PartLog> log,
             long fail_after = -1)
        : id_(std::move(id)),
          reports_(std::move(reports)),
          log_(std::move(log)),
          fail_after_(fail_after) {}
    std::map<uint8_t, std::vector<std::vector<uint8_t>>> replies;

    DeviceId id() const override { return id_; }
    Result<std::optional<InputReport>> read_input(int) override {
        if (fail_after_ >= 0 && long(next_) >= fail_after_)
            return make_error(id_.path + ": device is gone (unplugged)");
        if (next_ >= reports_.size()) return std::optional<InputReport>{};
        return std::optional<InputReport>{reports_[next_++]};
    }
    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t) override {
        {
            std::lock_guard lock(log_->mutex);
            log_->features_asked.push_back(report_id);
        }
        auto it = replies.find(report_id);
        size_t& k = served_[report_id];
        if (it == replies.end() || k >= it->second.size())
            return make_error(id_.path + ": no reply to feature report " +
                              std::to_string(report_id));
        return it->second[k++];
    }
    Status set_feature(std::span<const uint8_t>) override { return {}; }
    Status write_output(std::span<const uint8_t>) override {
        std::lock_guard lock(log_->mutex);
        ++log_->writes;
        return {};
    }
    bool finished() const override { return fail_after_ < 0 && next_ >= reports_.size(); }

  private:
    DeviceId id_;
    std::vector<InputReport> reports_;
    std::shared_ptr<PartLog> log_;
    long fail_after_;
    size_t next_ = 0;
    std::map<uint8_t, size_t> served_;
};

// One interface whose reads a function answers (given the read's timeout).
class ScriptedPart final : public Transport {
  public:
    using Read = std::function<std::optional<InputReport>(int timeout_ms)>;
    ScriptedPart(DeviceId id, Read read) : id_(std::move(id)), read_(std::move(read)) {}
    DeviceId id() const override { return id_; }
    Result<std::optional<InputReport>> read_input(int timeout_ms) override {
        return read_(timeout_ms);
    }
    Result<std::vector<uint8_t>> get_feature(uint8_t, size_t) override {
        return make_error("no feature reports");
    }
    Status set_feature(std::span<const uint8_t>) override { return {}; }
    Status write_output(std::span<const uint8_t>) override { return {}; }

  private:
    DeviceId id_;
    Read read_;
};

InputReport report(uint8_t id, int64_t t, uint8_t tag) {
    InputReport r;
    r.bytes = {id, tag};
    r.host_time_ns = t;
    return r;
}

DeviceId interface_id(int n, const std::string& usb_device) {
    DeviceId id;
    id.vendor_id = 0x28de;
    id.product_id = 0x2000;
    id.interface_number = n;
    id.usb_device = usb_device;
    id.path = usb_device + ":1." + std::to_string(n);
    return id;
}

// Reads the merged transport to its end; fails the test past `limit` reads.
std::vector<InputReport> drain(Transport& t, int timeout_ms, size_t limit = 100000) {
    std::vector<InputReport> out;
    for (size_t k = 0; k < limit && !t.finished(); ++k) {
        auto r = t.read_input(timeout_ms);
        EXPECT_TRUE(r.ok()) << r.error().message;
        if (!r.ok()) break;
        if (r->has_value()) out.push_back(std::move(**r));
    }
    EXPECT_TRUE(t.finished()) << "not finished after " << limit << " reads";
    return out;
}

TEST(InterfaceGroup, PolledMergeIsOrderedByHostTimeAndFeaturesGoToThePrimary) {
    auto log = std::make_shared<PartLog>();
    std::vector<InputReport> imu, light;
    for (int i = 0; i < 50; ++i) imu.push_back(report(0x20, 1000 * i, uint8_t(i)));
    for (int i = 0; i < 30; ++i) light.push_back(report(0x25, 1000 * i + 1700, uint8_t(i)));
    auto primary = std::make_unique<MockPart>(interface_id(0, "usb:1-4"), imu, log);
    primary->replies[0x01] = {{0x01, 7}};
    std::vector<std::unique_ptr<Transport>> parts;
    parts.push_back(std::move(primary));
    parts.push_back(std::make_unique<MockPart>(interface_id(1, "usb:1-4"), light, log));
    auto merged = merge_interfaces(std::move(parts), InterfaceReading::polled);
    ASSERT_TRUE(merged.ok()) << merged.error().message;
    Transport& t = **merged;
    EXPECT_EQ(t.id().interface_number, 0);
    auto f = t.get_feature(0x01, 64);
    ASSERT_TRUE(f.ok()) << f.error().message;
    EXPECT_EQ((*f)[1], 7);
    const uint8_t out[] = {0x04, 1};
    EXPECT_TRUE(t.write_output(out).ok());
    EXPECT_EQ(log->writes, 1);
    std::vector<InputReport> got = drain(t, 0);
    ASSERT_EQ(got.size(), 80u);
    for (size_t i = 1; i < got.size(); ++i)
        EXPECT_LE(got[i - 1].host_time_ns, got[i].host_time_ns) << "at " << i;
    // Each part's reports in their order, none lost.
    int next_imu = 0, next_light = 0;
    for (const InputReport& r : got) {
        if (r.bytes[0] == 0x20) {
            EXPECT_EQ(r.bytes[1], next_imu++);
        } else if (r.bytes[0] == 0x25) {
            EXPECT_EQ(r.bytes[1], next_light++);
        }
    }
    EXPECT_EQ(next_imu, 50);
    EXPECT_EQ(next_light, 30);
}

TEST(InterfaceGroup, ThreadedMergeDeliversEveryReportOfEveryPartInOrder) {
    auto log = std::make_shared<PartLog>();
    std::vector<std::unique_ptr<Transport>> parts;
    const int counts[] = {400, 300, 200};
    for (int p = 0; p < 3; ++p) {
        std::vector<InputReport> rs;
        for (int i = 0; i < counts[p]; ++i)
            rs.push_back(report(uint8_t(0x20 + p), 10 * i + p, uint8_t(i & 0xff)));
        parts.push_back(std::make_unique<MockPart>(interface_id(p, "usb:1-4"), rs, log));
    }
    auto merged = merge_interfaces(std::move(parts), InterfaceReading::threads);
    ASSERT_TRUE(merged.ok()) << merged.error().message;
    std::vector<InputReport> got = drain(**merged, 5);
    int next[3] = {0, 0, 0};
    for (const InputReport& r : got) {
        const int p = r.bytes[0] - 0x20;
        ASSERT_GE(p, 0);
        ASSERT_LT(p, 3);
        EXPECT_EQ(r.bytes[1], uint8_t(next[p] & 0xff));
        ++next[p];
    }
    EXPECT_EQ(next[0], 400);
    EXPECT_EQ(next[1], 300);
    EXPECT_EQ(next[2], 200);
}

TEST(InterfaceGroup, ASecondaryInterfaceGoneFailsTheDevice) {
    for (InterfaceReading reading : {InterfaceReading::polled, InterfaceReading::threads}) {
        auto log = std::make_shared<PartLog>();
        std::vector<InputReport> imu;
        for (int i = 0; i < 100000; ++i) imu.push_back(report(0x20, i, 0));
        std::vector<InputReport> light = {report(0x25, 5, 0), report(0x25, 6, 1)};
        std::vector<std::unique_ptr<Transport>> parts;
        parts.push_back(std::make_unique<MockPart>(interface_id(0, "usb:1-4"), imu, log));
        parts.push_back(std::make_unique<MockPart>(interface_id(1, "usb:1-4"), light, log, 2));
        auto merged = merge_interfaces(std::move(parts), reading);
        ASSERT_TRUE(merged.ok());
        // Waits for the state: the error arrives once the secondary's two reports are read.
        std::string error;
        for (int k = 0; k < 100000 && error.empty(); ++k) {
            auto r = (*merged)->read_input(1);
            if (!r.ok()) error = r.error().message;
        }
        EXPECT_NE(error.find("usb:1-4:1.1: device is gone"), std::string::npos) << error;
    }
}

// A report of another interface that arrives while the primary is waited for is older than the
// primary's report that ends the wait: it comes first (the kernel lane found the merge handing
// them the other way round).
TEST(InterfaceGroup, AReportArrivingDuringThePrimarysWaitComesBeforeThePrimarysReport) {
    bool waited = false;  // the primary waited: the light arrived (at 50) meanwhile, the IMU at 51
    bool imu_sent = false, light_sent = false;
    auto primary = [&](int timeout_ms) -> std::optional<InputReport> {
        if (timeout_ms == 0 || imu_sent) return std::nullopt;
        waited = imu_sent = true;
        return report(0x20, 51, 0);
    };
    auto light = [&](int) -> std::optional<InputReport> {
        if (!waited || light_sent) return std::nullopt;
        light_sent = true;
        return report(0x25, 50, 0);
    };
    std::vector<std::unique_ptr<Transport>> parts;
    parts.push_back(std::make_unique<ScriptedPart>(interface_id(0, "usb:1-4"), primary));
    parts.push_back(std::make_unique<ScriptedPart>(interface_id(1, "usb:1-4"), light));
    auto merged = merge_interfaces(std::move(parts), InterfaceReading::polled);
    ASSERT_TRUE(merged.ok());
    auto first = (*merged)->read_input(10);
    ASSERT_TRUE(first.ok() && first->has_value());
    EXPECT_EQ((*first)->bytes[0], 0x25);
    EXPECT_EQ((*first)->host_time_ns, 50);
    auto second = (*merged)->read_input(10);
    ASSERT_TRUE(second.ok() && second->has_value());
    EXPECT_EQ((*second)->bytes[0], 0x20);
}

TEST(InterfaceGroup, MergeRefusesNoParts) {
    auto none = merge_interfaces({}, InterfaceReading::polled);
    ASSERT_FALSE(none.ok());
    EXPECT_NE(none.error().message.find("no interface"), std::string::npos);
}

// A backend of made-up interfaces; opens are logged.
class MockBackend final : public TransportBackend {
  public:
    std::vector<DeviceId> ids;
    std::set<std::string> refuse;  // paths that do not open
    std::vector<std::string> opened;
    std::function<std::unique_ptr<Transport>(const DeviceId&)> make;
    std::string name() const override { return "mock"; }
    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& f) override {
        std::vector<DeviceId> out;
        for (const DeviceId& id : ids)
            if (f.matches(id)) out.push_back(id);
        return out;
    }
    Result<std::unique_ptr<Transport>> open(const DeviceId& id) override {
        if (refuse.count(id.path)) return make_error(id.path + ": permission denied");
        opened.push_back(id.path);
        if (make) return make(id);
        return std::unique_ptr<Transport>(std::make_unique<MockPart>(id, std::vector<InputReport>{},
                                                                     std::make_shared<PartLog>()));
    }
};

TEST(InterfaceGroup, BackendListsEachUsbDeviceOnceAndOpensAllItsInterfaces) {
    auto inner = std::make_unique<MockBackend>();
    MockBackend& mock = *inner;
    mock.ids = {interface_id(1, "usb:1-4"), interface_id(2, "usb:1-4"), interface_id(0, "usb:1-4"),
                interface_id(0, "usb:1-5.2"), interface_id(0, "")};
    mock.ids.back().path = "/dev/hidraw9";  // a node sysfs says nothing of: alone
    auto backend = group_interfaces(std::move(inner), InterfaceReading::polled);
    auto ids = backend->enumerate({});
    ASSERT_TRUE(ids.ok());
    ASSERT_EQ(ids->size(), 3u);
    EXPECT_EQ((*ids)[0].path, "usb:1-4:1.0");  // the lowest interface stands for the device
    EXPECT_EQ((*ids)[1].path, "usb:1-5.2:1.0");
    EXPECT_EQ((*ids)[2].path, "/dev/hidraw9");
    auto t = backend->open((*ids)[0]);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(mock.opened, (std::vector<std::string>{"usb:1-4:1.0", "usb:1-4:1.1", "usb:1-4:1.2"}));
    EXPECT_EQ((*t)->id().path, "usb:1-4:1.0");
    mock.opened.clear();
    ASSERT_TRUE(backend->open((*ids)[2]).ok());
    EXPECT_EQ(mock.opened, (std::vector<std::string>{"/dev/hidraw9"}));

    mock.refuse = {"usb:1-4:1.2"};
    auto refused = backend->open((*ids)[0]);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("usb:1-4: interface 2 (usb:1-4:1.2)"), std::string::npos)
        << refused.error().message;
    EXPECT_NE(refused.error().message.find("permission denied"), std::string::npos);
}

TEST(InterfaceGroup, HidrawNodeResolvesToItsUsbDeviceThroughSysfs) {
    const fs::path root = fs::temp_directory_path() / ("hmdnode_sysfs_" + std::to_string(getpid()));
    fs::remove_all(root);
    const fs::path usb = root / "devices/pci0000:00/0000:00:14.0/usb1/1-4/1-4.1";
    const fs::path hid0 = usb / "1-4.1:1.0/0003:28DE:2000.0004";
    const fs::path hid1 = usb / "1-4.1:1.1/0003:28DE:2000.0005";
    const fs::path uhid = root / "devices/virtual/misc/uhid/0003:28DE:2000.0006";
    for (const fs::path& p : {hid0, hid1, uhid}) fs::create_directories(p);
    fs::create_directories(root / "class/hidraw/hidraw3");
    fs::create_directories(root / "class/hidraw/hidraw4");
    fs::create_directories(root / "class/hidraw/hidraw5");
    fs::create_directory_symlink(hid0, root / "class/hidraw/hidraw3/device");
    fs::create_directory_symlink(hid1, root / "class/hidraw/hidraw4/device");
    fs::create_directory_symlink(uhid, root / "class/hidraw/hidraw5/device");
    EXPECT_EQ(hidraw_usb_device("/dev/hidraw3", root.string()), "usb:1-4.1");
    EXPECT_EQ(hidraw_usb_device("/dev/hidraw4", root.string()), "usb:1-4.1");
    EXPECT_EQ(hidraw_usb_device("/dev/hidraw5", root.string()), "");  // uhid, no HID_PHYS
    // A uhid device whose HID_PHYS ends in /inputN (as a USB interface's): its part before that.
    std::ofstream(uhid / "uevent") << "DRIVER=hid-generic\nHID_ID=0003:000028DE:00002000\n"
                                      "HID_PHYS=hmdnode-lane-vive/input1\nHID_UNIQ=LANE-VIVE\n";
    int iface = -1;
    EXPECT_EQ(hidraw_usb_device("/dev/hidraw5", root.string(), &iface), "phys:hmdnode-lane-vive");
    EXPECT_EQ(iface, 1);
    std::ofstream(uhid / "uevent") << "HID_PHYS=00:1a:7d:da:71:13\n";  // Bluetooth: the adapter
    EXPECT_EQ(hidraw_usb_device("/dev/hidraw5", root.string()), "");
    EXPECT_EQ(hidraw_usb_device("/dev/hidraw6", root.string()), "");  // no such node
    EXPECT_EQ(hidraw_usb_device("/dev/ttyUSB0", root.string()), "");
    fs::remove_all(root);
}

// ---- the live light path, end to end ----

const fs::path kViveCal = fs::path(HMDNODE_SOURCE_DIR) / "data/traces/vive_cal.pcap.gz";

// The Vive HMD of vive_cal as a two-interface device: interface 0 its endpoint 0x81 reports and
// its recorded feature-report replies (the configuration read), interface 1 its 0x82 reports.
std::unique_ptr<MockBackend> vive_cal_as_device(const CaptureDevice& dev) {
    std::vector<InputReport> by_endpoint[2];
    std::map<uint8_t, std::vector<std::vector<uint8_t>>> replies;
    std::map<uint64_t, uint8_t> asked;
    for (const UsbPacket& u : dev.capture->packets) {
        if (u.bus != dev.bus || u.device_address != dev.address) continue;
        if (is_interrupt_in_completion(u) && (u.endpoint == 0x81 || u.endpoint == 0x82)) {
            InputReport r;
            r.bytes = u.data;
            r.host_time_ns = u.time_ns;
            by_endpoint[u.endpoint - 0x81].push_back(std::move(r));
        }
        if (u.transfer_type == 2 && u.event == 'S' && u.setup_present && u.setup[0] == 0xa1 &&
            u.setup[1] == 0x01 && u.setup[3] == 0x03)
            asked[u.urb_id] = u.setup[2];
        if (u.transfer_type == 2 && u.event == 'C' && u.status == 0 && !u.data.empty())
            if (auto it = asked.find(u.urb_id); it != asked.end()) {
                replies[it->second].push_back(u.data);
                asked.erase(it);
            }
    }
    auto backend = std::make_unique<MockBackend>();
    backend->ids = {interface_id(0, "usb:1-62"), interface_id(1, "usb:1-62")};
    auto log = std::make_shared<PartLog>();
    backend->make = [by_endpoint, replies, log](const DeviceId& id) {
        auto part = std::make_unique<MockPart>(id, by_endpoint[id.interface_number], log);
        if (id.interface_number == 0) part->replies = replies;
        return std::unique_ptr<Transport>(std::move(part));
    };
    return backend;
}

struct TrackerRun {
    std::vector<TrackerSample> samples;
    DeviceTrackerStatus status;
};

TrackerRun run_to_end(DeviceTracker& t, SimulatedClock& clock) {
    TrackerRun run;
    EXPECT_TRUE(t.start().ok());
    std::vector<TrackerSample> buf(512);
    // Steps the simulated clock until the tracker says its source is spent (bounded).
    for (int step = 0; step < 200000 && !t.finished(); ++step) {
        clock.advance_ns(kNsPerMs);
        const size_t n = t.read(buf);
        run.samples.insert(run.samples.end(), buf.begin(), buf.begin() + long(n));
    }
    EXPECT_TRUE(t.finished());
    run.status = t.status();
    return run;
}

TEST(InterfaceGroup, LiveLightPathOfAViveMatchesTheCapturePath) {
    auto dev = find_capture_device(kViveCal, "28de:2000");
    ASSERT_TRUE(dev.ok()) << dev.error().message;
    // The base stations placed from the capture's still stretch (`hmdnode tracking place`).
    auto log = device_light_log_from_capture(kViveCal, "28de:2000");
    ASSERT_TRUE(log.ok()) << log.error().message;
    const std::vector<StillStretch> still = still_stretches(*log);
    auto best = best_still_stretch(still);
    ASSERT_TRUE(best.has_value());
    lighthouse::PlacementResult placed =
        place_from_log(*log, best->begin_ns, best->end_ns, best->mean_accel);
    ASSERT_FALSE(placed.placed.empty());

    const int64_t t0 = 5 * kNsPerSecond;
    SimulatedClock live_clock(t0);
    DeviceTrackerConfig cfg;
    cfg.filter.vendor_id = 0x28de;
    cfg.filter.product_id = 0x2000;
    cfg.first_report_host_ns = t0;
    auto light = std::make_shared<LightTrackingConfig>();
    light->setup = placed.placed;  // no sensors: the device's configuration gives them
    light->filter.world_up = glm::dvec3(0, 0, 1);
    cfg.light = light;
    auto live =
        create_device_tracker(group_interfaces(vive_cal_as_device(*dev), InterfaceReading::polled),
                              make_codec_for(0x28de, 0x2000), live_clock, cfg);
    ASSERT_TRUE(live.ok()) << live.error().message;
    const TrackerRun a = run_to_end(**live, live_clock);

    SimulatedClock capture_clock(t0);
    auto capture = create_capture_tracker(kViveCal, "28de:2000", capture_clock, t0, placed.placed);
    ASSERT_TRUE(capture.ok()) << capture.error().message;
    const TrackerRun b = run_to_end(**capture, capture_clock);

    // The live path read the configuration over feature reports 0x10/0x11 and took its model.
    EXPECT_TRUE(a.status.light.enabled) << a.status.light.light_error;
    EXPECT_EQ(a.status.light.reports, b.status.light.reports);
    EXPECT_GT(a.status.light.reports, 16000u);  // every 0x25 report of endpoint 0x82
    EXPECT_EQ(a.status.light.rejected, 0u) << a.status.light.light_error;
    EXPECT_GT(a.status.light.samples_with_position, 10000u);
    ASSERT_EQ(a.samples.size(), b.samples.size());
    size_t both = 0;
    double worst_m = 0, worst_rad = 0;
    for (size_t i = 0; i < a.samples.size(); ++i) {
        const TrackerSample& x = a.samples[i];
        const TrackerSample& y = b.samples[i];
        ASSERT_EQ(x.time_ns, y.time_ns) << "sample " << i;
        ASSERT_EQ(x.position.has_value(), y.position.has_value()) << "sample " << i;
        if (!x.position) continue;
        ++both;
        worst_m = std::max(worst_m, glm::length(*x.position - *y.position));
        worst_rad = std::max(
            worst_rad,
            2 * std::acos(std::min(1.0, std::abs(glm::dot(x.orientation, y.orientation)))));
    }
    std::printf(
        "live (grouped, merged) vs capture path: %zu samples, %zu with a position, %llu light "
        "reports; largest difference %.3g m, %.3g rad\n",
        a.samples.size(), both, static_cast<unsigned long long>(a.status.light.reports), worst_m,
        worst_rad);
    EXPECT_EQ(both, a.status.light.samples_with_position);
    EXPECT_LT(worst_m, 1e-6);
    EXPECT_LT(worst_rad, 1e-6);
}

TEST(InterfaceGroup, LiveDeviceWithoutASensorModelKeepsOrientationAndSaysWhy) {
    auto dev = find_capture_device(kViveCal, "28de:2000");
    ASSERT_TRUE(dev.ok()) << dev.error().message;
    auto backend = vive_cal_as_device(*dev);
    auto make = backend->make;
    // The device answers no feature report: no configuration, no sensor model.
    backend->make = [make](const DeviceId& id) {
        auto t = make(id);
        static_cast<MockPart&>(*t).replies.clear();
        return t;
    };
    SimulatedClock clock(kNsPerSecond);
    DeviceTrackerConfig cfg;
    cfg.filter.vendor_id = 0x28de;
    cfg.first_report_host_ns = kNsPerSecond;
    auto light = std::make_shared<LightTrackingConfig>();
    lighthouse::BaseStationPlacement bs;
    light->setup = {bs};
    cfg.light = light;
    auto t = create_device_tracker(group_interfaces(std::move(backend), InterfaceReading::polled),
                                   make_codec_for(0x28de, 0x2000), clock, cfg);
    ASSERT_TRUE(t.ok()) << t.error().message;
    const TrackerRun run = run_to_end(**t, clock);
    EXPECT_FALSE(run.status.light.enabled);
    EXPECT_NE(run.status.light.light_error.find("no configuration"), std::string::npos)
        << run.status.light.light_error;
    EXPECT_NE(run.status.light.light_error.find("orientation only"), std::string::npos);
    EXPECT_GT(run.samples.size(), 10000u);
    for (const TrackerSample& s : run.samples) ASSERT_FALSE(s.position.has_value());
}

}  // namespace
}  // namespace hmdnode
