// The real-kernel lane's guest program (docs/hardware.md). Run as root inside a qemu guest with
// uhid, hid-generic, vivid and bochs loaded, chrooted into the host's root, it proves against the
// kernel's own drivers:
//   1. the simulated reference tracker's firmware (SimReferenceFirmware) becomes a HID device
//      through /dev/uhid (UHID_CREATE2 with the protocol's report descriptor, UHID_INPUT2 per
//      report, UHID_GET_REPORT / UHID_SET_REPORT answered by the firmware);
//   2. our hidapi backend finds it by VID:PID, reads its input reports through hidraw and the
//      protocol decoder with contiguous sequence numbers, and does the device-info and time-sync
//      feature exchanges through hidraw;
//   3. the device is destroyed and re-created mid-stream: the open transport fails, the hidraw
//      hotplug monitor (kernel uevents: no udevd in the guest) sees it come back, and the backend
//      reads again within a second of the re-creation;
//   3b. 100 more destroy/re-create cycles, each recovered within a second, no fd leaked;
//   3c. a Vive's two HID interfaces (IMU and light, two uhid devices of one phys) found by the
//       grouped hidapi backend as one device and read as one merged transport, every report of
//       both delivered in its order (the live light path's transport);
//   4. our V4L2 backend streams a few frames from vivid's /dev/video0;
//   5. our KMS display drives bochs-display's connector (qemu's EDID): atomic modeset, 300 page
//      flips with their events' times, the scanned-out buffer read back and compared;
//   6. the frames are the real renderer's (Mesa from the host's filesystem, which the guest runs
//      in through a read-only 9p share): the demo room (argv[1]), a few frames rendered first and
//      cycled over the 300 flips, then a short run where each frame is rendered then flipped;
//   7. zero-copy scan-out: the GLES renderer on EGL's GBM platform on the same KMS device (Mesa's
//      kms_swrast: bochs-drm has no 3D driver) warps the demo room into its ring of GBM buffer
//      objects, which the display attached as framebuffers once; 300 flips of the buffer the warp
//      just drew (no CPU copy), the scanned-out buffer read back through the kernel (GETFB2 +
//      map) equal to the same frame read back from GL;
//   8. the latency marker through a real V4L2 driver: the same renderer's warp draws panels
//      carrying the marker for 20 consecutive ids (each equal to the CPU reference), written as
//      YUYV to vivid's HDMI output (/dev/video1) through our V4L2 output backend; vivid loops
//      it back to its HDMI input (/dev/video0, input 1), our V4L2 capture backend takes the
//      frames on the driver's schedule, and the marker decoder reads them: the ids decoded are
//      ones presented, in order, none undecoded between the first and the last, each frame
//      the one written byte for byte; repeats, skips and capture drops are printed;
//   9. `hmdnode latency --display kms` as a rig runs it: the lane lets the connector go and the
//      node (run_replay) presents on it with the marker on (node_on_kms).
// argv[2] (optional) picks the renderers of the KMS runs: "gles" (the default: one GLES renderer on
// GBM, its frames through the dumb-buffer copy, then zero-copy), "vulkan" (the Vulkan renderer's
// frames through the dumb-buffer copy, with the live run) or "both".
// Prints one line per check and a final "HMDNODE_KERNEL_LANE: PASS" or "...: FAIL"; exits 0 / 1.
#include <dirent.h>
#include <fcntl.h>
#include <linux/uhid.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/latency_marker.hpp"
#include "hmdnode/core/percentile.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/firmware_host/motion_profiles.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/camera.hpp"
#include "hmdnode/hal/camera/v4l2_output.hpp"
#include "hmdnode/hal/camera/yuyv.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/display/kms_display.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/transport.hpp"
#include "hmdnode/hal/transport/interface_group.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"
#include "hmdnode/render/lens.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {
namespace {

int64_t now_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

int g_failures = 0;
int64_t g_t0 = 0;

void check(bool ok, const char* what, const std::string& detail = "") {
    std::printf("[%7.3f s] %s %s%s%s\n", ns_to_s(now_ns() - g_t0), ok ? "ok  " : "FAIL", what,
                detail.empty() ? "" : ": ", detail.c_str());
    std::fflush(stdout);
    if (!ok) ++g_failures;
}

std::string fmt(const char* f, double v) {
    char b[96];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

// A UHID_CREATE2 event: a USB-bus HID device with these strings, ids and report descriptor.
uhid_event uhid_create_event(const char* name, const char* uniq, const char* phys, uint16_t vendor,
                             uint16_t product, std::span<const uint8_t> rd) {
    uhid_event ev{};
    ev.type = UHID_CREATE2;
    std::snprintf(reinterpret_cast<char*>(ev.u.create2.name), sizeof ev.u.create2.name, "%s", name);
    std::snprintf(reinterpret_cast<char*>(ev.u.create2.uniq), sizeof ev.u.create2.uniq, "%s", uniq);
    std::snprintf(reinterpret_cast<char*>(ev.u.create2.phys), sizeof ev.u.create2.phys, "%s", phys);
    ev.u.create2.rd_size = static_cast<uint16_t>(rd.size());
    std::memcpy(ev.u.create2.rd_data, rd.data(), rd.size());
    ev.u.create2.bus = 0x03;  // BUS_USB
    ev.u.create2.vendor = vendor;
    ev.u.create2.product = product;
    ev.u.create2.version = 0x0100;
    return ev;
}

constexpr const char* kSerial = "LANE-0001";
constexpr int64_t kDeviceClockOffsetUs = 4'000'000'000;  // device clock far from the host's

// The tracker firmware behind /dev/uhid, on its own thread (as a device is on its own MCU).
class UhidTracker {
  public:
    UhidTracker() : firmware_(make_config(), sinusoidal_motion(30.0, 0.5)) {}
    ~UhidTracker() {
        quit_ = true;
        if (thread_.joinable()) thread_.join();
        if (fd_ >= 0) close(fd_);
    }

    bool start(std::string* error) {
        fd_ = open("/dev/uhid", O_RDWR | O_CLOEXEC);
        if (fd_ < 0) {
            *error = std::string("/dev/uhid: ") + std::strerror(errno);
            return false;
        }
        if (!create(error)) return false;
        thread_ = std::thread([this] { loop(); });
        return true;
    }

    // Destroys the device, waits gap_ms, creates it again (rebooted firmware).
    void request_recreate(int gap_ms) {
        gap_ms_ = gap_ms;
        recreate_ = true;
    }
    int64_t created_ns() const { return created_ns_.load(); }
    int64_t boot_ns() const { return boot_ns_.load(); }
    uint64_t get_reports() const { return get_reports_.load(); }
    uint64_t set_reports() const { return set_reports_.load(); }

  private:
    static SimReferenceDeviceConfig make_config() {
        SimReferenceDeviceConfig c;
        c.serial = kSerial;
        c.latency_ns = 0;  // the real kernel adds its own
        c.device_clock_offset_us = kDeviceClockOffsetUs;
        return c;
    }

    bool write_event(const uhid_event& ev) {
        const ssize_t n = write(fd_, &ev, sizeof ev);
        return n == static_cast<ssize_t>(sizeof ev);
    }

    bool create(std::string* error) {
        const uhid_event ev = uhid_create_event("hmdnode reference tracker (lane)", kSerial, "",
                                                refproto::kDevVendorId, refproto::kDevProductId,
                                                refproto::report_descriptor());
        if (!write_event(ev)) {
            if (error) *error = std::string("UHID_CREATE2: ") + std::strerror(errno);
            return false;
        }
        const int64_t t = now_ns();
        {
            std::lock_guard lock(mutex_);
            firmware_.boot(t);
        }
        boot_ns_ = t;
        created_ns_ = t;
        created_ = true;
        return true;
    }

    void destroy() {
        uhid_event ev{};
        ev.type = UHID_DESTROY;
        write_event(ev);
        created_ = false;
    }

    void handle(const uhid_event& ev) {
        const int64_t t = now_ns();
        if (ev.type == UHID_GET_REPORT) {
            ++get_reports_;
            uhid_event reply{};
            reply.type = UHID_GET_REPORT_REPLY;
            reply.u.get_report_reply.id = ev.u.get_report.id;
            Result<std::vector<uint8_t>> r = firmware_.get_feature(ev.u.get_report.rnum, t);
            if (r.ok()) {
                reply.u.get_report_reply.err = 0;
                reply.u.get_report_reply.size = static_cast<uint16_t>(r->size());
                std::memcpy(reply.u.get_report_reply.data, r->data(), r->size());
            } else {
                reply.u.get_report_reply.err = EIO;
            }
            write_event(reply);
        } else if (ev.type == UHID_SET_REPORT) {
            ++set_reports_;
            uhid_event reply{};
            reply.type = UHID_SET_REPORT_REPLY;
            reply.u.set_report_reply.id = ev.u.set_report.id;
            Status s = firmware_.set_feature(
                std::span<const uint8_t>(ev.u.set_report.data, ev.u.set_report.size), t);
            reply.u.set_report_reply.err = s.ok() ? 0 : EIO;
            write_event(reply);
        }
    }

    void loop() {
        std::vector<InputReport> reports;
        while (!quit_) {
            if (recreate_) {
                destroy();
                const int64_t until = now_ns() + int64_t{gap_ms_} * kNsPerMs;
                while (now_ns() < until) drain(until);
                create(nullptr);
                recreate_ = false;
            }
            int64_t next;
            {
                std::lock_guard lock(mutex_);
                next = firmware_.next_arrival_ns();
            }
            drain(std::min(next, now_ns() + 5 * kNsPerMs));
            if (!created_) continue;
            reports.clear();
            {
                std::lock_guard lock(mutex_);
                firmware_.produce(now_ns(), reports);
            }
            for (const InputReport& r : reports) {
                uhid_event ev{};
                ev.type = UHID_INPUT2;
                ev.u.input2.size = static_cast<uint16_t>(r.bytes.size());
                std::memcpy(ev.u.input2.data, r.bytes.data(), r.bytes.size());
                write_event(ev);
            }
        }
        if (created_) destroy();
    }

    // Answers the kernel's events until host time `until`.
    void drain(int64_t until) {
        for (;;) {
            const int64_t left = until - now_ns();
            timespec ts{0, left > 0 ? static_cast<long>(left) : 0};
            pollfd p{fd_, POLLIN, 0};
            const int rc = ppoll(&p, 1, &ts, nullptr);
            if (rc <= 0) return;
            uhid_event ev{};
            if (read(fd_, &ev, sizeof ev) <= 0) return;
            std::lock_guard lock(mutex_);
            handle(ev);
        }
    }

    int fd_ = -1;
    std::mutex mutex_;
    SimReferenceFirmware firmware_;
    std::thread thread_;
    std::atomic<bool> quit_{false}, recreate_{false}, created_{false};
    std::atomic<int> gap_ms_{0};
    std::atomic<int64_t> created_ns_{0}, boot_ns_{0};
    std::atomic<uint64_t> get_reports_{0}, set_reports_{0};
};

std::unique_ptr<Transport> find_and_open(TransportBackend& backend, int64_t deadline_ns,
                                         std::string* error) {
    const DeviceFilter filter{refproto::kDevVendorId, refproto::kDevProductId, kSerial};
    while (now_ns() < deadline_ns) {
        auto list = backend.enumerate(filter);
        if (!list.ok()) {
            *error = list.error().message;
            return nullptr;
        }
        if (!list->empty()) {
            auto t = backend.open(list->front());
            if (t.ok()) return std::move(*t);
            *error = t.error().message;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (error->empty()) *error = "no 1209:0001 with serial LANE-0001 appeared";
    return nullptr;
}

double percentile(std::vector<double> v, double q) {
    return v.empty() ? 0.0 : hmdnode::percentile(std::move(v), q);
}

int open_fds() {
    int n = 0;
    if (DIR* d = opendir("/proc/self/fd")) {
        while (readdir(d)) ++n;
        closedir(d);
    }
    return n;
}

// 3b. kReplugs unplug/replug cycles through the kernel's uhid (the service's fault-injection
// target): each destroys the device and creates it again 20 ms later (a rebooted firmware), then
// the backend finds it, opens it and reads a decoded report; recovery = that report's host time -
// the re-creation. Checks every cycle recovers within a second and that the process holds as many
// fds after the cycles as before (no leak per cycle).
constexpr int kReplugs = 100;
void replug_cycles(UhidTracker& tracker, TransportBackend& backend) {
    const int fds_before = open_fds();
    std::vector<double> recovery_ms;
    std::string error;
    for (int i = 0; i < kReplugs && error.empty(); ++i) {
        const int64_t created_before = tracker.created_ns();
        tracker.request_recreate(20);
        const int64_t deadline = now_ns() + 3 * kNsPerSecond;
        while (tracker.created_ns() == created_before && now_ns() < deadline) usleep(1000);
        if (tracker.created_ns() == created_before) {
            error = "cycle " + std::to_string(i) + ": the uhid device was not re-created";
            break;
        }
        std::unique_ptr<Transport> t = find_and_open(backend, now_ns() + 3 * kNsPerSecond, &error);
        if (!t) {
            error = "cycle " + std::to_string(i) + ": " + error;
            break;
        }
        error.clear();
        for (int k = 0; k < 100; ++k) {  // reports still queued from before do not decode
            auto r = t->read_input(1000);
            if (!r.ok() || !r->has_value()) {
                error = "cycle " + std::to_string(i) + ": " +
                        (r.ok() ? std::string("no report within 1 s") : r.error().message);
                break;
            }
            if (refproto::decode_pose((*r)->bytes).ok()) {
                recovery_ms.push_back(ns_to_ms((*r)->host_time_ns - tracker.created_ns()));
                break;
            }
        }
    }
    const int fds_after = open_fds();
    const double worst = recovery_ms.empty() ? 0.0 : percentile(recovery_ms, 1.0);
    check(error.empty() && int(recovery_ms.size()) == kReplugs && worst < 1000.0,
          "100 uhid unplug/replug cycles, each recovered within a second",
          error.empty() ? std::to_string(recovery_ms.size()) + " cycles" +
                              fmt(", recovery median %.1f ms", percentile(recovery_ms, 0.5)) +
                              fmt(", max %.1f ms", worst)
                        : error);
    check(fds_after == fds_before, "no fd leaked over the replug cycles",
          std::to_string(fds_before) + " open fds before, " + std::to_string(fds_after) + " after");
}

// 3c. A lighthouse device's two HID interfaces through the kernel: two uhid devices stand for a
// Vive's (28de:2000, serial LANE-VIVE, phys "hmdnode-lane-vive/input0" with the IMU report 0x20
// and ".../input1" with the light report 0x25, vendor-defined report descriptors of the capture's
// sizes), fed the first seconds of data/traces/vive_cal.pcap.gz's endpoint 0x81 and 0x82 reports
// at the capture's pace from a thread of their own. The hidapi backend grouped by device
// (group_interfaces, the secondary interface on a reader thread, as `record --backend hidapi
// --base-stations` opens one) lists one device, and its merged transport delivers every report of
// both interfaces, byte for byte, each interface's in its order.
class UhidInterface {
  public:
    ~UhidInterface() {
        if (fd_ >= 0) {
            uhid_event ev{};
            ev.type = UHID_DESTROY;
            (void)!write(fd_, &ev, sizeof ev);
            close(fd_);
        }
    }
    bool create(const char* phys, uint8_t report_id, size_t report_size, std::string* error) {
        fd_ = open("/dev/uhid", O_RDWR | O_CLOEXEC | O_NONBLOCK);
        if (fd_ < 0) {
            *error = std::string("/dev/uhid: ") + std::strerror(errno);
            return false;
        }
        // Vendor-defined page, one input report of report_size - 1 bytes after its id.
        const uint8_t count = uint8_t(report_size - 1);
        const uint8_t rd[] = {0x06,      0x00, 0xFF, 0x09,  0x01, 0xA1, 0x01, 0x85,
                              report_id, 0x09, 0x01, 0x15,  0x00, 0x26, 0xFF, 0x00,
                              0x75,      0x08, 0x95, count, 0x81, 0x02, 0xC0};
        const uhid_event ev =
            uhid_create_event("hmdnode lane Vive interface", "LANE-VIVE", phys, 0x28de, 0x2000, rd);
        if (write(fd_, &ev, sizeof ev) != ssize_t(sizeof ev)) {
            *error = std::string("UHID_CREATE2 (") + phys + "): " + std::strerror(errno);
            return false;
        }
        return true;
    }
    bool input(const std::vector<uint8_t>& bytes) {
        uhid_event ev{};
        ev.type = UHID_INPUT2;
        ev.u.input2.size = uint16_t(bytes.size());
        std::memcpy(ev.u.input2.data, bytes.data(), bytes.size());
        // note: the kernel's events to us (start, open, close) are read and dropped.
        uhid_event in{};
        while (read(fd_, &in, sizeof in) > 0) {
        }
        return write(fd_, &ev, sizeof ev) == ssize_t(sizeof ev);
    }

  private:
    int fd_ = -1;
};

void interface_group_lane() {
    constexpr double kSeconds = 3.0;  // of the capture
    auto dev = find_capture_device(HMDNODE_SOURCE_DIR "/data/traces/vive_cal.pcap.gz", "28de:2000");
    if (!dev.ok()) {
        check(false, "two-interface Vive through uhid: the capture", dev.error().message);
        return;
    }
    std::vector<UsbPacket> sent[2];
    int64_t first = -1;
    for (const UsbPacket& u : dev->capture->packets) {
        if (u.bus != dev->bus || u.device_address != dev->address) continue;
        if (!is_interrupt_in_completion(u) || (u.endpoint != 0x81 && u.endpoint != 0x82)) continue;
        // note: only the interface's own report (the capture's first 0x81 transfer is a stray
        // id 0, which a numbered-report device cannot send)
        if (u.data[0] != (u.endpoint == 0x81 ? 0x20 : 0x25)) continue;
        if (first < 0) first = u.time_ns;
        if (u.time_ns - first > int64_t(kSeconds * 1e9)) break;
        sent[u.endpoint - 0x81].push_back(u);
    }
    UhidInterface imu, light;
    std::string error;
    const bool made =
        !sent[0].empty() && !sent[1].empty() &&
        imu.create("hmdnode-lane-vive/input0", 0x20, sent[0].front().data.size(), &error) &&
        light.create("hmdnode-lane-vive/input1", 0x25, sent[1].front().data.size(), &error);
    check(made,
          "two uhid interfaces of one Vive (28de:2000, phys hmdnode-lane-vive/input0, /input1)",
          made ? std::to_string(sent[0].size()) + " IMU and " + std::to_string(sent[1].size()) +
                     " light reports to send"
               : error);
    if (!made) return;
    TransportBackendOptions options;
    options.udev_event_source = "kernel";
    auto inner = create_hidapi_backend(options);
    if (!inner.ok()) {
        check(false, "hidapi backend", inner.error().message);
        return;
    }
    auto backend = group_interfaces(std::move(*inner), InterfaceReading::threads);
    const DeviceFilter filter{0x28de, 0x2000, "LANE-VIVE"};
    std::vector<DeviceId> ids;
    for (const int64_t deadline = now_ns() + 5 * kNsPerSecond; now_ns() < deadline;) {
        auto list = backend->enumerate(filter);
        if (list.ok() && list->size() == 1 && !list->front().usb_device.empty()) {
            ids = *list;
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    check(ids.size() == 1, "the grouped hidapi backend lists the two hidraw nodes as one device",
          ids.size() == 1 ? ids.front().path + " " + ids.front().usb_device + " interface " +
                                std::to_string(ids.front().interface_number)
                          : "not one device within 5 s");
    if (ids.size() != 1) return;
    auto t = backend->open(ids.front());
    check(t.ok(), "its interfaces opened as one merged transport",
          t.ok() ? (*t)->id().path : t.error().message);
    if (!t.ok()) return;
    // The device: the capture's reports at its pace, each to its interface.
    std::atomic<bool> fed{false};
    std::thread feeder([&] {
        const int64_t start = now_ns();
        size_t k[2] = {0, 0};
        while (k[0] < sent[0].size() || k[1] < sent[1].size()) {
            const int e = k[1] >= sent[1].size() || (k[0] < sent[0].size() &&
                                                     sent[0][k[0]].time_ns <= sent[1][k[1]].time_ns)
                              ? 0
                              : 1;
            const UsbPacket& u = sent[e][k[e]++];
            const int64_t at = start + (u.time_ns - first);
            while (now_ns() < at) std::this_thread::sleep_for(std::chrono::microseconds(200));
            (e == 0 ? imu : light).input(u.data);
        }
        fed = true;
    });
    std::vector<std::vector<uint8_t>> got[2];
    size_t out_of_order = 0;
    int64_t last_t = 0;
    const int64_t limit = now_ns() + int64_t((kSeconds + 5) * 1e9);
    while (now_ns() < limit && got[0].size() + got[1].size() < sent[0].size() + sent[1].size()) {
        auto r = (*t)->read_input(50);
        if (!r.ok()) {
            error = r.error().message;
            break;
        }
        if (!r->has_value()) continue;
        const InputReport& rep = **r;
        if (rep.host_time_ns < last_t) ++out_of_order;
        last_t = rep.host_time_ns;
        got[!rep.bytes.empty() && rep.bytes[0] == 0x25 ? 1 : 0].push_back(rep.bytes);
    }
    feeder.join();
    bool same[2];
    for (int e = 0; e < 2; ++e) {
        same[e] = got[e].size() == sent[e].size();
        for (size_t i = 0; same[e] && i < got[e].size(); ++i)
            same[e] = got[e][i] == sent[e][i].data;
    }
    check(fed && same[0] && same[1] && error.empty(),
          "every report of both interfaces, byte for byte, each in its order",
          std::to_string(got[0].size()) + "/" + std::to_string(sent[0].size()) + " IMU (0x20), " +
              std::to_string(got[1].size()) + "/" + std::to_string(sent[1].size()) +
              " light (0x25); " + std::to_string(out_of_order) +
              " delivered before an older report of the other interface" +
              (error.empty() ? "" : "; " + error));
}

void hid_lane() {
    UhidTracker tracker;
    std::string error;
    check(tracker.start(&error), "uhid device created (UHID_CREATE2)", error);
    if (!error.empty()) return;

    TransportBackendOptions options;
    options.udev_event_source = "kernel";  // no udevd in the guest
    auto backend = create_hidapi_backend(options);
    check(backend.ok(), "hidapi backend", backend.ok() ? "" : backend.error().message);
    if (!backend.ok()) return;

    std::unique_ptr<Transport> t = find_and_open(**backend, now_ns() + 5 * kNsPerSecond, &error);
    check(t != nullptr, "hidapi found and opened the tracker",
          t ? t->id().path + " " + format_vid_pid(t->id().vendor_id, t->id().product_id) +
                  " serial \"" + t->id().serial + "\""
            : error);
    if (!t) return;

    // Input reports through hidraw and the decoder.
    const int kReports = 500;
    int decoded = 0, gaps = 0, malformed = 0;
    uint32_t last = 0;
    const int64_t read_start = now_ns();
    for (int i = 0; i < kReports; ++i) {
        auto r = t->read_input(1000);
        if (!r.ok() || !r->has_value()) {
            error = r.ok() ? "timeout" : r.error().message;
            break;
        }
        auto p = refproto::decode_pose((*r)->bytes);
        if (!p.ok()) {
            ++malformed;
            continue;
        }
        if (decoded > 0 && p->sequence != last + 1) ++gaps;
        last = p->sequence;
        ++decoded;
    }
    const double rate = decoded / ns_to_s(now_ns() - read_start);
    check(decoded == kReports && gaps == 0 && malformed == 0,
          "input reports via hidraw, contiguous sequence",
          std::to_string(decoded) + " decoded, " + std::to_string(gaps) + " gaps, " +
              std::to_string(malformed) + " malformed, " + fmt("%.0f reports/s", rate) +
              (error.empty() ? "" : ", " + error));

    // Feature reports through hidraw: device info, then the time-sync exchange.
    auto info_bytes = t->get_feature(refproto::kDeviceInfoReport, refproto::kDeviceInfoReportSize);
    bool info_ok = false;
    std::string info_detail = info_bytes.ok() ? "" : info_bytes.error().message;
    if (info_bytes.ok()) {
        auto info = refproto::decode_device_info(*info_bytes);
        info_ok = info.ok() && info->serial == kSerial && info->pose_rate_hz == 1000;
        info_detail = info.ok() ? "serial " + info->serial + ", product \"" + info->product +
                                      "\", " + std::to_string(info->pose_rate_hz) + " Hz"
                                : info.error().message;
    }
    check(info_ok, "feature report 0x10 (device info) via hidraw", info_detail);

    refproto::TimeSyncReport ask;
    ask.nonce = 0xC0FFEE;
    ask.host_send_ns = now_ns();
    Status sent = t->set_feature(refproto::encode(ask));
    auto answer_bytes = t->get_feature(refproto::kTimeSyncReport, refproto::kTimeSyncReportSize);
    const int64_t received = now_ns();
    bool sync_ok = false;
    std::string sync_detail = !sent.ok()           ? sent.error().message
                              : !answer_bytes.ok() ? answer_bytes.error().message
                                                   : "";
    if (sent.ok() && answer_bytes.ok()) {
        auto answer = refproto::decode_time_sync(*answer_bytes);
        if (answer.ok()) {
            const refproto::TimeSyncEstimate e = refproto::time_sync_estimate(*answer, received);
            const int64_t truth = tracker.boot_ns() - kDeviceClockOffsetUs * 1000;
            const int64_t err = e.offset_ns - truth;
            sync_ok = answer->nonce == ask.nonce && std::llabs(err) <= e.round_trip_ns / 2 + 1000;
            sync_detail = fmt("offset error %.3f ms", ns_to_ms(err)) +
                          fmt(", round trip %.3f ms", ns_to_ms(e.round_trip_ns));
        } else {
            sync_detail = answer.error().message;
        }
    }
    check(sync_ok, "feature report 0x13 (time sync) set + get via hidraw", sync_detail);

    // Removal and re-creation mid-stream.
    auto monitor =
        (*backend)->watch(DeviceFilter{refproto::kDevVendorId, refproto::kDevProductId, ""});
    check(monitor.ok(), "hidraw hotplug monitor (kernel uevents)",
          monitor.ok() ? "" : monitor.error().message);
    tracker.request_recreate(300);
    const int64_t gone_deadline = now_ns() + 3 * kNsPerSecond;
    std::string gone_error;
    while (now_ns() < gone_deadline) {
        auto r = t->read_input(100);
        if (!r.ok()) {
            gone_error = r.error().message;
            break;
        }
    }
    check(!gone_error.empty(), "open transport fails when the device is destroyed", gone_error);
    t.reset();
    if (monitor.ok()) {
        bool left = false, arrived = false;
        std::string path;
        const int64_t deadline = now_ns() + 3 * kNsPerSecond;
        while (!arrived && now_ns() < deadline) {
            auto ev = (*monitor)->wait(200);
            if (!ev.ok()) break;
            if (!ev->has_value()) continue;
            if ((*ev)->kind == HotplugEvent::Kind::left) left = true;
            if ((*ev)->kind == HotplugEvent::Kind::arrived) {
                arrived = true;
                path = (*ev)->id.path + " " +
                       format_vid_pid((*ev)->id.vendor_id, (*ev)->id.product_id);
            }
        }
        check(arrived, "hotplug monitor saw the device come back",
              std::string(left ? "left + " : "") + (arrived ? "arrived " + path : "no arrival"));
    }
    error.clear();
    t = find_and_open(**backend, now_ns() + 3 * kNsPerSecond, &error);
    bool resumed = false;
    std::string resume_detail = error;
    if (t) {
        auto r = t->read_input(1000);
        if (r.ok() && r->has_value()) {
            auto p = refproto::decode_pose((*r)->bytes);
            const double after_ms = ns_to_ms((*r)->host_time_ns - tracker.created_ns());
            // note: the rebooted firmware restarts its sequence at 0; reports sent before
            // hidraw was reopened went nowhere, so the first one seen is a small number.
            resumed = p.ok() && p->sequence < 1000 && after_ms < 1000.0;
            resume_detail = fmt("first report %.1f ms after re-creation", after_ms) +
                            (p.ok() ? ", sequence " + std::to_string(p->sequence) : "");
        } else {
            resume_detail = r.ok() ? "timeout" : r.error().message;
        }
    }
    check(resumed, "tracking resumed after re-creation within a second", resume_detail);
    t.reset();
    replug_cycles(tracker, **backend);
    std::printf("uhid: %" PRIu64 " GET_REPORT and %" PRIu64 " SET_REPORT answered\n",
                tracker.get_reports(), tracker.set_reports());
}

void camera_lane() {
    V4l2CameraConfig cfg;
    cfg.device = "/dev/video0";
    cfg.width = 640;
    cfg.height = 480;
    cfg.fourcc = kFourccYuyv;
    auto cam = open_v4l2_camera(cfg);
    check(cam.ok(), "V4L2 open + QUERYCAP + S_FMT + REQBUFS (vivid)",
          cam.ok() ? std::to_string((*cam)->width()) + "x" + std::to_string((*cam)->height()) +
                         " " + fourcc_to_string((*cam)->fourcc())
                   : cam.error().message);
    if (!cam.ok()) return;
    Status s = (*cam)->start();
    check(s.ok(), "V4L2 STREAMON", s.ok() ? "" : s.error().message);
    if (!s.ok()) return;
    int frames = 0;
    bool ordered = true, sized = true, timed = true;
    uint64_t last_seq = 0;
    int64_t last_t = 0;
    std::string detail;
    for (int i = 0; i < 3; ++i) {
        auto f = (*cam)->next_frame(5000);
        if (!f.ok() || !f->has_value()) {
            detail = f.ok() ? "timeout" : f.error().message;
            break;
        }
        const CameraFrame& fr = **f;
        const int64_t now = now_ns();
        if (frames && (fr.sequence <= last_seq || fr.host_time_ns <= last_t)) ordered = false;
        if (fr.bytes.size() < size_t{fr.bytes_per_line} * fr.height) sized = false;
        // note: vivid stamps frames from its own frame schedule (start + sequence x period),
        // which under TCG runs up to a few hundred ms ahead of or behind the moment the frame
        // is dequeued; what is checked is the clock domain: CLOCK_MONOTONIC, within a second.
        if (std::llabs(fr.host_time_ns - now) > kNsPerSecond) timed = false;
        detail = "frame " + std::to_string(fr.sequence) + " " + std::to_string(fr.bytes.size()) +
                 " bytes, " + fmt("stamped %+.1f ms from dequeue", ns_to_ms(fr.host_time_ns - now));
        last_seq = fr.sequence;
        last_t = fr.host_time_ns;
        ++frames;
    }
    (*cam)->stop();
    check(frames == 3 && ordered && sized && timed,
          "3 frames from vivid, monotonic timestamps on the host clock",
          std::to_string(frames) + " frames; last " + detail);

    V4l2CameraConfig missing;
    missing.device = "/dev/video9";
    auto m = open_v4l2_camera(missing);
    check(!m.ok() && m.error().message.find("ENOENT") != std::string::npos,
          "missing /dev/video9 is a clear error", m.ok() ? "opened?" : m.error().message);
}

// The flips of one KMS run and what they showed.
struct FlipRun {
    int flips = 0;           // presents that flipped
    int missed_targets = 0;  // presents that missed the vsync they were meant for
    int vsyncs = 0;          // vsyncs from the first flip's to the last one's
    int readbacks = 0, readback_ok = 0;
    std::string readback_detail;
    bool monotonic = true;
    std::vector<double> intervals_ms;               // between consecutive flip events
    double commit_to_event_ms = 0, present_ms = 0;  // sums
};

// Flips whose scanned-out buffer is read back and compared: every 50th and the last.
bool is_check_flip(int i, int flips) {
    return i % 50 == 49 || i == flips - 1;
}

// Presents `flips` frames (frame(i) gives flip i's, null on failure with the reason in *error),
// each at the display's next free vsync; every 50th flip and the last read the scanned-out buffer
// back and compare it byte for byte with the frame written.
template <typename FrameFn>
FlipRun run_flips(KmsDisplay& disp, SystemClock& clock, int flips, FrameFn&& frame,
                  std::string* error) {
    FlipRun run;
    std::vector<int64_t> stamps;
    for (int i = 0; i < flips; ++i) {
        const StereoImage* f = frame(i, error);
        if (!f) return run;
        const int64_t before = clock.now_ns();
        auto r = disp.present(f, disp.free_vsync_ns(before));
        const int64_t after = clock.now_ns();
        if (!r.ok()) {
            *error = "page flip " + std::to_string(i) + ": " + r.error().message;
            return run;
        }
        ++run.flips;
        if (i > 0) {  // the event of the flip before (without vblank, see finish())
            const KmsFlip fl = disp.last_flip();
            run.commit_to_event_ms += ns_to_ms(fl.timestamp_ns - fl.commit_ns);
            stamps.push_back(fl.timestamp_ns);
        }
        run.present_ms += ns_to_ms(after - before);
        if (!r->on_time) ++run.missed_targets;
        if (is_check_flip(i, flips)) {
            ++run.readbacks;
            auto img = disp.read_scanout();
            if (!img.ok()) {
                run.readback_detail = img.error().message;
                continue;
            }
            const ImageRGBA8 want = side_by_side(*f);
            size_t diff = 0;
            if (img->width != want.width || img->height != want.height)
                diff = size_t(-1);
            else
                for (size_t k = 0; k < want.pixels.size(); ++k)
                    diff += img->pixels[k] != want.pixels[k];
            if (diff == 0) ++run.readback_ok;
            run.readback_detail = std::to_string(img->width) + "x" + std::to_string(img->height) +
                                  ", " + std::to_string(diff == size_t(-1) ? 0 : diff) +
                                  " differing bytes in the last";
        }
    }
    if (Status st = disp.finish(); st.ok()) stamps.push_back(disp.last_flip().timestamp_ns);
    for (size_t i = 1; i < stamps.size(); ++i) {
        if (stamps[i] <= stamps[i - 1]) run.monotonic = false;
        run.intervals_ms.push_back(ns_to_ms(stamps[i] - stamps[i - 1]));
    }
    if (stamps.size() > 1)
        run.vsyncs = 1 + int(std::lround(double(stamps.back() - stamps.front()) /
                                         double(disp.info().period_ns)));
    run.flips = int(stamps.size());
    return run;
}

// Checks a run's flips and read-backs and prints its pacing: the flip intervals, the presents
// that missed their target vsync, and the vsyncs between the first and the last flip that showed
// no new frame.
void report_flips(const char* what, int flips, const FlipRun& run, const DisplayInfo& info,
                  uint64_t sequence, const std::string& error) {
    check(error.empty() && run.flips == flips && run.monotonic,
          (std::string(what) + ": " + std::to_string(flips) + " page flips, event times monotonic")
              .c_str(),
          error.empty()
              ? std::to_string(run.flips) + " flips, last sequence " + std::to_string(sequence)
              : error);
    if (!error.empty()) return;
    double sum = 0, sum2 = 0;
    for (double dt : run.intervals_ms) {
        sum += dt;
        sum2 += dt * dt;
    }
    const double n = double(run.intervals_ms.size());
    const double mean = sum / n, sd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
    // note: bochs-display has no vblank interrupt: the kernel completes a flip at its commit, and
    // the display commits on its own timer at the mode's period. The pacing figures are reported,
    // not checked: a TCG guest on a loaded 2-core host is descheduled for tens of ms, so they
    // measure the host's load as much as the display (docs/hardware.md, "KMS output").
    std::printf(
        "[%7.3f s] info %s pacing at %.3f Hz (period %.3f ms): flip interval median "
        "%.3f ms, mean %.3f ms, sd %.3f ms, p99 %.3f ms; %d of %d presents missed their "
        "vsync; %d of %d vsyncs showed no new frame; commit to event %.3f ms, present() "
        "%.3f ms (means)\n",
        ns_to_s(now_ns() - g_t0), what, info.refresh_hz, ns_to_ms(info.period_ns),
        percentile(run.intervals_ms, 0.5), mean, sd, percentile(run.intervals_ms, 0.99),
        run.missed_targets, flips, std::max(0, run.vsyncs - run.flips), run.vsyncs,
        run.commit_to_event_ms / flips, run.present_ms / flips);
    check(run.readbacks > 0 && run.readback_ok == run.readbacks,
          (std::string(what) + ": scanned-out buffer read back (GETFB2 + map) equals the frame")
              .c_str(),
          std::to_string(run.readback_ok) + "/" + std::to_string(run.readbacks) + " equal; " +
              run.readback_detail);
}

// 5, 6 and 7. KMS output on bochs-display with the real renderer's frames: the demo room (every
// object at its coarsest LOD level) loaded from the host's filesystem (the read-only 9p share the
// guest runs in) and rendered by the default backend (Vulkan on lavapipe; HMDNODE_RENDERER=gles:
// GLES on llvmpipe) at the display's eye size, the head turning so that every frame differs.
// Under TCG a frame takes about half a second to render (docs/hardware.md), so the 300 flips
// cycle kPrepared frames rendered first, and then kLive frames are each rendered and flipped at
// the next free vsync, as the daemon does. Every run reads the scanned-out buffer back and
// compares it with the renderer's frame. The dumb-buffer copy runs first (5, 6), then the
// zero-copy GBM path on the same display (7).
constexpr int kPrepared = 4, kFlips = 300, kLive = 10;

// The live frames of a run: `dflt`, or HMDNODE_KERNEL_LANE_LIVE_FLIPS (1..10000; run.sh sets 300
// under KVM, where the target "0 missed vsyncs over 300 flips" is checked).
int live_flips(int dflt) {
    const char* v = std::getenv("HMDNODE_KERNEL_LANE_LIVE_FLIPS");
    const int n = v ? std::atoi(v) : 0;
    return n > 0 && n <= 10000 ? n : dflt;
}

// The demo room at its coarsest levels, uploaded; the head turning so that every frame differs.
struct LaneScene {
    std::vector<DrawItem> items;
    uint64_t triangles = 0;
    std::vector<double> render_ms;

    Status upload(Renderer& r, const Scene& scene) {
        const int64_t t = now_ns();
        Status up = r.upload(scene);
        items.clear();
        triangles = 0;
        for (const SceneObject& o : flatten_objects(scene)) {
            items.push_back(DrawItem{o.levels.back().mesh, glm::mat4(o.world)});
            triangles += o.levels.back().triangles;
        }
        check(up.ok(), (std::string("demo room uploaded (") + r.backend_name() + ")").c_str(),
              up.ok() ? std::to_string(items.size()) + " objects at their coarsest level, " +
                            std::to_string(triangles) + " triangles" +
                            fmt(", %.2f s", ns_to_s(now_ns() - t))
                      : up.error().message);
        return up;
    }

    bool render(Renderer& r, int i, StereoImage* out, std::string* error) {
        Pose head;
        head.position = {0.0, 1.6, 0.0};
        head.orientation = glm::angleAxis(0.2 * kPi * std::sin(i * 0.05), glm::dvec3(0, 1, 0));
        const StereoRig rig = StereoRig::typical();
        StereoViews views;
        for (int e = 0; e < 2; ++e) {
            views.view[e] = eye_view_matrix(rig, head, e);
            views.projection[e] = eye_projection(rig.eye[e], rig.near_m, rig.far_m);
        }
        const int64_t t0 = now_ns();
        auto stats = r.render(views, items, out);
        render_ms.push_back(ns_to_ms(now_ns() - t0));
        if (!stats.ok()) *error = "render " + std::to_string(i) + ": " + stats.error().message;
        return stats.ok();
    }
};

Result<std::unique_ptr<Renderer>> make_lane_renderer(const RendererConfig& rc, const char* what) {
    const int64_t t = now_ns();
    auto renderer = create_renderer(rc);
    check(renderer.ok(), what,
          renderer.ok() ? std::string((*renderer)->backend_name()) + ", " +
                              (*renderer)->device_name() + fmt(", %.2f s", ns_to_s(now_ns() - t))
                        : renderer.error().message);
    return renderer;
}

// 5 and 6: the dumb-buffer copy of a renderer's frames (read back, converted into the display's
// dumb buffers): kPrepared frames cycled over kFlips flips, then `lives` frames each rendered and
// flipped.
void dumb_run(KmsDisplay& disp, SystemClock& clock, Renderer& r, LaneScene& ls, int lives) {
    const DisplayInfo info = disp.info();
    std::string error;
    std::vector<StereoImage> frames(kPrepared);
    for (int i = 0; i < kPrepared && error.empty(); ++i)
        ls.render(r, i, &frames[size_t(i)], &error);
    const std::vector<double>& render_ms = ls.render_ms;
    check(
        error.empty(), "renderer frames rendered",
        error.empty()
            ? std::to_string(kPrepared) + " frames of " + std::to_string(info.eye_width) + "x" +
                  std::to_string(info.eye_height) + " per eye, the first in" +
                  fmt(" %.0f ms (shader compilation),", render_ms.front()) +
                  fmt(" the others %.0f ms median",
                      percentile(std::vector<double>(render_ms.begin() + 1, render_ms.end()), 0.5))
            : error);
    if (!error.empty()) return;
    const FlipRun run = run_flips(
        disp, clock, kFlips,
        [&](int i, std::string*) { return &frames[size_t(i) % frames.size()]; }, &error);
    const std::string what = std::string("KMS dumb-buffer copy of ") + r.backend_name() + " frames";
    report_flips(what.c_str(), kFlips, run, info, disp.last_flip().sequence, error);
    if (!error.empty() || lives == 0) return;

    ls.render_ms.clear();
    StereoImage live;
    const FlipRun live_run = run_flips(
        disp, clock, lives,
        [&](int i, std::string* e) {
            return ls.render(r, kPrepared + i, &live, e) ? &live : nullptr;
        },
        &error);
    std::printf(
        "[%7.3f s] info live: each frame rendered then flipped: render + read-back median "
        "%.1f ms, max %.1f ms, against the %.3f ms period\n",
        ns_to_s(now_ns() - g_t0), percentile(ls.render_ms, 0.5), percentile(ls.render_ms, 1.0),
        ns_to_ms(info.period_ns));
    report_flips("KMS live renderer", lives, live_run, info, disp.last_flip().sequence, error);
}

// 7: zero-copy scan-out. The GLES renderer runs on EGL's GBM platform on the display's own DRM
// file with its ring of buffer objects; the display makes them framebuffers once and each flip
// shows a buffer the late warp drew, with no copy. A warp of the demo room costs about half a
// second under TCG (llvmpipe, docs/hardware.md), so, as the dumb-buffer run cycles prepared frames,
// the warp first draws each of the ring's buffers once (through the ring: warp, flip), those are
// cycled over the kFlips flips, and then kGbmLive frames are each rendered, warped into the ring's
// next free buffer and flipped. On every check flip the scanned-out framebuffer, read back through
// the kernel (GETFB2 + map), must equal the frame the warp drew, read back from GL.
constexpr int kGbmLive = 6;

// The display's buffer source during the run: the renderer's ring, or (cycling) a buffer the lane
// names.
struct LaneBufferSource {
    Renderer* renderer = nullptr;
    int cycled = -1;  // >= 0: flip this buffer, the ring untouched
    KmsBufferSource source() {
        return KmsBufferSource{[this] { return cycled >= 0 ? cycled : renderer->scanout_drawn(); },
                               [this](int b) {
                                   if (cycled < 0) renderer->scanout_committed(b);
                               }};
    }
};

void gbm_run(KmsDisplay& disp, SystemClock& clock, Renderer& r, LaneScene& ls) {
    const DisplayInfo info = disp.info();
    std::printf("[%7.3f s] info scan-out ring: %s\n", ns_to_s(now_ns() - g_t0),
                r.scanout_describe().c_str());
    const HeadsetProfile headset = generic_headset_profile();
    LaneBufferSource src;
    src.renderer = &r;
    Status st =
        r.set_warp(info.eye_width, info.eye_height, make_distortion_mesh(headset, 0, 16, 16),
                   make_distortion_mesh(headset, 1, 16, 16));
    if (st.ok()) st = disp.attach_buffers(r.scanout_buffers(), src.source());
    check(st.ok(), "GBM buffer objects attached as framebuffers (ADDFB2), warp set up",
          st.ok() ? disp.scanout_path() : st.error().message);
    if (!st.ok()) return;

    std::vector<double> warp_ms;
    auto warp = [&](int i, StereoImage* out, std::string* e) {
        const glm::dquat delta = glm::angleAxis(0.05 * std::sin(i * 0.3), glm::dvec3(0, 1, 0));
        const int64_t t0 = now_ns();
        auto w = r.warp(delta, out);
        warp_ms.push_back(ns_to_ms(now_ns() - t0));
        if (!w.ok()) *e = "warp " + std::to_string(i) + ": " + w.error().message;
        return w.ok();
    };
    // Each ring buffer drawn once by the warp and flipped through the ring; its frame read back
    // from GL.
    const int n = int(r.scanout_buffers().size());
    std::vector<StereoImage> drawn(static_cast<size_t>(n));
    std::string error;
    const FlipRun prep = run_flips(
        disp, clock, n,
        [&](int i, std::string* e) -> const StereoImage* {
            if (!warp(i, &drawn[size_t(i)], e)) return nullptr;
            if (r.scanout_drawn() != i) *e = "the ring's buffers were not drawn in turn";
            return e->empty() ? &drawn[size_t(i)] : nullptr;
        },
        &error);
    check(error.empty() && prep.flips == n, "the warp drew each GBM buffer of the ring once",
          error.empty() ? fmt("warp into a buffer object %.0f ms median", percentile(warp_ms, 0.5))
                        : error);
    if (!error.empty()) return;
    // The kFlips flips cycle the drawn buffers, ending on the two the ring holds as shown and
    // queued (n - 2, n - 1), so the ring is right again for the live frames.
    const int offset = (n - kFlips % n) % n;
    const FlipRun run = run_flips(
        disp, clock, kFlips,
        [&](int i, std::string*) {
            src.cycled = (i + offset) % n;
            return &drawn[size_t(src.cycled)];
        },
        &error);
    src.cycled = -1;
    report_flips("KMS GBM zero-copy (warp output)", kFlips, run, info, disp.last_flip().sequence,
                 error);
    if (!error.empty()) return;

    ls.render_ms.clear();
    warp_ms.clear();
    StereoImage live;
    const int lives = live_flips(kGbmLive);
    const FlipRun live_run = run_flips(
        disp, clock, lives,
        [&](int i, std::string* e) -> const StereoImage* {
            if (!ls.render(r, 1 + i, nullptr, e) || !warp(n + i, &live, e)) return nullptr;
            return &live;
        },
        &error);
    std::printf(
        "[%7.3f s] info GBM live: each frame rendered, warped into the ring's next buffer and "
        "flipped: render median %.1f ms, warp median %.1f ms, against the %.3f ms period\n",
        ns_to_s(now_ns() - g_t0), percentile(ls.render_ms, 0.5), percentile(warp_ms, 0.5),
        ns_to_ms(info.period_ns));
    report_flips("KMS GBM live (render, warp, flip)", lives, live_run, info,
                 disp.last_flip().sequence, error);
}

// 8. The latency marker through a real V4L2 driver (issue 36, docs/latency.md, "The kernel lane's
// loopback"): the GLES renderer's warp draws the panel with the latency marker for kLoopIds
// consecutive ids (the renderer's set_latency_marker, as the observed replay does; each panel
// checked against the unmarked warp with draw_latency_marker applied, the CPU reference), each
// panel goes as YUYV into vivid's HDMI output (/dev/video1), and vivid's loopback returns it on
// its HDMI input (/dev/video0, input 1), captured on the driver's own schedule by a thread of its
// own. Each captured frame is decoded afterwards with the project's marker decoder (on its luma,
// as the camera observer does). Checked: every decoded payload is one presented (none invented),
// the ids never go back, no frame between the first and the last decoded marker fails to decode,
// at least two ids came through, each decoded frame is the one written with its id byte for byte,
// and the output returned every frame but its last shown, in order. Printed: ids seen, repeats,
// skips, capture drops and the stamps' offsets -- not checked: vivid's capture and output run on
// their own schedules and, under TCG, its stamps can be hundreds of ms off. A marked warp costs
// 0.3-0.8 s under TCG (llvmpipe): 20 ids keep the step to about 10-15 s.
constexpr int kLoopIds = 20;
// The HDMI link's frame: the smallest standard DV timing vivid offers at 4:3 (640x480p59.94);
// the panel (both eyes side by side) sits at its centre on black.
constexpr uint32_t kLoopWidth = 640, kLoopHeight = 480;
constexpr int kLoopMaxCaptures = 240;  // bound on the capture frames kept (4 s at 60 Hz)
constexpr int kLoopCellPx = 4;         // marker cells of 4 panel pixels

// The capture thread: every frame of the HDMI input until told to stop or the bound.
struct LoopCapture {
    std::vector<CameraFrame> frames;
    std::string error;  // read after the thread ends; `failed` says so before
    std::atomic<bool> stop{false}, failed{false};
    std::atomic<int> count{0};
    void run(Camera& cam) {
        while (!stop && int(frames.size()) < kLoopMaxCaptures) {
            auto f = cam.next_frame(200);
            if (!f.ok()) {
                error = f.error().message;
                failed = true;
                return;
            }
            if (!f->has_value()) continue;
            frames.push_back(std::move(**f));
            ++count;
        }
    }
};

// Waits until `pred` holds or `timeout_ms` passes, polling every ms.
template <typename Pred>
bool loop_wait_for(Pred&& pred, int timeout_ms) {
    const int64_t until = now_ns() + int64_t(timeout_ms) * kNsPerMs;
    while (!pred()) {
        if (now_ns() > until) return false;
        usleep(1000);
    }
    return true;
}

// The marked panels as YUYV frames of the link, each checked against the CPU reference.
bool loop_panels(Renderer& r, const DisplayInfo& info, std::vector<std::vector<uint8_t>>* frames,
                 std::vector<LatencyMarkerPayload>* payloads) {
    LatencyMarkerOverlay o =
        default_latency_marker_overlay(info.eye_width, info.eye_height, kLoopCellPx);
    const glm::dquat still(1, 0, 0, 0);
    std::string error;
    std::vector<double> warp_ms, readback_ms;
    StereoImage plain, marked;
    r.set_latency_marker(nullptr);
    auto first = r.warp(still, &plain);
    if (!first.ok()) error = "unmarked warp: " + first.error().message;
    int equal = 0;
    const uint32_t x0 = (kLoopWidth - 2 * uint32_t(info.eye_width)) / 2 & ~1u;
    const uint32_t y0 = (kLoopHeight - uint32_t(info.eye_height)) / 2;
    for (int k = 0; k < kLoopIds && error.empty(); ++k) {
        o.payload = make_latency_marker_payload(now_ns(), uint64_t(k));
        r.set_latency_marker(&o);
        const int64_t t0 = now_ns();
        auto w = r.warp(still, &marked);
        warp_ms.push_back(ns_to_ms(now_ns() - t0));
        if (!w.ok()) {
            error = "marked warp " + std::to_string(k) + ": " + w.error().message;
            break;
        }
        readback_ms.push_back(ns_to_ms(w->readback_ns));
        bool same = true;
        for (int e = 0; e < 2; ++e) {
            ImageRGBA8 want = plain.eye[e];
            draw_latency_marker(want, o.payload, o.x, o.y, o.cell_px);
            same = same && want.pixels == marked.eye[e].pixels;
        }
        equal += same;
        payloads->push_back(o.payload);
        std::vector<uint8_t> frame(size_t(kLoopWidth) * 2 * kLoopHeight);
        const YuyvFrameView view{frame, kLoopWidth, kLoopHeight, kLoopWidth * 2};
        fill_yuyv_black(view);
        write_rgba_to_yuyv(side_by_side(marked), int(x0), int(y0), view);
        frames->push_back(std::move(frame));
    }
    r.set_latency_marker(nullptr);
    check(error.empty() && equal == kLoopIds,
          "GLES warp panels with the latency marker equal the CPU reference",
          error.empty()
              ? std::to_string(equal) + "/" + std::to_string(kLoopIds) + " panels of ids 0.." +
                    std::to_string(kLoopIds - 1) + fmt(" (cell %.0f px)", kLoopCellPx) +
                    fmt(", warp median %.0f ms", percentile(warp_ms, 0.5)) +
                    fmt(" (read-back %.0f ms)", percentile(readback_ms, 0.5))
              : error);
    return error.empty() && equal == kLoopIds;
}

// The loopback's output and capture devices, configured for the link.
bool loop_devices(std::unique_ptr<VideoOutput>* out, std::unique_ptr<Camera>* cam) {
    V4l2OutputConfig oc;
    oc.device = "/dev/video1";
    oc.width = kLoopWidth;
    oc.height = kLoopHeight;
    oc.fourcc = kFourccYuyv;
    oc.buffers = 32;  // half a second of frames queued: the writer never lets the output run dry
    oc.dv_timings = true;
    auto o = open_v4l2_output(oc);
    check(o.ok(), "V4L2 output open + S_DV_TIMINGS + S_FMT + REQBUFS (vivid HDMI output)",
          o.ok() ? (*o)->name() + " " + std::to_string((*o)->width()) + "x" +
                       std::to_string((*o)->height()) + " " + fourcc_to_string((*o)->fourcc()) +
                       ", " + std::to_string((*o)->buffers()) + " buffers"
                 : o.error().message);
    V4l2OutputConfig not_output = oc;
    not_output.device = "/dev/video0";
    auto n = open_v4l2_output(not_output);
    check(!n.ok() && n.error().message.find("is not a video output device") != std::string::npos,
          "a capture device opened as an output is a clear error",
          n.ok() ? "opened?" : n.error().message);
    V4l2CameraConfig cc;
    cc.device = "/dev/video0";
    cc.width = kLoopWidth;
    cc.height = kLoopHeight;
    cc.fourcc = kFourccYuyv;
    cc.buffers = 16;
    cc.input = 1;  // vivid's HDMI input (input 0 is the webcam the camera check streams)
    cc.controls = {{"Loop Video", 1}, {"OSD Text Mode", 2}};  // loop back; no text drawn over it
    cc.dv_timings = true;
    auto c = open_v4l2_camera(cc);
    check(c.ok(),
          "V4L2 capture of the HDMI input (S_INPUT 1, Loop Video, S_DV_TIMINGS, S_FMT, REQBUFS)",
          c.ok() ? (*c)->name() + " " + std::to_string((*c)->width()) + "x" +
                       std::to_string((*c)->height()) + " " + fourcc_to_string((*c)->fourcc())
                 : c.error().message);
    if (!o.ok() || !c.ok()) return false;
    *out = std::move(*o);
    *cam = std::move(*c);
    return true;
}

// Writes every panel and waits until the output has shown all but the last (vivid keeps its
// newest output frame until the next comes: it stays on the link) and the capture has taken
// kLoopAfter frames more, which see the last panel.
constexpr int kLoopAfter = 5;
std::string loop_stream(VideoOutput& out, const std::vector<std::vector<uint8_t>>& frames,
                        LoopCapture& cap) {
    if (Status s = out.start(); !s.ok()) return s.error().message;
    for (int k = 0; k < kLoopIds; ++k) {
        auto w = out.write(frames[size_t(k)], uint64_t(k), 3000);
        if (!w.ok()) return "write " + std::to_string(k) + ": " + w.error().message;
        if (!*w) return "write " + std::to_string(k) + ": no output buffer came back within 3 s";
        if (cap.failed) return "the capture failed";
    }
    auto d = out.wait_in_flight(1, 5000);
    if (!d.ok()) return "output: " + d.error().message;
    if (!*d) return "the output did not show all but its last frame within 5 s";
    const int seen = cap.count;
    if (!loop_wait_for([&] { return cap.count >= seen + kLoopAfter || cap.failed; }, 3000))
        return "the capture took no frames after the output's last";
    return cap.failed ? "the capture failed" : "";
}

void loop_report(const std::vector<CameraFrame>& frames,
                 const std::vector<std::vector<uint8_t>>& written,
                 const std::vector<LatencyMarkerPayload>& payloads,
                 const std::vector<ShownFrame>& shown) {
    // Per frame: the id decoded, -1 undecoded, -2 a payload never presented.
    std::vector<int> ids(frames.size(), -1);
    std::vector<std::string> reasons(frames.size());
    std::vector<uint8_t> luma;
    int invented = 0, decoded = 0, exact = 0;
    std::string invented_detail;
    for (size_t i = 0; i < frames.size(); ++i) {
        const CameraFrame& f = frames[i];
        if (f.fourcc != kFourccYuyv || f.bytes.size() < size_t(f.bytes_per_line) * f.height ||
            f.bytes_per_line < 2 * f.width) {
            reasons[i] = "not a whole YUYV frame";
            continue;
        }
        luma.resize(size_t(f.width) * f.height);  // Y0 U Y1 V: every other byte, as the observer
        for (uint32_t y = 0; y < f.height; ++y)
            for (uint32_t x = 0; x < f.width; ++x)
                luma[size_t(y) * f.width + x] = f.bytes[size_t(y) * f.bytes_per_line + 2 * x];
        const LatencyMarkerDecode d =
            decode_latency_marker(luma.data(), int(f.width), int(f.height), int(f.width));
        if (!d.ok) {
            reasons[i] = d.reason;
            continue;
        }
        const int id = d.payload.present_sequence;
        if (id >= int(payloads.size()) || payloads[size_t(id)] != d.payload) {
            ids[i] = -2;
            if (invented++ == 0)
                invented_detail = "frame " + std::to_string(f.sequence) + " decoded sequence " +
                                  std::to_string(id) + ", sample " +
                                  std::to_string(d.payload.sample_time_us) + " us";
            continue;
        }
        ids[i] = id;
        // vivid copies the output's lines unscaled: the frame is the one written, byte for byte.
        exact += f.bytes == written[size_t(id)];
        ++decoded;
    }
    int first = -1, last = -1;
    for (size_t i = 0; i < ids.size(); ++i)
        if (ids[i] >= 0) {
            if (first < 0) first = int(i);
            last = int(i);
        }
    int undecoded_between = 0, back_steps = 0, repeats = 0, distinct = 0;
    std::string between_detail;
    std::vector<bool> seen(payloads.size(), false);
    int prev = -1;
    for (int i = std::max(first, 0); first >= 0 && i <= last; ++i) {
        if (ids[size_t(i)] == -1 && undecoded_between++ == 0)
            between_detail =
                "frame " + std::to_string(frames[size_t(i)].sequence) + ": " + reasons[size_t(i)];
        if (ids[size_t(i)] < 0) continue;
        const int id = ids[size_t(i)];
        if (prev >= 0 && id < prev) ++back_steps;
        if (id == prev) ++repeats;
        if (!seen[size_t(id)]) ++distinct;
        seen[size_t(id)] = true;
        prev = id;
    }
    const int first_id = first >= 0 ? ids[size_t(first)] : -1;
    const int last_id = last >= 0 ? ids[size_t(last)] : -1;
    int skipped = 0;
    for (int id = first_id; first_id >= 0 && id <= last_id; ++id) skipped += !seen[size_t(id)];
    uint64_t drops = 0;
    for (size_t i = 1; i < frames.size(); ++i)
        if (frames[i].sequence > frames[i - 1].sequence + 1)
            drops += frames[i].sequence - frames[i - 1].sequence - 1;
    // The capture's stamp minus the output's stamp, for the first capture of each id.
    std::vector<double> offsets_ms;
    bool driver_stamps = !shown.empty();
    std::vector<bool> counted(payloads.size(), false);
    for (size_t i = 0; i < ids.size(); ++i) {
        if (ids[i] < 0 || counted[size_t(ids[i])]) continue;
        counted[size_t(ids[i])] = true;
        for (const ShownFrame& s : shown)
            if (s.tag == uint64_t(ids[i])) {
                offsets_ms.push_back(ns_to_ms(frames[i].host_time_ns - s.host_time_ns));
                driver_stamps = driver_stamps && s.driver_stamp;
                break;
            }
    }
    std::string detail = std::to_string(last >= 0 ? last - first + 1 : 0) +
                         " frames from the first decoded marker to the last, " +
                         std::to_string(distinct) + " distinct ids";
    if (invented) detail += "; " + std::to_string(invented) + " invented: " + invented_detail;
    if (back_steps) detail += "; the id went back " + std::to_string(back_steps) + " times";
    if (undecoded_between)
        detail +=
            "; " + std::to_string(undecoded_between) + " undecoded between: " + between_detail;
    if (first < 0)
        detail += "; nothing decoded (first frame: " +
                  (reasons.empty() ? std::string("no frames") : reasons[0]) + ")";
    check(invented == 0 && back_steps == 0 && undecoded_between == 0 && distinct >= 2,
          "vivid loopback: decoded marker ids were presented, in order, none undecoded between",
          detail);
    check(decoded > 0 && exact == decoded,
          "vivid loopback: each decoded frame is the frame written with its id, byte for byte",
          std::to_string(exact) + " of " + std::to_string(decoded) + " decoded frames equal");
    std::printf(
        "[%7.3f s] info vivid loopback counts: %d of %d ids seen (first %d, last %d); %d repeats, "
        "%d skipped between, %d missed before the first and %d after the last; %" PRIu64
        " capture frames dropped (sequence gaps) of %zu captured, %d undecoded before the first "
        "marker and %d after the last; capture stamp - output stamp of the same id median %.1f "
        "ms, range %.1f..%.1f ms (%s; vivid's own schedules: not checked)\n",
        ns_to_s(now_ns() - g_t0), distinct, kLoopIds, first_id, last_id, repeats, skipped,
        std::max(first_id, 0), last_id >= 0 ? kLoopIds - 1 - last_id : kLoopIds, drops,
        frames.size(), std::max(first, 0),
        last >= 0 ? int(frames.size()) - 1 - last : int(frames.size()), percentile(offsets_ms, 0.5),
        percentile(offsets_ms, 0.0), percentile(offsets_ms, 1.0),
        driver_stamps ? "both the driver's stamps" : "output stamps at dequeue");
    std::fflush(stdout);
}

void loopback_run(Renderer& r, const DisplayInfo& info) {
    std::vector<std::vector<uint8_t>> frames;
    std::vector<LatencyMarkerPayload> payloads;
    if (!loop_panels(r, info, &frames, &payloads)) return;
    std::unique_ptr<VideoOutput> out;
    std::unique_ptr<Camera> cam;
    if (!loop_devices(&out, &cam)) return;
    if (Status s = cam->start(); !s.ok()) {
        check(false, "V4L2 STREAMON (HDMI input)", s.error().message);
        return;
    }
    LoopCapture cap;
    std::thread capture([&] { cap.run(*cam); });
    const int64_t t0 = now_ns();
    std::string error = loop_stream(*out, frames, cap);
    cap.stop = true;
    capture.join();
    if (!cap.error.empty()) error += (error.empty() ? "capture: " : "; capture: ") + cap.error;
    cam->stop();
    out->stop();
    const double stream_s = ns_to_s(now_ns() - t0);
    // The output's own account: every frame but the last it keeps, shown in the order written.
    const std::vector<ShownFrame> shown = out->take_shown();
    bool in_order = shown.size() + 1 >= size_t(kLoopIds);
    for (size_t i = 0; i < shown.size(); ++i) in_order = in_order && shown[i].tag == i;
    if (error.empty() && !in_order)
        error = "the output returned " + std::to_string(shown.size()) +
                " frames shown, not ids 0.." + std::to_string(kLoopIds - 2) + " in order";
    check(error.empty(), "vivid loopback: panels written to the HDMI output, its input captured",
          error.empty()
              ? std::to_string(kLoopIds) + " output frames (" + std::to_string(shown.size()) +
                    " returned shown, in the order written), " + std::to_string(cap.frames.size()) +
                    " captured" + fmt(", %.1f s", stream_s)
              : error);
    if (!error.empty()) return;
    loop_report(cap.frames, frames, payloads, shown);
}

// `hmdnode latency --display kms` as a rig runs it (docs/latency.md, "A real rig"): the node
// itself (run_replay, the one assembly place) on bochs-display's connector, on the real clock,
// with the latency marker on and the GLES renderer scanning out zero-copy, under 30 deg step
// flicks for one second. Checks that it presents on the KMS panel at the panel's own mode and
// that every present carries the marker row's photon time, after the pose sample that shaped it.
void node_on_kms(const char* scene_path) {
    Result<Trace> motion = make_motion_profile("step", 1.0);
    if (!motion.ok()) return check(false, "the step profile", motion.error().message);
    ReplayOptions o;
    o.scene = scene_path;
    o.trace_data = std::make_shared<const Trace>(std::move(motion).value());
    o.trace = "step";
    o.simulated_clock = false;
    o.duration_s = 1.0;
    o.display_type = "kms";
    o.real_display.latch_margin_ns = 4'000'000;  // as the lane's own KMS runs (kms_lane)
    o.renderer.backend = "gles";
    o.node.latency_marker_cell_px = 4;
    // note: a fixed distortion mesh and the fused pass: the start-up calibration times every pass
    // it may choose with 15 warps each, at 0.3-0.8 s a warp under TCG; the choice proves nothing
    // here.
    o.node.mesh_cols = o.node.mesh_rows = 16;
    o.node.lens_pass = LensPassChoice::fused;  // and one pass to calibrate at start-up, not two
    const int64_t t0 = now_ns();
    Result<ReplayResult> r = run_replay(o);
    if (!r.ok())
        return check(false, "the node on the KMS panel (latency --display kms)", r.error().message);
    size_t marked = 0;
    for (const FrameRecord& f : r->frames)
        if (f.marker_photon_time_ns > f.pose_sample_time_ns && f.pose_sample_time_ns > 0) ++marked;
    check(!r->frames.empty() && marked == r->frames.size() && r->display.eye_width > 0,
          "the node on the KMS panel (latency --display kms): presents at the panel's mode, each "
          "with the marker row's photon time after its sample",
          r->display.name + " " + std::to_string(r->display.eye_width) + "x" +
              std::to_string(r->display.eye_height) + " per eye" +
              fmt(" at %.2f Hz, ", r->display.refresh_hz) + std::to_string(r->frames.size()) +
              " presents (" + std::to_string(marked) + " marked), " +
              std::to_string(r->summary.missed_vsyncs) + " of " +
              std::to_string(r->summary.vsyncs) + " vsyncs missed, renderer " +
              r->renderer_backend + fmt(", %.1f s", ns_to_s(now_ns() - t0)));
}

void kms_lane(const char* scene_path, const std::string& runs) {
    for (int i = 0; i < 100 && access("/dev/dri/card0", F_OK) != 0; ++i) usleep(50'000);
    auto conns = list_kms_connectors();
    std::string listing;
    if (conns.ok())
        for (const KmsConnectorInfo& c : *conns) {
            listing += c.device + " " + c.name + " " + c.connection;
            if (c.edid) {
                char id[32];
                std::snprintf(id, sizeof id, " edid %s:%04X", c.edid->vendor.c_str(),
                              c.edid->product);
                listing += id;
            }
            char modes[96];
            if (c.modes.empty())
                std::snprintf(modes, sizeof modes, " no modes");
            else
                std::snprintf(modes, sizeof modes, " %zu modes, first %dx%d@%.2f Hz",
                              c.modes.size(), c.modes[0].width, c.modes[0].height,
                              c.modes[0].refresh_hz);
            listing += modes;
            listing += "; ";
        }
    check(conns.ok() && !conns->empty(), "KMS connectors listed (bochs-display)",
          conns.ok() ? listing : conns.error().message);
    SystemClock clock;
    KmsDisplayConfig cfg;
    // note: without a vblank interrupt the latch point is the display's commit timer; a TCG guest
    // on a loaded host wakes up to a few ms late, so it commits this early.
    cfg.latch_margin_ns = 4'000'000;
    auto d = create_kms_display(clock, cfg);
    check(d.ok(), "KMS open + DRM master + modeset",
          d.ok() ? (*d)->connector_name() + " " + std::to_string((*d)->mode().width) + "x" +
                       std::to_string((*d)->mode().height) +
                       fmt("@%.3f Hz, ", (*d)->mode().refresh_hz) + (*d)->modeset_path() +
                       ((*d)->hardware_vblank() ? ", hardware vblank"
                                                : ", no vblank interrupt: display-timed flips")
                 : d.error().message);
    if (!d.ok()) return;
    KmsDisplay& disp = **d;

    const int64_t t = now_ns();
    Result<Scene> scene = load_gltf(scene_path);
    check(scene.ok(), "demo room loaded from the host's filesystem (9p)",
          scene.ok() ? std::string(scene_path) + fmt(", %.2f s", ns_to_s(now_ns() - t))
                     : scene.error().message);
    if (!scene.ok()) return;
    const DisplayInfo info = disp.info();
    RendererConfig rc;
    rc.eye_width = info.eye_width;
    rc.eye_height = info.eye_height;
    if (runs != "gles") {  // the Vulkan renderer's frames through the dumb-buffer copy
        rc.backend = "vulkan";
        auto renderer = make_lane_renderer(rc, "Vulkan renderer created in the guest");
        LaneScene ls;
        if (renderer.ok() && ls.upload(**renderer, *scene).ok())
            dumb_run(disp, clock, **renderer, ls, live_flips(kLive));
    }
    if (runs == "vulkan") return;
    // One GLES renderer on GBM: its read-back frames through the dumb-buffer copy, then zero-copy.
    rc.backend = "gles";
    rc.scanout = disp.scanout_target();
    auto renderer =
        make_lane_renderer(rc, "GLES renderer on EGL's GBM platform (Mesa from the host)");
    if (!renderer.ok()) return;
    LaneScene ls;
    if (!ls.upload(**renderer, *scene).ok()) return;
    dumb_run(disp, clock, **renderer, ls, 0);
    gbm_run(disp, clock, **renderer, ls);
    loopback_run(**renderer, info);
    // The connector is the node's now: the lane's renderer and display let it go first.
    renderer->reset();
    d->reset();
    node_on_kms(scene_path);
}

}  // namespace
}  // namespace hmdnode

int main(int argc, char** argv) {
    using namespace hmdnode;
    g_t0 = now_ns();
    const std::string runs = argc == 3 ? argv[2] : "gles";
    if ((argc != 2 && argc != 3) || (runs != "gles" && runs != "vulkan" && runs != "both")) {
        std::fprintf(stderr,
                     "usage: hmdnode_kernel_lane DEMO_SCENE.glb [gles|vulkan|both] (run in the "
                     "guest)\n");
        return 2;
    }
    std::printf(
        "hmdnode kernel lane: uhid -> hidraw -> hidapi, vivid -> V4L2, bochs-display -> "
        "KMS, the renderer -> KMS, the renderer -> V4L2 output -> vivid loopback -> V4L2\n");
    hid_lane();
    interface_group_lane();
    camera_lane();
    kms_lane(argv[1], runs);
    std::printf("HMDNODE_KERNEL_LANE: %s (%d failed, %.2f s)\n", g_failures ? "FAIL" : "PASS",
                g_failures, ns_to_s(now_ns() - g_t0));
    std::fflush(stdout);
    return g_failures ? 1 : 0;
}
