// Tracker pipeline costs at 1 kHz, side by side with the budget they must fit:
//  1. decode + clock sync + fusion cost per sample (the real Vive capture's reports when the
//     bundled capture in data/traces, else synthetic ones), against the 1,000,000 ns a 1 kHz sample
//     period gives -- and against the simplest possible baseline in the same run: a plain memcpy of
//     the report (what any decoder at least costs);
//  2. sample-to-pose-history latency through the device tracker's reader thread and SPSC ring,
//     on the system clock with the simulated reference tracker (t2's sim backend, 1 kHz, zero
//     transport latency), median / p99 / max -- beside the same figure for the trace-replay
//     sim_tracker, whose reader thread only sleeps and pushes (the ring alone).
//
// Usage: bench_tracker_bench [seconds=3] [--capture FILE.pcap[.gz]] [--write-docs]
//   (--capture: decode that capture's Vive IMU reports instead of the bundled one; an unreadable
//   one is an error. --write-docs: also 1. into docs/results/tracker-bench-decode.md and 2. into
//   docs/results/tracker-bench-latency.md)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/firmware_host/pose_history.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/sim/sim_tracker.hpp"
#include "hmdnode/hal/tracking/clock_sync.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/imu_fusion.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

using namespace hmdnode;
using Clk = std::chrono::steady_clock;

namespace {

std::string out;  // what the bench prints, and writes into the results files with --write-docs

template <typename... Args>
void appendf(const char* fmt, Args... args) {
    char line[512];
    std::snprintf(line, sizeof line, fmt, args...);
    out += line;
}

double pct(std::vector<double> v, double f) {
    return bench::quantile(std::move(v), f);
}

// The Vive IMU reports of `capture` (default: the repository's vive_cal.pcap.gz; synthetic
// reports when that is absent). A capture given with --capture that cannot be read is an error.
std::optional<std::vector<std::vector<uint8_t>>> vive_reports(const std::string& capture) {
    std::vector<std::vector<uint8_t>> reports;
    const auto file =
        capture.empty() ? std::filesystem::path(HMDNODE_SOURCE_DIR) / "data/traces/vive_cal.pcap.gz"
                        : std::filesystem::path(capture);
    auto cap = read_usbmon_capture(file);
    if (!cap.ok() && !capture.empty()) {
        std::fprintf(stderr, "tracker bench: --capture: %s\n", cap.error().message.c_str());
        return std::nullopt;
    }
    if (cap.ok()) {
        for (const UsbPacket& u : cap->packets)
            if (is_interrupt_in_completion(u) && u.data[0] == vive::kImuReportId)
                reports.push_back(u.data);
        appendf("decode input: %zu Vive IMU reports from %s\n", reports.size(),
                bench::in_tree(file.string()).c_str());
        return reports;
    }
    for (uint32_t k = 0; k < 20000; ++k) {
        std::array<vive::RawSlot, 3> s{};
        for (uint32_t j = 0; j < 3; ++j) {
            s[j].sequence = uint8_t(k + j);
            s[j].ticks = (k + j) * 48000;
            s[j].accel = {10, 8192, -20};
            s[j].gyro = {3, -2, 1};
        }
        auto b = vive::encode_imu_report(s);
        reports.emplace_back(b.begin(), b.end());
    }
    appendf(
        "decode input: 20000 synthetic Vive IMU reports (data/traces/vive_cal.pcap.gz absent)\n");
    return reports;
}

bool bench_decode(const std::string& capture) {
    const auto got = vive_reports(capture);
    if (!got) return false;
    const auto& reports = *got;
    const int reps = 5;
    // Baseline: copying each report once.
    std::vector<uint8_t> sink(64);
    auto t0 = Clk::now();
    uint64_t bytes = 0;
    for (int r = 0; r < reps; ++r)
        for (const auto& rep : reports) {
            std::memcpy(sink.data(), rep.data(), std::min<size_t>(rep.size(), 64));
            bytes += sink[r % 64];
        }
    const double copy_ns =
        std::chrono::duration<double, std::nano>(Clk::now() - t0).count() / (reps * reports.size());

    uint64_t samples = 0;
    double decode_ns = 0, full_ns = 0;
    for (int pass = 0; pass < 2; ++pass) {
        t0 = Clk::now();
        samples = 0;
        for (int r = 0; r < reps; ++r) {
            vive::ImuDecoder dec;
            ClockSync sync;
            ImuFusion fusion;
            std::array<vive::ImuSample, 3> out;
            int64_t host = 0;
            for (const auto& rep : reports) {
                const size_t n = dec.decode(rep, out);
                host += 1'000'000;
                for (size_t i = 0; i < n; ++i) {
                    if (pass == 1) {
                        sync.update(out[i].device_time_ns, host);
                        fusion.update(out[i].device_time_ns, out[i].gyro, out[i].accel);
                    }
                }
                samples += n;
            }
            bytes += uint64_t(fusion.orientation().w * 10);
        }
        const double ns = std::chrono::duration<double, std::nano>(Clk::now() - t0).count();
        (pass == 0 ? decode_ns : full_ns) = ns / double(samples);
    }
    appendf("\n1. cost per sample (ns; %llu samples x %d runs)       hmdnode    reference\n",
            (unsigned long long)(samples / reps), reps);
    appendf("   memcpy of the report (per report)               %9.1f\n", copy_ns);
    appendf("   Vive decode                                     %9.1f\n", decode_ns);
    appendf(
        "   decode + clock sync + Mahony fusion             %9.1f    1000000 (1 kHz "
        "period): %.4f %% of a core\n",
        full_ns, full_ns / 1e4);
    if (bytes == 42) std::printf(" ");
    return true;
}

struct Lat {
    std::vector<double> us;
    uint64_t samples = 0, dropped = 0;
};

// Polls the tracker every 50 µs (a frame thread would poll once per frame; the poll interval
// adds to the figure, up to 50 µs) and pushes into a pose history.
Lat consume(Tracker& t, Clock& clock, double seconds) {
    Lat l;
    PoseHistory history;
    std::array<TrackerSample, 256> buf;
    const int64_t end = clock.now_ns() + s_to_ns(seconds);
    while (clock.now_ns() < end) {
        const size_t n = t.read(buf);
        const int64_t now = clock.now_ns();
        for (size_t i = 0; i < n; ++i) {
            history.push(buf[i]);
            l.us.push_back(double(now - buf[i].arrival_ns) / 1e3);
        }
        l.samples += n;
        std::this_thread::sleep_for(std::chrono::microseconds(50));
    }
    l.dropped = t.counters().samples_dropped;
    return l;
}

void bench_latency(double seconds) {
    SystemClock clock;
    // Device tracker over the simulated reference tracker (reader thread, decode, sync, ring).
    SimReferenceDeviceConfig dc;
    dc.latency_ns = 0;
    auto backend = create_sim_reference_backend(clock, dc, sinusoidal_motion());
    DeviceTrackerConfig cfg;
    cfg.filter = DeviceFilter{dc.vendor_id, dc.product_id, {}};
    auto dt = create_device_tracker(std::move(backend), make_reference_codec(), clock, cfg);
    if (!dt.ok()) {
        std::fprintf(stderr, "device tracker: %s\n", dt.error().message.c_str());
        std::exit(1);
    }
    (void)(*dt)->start();
    const Lat a = consume(**dt, clock, seconds);
    (*dt)->stop();

    // Reference: the trace-replay sim tracker (a reader thread that sleeps and pushes).
    auto trace = std::make_shared<Trace>();
    for (int i = 0; i <= int(seconds * 1000) + 1000; ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * 1'000'000;
        trace->samples.push_back(s);
    }
    SimTrackerConfig sc;
    sc.host_start_ns = clock.now_ns() + 5'000'000;
    sc.latency_ns = 0;
    auto st = create_sim_tracker(trace, clock, sc);
    (void)(*st)->start();
    const Lat b = consume(**st, clock, seconds);
    (*st)->stop();

    appendf("\n2. sample arrival -> pose history (us, 1 kHz, %.0f s, 50 us polling)\n", seconds);
    appendf("                                 samples  dropped   median      p99      max\n");
    appendf("   device tracker (sim ref dev)  %7llu  %7llu  %7.1f  %7.1f  %7.1f\n",
            (unsigned long long)a.samples, (unsigned long long)a.dropped, pct(a.us, 0.5),
            pct(a.us, 0.99), pct(a.us, 1.0));
    appendf("   reference: sim_tracker ring   %7llu  %7llu  %7.1f  %7.1f  %7.1f\n",
            (unsigned long long)b.samples, (unsigned long long)b.dropped, pct(b.us, 0.5),
            pct(b.us, 0.99), pct(b.us, 1.0));
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    std::string seconds_arg, capture;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--capture" && i + 1 < argc)
            capture = argv[++i];
        else if (a != "--write-docs" && seconds_arg.empty())
            seconds_arg = a;
    }
    const double parsed = seconds_arg.empty() ? 3.0 : std::atof(seconds_arg.c_str());
    const double seconds = parsed > 0 ? parsed : 3.0;
    std::string command = "build/release/bench/bench_tracker_bench";
    if (!seconds_arg.empty()) {
        command += ' ';
        command += seconds_arg;
    }
    if (!capture.empty()) command += " --capture " + bench::in_tree(capture);
    if (write_docs) command += " --write-docs";
    out = "Measured by `" + command + "` (" + bench::build_kind() + "; " + bench::machine_facts() +
          "; 1. on one thread, 2. a reader thread per tracker and the polling thread):\n\n```\n";
    // The results files name the command and the machine in their headers and hold one part
    // each.
    const size_t decode_start = out.size();
    if (!bench_decode(capture)) return 1;
    const size_t latency_start = out.size();
    bench_latency(seconds);
    const size_t latency_end = out.size();
    out += "```\n";
    std::fputs(out.c_str(), stdout);
    if (write_docs) {
        const std::string decode = out.substr(decode_start, latency_start - decode_start);
        // The latency part opens with a blank line on the terminal.
        const std::string latency = out.substr(latency_start + 1, latency_end - latency_start - 1);
        if (!bench::write_result("tracker-bench-decode",
                                 "Tracker pipeline cost per sample at 1 kHz", command,
                                 "Settings: one thread.\n\n```\n" + decode + "```\n") ||
            !bench::write_result("tracker-bench-latency",
                                 "Sample arrival to pose history through the tracker's reader "
                                 "thread, at 1 kHz",
                                 command,
                                 "Settings: a reader thread per tracker and the polling "
                                 "thread.\n\n```\n" +
                                     latency + "```\n"))
            return 1;
    }
    return 0;
}
