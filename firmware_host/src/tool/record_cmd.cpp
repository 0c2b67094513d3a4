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
#include <algorithm>
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
#include "hmdnode/hal/tracking/base_station_placement.hpp"
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
    std::string base_stations;           // --base-stations FILE: a stored setup (6DoF)
    std::string world_up = "z";          // the setup's world up
    bool place_base_stations = false;    // --place-base-stations: place what the setup lacks
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
    // 6DoF (a light path): rows only where the position is tracked; the samples left out still
    // give their instants to row_time_of_arrival (the reference's times).
    bool six_dof = false;
    uint64_t without_position = 0;
    int64_t first_position_ns = -1;  // row time of the first row
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
    if (rec->six_dof && !t.position) {
        ++rec->without_position;
        if (rec->keep_arrivals) rec->row_time_of_arrival[t.arrival_ns - t0] = s.time_ns;
        return;
    }
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
    if (rec->six_dof && rows.empty()) rec->first_position_ns = s.time_ns;
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
                                bool keep_arrivals = false, bool need_pose = true,
                                bool six_dof = false) {
    TrackerRecording rec;
    rec.keep_arrivals = keep_arrivals;
    rec.six_dof = six_dof;
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
        // 6DoF: an orientation is a pose (the position waits for the light).
        if (need_pose && (rec.six_dof ? rec.delivered == 0 : rec.trace.samples.empty()) &&
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

// An output written beside the trace (--reference-out): with it, or not at all.
struct ExtraOutput {
    std::string option, path;
    Trace trace;
};

// Writes the CSV, the pcap and `extra` (each atomically, all or none: an output already written is
// removed when a later one fails, and none is written when `refused` says why the recording is
// refused or the trace has fewer than 2 rows), prints the figures of a tracker-path recording.
// `time_base` goes into the trace as the comment `time_base ...` (docs/trace-format.md): what its
// time 0 is, so `hmdnode tracking eval` can tell traces on different timelines apart.
void finish_tracker_recording(const RecordArgs& args, const std::string& label,
                              const std::string& via, TrackerRecording& rec,
                              const DeviceTrackerStatus& st, const UsbmonPcapWriter* pcap,
                              const std::string& time_base, std::vector<ExtraOutput> extra = {},
                              const std::string& refused = "") {
    const size_t rows = rec.trace.samples.size();  // (the trace moves into `extra` below)
    bool ok = true;
    std::vector<std::pair<std::string, std::string>> files;  // path, bytes
    if (!refused.empty()) {
        errors.fail(refused);
        ok = false;
    }
    if (ok && !args.out.empty()) {
        if (rec.trace.samples.size() < 2) {
            char seconds[32];
            std::snprintf(seconds, sizeof seconds, "%.3f", rec.seconds);
            errors.fail("only " + std::to_string(rec.trace.samples.size()) + " pose sample(s) in " +
                        seconds + " s: " + args.out + " not written" +
                        (extra.empty() ? "" : " (nor " + extra.front().path + ")"));
            ok = false;
        } else {
            rec.trace.comments.push_back("recorded by hmdnode record from " + label + " via " +
                                         via +
                                         " (codec, clock sync and IMU fusion of "
                                         "hmdnode's device tracker)");
            rec.trace.comments.push_back("time_base " + time_base);
            extra.insert(extra.begin(), ExtraOutput{"--out", args.out, std::move(rec.trace)});
        }
    } else if (!ok) {
        extra.clear();
    }
    if (ok)
        for (ExtraOutput& e : extra) {
            if (e.option != "--out") e.trace.comments.push_back("time_base " + time_base);
            Result<std::string> text = format_trace_csv(e.trace);
            if (!text.ok()) {
                errors.fail(e.option + " " + e.path + ": " + text.error().message);
                ok = false;
                break;
            }
            files.emplace_back(e.path, std::move(*text));
        }
    if (ok && pcap && !args.capture.empty()) {
        files.emplace(files.begin(), args.capture, pcap->bytes());
    }
    std::vector<std::string> written;
    if (ok)
        for (const auto& [path, bytes] : files) {
            Status w = write_file_atomically(path, bytes);
            if (!w.ok()) {
                errors.fail(w.error().message);
                ok = false;
                std::error_code ec;
                for (const std::string& p : written) std::filesystem::remove(p, ec);
                break;
            }
            written.push_back(path);
        }
    const double s = rec.seconds;
    std::printf("recorded %s via %s for %.3f s\n", label.c_str(), via.c_str(), s);
    std::printf("  %-24s %llu (%.1f per s)\n", "input reports",
                static_cast<unsigned long long>(st.codec.reports),
                s > 0 ? st.codec.reports / s : 0.0);
    std::printf("  %-24s %llu (%llu before the fusion was aligned)\n", "samples",
                static_cast<unsigned long long>(rec.delivered),
                static_cast<unsigned long long>(rec.before_fusion));
    std::printf("  %-24s %zu (%.1f per s)\n", "trace rows", rows, s > 0 ? rows / s : 0.0);
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

void print_light_status(const DeviceTrackerStatus& st, const TrackerRecording& out, size_t rows,
                        const std::string& source, size_t stations);

// A 6DoF recording with fewer than two rows of a tracked position (of at least two samples): why,
// and that `out` is not written (the light path's counts, or why it is off); empty otherwise.
// Clears rec's own failure (this one says more).
std::string six_dof_refusal(const std::string& device, TrackerRecording& rec,
                            const DeviceTrackerStatus& st, const std::string& out) {
    if (rec.trace.samples.size() >= 2 || rec.delivered < 2) return {};
    rec.failure.clear();
    const std::string why =
        !st.light.enabled && !st.light.light_error.empty()
            ? "the light path is off: " + st.light.light_error
            : std::to_string(st.light.reports) + " light reports, " +
                  std::to_string(st.light.tracking.solved) + " turns solved of " +
                  std::to_string(st.light.tracking.solves) + ", " +
                  std::to_string(st.light.filter.accepted) + " accepted by the filter";
    return device + ": " + std::to_string(rec.trace.samples.size()) +
           " sample(s) with a tracked position of " + std::to_string(rec.delivered) + " (" + why +
           "): " + out + " not written";
}

// --base-stations for a device's own light (capture, live): the setup file's world is +z up (no
// --world-up), it loads and holds a base station (with --place-base-stations it may be empty or
// not there yet); *stations gets their count. False (the exit status set) otherwise.
bool setup_stations(const RecordArgs& args, const std::string& what, size_t* stations) {
    if (args.world_up != "z") {
        errors.usage("--world-up with " + what + ": a setup file's world is +z up");
        return false;
    }
    std::error_code ec;
    if (args.place_base_stations && !std::filesystem::exists(args.base_stations, ec)) {
        *stations = 0;
        return true;
    }
    auto setup = lighthouse::load_base_station_setup(args.base_stations);
    if (!setup) {
        errors.fail("--base-stations: " + setup.error().message);
        return false;
    }
    if (setup->empty() && !args.place_base_stations) {
        errors.fail("--base-stations " + args.base_stations + ": no base station");
        return false;
    }
    *stations = setup->size();
    return true;
}

// --place-base-stations: the tracker's setup (the base stations it placed beside the stored ones)
// written to --base-stations when it grew, and what happened said. `stored`: the count the file
// held at the start.
void store_placed_setup(const RecordArgs& args, const DeviceTracker& tracker, size_t stored) {
    if (!args.place_base_stations) return;
    TrackerSpec spec;
    spec.base_stations = args.base_stations;
    spec.place_base_stations = true;
    const DeviceTrackerStatus st = tracker.status();
    const LightTrackingCounters& t = st.light.tracking;
    const size_t had = stored;
    if (Status w = save_placed_setup(spec, tracker, &stored); !w)
        return errors.fail("--base-stations " + args.base_stations + ": " + w.error().message);
    if (stored > had)
        std::printf(
            "  %-24s %llu base station(s) placed in the tracker, the setup of %zu "
            "written to %s\n",
            "placement", static_cast<unsigned long long>(t.placed_in_tracker), stored,
            args.base_stations.c_str());
    else
        std::printf("  %-24s none placed (%llu still stretch(es)%s%s); %s left as it was\n",
                    "placement", static_cast<unsigned long long>(t.still_stretches),
                    t.last_placement_note.empty() ? "" : ": ", t.last_placement_note.c_str(),
                    args.base_stations.c_str());
}

// --backend capture --from FILE: the capture's device through the device tracker, simulated clock
// (with --base-stations, 6DoF from its light).
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
    spec.base_stations = args.base_stations;  // 6DoF: the capture's light with a stored setup
    spec.place_base_stations = args.place_base_stations;
    const bool six_dof = !args.base_stations.empty();
    size_t stations = 0;
    if (six_dof && !setup_stations(args, "--backend capture", &stations)) return;
    Result<WiredTracker> wired = make_tracker(spec, clock, WiringKeys::command_line());
    if (!wired.ok()) return errors.fail(wired.error().message);
    DeviceTracker* tracker = wired->device;
    if (Status st = tracker->start(); !st.ok()) return errors.fail(st.error().message);
    // The whole capture unless --duration is given.
    const int64_t end = args.duration_given && args.duration_s > 0
                            ? start + s_to_ns(args.duration_s)
                            : std::numeric_limits<int64_t>::max();
    TrackerRecording rec =
        record_tracker(*tracker, clock, start, end, std::nullopt, false, true, six_dof);
    rec.seconds = ns_to_s(clock.now_ns() - start);
    const DeviceTrackerStatus st = tracker->status();
    std::string refused;
    if (six_dof) refused = six_dof_refusal(args.device, rec, st, args.out);
    if (six_dof)
        rec.trace.comments.push_back(
            "6DoF: light + IMU (hmdnode's solver and filter), base stations from " +
            args.base_stations +
            ", their world (up z) turned to +y up; rows only where the "
            "position is tracked");
    const size_t rows = rec.trace.samples.size();  // (moved into the outputs below)
    finish_tracker_recording(args,
                             format_vid_pid(filter.vendor_id, filter.product_id) + " (" +
                                 make_codec_for(filter.vendor_id, filter.product_id)->name() + ")",
                             "capture " + args.from, rec, st, nullptr,
                             "first_sample capture " +
                                 std::filesystem::path(args.from).filename().string() +
                                 " (0 = its first pose)",
                             {}, refused);
    if (six_dof) print_light_status(st, rec, rows, args.base_stations, stations);
    if (six_dof) store_placed_setup(args, *tracker, stations);
}

// --reference-out: a libsurvive recording's lighthouse-solved poses as a trace (libsurvive's world,
// z up, and its object frame: `hmdnode tracking eval` fits both rotations): the device's POSE
// lines, or without them its EXTERNAL_POSE lines (libsurvive's replay output;
// survive_device_poses). libsurvive emits a headset's POSE right after the IMU sample whose TIME it
// carries (every POSE of the bundled Index recording shares its TIME with an `i` line), its state
// predicted to that sample's instant; with `imu_row_time` (TIME of an IMU line -> the fused row of
// that sample) such a pose gets that row's time: the instant the sample was taken by the device
// clock, on the fused trace's timeline, free of the USB arrival jitter and delay in TIME. A pose
// that shares no IMU line's TIME (a controller's or a tracker's follow its light, an
// EXTERNAL_POSE a replay's clock) gets the row time interpolated linearly in TIME between the IMU
// lines logged before and after it (monotonic: both timelines rise), or after the last one that
// line's row time plus the TIME since; the line before must lie within 50 ms, else the pose is
// skipped and counted. Without the map, the pose's TIME. Poses whose time does not increase are
// skipped and counted.
struct ReferenceCounts {
    std::string what;  // which lines (survive_device_poses)
    size_t written = 0, exact = 0, before = 0, skipped = 0, unmatched = 0;
};

Result<Trace> survive_reference(const SurviveRecording& rec,
                                const std::unordered_map<int64_t, int64_t>* imu_row_time,
                                const std::string& path, ReferenceCounts* n) {
    const std::vector<SurvivePose>* poses = survive_device_poses(rec, &n->what);
    if (!poses)
        return make_error(rec.device + ": " + n->what + ": --reference-out " + path +
                          " not written");
    std::vector<std::pair<int64_t, int64_t>> by_time;  // (TIME, row time), sorted
    if (imu_row_time) {
        by_time.assign(imu_row_time->begin(), imu_row_time->end());
        std::sort(by_time.begin(), by_time.end());
    }
    constexpr int64_t kMaxBeforeNs = 50 * kNsPerMs;
    Trace t;
    for (const SurvivePose& p : *poses) {
        int64_t time = p.host_time_ns;
        if (imu_row_time) {
            auto it = std::upper_bound(
                by_time.begin(), by_time.end(),
                std::make_pair(p.host_time_ns, std::numeric_limits<int64_t>::max()));
            if (it == by_time.begin() || p.host_time_ns - std::prev(it)->first > kMaxBeforeNs) {
                ++n->unmatched;
                continue;
            }
            const auto next = it;
            --it;
            time = it->second + (p.host_time_ns - it->first);
            if (it->first != p.host_time_ns && next != by_time.end() &&
                next->first - it->first <= kMaxBeforeNs)
                time = it->second + int64_t(std::llround(double(next->second - it->second) *
                                                         double(p.host_time_ns - it->first) /
                                                         double(next->first - it->first)));
            ++(it->first == p.host_time_ns ? n->exact : n->before);
        }
        if (!t.samples.empty() && time <= t.samples.back().time_ns) {
            ++n->skipped;
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
    n->written = t.samples.size();
    if (t.samples.size() < 2)
        return make_error(rec.device + ": " + std::to_string(t.samples.size()) +
                          " lighthouse pose(s) usable of " + std::to_string(poses->size()) + " " +
                          n->what + " (" + std::to_string(n->unmatched) +
                          " with no IMU sample in the 50 ms before): --reference-out " + path +
                          " not written");
    t.comments.push_back(
        "lighthouse-solved poses (libsurvive " + n->what + "), libsurvive's world frame (z up), " +
        "time = " +
        (imu_row_time ? "the instant of the IMU sample each follows, on the fused trace's timeline"
                      : "the recording's TIME"));
    return t;
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

// Why a recording's device gave fewer than 2 trace rows, from what its IMU lines gave.
std::string no_samples_cause(const SurviveRecording& rec, const DeviceTrackerStatus& st,
                             const TrackerRecording& out) {
    const CodecCounters& c = st.codec;
    std::string s = rec.device + ": " + std::to_string(out.trace.samples.size()) +
                    " trace row(s) from " + std::to_string(rec.imu.size()) + " IMU lines (" +
                    std::to_string(c.reports) + " reports decoded, " + std::to_string(c.samples) +
                    " samples, " + std::to_string(c.stale_first_dropped) +
                    " first samples dropped as stale, " + std::to_string(c.malformed) +
                    " malformed): ";
    bool ticks_move = false;
    for (size_t k = 1; k < rec.imu.size(); ++k) ticks_move |= rec.imu[k].ticks != rec.imu[0].ticks;
    if (rec.imu.size() < 2) return s + "a device needs at least 2 IMU lines";
    if (!ticks_move) return s + "every IMU line has the same TICK: no sample follows another";
    if (c.samples == 0 && c.stale_first_dropped > 0)
        return s + "each first sample was taken for a stale report (its next is more than 8 " +
               "sequence steps, or more than 10 ms of TICK per step, away)";
    if (c.samples == 0) return s + "no line carries a new sample (its SEQ repeats the one before)";
    if (out.before_fusion == out.delivered)
        return s + "the fusion never aligned to gravity (no accelerometer reading near 1 g)";
    return s + "the recording ends before a second sample";
}

// The light path of a recording (6DoF) when it has light lines and a stored setup: --base-stations
// FILE (a state file), else the recording's own base-station poses from before its light (as
// libsurvive writes its saved configuration; poses solved during the recording are look-ahead and
// not used). Null (IMU only) with `why` saying so; an error for a bad --base-stations file.
Result<std::shared_ptr<const LightTrackingConfig>> recording_light_path(const RecordArgs& args,
                                                                        const SurviveRecording& rec,
                                                                        std::string* source,
                                                                        std::string* why) {
    using Setup = std::vector<lighthouse::BaseStationPlacement>;
    Setup setup;
    std::error_code ec;
    if (args.place_base_stations && !std::filesystem::exists(args.base_stations, ec)) {
        *source = "none stored (" + args.base_stations + " not there yet): placed in the tracker";
    } else if (!args.base_stations.empty()) {
        auto loaded = lighthouse::load_base_station_setup(args.base_stations);
        if (!loaded) return make_error("--base-stations: " + loaded.error().message);
        setup = std::move(*loaded);
        *source = args.base_stations;
        if (args.place_base_stations) *source += " (those it lacks placed in the tracker)";
    }
    if (rec.light.empty()) {
        *why = "no light line (W, Y, C) of " + rec.device + ": orientation only";
        if (!args.base_stations.empty())
            return make_error("--base-stations " + args.base_stations + ": " + *why);
        return std::shared_ptr<const LightTrackingConfig>();
    }
    if (args.base_stations.empty()) {
        if (rec.base_station_poses.empty()) {
            *why =
                "no stored base-station setup (no LH_POSE line; give --base-stations FILE): "
                "orientation only";
            return std::shared_ptr<const LightTrackingConfig>();
        }
        // The calibration ids only map the LH_POSE lines' numbers to base stations.
        lighthouse::LightDecoder all(survive_sensor_model(rec));
        if (Status st = replay_survive_light(rec, all); !st) {
            *why = args.from + ": " + st.error().message + ": orientation only";
            return std::shared_ptr<const LightTrackingConfig>();
        }
        auto stored = lighthouse::recording_base_station_setup(rec, all.base_stations(), false);
        if (!stored || stored->empty()) {
            *why = "no stored base-station setup (" +
                   (stored ? std::string("no LH_POSE line") : stored.error().message) +
                   "; give --base-stations FILE): orientation only";
            return std::shared_ptr<const LightTrackingConfig>();
        }
        setup = std::move(*stored);
        *source = "the recording's LH_POSE lines before its light";
    }
    const glm::dvec3 up = args.world_up == "x"   ? glm::dvec3(1, 0, 0)
                          : args.world_up == "y" ? glm::dvec3(0, 1, 0)
                                                 : glm::dvec3(0, 0, 1);
    auto cfg = survive_light_tracking_config(rec, std::move(setup), up);
    if (!cfg && args.base_stations.empty()) {
        *why = cfg.error().message + ": orientation only";
        return std::shared_ptr<const LightTrackingConfig>();
    }
    if (!cfg)
        return make_error("--base-stations " + args.base_stations + ": " + cfg.error().message);
    cfg->place.enabled = args.place_base_stations;
    return std::shared_ptr<const LightTrackingConfig>(
        std::make_shared<LightTrackingConfig>(std::move(*cfg)));
}

// The light path's figures.
void print_light_status(const DeviceTrackerStatus& st, const TrackerRecording& out, size_t rows,
                        const std::string& source, size_t stations) {
    const DeviceLightStatus& l = st.light;
    std::printf("  %-24s %zu base station(s) from %s\n", "base stations", stations, source.c_str());
    if (!l.enabled) {  // a live device that gave no sensor model
        std::printf("  %-24s off: %s\n", "light path",
                    l.light_error.empty() ? "no sensor model" : l.light_error.c_str());
        return;
    }
    std::printf("  %-24s %llu (%llu refused%s%s), %llu light events\n", "light reports",
                static_cast<unsigned long long>(l.reports),
                static_cast<unsigned long long>(l.rejected), l.rejected ? ": " : "",
                l.light_error.c_str(), static_cast<unsigned long long>(l.decoder.events));
    std::printf("  %-24s %llu turns solved of %llu (%llu not enough data, %llu no fit)\n",
                "pose solves", static_cast<unsigned long long>(l.tracking.solved),
                static_cast<unsigned long long>(l.tracking.solves),
                static_cast<unsigned long long>(l.tracking.not_enough_data),
                static_cast<unsigned long long>(l.tracking.no_fit));
    std::printf(
        "  %-24s base stations solved with the setup's stored calibration %llu times, with the "
        "one decoded from their light %llu; %llu turns before any\n",
        "calibrations", static_cast<unsigned long long>(l.tracking.stored_calibration_uses),
        static_cast<unsigned long long>(l.tracking.decoded_calibration_uses),
        static_cast<unsigned long long>(l.tracking.uncalibrated_windows));
    std::printf("  %-24s %llu accepted, %llu initialisations, %llu gated, %llu lost\n",
                "light + IMU filter", static_cast<unsigned long long>(l.filter.accepted),
                static_cast<unsigned long long>(l.filter.initialisations),
                static_cast<unsigned long long>(l.filter.gated),
                static_cast<unsigned long long>(l.filter.lost));
    std::printf(
        "  %-24s %zu rows with a tracked position (first at %.3f s); %llu samples "
        "without one left out\n",
        "6DoF", rows, out.first_position_ns >= 0 ? ns_to_s(out.first_position_ns) : 0.0,
        static_cast<unsigned long long>(out.without_position));
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
    std::string light_source, light_why;
    auto light = recording_light_path(args, *rec, &light_source, &light_why);
    if (!light) return errors.fail(light.error().message);
    if (*light && args.fusion == "gyro")
        return errors.usage(
            "--fusion gyro is the IMU-only path: not with a light path (give "
            "neither --base-stations nor a recording with a stored setup)");
    const bool six_dof = *light != nullptr;
    const size_t stations = six_dof ? (*light)->setup.size() : 0;
    auto tracker = create_survive_tracker(rec, clock, start, fusion, *light);
    if (!tracker.ok()) return errors.fail(tracker.error().message);
    if (Status st = (*tracker)->start(); !st.ok()) return errors.fail(st.error().message);
    const int64_t end = args.duration_given && args.duration_s > 0
                            ? start + s_to_ns(args.duration_s)
                            : std::numeric_limits<int64_t>::max();
    // The tracker's host times are the recording's shifted so its first IMU line is at `start`.
    TrackerRecording out = record_tracker(
        **tracker, clock, start, end, start - rec->imu.front().host_time_ns, true, true, six_dof);
    add_saturation_comments(*rec, out.row_time_of_arrival, &out.trace);
    if (args.fusion == "gyro")
        out.trace.comments.push_back(
            "--fusion gyro: the gyro integrated with the still-window bias, no gravity correction");
    out.seconds = ns_to_s(clock.now_ns() - start);
    const DeviceTrackerStatus st = (*tracker)->status();
    // Fewer than 2 rows: why, from what the IMU lines gave.
    std::string refused;
    if (six_dof) refused = six_dof_refusal(rec->device, out, st, args.out);
    if (refused.empty() && out.trace.samples.size() < 2) {
        refused = no_samples_cause(*rec, st, out) + ": " + args.out + " not written";
        out.failure.clear();
    }
    if (six_dof)
        out.trace.comments.push_back(
            "6DoF: light + IMU (hmdnode's solver and filter), base stations from " + light_source +
            ", their world (up " + args.world_up +
            ") turned to +y up; rows only where the position is tracked");
    std::vector<ExtraOutput> extra;
    ReferenceCounts counts;
    if (refused.empty() && !args.reference_out.empty()) {
        Result<Trace> ref = survive_reference(
            *rec, args.reference_time == "imu" ? &out.row_time_of_arrival : nullptr,
            args.reference_out, &counts);
        if (ref.ok())
            extra.push_back({"--reference-out", args.reference_out, std::move(*ref)});
        else
            refused = ref.error().message + " (nor --out " + args.out + ")";
    }
    const size_t rows = out.trace.samples.size();  // (moved into the outputs below)
    for (const std::string& n : rec->notes) std::printf("  note: %s\n", n.c_str());
    if (!light_why.empty()) std::printf("  note: light: %s\n", light_why.c_str());
    finish_tracker_recording(args,
                             rec->device + " (Vive/Index-family IMU" +
                                 (rec->model.empty() ? "" : ", " + rec->model) + ")",
                             "libsurvive recording " + args.from, out, st, nullptr,
                             "recording_time libsurvive " +
                                 std::filesystem::path(args.from).filename().string() +
                                 " (its TIME, seconds on the recording host's clock)",
                             std::move(extra), refused);
    std::printf("  %-24s %s\n", "factory calibration",
                rec->has_config ? "applied (CONFIG imu: acc_bias, acc_scale, gyro_bias, axes)"
                                : "none (no CONFIG line)");
    std::printf("  %-24s %s\n", "IMU ranges", describe_survive_imu_scales(*rec).c_str());
    if (six_dof) print_light_status(st, out, rows, light_source, stations);
    if (six_dof) store_placed_setup(args, **tracker, stations);
    if (exit_code() != 0 || args.reference_out.empty()) return;
    std::printf(
        "  %-24s %s (%zu lighthouse poses from %s at %s; %zu with a repeated time, %zu with no "
        "IMU sample in the 50 ms before, skipped)\n",
        "reference", args.reference_out.c_str(), counts.written, counts.what.c_str(),
        args.reference_time == "imu"
            ? ("their IMU sample's instant (" + std::to_string(counts.exact) +
               " sharing its TIME, " + std::to_string(counts.before) + " after it)")
                  .c_str()
            : "their TIME",
        counts.skipped, counts.unmatched);
}

void run_record(const RecordArgs& args) {
    if (args.out.empty() && args.capture.empty())
        return errors.usage("nothing to write: give --out FILE.csv and/or --capture FILE.pcap");
    if (!args.from.empty() && args.backend != "capture" && args.backend != "rec")
        return errors.usage("--from needs --backend capture or rec");
    if (!args.reference_out.empty() && args.backend != "rec")
        return errors.usage("--reference-out needs --backend rec (a recording's lighthouse poses)");
    if (!args.base_stations.empty() && args.backend != "rec" && args.backend != "capture" &&
        args.backend != "hidapi" && args.backend != "libusb")
        return errors.usage(
            "--base-stations needs --backend hidapi, libusb, rec or capture (a device's, a "
            "recording's or a capture's light)");
    if (args.place_base_stations && args.base_stations.empty())
        return errors.usage(
            "--place-base-stations needs --base-stations FILE (read when it is there, the placed "
            "setup written to it)");
    if (args.place_base_stations && args.world_up != "z")
        return errors.usage("--world-up with --place-base-stations: a setup file's world is +z up");
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
    // 6DoF: the device's light interface beside its IMU, with a stored setup.
    spec.base_stations = args.base_stations;
    spec.place_base_stations = args.place_base_stations;
    const bool six_dof = !args.base_stations.empty();
    size_t stations = 0;
    if (six_dof && !setup_stations(args, "--backend " + args.backend, &stations)) return;
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
    TrackerRecording rec =
        record_tracker(tracker, clock, start, end, std::nullopt,
                       /*keep_arrivals=*/false, /*need_pose=*/!args.out.empty(), six_dof);
    const DeviceTrackerStatus st = tracker.status();
    if (six_dof)
        rec.trace.comments.push_back(
            "6DoF: light + IMU (hmdnode's solver and filter), base stations from " +
            args.base_stations +
            ", their world (up z) turned to +y up; rows only where the position is tracked");
    const size_t rows = rec.trace.samples.size();  // (moved into the outputs below)
    // Time 0 is the recording's start on this host's clock: no other trace shares it.
    const std::string time_base =
        "record_start " + backend_name + " " + args.device +
        (args.sim_clock ? std::string(" (simulated clock)")
                        : " at " + std::to_string(start + rt_offset) + " ns realtime");
    // note: --capture alone keeps the raw reports whatever the light did
    const std::string refused =
        six_dof && !args.out.empty() ? six_dof_refusal(args.device, rec, st, args.out) : "";
    finish_tracker_recording(args, label, via, rec, st, pcap.get(), time_base, {}, refused);
    if (six_dof) print_light_status(st, rec, rows, args.base_stations, stations);
    if (six_dof) store_placed_setup(args, tracker, stations);
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
    rec->add_option("--base-stations", args->base_stations,
                    "With --backend hidapi, libusb, rec or capture: a stored base-station setup "
                    "(JSON, docs/formats.md; `hmdnode tracking place` writes one): 6DoF from the "
                    "device's (its light interface beside its IMU one), the recording's or the "
                    "capture's light (rec's default: its LH_POSE lines from before its light, "
                    "when it has them)");
    rec->add_flag("--place-base-stations", args->place_base_stations,
                  "With --base-stations FILE: the base stations FILE lacks (all of them while it "
                  "is not there) placed in the tracker from the device's first still stretch, "
                  "each once its calibration has arrived; the setup written to FILE when it grew "
                  "(docs/tracking.md, placement inside the tracker)");
    rec->add_option("--world-up", args->world_up,
                    "With a light path: the setup's world up axis (z: libsurvive's world; y: a "
                    "setup hmdnode placed levelled)")
        ->check(CLI::IsMember({"x", "y", "z"}))
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
