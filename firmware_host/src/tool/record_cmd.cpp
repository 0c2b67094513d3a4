// `hmdnode record`: read a tracker through a transport backend (hidapi, libusb, or the simulated
// reference tracker) and write what it said: our trace CSV (docs/trace-format.md) from the
// decoded reports, and the raw reports as a pcap with the Linux usbmon link type
// DLT_USB_LINUX_MMAPPED (220), which Wireshark, tshark and `hmdnode replay --capture` read.
// Formats and limits: docs/hardware.md.
//
// The pcap is written by hand (pcap file format 2.4, 64-byte usbmon headers, host byte order):
// it opens with a synthetic GET_DESCRIPTOR(DEVICE) exchange so readers learn the VID:PID from the
// capture itself, then the device-info GET_REPORT exchange when the device answered one, then one
// interrupt-IN completion ('C', endpoint 0x81) per input report, stamped with the host's
// realtime clock at arrival as usbmon does. Bus and device address are not known through hidraw;
// they are written as bus 1, address 1.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/clock_sync.hpp"
#include "hmdnode/hal/reference_protocol.hpp"
#include "hmdnode/hal/sim_reference_device.hpp"
#include "hmdnode/hal/transport.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

std::atomic<bool> g_stop{false};

extern "C" void on_sigint(int) {
    g_stop.store(true);
}

struct RecordArgs {
    std::string device;
    std::string out;
    std::string capture;
    double duration_s = 10.0;
    std::string backend = "hidapi";
    bool sim_clock = false;
};

// Little-endian appends.
void put(std::string& b, const void* p, size_t n) {
    b.append(static_cast<const char*>(p), n);
}
template <class T>
void put_le(std::string& b, T v) {
    for (size_t i = 0; i < sizeof(T); ++i) b.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

// A pcap of usbmon events (DLT_USB_LINUX_MMAPPED), built in memory.
class UsbmonPcapWriter {
  public:
    UsbmonPcapWriter() {
        put_le<uint32_t>(bytes_, 0xa1b2c3d4);  // microsecond timestamps
        put_le<uint16_t>(bytes_, 2);
        put_le<uint16_t>(bytes_, 4);
        put_le<int32_t>(bytes_, 0);
        put_le<uint32_t>(bytes_, 0);
        put_le<uint32_t>(bytes_, 65535);
        put_le<uint32_t>(bytes_, 220);  // LINKTYPE_USB_LINUX_MMAPPED
    }

    // One usbmon event. `setup` non-null: a control submission carrying the setup packet.
    void event(int64_t realtime_ns, uint64_t urb_id, char type, uint8_t xfer_type, uint8_t endpoint,
               uint32_t urb_length, const uint8_t* setup, std::span<const uint8_t> data) {
        std::string h;
        put_le<uint64_t>(h, urb_id);
        h.push_back(type);
        h.push_back(static_cast<char>(xfer_type));
        h.push_back(static_cast<char>(endpoint));
        h.push_back(1);                // device address
        put_le<uint16_t>(h, 1);        // bus
        h.push_back(setup ? 0 : '-');  // flag_setup: 0 = setup present
        h.push_back(data.empty() ? (endpoint & 0x80 ? '<' : '>') : 0);  // flag_data: 0 = present
        put_le<int64_t>(h, realtime_ns / kNsPerSecond);
        put_le<int32_t>(h, static_cast<int32_t>((realtime_ns % kNsPerSecond) / 1000));
        put_le<int32_t>(h, 0);  // status
        put_le<uint32_t>(h, urb_length);
        put_le<uint32_t>(h, static_cast<uint32_t>(data.size()));
        uint8_t s[8] = {};
        if (setup) std::memcpy(s, setup, 8);
        put(h, s, 8);
        put_le<int32_t>(h, xfer_type == 1 ? 1 : 0);  // interval (ms)
        put_le<int32_t>(h, 0);                       // start_frame
        put_le<uint32_t>(h, 0);                      // xfer_flags
        put_le<uint32_t>(h, 0);                      // ndesc
        const uint32_t len = static_cast<uint32_t>(h.size() + data.size());
        put_le<uint32_t>(bytes_, static_cast<uint32_t>(realtime_ns / kNsPerSecond));
        put_le<uint32_t>(bytes_, static_cast<uint32_t>((realtime_ns % kNsPerSecond) / 1000));
        put_le<uint32_t>(bytes_, len);
        put_le<uint32_t>(bytes_, len);
        bytes_ += h;
        put(bytes_, data.data(), data.size());
        ++events_;
    }

    // A control transfer: 'S' with the setup packet, 'C' with the answer (IN requests).
    void control_in(int64_t realtime_ns, const UsbSetupPacket& setup,
                    std::span<const uint8_t> answer) {
        const auto s = setup.bytes();
        const uint64_t urb = next_urb_++;
        event(realtime_ns, urb, 'S', 2, 0x80, setup.length, s.data(), {});
        event(realtime_ns, urb, 'C', 2, 0x80, static_cast<uint32_t>(answer.size()), nullptr,
              answer);
    }

    void interrupt_in(int64_t realtime_ns, std::span<const uint8_t> data) {
        event(realtime_ns, 0x1000, 'C', 1, 0x81, static_cast<uint32_t>(data.size()), nullptr, data);
    }

    const std::string& bytes() const { return bytes_; }
    uint64_t events() const { return events_; }

  private:
    std::string bytes_;
    uint64_t events_ = 0;
    uint64_t next_urb_ = 0x100;
};

// A USB device descriptor (USB 2.0 §9.6.1) with the device's ids, for the capture's GET_DESCRIPTOR.
std::vector<uint8_t> device_descriptor(uint16_t vid, uint16_t pid) {
    return {18,
            1,
            0x00,
            0x02,
            0,
            0,
            0,
            64,
            static_cast<uint8_t>(vid & 0xff),
            static_cast<uint8_t>(vid >> 8),
            static_cast<uint8_t>(pid & 0xff),
            static_cast<uint8_t>(pid >> 8),
            0x00,
            0x01,
            1,
            2,
            3,
            1};
}

int64_t realtime_minus_monotonic_ns() {
    timespec rt{}, mono{};
    clock_gettime(CLOCK_REALTIME, &rt);
    clock_gettime(CLOCK_MONOTONIC, &mono);
    return (static_cast<int64_t>(rt.tv_sec) - mono.tv_sec) * kNsPerSecond +
           (rt.tv_nsec - mono.tv_nsec);
}

void fail(const std::string& message) {
    std::fprintf(stderr, "hmdnode record: %s\n", message.c_str());
    set_exit_code(1);
}

void run_record(const RecordArgs& args) {
    if (args.out.empty() && args.capture.empty())
        return fail("nothing to write: give --out FILE.csv and/or --capture FILE.pcap");
    Result<DeviceFilter> filter = parse_vid_pid(std::string_view(args.device));
    if (!filter.ok()) return fail("--device: " + filter.error().message);
    if (args.sim_clock && args.backend != "sim")
        return fail("--sim-clock needs --backend sim (a real device runs on the real clock)");

    SystemClock system_clock;
    SimulatedClock sim_clock(kNsPerSecond);
    Clock& clock = args.sim_clock ? static_cast<Clock&>(sim_clock) : system_clock;

    std::unique_ptr<TransportBackend> backend;
    if (args.backend == "sim") {
        SimReferenceDeviceConfig cfg;
        cfg.vendor_id = filter->vendor_id;
        cfg.product_id = filter->product_id;
        if (!filter->serial.empty()) cfg.serial = filter->serial;
        backend = create_sim_reference_backend(clock, cfg, sinusoidal_motion());
    } else {
        auto b = create_transport_backend(args.backend);
        if (!b.ok()) return fail(b.error().message);
        backend = std::move(*b);
    }
    auto list = backend->enumerate(*filter);
    if (!list.ok()) return fail(list.error().message);
    if (list->empty())
        return fail("no device " + args.device + " found by the " + backend->name() +
                    " backend (plugged in? udev rules: docs/udev.md)");
    auto opened = backend->open(list->front());
    if (!opened.ok()) return fail(opened.error().message);
    std::unique_ptr<Transport> transport = std::move(*opened);
    const DeviceId id = transport->id();

    const int64_t rt_offset = args.sim_clock ? 0 : realtime_minus_monotonic_ns();
    UsbmonPcapWriter pcap;
    pcap.control_in(clock.now_ns() + rt_offset, UsbSetupPacket{0x80, 0x06, 0x0100, 0, 18},
                    device_descriptor(id.vendor_id, id.product_id));

    // The reference protocol says who it is in feature report 0x10.
    bool reference = false;
    std::string device_label = format_vid_pid(id.vendor_id, id.product_id);
    auto info_bytes =
        transport->get_feature(refproto::kDeviceInfoReport, refproto::kDeviceInfoReportSize);
    if (info_bytes.ok()) {
        auto info = refproto::decode_device_info(*info_bytes);
        if (info.ok()) {
            reference = true;
            device_label += " \"" + info->product + "\" serial " + info->serial;
            pcap.control_in(
                clock.now_ns() + rt_offset,
                hid_get_report_setup(HidReportType::feature, refproto::kDeviceInfoReport,
                                     static_cast<uint16_t>(std::max(0, id.interface_number)),
                                     refproto::kDeviceInfoReportSize),
                *info_bytes);
        }
    }
    if (!reference && !args.out.empty())
        return fail(device_label +
                    " does not speak the hmdnode reference protocol (no device-info feature "
                    "report 0x10); record its raw reports with --capture alone");

    Trace trace;
    trace.comments.push_back("recorded by hmdnode record from " + device_label + " via " +
                             backend->name() + " (" + id.path + ")");
    ClockSync sync;
    uint64_t reports = 0, poses = 0, malformed = 0, gaps = 0, missing = 0, non_increasing = 0;
    bool have_seq = false;
    uint32_t last_seq = 0;
    bool with_gyro = false, with_position = false;
    std::string failure;

    g_stop = false;
    auto old_handler = std::signal(SIGINT, on_sigint);
    const int64_t start = clock.now_ns();
    const int64_t end = args.duration_s > 0 ? start + s_to_ns(args.duration_s) : INT64_MAX;
    while (!g_stop.load() && clock.now_ns() < end) {
        const int64_t left_ms = (end - clock.now_ns()) / kNsPerMs;
        auto r = transport->read_input(static_cast<int>(std::clamp<int64_t>(left_ms, 1, 100)));
        if (!r.ok()) {
            failure = r.error().message;
            break;
        }
        if (!r->has_value()) continue;
        const InputReport& report = **r;
        if (report.host_time_ns >= end) break;
        ++reports;
        pcap.interrupt_in(report.host_time_ns + rt_offset, report.bytes);
        if (!reference || report.bytes.empty() || report.bytes[0] != refproto::kPoseReport)
            continue;
        auto pose = refproto::decode_pose(report.bytes);
        if (!pose.ok()) {
            ++malformed;
            continue;
        }
        if (have_seq && pose->sequence != last_seq + 1) {
            ++gaps;
            missing += pose->sequence - last_seq - 1;
        }
        have_seq = true;
        last_seq = pose->sequence;
        if (!(pose->flags & refproto::kPoseFlagOrientationValid)) continue;
        const int64_t t =
            sync.update(static_cast<int64_t>(pose->device_time_us) * kNsPerUs, report.host_time_ns);
        TraceSample s;
        s.time_ns = t - start;
        if (!trace.samples.empty() && s.time_ns <= trace.samples.back().time_ns) {
            ++non_increasing;
            continue;
        }
        if (trace.samples.empty()) {
            with_gyro = pose->flags & refproto::kPoseFlagAngularVelocityValid;
            with_position = pose->flags & refproto::kPoseFlagPositionValid;
        }
        s.orientation = trace.samples.empty()
                            ? pose->orientation
                            : same_hemisphere(pose->orientation, trace.samples.back().orientation);
        // note: the trace format wants a column group in every row or none; a report without the
        // group repeats the previous value.
        if (with_gyro)
            s.gyro = (pose->flags & refproto::kPoseFlagAngularVelocityValid)
                         ? pose->angular_velocity
                         : (trace.samples.empty() ? glm::dvec3(0) : *trace.samples.back().gyro);
        if (with_position)
            s.position =
                (pose->flags & refproto::kPoseFlagPositionValid)
                    ? pose->position_m
                    : (trace.samples.empty() ? glm::dvec3(0) : *trace.samples.back().position);
        trace.samples.push_back(s);
        ++poses;
    }
    std::signal(SIGINT, old_handler);
    const double seconds = ns_to_s(clock.now_ns() - start);

    bool ok = true;
    if (!args.capture.empty()) {
        Status w = write_file_atomically(args.capture, pcap.bytes());
        if (!w.ok()) {
            std::fprintf(stderr, "hmdnode record: %s\n", w.error().message.c_str());
            ok = false;
        }
    }
    if (!args.out.empty()) {
        if (trace.samples.size() < 2) {
            std::fprintf(stderr,
                         "hmdnode record: only %zu pose sample(s) in %.3f s: %s not written\n",
                         trace.samples.size(), seconds, args.out.c_str());
            ok = false;
        } else {
            Status w = write_trace_csv(trace, args.out);
            if (!w.ok()) {
                std::fprintf(stderr, "hmdnode record: %s\n", w.error().message.c_str());
                ok = false;
            }
        }
    }
    std::printf("recorded %s via %s (%s) for %.3f s\n", device_label.c_str(),
                backend->name().c_str(), id.path.c_str(), seconds);
    std::printf("  %-24s %llu (%.1f per s)\n", "input reports",
                static_cast<unsigned long long>(reports), seconds > 0 ? reports / seconds : 0.0);
    std::printf("  %-24s %llu\n", "pose samples", static_cast<unsigned long long>(poses));
    std::printf("  %-24s %llu (%llu reports missing)\n", "sequence gaps",
                static_cast<unsigned long long>(gaps), static_cast<unsigned long long>(missing));
    std::printf("  %-24s %llu\n", "malformed reports", static_cast<unsigned long long>(malformed));
    if (non_increasing)
        std::printf("  %-24s %llu\n", "dropped (time not increasing)",
                    static_cast<unsigned long long>(non_increasing));
    if (sync.valid())
        std::printf("  %-24s %.3f ms (jitter %.3f ms, drift %.1f ppm)\n", "clock offset",
                    ns_to_ms(sync.offset_ns()), sync.jitter_ns() * 1e-6, sync.drift_ppm());
    if (!args.capture.empty() && ok)
        std::printf("  %-24s %s (%llu usbmon events)\n", "capture", args.capture.c_str(),
                    static_cast<unsigned long long>(pcap.events()));
    if (!args.out.empty() && ok) std::printf("  %-24s %s\n", "trace", args.out.c_str());
    if (!failure.empty()) {
        std::fprintf(stderr, "hmdnode record: %s -- stopped; what arrived before was written\n",
                     failure.c_str());
        set_exit_code(3);
        return;
    }
    if (!ok) set_exit_code(1);
}

void add_record_command(CLI::App& app) {
    auto args = std::make_shared<RecordArgs>();
    CLI::App* rec = app.add_subcommand(
        "record", "Record a tracker: trace CSV from its decoded reports, raw reports as a pcap");
    rec->add_option("--device", args->device, "VID:PID[:SERIAL] in hex, e.g. 1209:0001")
        ->required();
    rec->add_option("--out", args->out, "Trace CSV to write (hmdnode reference protocol devices)");
    rec->add_option("--capture", args->capture,
                    "pcap to write: raw reports, usbmon link type 220 (Wireshark, tshark)");
    rec->add_option("--duration", args->duration_s, "Seconds to record (0: until Ctrl-C)")
        ->capture_default_str();
    rec->add_option("--backend", args->backend,
                    "hidapi, libusb or sim (simulated reference tracker)")
        ->check(CLI::IsMember({"hidapi", "libusb", "sim"}))
        ->capture_default_str();
    rec->add_flag("--sim-clock", args->sim_clock,
                  "With --backend sim: run on a simulated clock (instant, deterministic)");
    rec->callback([args] { run_record(*args); });
}

const CommandRegistration reg{55, add_record_command};

}  // namespace
}  // namespace hmdnode::tool
