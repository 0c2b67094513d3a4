// Replug benchmark (the service's fault-injection target: recovery < 1 s): the simulated reference
// tracker (1 kHz) under the device tracker on the real clock, with its reader thread and the
// default reopen interval (150 ms), unplugged and replugged N times (every other replug a reboot:
// new sequence and device clock). Recovery of one cycle: the replug to the arrival of the first
// sample after it, on the host clock. It prints the minimum, median, p99 and maximum recovery
// beside the target (< 1 s each), the cycles that resumed, and the open file descriptors
// (/proc/self/fd) and threads of this process before the tracker started and after it stopped
// (target: equal).
//
// Usage: bench_replug_bench [--cycles N=100] [--unplugged-ms MS=200] [--write-docs]
// --write-docs writes the table to docs/results/replug-bench.md (bench/doc_table.hpp).
// Cost: N x (MS + recovery) of wall time; one reader thread.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

using namespace hmdnode;

namespace {

// Open file descriptors of this process (less the one listing them).
size_t open_fds() {
    size_t n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) ++n;
    return n - 1;
}

// Threads of this process (/proc/self/status).
size_t threads() {
    std::ifstream in("/proc/self/status");
    for (std::string line; std::getline(in, line);)
        if (line.rfind("Threads:", 0) == 0) return size_t(std::atol(line.c_str() + 8));
    return 0;
}

int usage() {
    std::fprintf(stderr,
                 "usage: bench_replug_bench [--cycles N] [--unplugged-ms MS] [--write-docs]\n");
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    int cycles = 100, unplugged_ms = 200;
    const bool write_docs = bench::wants_docs(argc, argv);
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--write-docs") continue;
        if (i + 1 >= argc) return usage();
        const std::string v = argv[++i];
        if (a == "--cycles")
            cycles = std::atoi(v.c_str());
        else if (a == "--unplugged-ms")
            unplugged_ms = std::atoi(v.c_str());
        else
            return usage();
    }
    if (cycles < 1 || unplugged_ms < 0) return usage();

    const size_t fds_before = open_fds(), threads_before = threads();
    SystemClock clock;
    SimReferenceDeviceConfig dc;
    auto backend_owned = create_sim_reference_backend(clock, dc, sinusoidal_motion());
    SimReferenceBackend* device = backend_owned.get();
    DeviceTrackerConfig tc;
    tc.filter = DeviceFilter{dc.vendor_id, dc.product_id, ""};
    auto tracker =
        create_device_tracker(std::move(backend_owned), make_reference_codec(), clock, tc);
    if (!tracker || !(*tracker)->start().ok()) {
        std::fprintf(stderr, "the device tracker did not start\n");
        return 1;
    }
    std::vector<TrackerSample> buf(256);
    // The arrival of the first sample at or after `since`, polling every 0.2 ms for up to 10 s;
    // 0 when none came.
    auto first_after = [&](int64_t since) -> int64_t {
        const int64_t give_up = clock.now_ns() + 10 * kNsPerSecond;
        while (clock.now_ns() < give_up) {
            const size_t n = (*tracker)->read(buf);
            for (size_t k = 0; k < n; ++k)
                if (buf[k].arrival_ns >= since) return buf[k].arrival_ns;
            std::this_thread::sleep_for(std::chrono::microseconds(200));
        }
        return 0;
    };
    if (!first_after(clock.now_ns())) {
        std::fprintf(stderr, "no sample before the first unplug\n");
        return 1;
    }
    std::vector<double> recovery_ms;
    int resumed = 0;
    for (int c = 0; c < cycles; ++c) {
        device->unplug();
        std::this_thread::sleep_for(std::chrono::milliseconds(unplugged_ms));
        device->replug(/*reboot=*/c % 2 == 0);
        const int64_t replug_ns = clock.now_ns();
        const int64_t first = first_after(replug_ns);
        if (first) {
            ++resumed;
            recovery_ms.push_back(double(first - replug_ns) / 1e6);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));  // steady again
    }
    const DeviceTrackerStatus st = (*tracker)->status();
    (*tracker)->stop();
    tracker->reset();
    const size_t fds_after = open_fds(), threads_after = threads();

    const double worst =
        recovery_ms.empty() ? 0.0 : *std::max_element(recovery_ms.begin(), recovery_ms.end());
    const bool met = resumed == cycles && worst < 1000.0 && fds_after == fds_before &&
                     threads_after == threads_before;
    char line[1024];
    std::snprintf(line, sizeof line,
                  "build/release/bench/bench_replug_bench --cycles %d --unplugged-ms %d", cycles,
                  unplugged_ms);
    const std::string command = line;
    const std::string measured_by = "Measured by `" + command + "` (" + bench::build_kind() + "; " +
                                    bench::machine_facts() + "): ";
    // The results file names the command and the machine in its header: it holds the rest.
    std::string out;
    std::snprintf(line, sizeof line,
                  "the simulated reference tracker at 1 kHz under the device "
                  "tracker (reader thread, reopen interval %lld ms), %d unplug/replug cycles of "
                  "%d ms, every other replug a reboot; the tracker counted %llu disconnects and "
                  "%llu opens.\n\n",
                  static_cast<long long>(tc.reopen_interval_ns / kNsPerMs), cycles, unplugged_ms,
                  static_cast<unsigned long long>(st.disconnects),
                  static_cast<unsigned long long>(st.opens));
    out += line;
    out += "| measure | value | target | met |\n|---|---|---|---|\n";
    std::snprintf(line, sizeof line, "| cycles resumed | %d / %d | all | %s |\n", resumed, cycles,
                  resumed == cycles ? "yes" : "no");
    out += line;
    std::snprintf(line, sizeof line,
                  "| recovery (replug to first sample) | min %.1f ms, median %.1f ms, p99 %.1f ms, "
                  "max %.1f ms | < 1 s each | %s |\n",
                  bench::quantile(recovery_ms, 0.0), bench::quantile(recovery_ms, 0.5),
                  bench::quantile(recovery_ms, 0.99), worst, worst < 1000.0 ? "yes" : "no");
    out += line;
    std::snprintf(line, sizeof line, "| open fds, before / after | %zu / %zu | equal | %s |\n",
                  fds_before, fds_after, fds_after == fds_before ? "yes" : "no");
    out += line;
    std::snprintf(line, sizeof line, "| threads, before / after | %zu / %zu | equal | %s |\n",
                  threads_before, threads_after, threads_after == threads_before ? "yes" : "no");
    out += line;
    std::printf("%s%s", measured_by.c_str(), out.c_str());
    out[0] = 'T';  // "The simulated reference tracker ..."
    if (write_docs && !bench::write_result("replug-bench",
                                           "Recovery of the device tracker from unplug and replug",
                                           command + " --write-docs", out))
        return 1;
    return met ? 0 : 1;
}
