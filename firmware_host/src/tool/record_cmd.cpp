// `hmdnode record`: read a tracker through a transport backend (hidapi, libusb, the simulated
// reference tracker, or a recorded usbmon capture) and write what it said: our trace CSV
// (docs/trace-format.md) from the decoded reports, and the raw reports as a pcap with the Linux
// usbmon link type DLT_USB_LINUX_MMAPPED (220), which Wireshark, tshark and `hmdnode replay
// --capture` read. Formats and limits: docs/hardware.md.
//
// One path to the CSV: every tracker backend (a live or simulated device, a capture, a libsurvive
// recording) is made by the one wiring place (hmdnode/firmware_host/wiring.hpp) and read through
// the DeviceTracker of live tracking (codec by VID:PID -> ClockSync -> fusion,
// hal/include/hmdnode/hal/tracking/device_tracker.hpp); each delivered TrackerSample with an
// orientation becomes a row. A device's raw reports reach the pcap through the tee backend of
// hal/include/hmdnode/hal/transport/usbmon_pcap_writer.hpp, wrapped around the backend's (the
// feature reports the codec reads become GET_REPORT exchanges; each open writes a synthetic
// GET_DESCRIPTOR(DEVICE) exchange so readers learn the VID:PID from the capture itself; input
// reports are stamped with the host's realtime clock at arrival, as usbmon does). A capture or a
// recording runs on a simulated clock advanced in 10 ms steps: deterministic, as fast as it
// decodes.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include <CLI/CLI.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/wiring.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/clock_sync.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"
#include "hmdnode/hal/transport.hpp"
#include "hmdnode/hal/transport/usbmon_pcap_writer.hpp"
#include "tool/cli_errors.hpp"
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
    std::string from;
    std::string reference_out;
    std::string reference_time = "imu";  // imu: the IMU sample a POSE follows; recorded: its TIME
    std::string fusion = "mahony";       // or gyro: the gyro integrated, no gravity correction
    bool sim_clock = false;
    bool duration_given = false;
};

const CliErrors errors{"record"};

// What the tracker path recorded.
struct TrackerRecording {
    Trace trace;
    uint64_t delivered = 0;       // samples the tracker delivered
    uint64_t before_fusion = 0;   // delivered before the fusion had an orientation
    uint64_t non_increasing = 0;  // dropped: time not strictly increasing
    std::string failure;          // the device went away
    double seconds = 0.0;         // on the recording clock
    // With keep_arrivals: a report's arrival time (from t0) -> the row time of its newest sample.
    bool keep_arrivals = false;
    std::unordered_map<int64_t, int64_t> row_time_of_arrival;
};

// Appends one delivered sample as a trace row (times from t0; a column group in every row or
// none: a sample lacking it repeats the previous row's value).
void append_row(const TrackerSample& t, int64_t t0, TrackerRecording* rec) {
    ++rec->delivered;
    if (!t.has_orientation) {
        ++rec->before_fusion;
        return;
    }
    std::vector<TraceSample>& rows = rec->trace.samples;
    TraceSample s;
    s.time_ns = t.time_ns - t0;
    if (!rows.empty() && s.time_ns <= rows.back().time_ns) {
        ++rec->non_increasing;
        return;
    }
    const TraceSample* prev = rows.empty() ? nullptr : &rows.back();
    s.orientation = prev ? same_hemisphere(t.orientation, prev->orientation) : t.orientation;
    auto group = [&](const std::optional<glm::dvec3>& v,
                     std::optional<glm::dvec3> TraceSample::*member) -> std::optional<glm::dvec3> {
        if (!prev) return v;
        if (!(prev->*member)) return std::nullopt;
        return v ? *v : *(prev->*member);
    };
    s.gyro = group(t.gyro, &TraceSample::gyro);
    s.accel = group(t.accel, &TraceSample::accel);
    s.position = group(t.position, &TraceSample::position);
    rows.push_back(s);
    if (rec->keep_arrivals) rec->row_time_of_arrival[t.arrival_ns - t0] = s.time_ns;
}

// The longest wait for the first pose of a device (or a capture) before giving up with an error.
constexpr int64_t kFirstPoseTimeoutNs = 5 * kNsPerSecond;

// Runs a started device tracker until `end` on `clock` (or Ctrl-C, or the end of a capture).
// Simulated clock: advanced in 10 ms steps, times from the first row. System clock: polled every
// 5 ms, times from `start`; a disconnect ends the recording (what arrived is kept). A device that
// cannot be opened, or gives no pose within kFirstPoseTimeoutNs, ends it with a failure.
// `origin`, when given, is the clock time that row time 0 stands for (a recording's own timeline).
// need_pose false (a raw capture alone): no first-pose timeout.
TrackerRecording record_tracker(DeviceTracker& tracker, Clock& clock, int64_t start, int64_t end,
                                std::optional<int64_t> origin = std::nullopt,
                                bool keep_arrivals = false, bool need_pose = true) {
    TrackerRecording rec;
    rec.keep_arrivals = keep_arrivals;
    std::vector<TrackerSample> buf(1024);
    std::optional<int64_t> t0 = origin;
    if (!t0 && !clock.is_simulated()) t0 = start;
    auto drain = [&] {
        size_t n;
        do {
            n = tracker.read(buf);
            for (size_t i = 0; i < n; ++i) {
                if (buf[i].arrival_ns >= end) continue;
                if (!t0 && buf[i].has_orientation) t0 = buf[i].time_ns;
                append_row(buf[i], t0.value_or(0), &rec);
            }
        } while (n == buf.size());
    };
    // A simulated clock: the device tracker is pumped by read(), which opens the device; open it
    // at the start (a simulated device's reports before its open would be lost, not recorded).
    if (clock.is_simulated()) drain();
    g_stop = false;
    auto old_handler = std::signal(SIGINT, on_sigint);
    while (!g_stop.load() && clock.now_ns() < end && !tracker.finished()) {
        if (clock.is_simulated()) {
            auto* sim = static_cast<SimulatedClock*>(&clock);
            sim->advance_ns(std::min<int64_t>(10 * kNsPerMs, end - clock.now_ns()));
        } else {
            clock.sleep_until_ns(std::min(end, clock.now_ns() + 5 * kNsPerMs));
        }
        drain();
        const DeviceTrackerStatus st = tracker.status();
        if (st.disconnects > 0) {
            rec.failure = st.last_error;
            break;
        }
        if (st.opens == 0 && st.open_failures > 0) {
            rec.failure =
                "could not open the device: " +
                (st.last_error.empty() ? std::string("no matching device") : st.last_error);
            break;
        }
        if (need_pose && rec.trace.samples.empty() &&
            clock.now_ns() - start >= kFirstPoseTimeoutNs) {
            rec.failure = "no pose from the device within " +
                          std::to_string(kFirstPoseTimeoutNs / kNsPerSecond) + " s (" +
                          std::to_string(st.samples) + " samples, " +
                          std::to_string(st.codec.reports) + " reports decoded, " +
                          std::to_string(st.codec.unknown) + " of unknown id)";
            break;
        }
    }
    std::signal(SIGINT, old_handler);
    tracker.stop();
    drain();
    rec.seconds = ns_to_s(std::min(clock.now_ns(), end) - start);
    return rec;
}

// Writes the CSV (atomically) and the pcap, prints the figures of a tracker-path recording.
void finish_tracker_recording(const RecordArgs& args, const std::string& label,
                              const std::string& via, TrackerRecording& rec,
                              const DeviceTrackerStatus& st, const UsbmonPcapWriter* pcap) {
    bool ok = true;
    if (pcap && !args.capture.empty()) {
        Status w = write_file_atomically(args.capture, pcap->bytes());
        if (!w.ok()) {
            errors.fail(w.error().message);
            ok = false;
        }
    }
    if (!args.out.empty()) {
        if (rec.trace.samples.size() < 2) {
            char seconds[32];
            std::snprintf(seconds, sizeof seconds, "%.3f", rec.seconds);
            errors.fail("only " + std::to_string(rec.trace.samples.size()) + " pose sample(s) in " +
                        seconds + " s: " + args.out + " not written");
            ok = false;
        } else {
            rec.trace.comments.push_back("recorded by hmdnode record from " + label + " via " +
                                         via +
                                         " (codec, clock sync and IMU fusion of "
                                         "hmdnode's device tracker)");
            Status w = write_trace_csv(rec.trace, args.out);
            if (!w.ok()) {
                errors.fail(w.error().message);
                ok = false;
            }
        }
    }
    const double s = rec.seconds;
    std::printf("recorded %s via %s for %.3f s\n", label.c_str(), via.c_str(), s);
    std::printf("  %-24s %llu (%.1f per s)\n", "input reports",
                static_cast<unsigned long long>(st.codec.reports),
                s > 0 ? st.codec.reports / s : 0.0);
    std::printf("  %-24s %llu (%llu before the fusion was aligned)\n", "samples",
                static_cast<unsigned long long>(rec.delivered),
                static_cast<unsigned long long>(rec.before_fusion));
    std::printf("  %-24s %zu (%.1f per s)\n", "trace rows", rec.trace.samples.size(),
                s > 0 ? rec.trace.samples.size() / s : 0.0);
    std::printf("  %-24s %llu (%llu samples missing)\n", "sequence gaps",
                static_cast<unsigned long long>(st.codec.sequence_gaps),
                static_cast<unsigned long long>(st.codec.missing_samples));
    if (!st.codec_warning.empty()) errors.warning(st.codec_warning);
    if (!st.codec_info.empty())
        std::printf("  %-24s %s\n", "IMU calibration", st.codec_info.c_str());
    if (st.codec.saturated_samples || st.codec.stale_first_dropped)
        std::printf("  %-24s %llu saturated (axis at full scale), %llu stale first dropped\n",
                    "IMU samples not trusted",
                    static_cast<unsigned long long>(st.codec.saturated_samples),
                    static_cast<unsigned long long>(st.codec.stale_first_dropped));
    std::printf("  %-24s %llu (%llu of other ids skipped)\n", "malformed reports",
                static_cast<unsigned long long>(st.codec.malformed),
                static_cast<unsigned long long>(st.codec.unknown));
    if (rec.non_increasing)
        std::printf("  %-24s %llu\n", "dropped (time not increasing)",
                    static_cast<unsigned long long>(rec.non_increasing));
    std::printf("  %-24s %.3f ms (jitter %.3f ms, drift %.1f ppm)\n", "clock offset",
                ns_to_ms(st.clock_offset_ns), st.clock_jitter_ns * 1e-6, st.clock_drift_ppm);
    if (pcap && !args.capture.empty() && ok)
        std::printf("  %-24s %s (%llu usbmon events)\n", "capture", args.capture.c_str(),
                    static_cast<unsigned long long>(pcap->events()));
    if (!args.out.empty() && ok) std::printf("  %-24s %s\n", "trace", args.out.c_str());
    if (!rec.failure.empty()) {
        // Never opened or no pose at all: bad input (exit 1). Gone mid-recording: exit 3.
        const bool never_opened = st.opens == 0 || rec.trace.samples.empty();
        errors.fail_with(never_opened ? 1 : 3,
                         rec.failure + " -- stopped" +
                             (never_opened ? "" : "; what arrived before was written"));
    }
    // note: a write that failed above has set exit status 1 already.
}

// --backend capture --from FILE: the capture's device through the device tracker, simulated clock.
void run_record_capture(const RecordArgs& args, const DeviceFilter& filter) {
    if (args.from.empty()) return errors.usage("--backend capture needs --from FILE.pcap[.gz]");
    if (!args.capture.empty())
        return errors.usage("--capture with --backend capture: the input is a capture already");
    std::error_code ec;
    if (!std::filesystem::is_regular_file(args.from, ec))
        return errors.fail("--from " + args.from + ": no such file");
    SimulatedClock clock(kNsPerSecond);
    const int64_t start = clock.now_ns();
    TrackerSpec spec;
    spec.backend = TrackerBackend::capture;
    spec.from = args.from;
    spec.device = args.device;
    Result<WiredTracker> wired = make_tracker(spec, clock, WiringKeys::command_line());
    if (!wired.ok()) return errors.fail(wired.error().message);
    DeviceTracker* tracker = wired->device;
    if (Status st = tracker->start(); !st.ok()) return errors.fail(st.error().message);
    // The whole capture unless --duration is given.
    const int64_t end = args.duration_given && args.duration_s > 0
                            ? start + s_to_ns(args.duration_s)
                            : std::numeric_limits<int64_t>::max();
    TrackerRecording rec = record_tracker(*tracker, clock, start, end);
    rec.seconds = ns_to_s(clock.now_ns() - start);
    const DeviceTrackerStatus st = tracker->status();
    finish_tracker_recording(args,
                             format_vid_pid(filter.vendor_id, filter.product_id) + " (" +
                                 make_codec_for(filter.vendor_id, filter.product_id)->name() + ")",
                             "capture " + args.from, rec, st, nullptr);
}

// --reference-out: a libsurvive recording's lighthouse-solved poses (POSE lines) as a trace
// (libsurvive's world, z up, and its object frame: `hmdnode tracking eval` fits both rotations).
// libsurvive emits a POSE right after the IMU sample whose TIME it carries (every POSE of the
// bundled recording shares its TIME with an `i` line), its state predicted to that sample's
// instant; with `imu_row_time` (TIME of an IMU line -> the fused row of that sample) a pose gets
// that row's time: the instant the sample was taken by the device clock, on the fused trace's
// timeline, free of the USB arrival jitter and delay in TIME. Without it, the pose's TIME. Poses
// whose time does not increase, or (with the map) that follow no IMU line, are skipped and counted.
Status write_survive_reference(const SurviveRecording& rec, const std::string& path,
                               const std::unordered_map<int64_t, int64_t>* imu_row_time,
                               size_t* skipped, size_t* unmatched) {
    Trace t;
    for (const SurvivePose& p : rec.poses) {
        int64_t time = p.host_time_ns;
        if (imu_row_time) {
            auto it = imu_row_time->find(p.host_time_ns);
            if (it == imu_row_time->end()) {
                ++*unmatched;
                continue;
            }
            time = it->second;
        }
        if (!t.samples.empty() && time <= t.samples.back().time_ns) {
            ++*skipped;
            continue;
        }
        TraceSample s;
        s.time_ns = time;
        s.orientation = t.samples.empty()
                            ? p.orientation
                            : same_hemisphere(p.orientation, t.samples.back().orientation);
        s.position = p.position;
        t.samples.push_back(s);
    }
    if (t.samples.size() < 2)
        return make_error(rec.device + ": " + std::to_string(t.samples.size()) +
                          " lighthouse pose(s) (POSE lines) in the recording: --reference-out " +
                          path + " not written");
    t.comments.push_back(
        "lighthouse-solved poses (libsurvive POSE lines) of " + rec.device +
        ", libsurvive's world frame (z up), time = " +
        (imu_row_time ? "the instant of the IMU sample each follows, on the fused trace's timeline"
                      : "the recording's TIME"));
    return write_trace_csv(t, path);
}

// The recording's IMU samples with an axis at full scale, as trace comments
// `saturated_ns FIRST LAST COUNT` (runs of such samples less than 50 ms apart; row times):
// `hmdnode tracking eval` reports the error without the intervals they disturb.
void add_saturation_comments(const SurviveRecording& rec,
                             const std::unordered_map<int64_t, int64_t>& row_time, Trace* trace) {
    auto full = [](const std::array<int16_t, 3>& v) {
        for (int16_t c : v)
            if (c == 32767 || c == -32768) return true;
        return false;
    };
    int64_t first = 0, last = 0;
    int count = 0;
    auto flush = [&] {
        if (count > 0)
            trace->comments.push_back("saturated_ns " + std::to_string(first) + " " +
                                      std::to_string(last) + " " + std::to_string(count));
        count = 0;
    };
    for (const SurviveImuLine& l : rec.imu) {
        if (!full(l.gyro) && !full(l.accel)) continue;
        auto it = row_time.find(l.host_time_ns);
        if (it == row_time.end()) continue;
        if (count > 0 && it->second - last > 50 * kNsPerMs) flush();
        if (count == 0) first = it->second;
        last = it->second;
        ++count;
    }
    flush();
}

// --backend rec --from FILE.rec[.gz] --device NAME: a libsurvive recording's IMU samples through
// the device tracker as the Index's own reports (Index codec with the recording's factory
// calibration, clock sync, fusion) on a simulated clock; rows on the recording's timeline (its
// TIME column), as --reference-out's lighthouse poses.
void run_record_survive(const RecordArgs& args) {
    if (args.from.empty()) return errors.usage("--backend rec needs --from FILE.rec[.gz]");
    if (!args.capture.empty())
        return errors.usage("--capture with --backend rec: a recording has no USB reports to keep");
    if (args.out.empty()) return errors.usage("--backend rec needs --out FILE.csv");
    std::error_code ec;
    if (!std::filesystem::is_regular_file(args.from, ec))
        return errors.fail("--from " + args.from + ": no such file");
    auto loaded = read_survive_recording(args.from, args.device);
    if (!loaded.ok()) return errors.fail(loaded.error().message);
    for (const std::string& w : loaded->warnings) errors.warning(w);
    if (!loaded->has_config)
        errors.warning(args.from + " has no CONFIG line for " + args.device +
                       ": no factory IMU calibration, the Index's axes");
    auto rec = std::make_shared<const SurviveRecording>(std::move(*loaded));
    SimulatedClock clock(kNsPerSecond);
    const int64_t start = clock.now_ns();
    ImuFusionConfig fusion;
    if (args.fusion == "gyro") {  // the gyro integrated (still-window bias kept), no gravity
        fusion.kp = fusion.ki = fusion.init_kp = fusion.init_ki = 0.0;
    }
    auto tracker = create_survive_tracker(rec, clock, start, fusion);
    if (!tracker.ok()) return errors.fail(tracker.error().message);
    if (Status st = (*tracker)->start(); !st.ok()) return errors.fail(st.error().message);
    const int64_t end = args.duration_given && args.duration_s > 0
                            ? start + s_to_ns(args.duration_s)
                            : std::numeric_limits<int64_t>::max();
    // The tracker's host times are the recording's shifted so its first IMU line is at `start`.
    TrackerRecording out =
        record_tracker(**tracker, clock, start, end, start - rec->imu.front().host_time_ns, true);
    add_saturation_comments(*rec, out.row_time_of_arrival, &out.trace);
    if (args.fusion == "gyro")
        out.trace.comments.push_back(
            "--fusion gyro: the gyro integrated with the still-window bias, no gravity correction");
    out.seconds = ns_to_s(clock.now_ns() - start);
    const DeviceTrackerStatus st = (*tracker)->status();
    finish_tracker_recording(
        args,
        rec->device + " (Valve Index IMU" + (rec->model.empty() ? "" : ", " + rec->model) + ")",
        "libsurvive recording " + args.from, out, st, nullptr);
    std::printf("  %-24s %s\n", "factory calibration",
                rec->has_config ? "applied (CONFIG imu: acc_bias, acc_scale, gyro_bias, axes)"
                                : "none (no CONFIG line)");
    if (exit_code() != 0) return;  // the fused trace was not written: neither is the reference
    if (!args.reference_out.empty()) {
        size_t skipped = 0, unmatched = 0;
        Status w = write_survive_reference(
            *rec, args.reference_out,
            args.reference_time == "imu" ? &out.row_time_of_arrival : nullptr, &skipped,
            &unmatched);
        if (!w.ok()) return errors.fail(w.error().message);
        std::printf(
            "  %-24s %s (%zu lighthouse poses at %s; %zu with a repeated time, %zu following no "
            "IMU sample, skipped)\n",
            "reference", args.reference_out.c_str(), rec->poses.size() - skipped - unmatched,
            args.reference_time == "imu" ? "their IMU sample's instant" : "their TIME", skipped,
            unmatched);
    }
}

void run_record(const RecordArgs& args) {
    if (args.out.empty() && args.capture.empty())
        return errors.usage("nothing to write: give --out FILE.csv and/or --capture FILE.pcap");
    if (!args.from.empty() && args.backend != "capture" && args.backend != "rec")
        return errors.usage("--from needs --backend capture or rec");
    if (!args.reference_out.empty() && args.backend != "rec")
        return errors.usage("--reference-out needs --backend rec (a recording's lighthouse poses)");
    if (args.fusion != "mahony" && args.backend != "rec")
        return errors.usage("--fusion gyro needs --backend rec");
    if (!errors.check_outputs({{"--out", args.out},
                               {"--capture", args.capture},
                               {"--reference-out", args.reference_out}}))
        return;
    // A libsurvive recording names its devices (T20, WM0, ...), not by VID:PID.
    if (args.backend == "rec") return run_record_survive(args);
    Result<DeviceFilter> filter = parse_vid_pid(std::string_view(args.device));
    if (!filter.ok()) return errors.usage("--device: " + filter.error().message);
    if (args.backend == "capture") return run_record_capture(args, *filter);
    if (args.sim_clock && args.backend != "sim")
        return errors.usage(
            "--sim-clock needs --backend sim (a real device runs on the real clock)");

    SystemClock system_clock;
    SimulatedClock sim_clock(kNsPerSecond);
    Clock& clock = args.sim_clock ? static_cast<Clock&>(sim_clock) : system_clock;

    // Every device through the device tracker of live tracking (the one wiring place,
    // wiring.hpp): codec by VID:PID (Vive/Index, Rift IMU, else the reference protocol), clock
    // sync, fusion; its raw reports teed into the pcap (hal/transport/usbmon_pcap_writer.hpp).
    auto pcap = std::make_shared<UsbmonPcapWriter>();
    const int64_t rt_offset = args.sim_clock ? 0 : realtime_minus_monotonic_ns();
    WiringKeys keys = WiringKeys::command_line();
    keys.backend = "--backend";
    Result<TrackerBackend> backend = parse_tracker_backend(args.backend, keys);
    if (!backend.ok()) return errors.usage(backend.error().message);
    std::vector<DeviceId> found;
    std::string backend_name, enumerate_error;
    TrackerSpec spec;
    spec.backend = *backend;
    spec.device = args.device;
    spec.wrap_backend = [&](std::unique_ptr<TransportBackend> b) {
        backend_name = b->name();
        Result<std::vector<DeviceId>> list = b->enumerate(*filter);
        if (list.ok())
            found = *list;
        else
            enumerate_error = list.error().message;
        return create_pcap_tee_backend(std::move(b), pcap, clock, rt_offset);
    };
    Result<WiredTracker> wired = make_tracker(spec, clock, keys);
    if (!wired.ok()) return errors.fail(wired.error().message);
    if (!enumerate_error.empty()) return errors.fail(enumerate_error);
    if (found.empty())
        return errors.fail("no device " + args.device + " found by the " + backend_name +
                           " backend (plugged in? udev rules: docs/udev.md)");
    const DeviceId& id = found.front();
    auto codec = make_codec_for(id.vendor_id, id.product_id);
    const std::string label = format_vid_pid(id.vendor_id, id.product_id) + " (" + codec->name() +
                              (id.serial.empty() ? "" : ", serial " + id.serial) + ")";
    const std::string via = backend_name + " (" + id.path + ")";
    DeviceTracker& tracker = *wired->device;
    const int64_t start = clock.now_ns();
    if (Status st = tracker.start(); !st.ok()) return errors.fail(st.error().message);
    const int64_t end = args.duration_s > 0 ? start + s_to_ns(args.duration_s)
                                            : std::numeric_limits<int64_t>::max();
    // --capture alone records a device hmdnode cannot decode: no pose is waited for.
    TrackerRecording rec = record_tracker(tracker, clock, start, end, std::nullopt,
                                          /*keep_arrivals=*/false, /*need_pose=*/!args.out.empty());
    const DeviceTrackerStatus st = tracker.status();
    finish_tracker_recording(args, label, via, rec, st, pcap.get());
}

void add_record_command(CLI::App& app) {
    auto args = std::make_shared<RecordArgs>();
    CLI::App* rec = app.add_subcommand(
        "record", "Record a tracker: trace CSV from its decoded reports, raw reports as a pcap");
    rec->add_option("--device", args->device,
                    "VID:PID[:SERIAL] in hex, e.g. 1209:0001; --backend rec: the recording's "
                    "device name, e.g. T20")
        ->required();
    rec->add_option("--out", args->out,
                    "Trace CSV to write (reference-protocol devices; Vive/Index and Rift IMUs "
                    "through the tracker's fusion)");
    rec->add_option("--capture", args->capture,
                    "pcap to write: raw reports, usbmon link type 220 (Wireshark, tshark)");
    CLI::Option* duration = rec->add_option("--duration", args->duration_s,
                                            "Seconds to record (0: until Ctrl-C); --backend "
                                            "capture: the whole capture unless given")
                                ->capture_default_str();
    rec->add_option("--backend", args->backend,
                    "hidapi, libusb, sim (simulated reference tracker), capture (a usbmon "
                    "capture, --from) or rec (a libsurvive recording, --from)")
        ->check(CLI::IsMember({"hidapi", "libusb", "sim", "capture", "rec"}))
        ->capture_default_str();
    rec->add_flag("--sim-clock", args->sim_clock,
                  "With --backend sim: run on a simulated clock (instant, deterministic)");
    rec->add_option("--from", args->from,
                    "With --backend capture: the usbmon capture to decode (.pcap or .pcap.gz); "
                    "with --backend rec: the libsurvive recording (.rec or .rec.gz)");
    rec->add_option("--reference-out", args->reference_out,
                    "With --backend rec: trace CSV of the recording's lighthouse poses");
    rec->add_option("--reference-time", args->reference_time,
                    "With --reference-out: imu (a pose at the instant of the IMU sample it "
                    "follows, on the fused timeline) or recorded (its TIME)")
        ->check(CLI::IsMember({"imu", "recorded"}))
        ->capture_default_str();
    rec->add_option("--fusion", args->fusion,
                    "With --backend rec: mahony (the tracker's fusion) or gyro (the gyro "
                    "integrated, no gravity correction: the fusion's share of an error)")
        ->check(CLI::IsMember({"mahony", "gyro"}))
        ->capture_default_str();
    rec->callback([args, duration] {
        args->duration_given = duration->count() > 0;
        run_record(*args);
    });
}

const CommandRegistration reg{55, add_record_command};

}  // namespace
}  // namespace hmdnode::tool
