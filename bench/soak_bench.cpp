// Soak benchmark (the service's reliability targets): hmdnoded as deployed -- its own process, a
// config on the simulated clock (or the real one) with the simulated tracker, a status file and a
// control socket -- runs for a given time while this program samples, every few seconds, its
// resident memory (VmRSS), open file descriptors (/proc/PID/fd) and threads, and asks the control
// socket for `status` and `metrics` (so the socket's own path is soaked too). It prints each sample
// and the least-squares slopes after a warm-up (the first fifth of the run, at least one sample:
// caches, the allocator's arenas and the pipeline settle) beside the targets: RSS < 1 KiB/min, no
// fd growth, a constant thread count, no crash (the daemon exits 0 on SIGTERM at the end).
// Descriptors are read by what they point at (readlink of /proc/PID/fd/N). The status file's atomic
// write (core/src/atomic_file.cpp) holds its temporary `.status.json.tmp.XXXXXX` open while it
// writes and fsyncs it, several times a wall second on the simulated clock, so a sample can catch
// it; it is named in the output and not counted. Growth is a descriptor open at the last two
// samples that was not open at the first after the warm-up (a leak stays open); any other open at a
// sample in between and gone by the end is transient and named too.
//
// Usage: bench_soak_bench [--minutes M=1] [--every S=5] [--clock sim|real] [--tracker
//        trace|sim] [--eye N=64] [--write-docs]
// --write-docs writes the table to docs/results/soak-bench.md (bench/doc_table.hpp), or to
// docs/results/soak-bench-real.md with --clock real.
// Cost: one daemon rendering two N x N eyes as fast as it can (sim clock) for M minutes.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "doc_table.hpp"
#include "hmdnode/firmware_host/control_socket.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using namespace hmdnode;

struct Sample {
    double minutes = 0.0;  // since the first sample
    double rss_kib = 0.0;
    double fds = 0.0;  // open descriptors, the status file's temporary not counted
    double threads = 0.0;
    int64_t frames = 0;
    std::set<std::string> open;     // "N -> target" of each counted descriptor
    bool status_temporary = false;  // the status file's temporary was open
};

// VmRSS (KiB) and Threads from /proc/PID/status, the descriptors from /proc/PID/fd (the one whose
// target starts with `status_temporary` set aside); false when the process is gone.
bool read_status(pid_t pid, const std::string& status_temporary, Sample* s) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    bool rss = false, thr = false;
    for (std::string line; std::getline(in, line);) {
        if (line.rfind("VmRSS:", 0) == 0) rss = (s->rss_kib = std::atof(line.c_str() + 6)) > 0;
        if (line.rfind("Threads:", 0) == 0) thr = (s->threads = std::atof(line.c_str() + 8)) > 0;
    }
    if (!rss || !thr) return false;
    std::error_code ec;
    for (fs::directory_iterator it("/proc/" + std::to_string(pid) + "/fd", ec), end;
         !ec && it != end; it.increment(ec)) {
        std::error_code lec;
        const std::string target = fs::read_symlink(it->path(), lec).string();
        if (lec) continue;  // closed between the listing and the readlink
        if (target.rfind(status_temporary, 0) == 0)
            s->status_temporary = true;
        else
            s->open.insert(it->path().filename().string() + " -> " + target);
    }
    s->fds = double(s->open.size());
    return !ec;
}

// Least-squares slope of y over x (per unit of x); 0 for fewer than two points.
double slope(const std::vector<Sample>& v, double Sample::*y) {
    if (v.size() < 2) return 0.0;
    double mx = 0, my = 0;
    for (const Sample& s : v) mx += s.minutes, my += s.*y;
    mx /= double(v.size());
    my /= double(v.size());
    double sxy = 0, sxx = 0;
    for (const Sample& s : v) {
        sxy += (s.minutes - mx) * (s.*y - my);
        sxx += (s.minutes - mx) * (s.minutes - mx);
    }
    return sxx > 0 ? sxy / sxx : 0.0;
}

int usage() {
    std::fprintf(stderr,
                 "usage: bench_soak_bench [--minutes M] [--every S] [--clock sim|real] "
                 "[--tracker trace|sim] [--eye N] [--write-docs]\n");
    return 2;
}

}  // namespace

int main(int argc, char** argv) {
    double minutes = 1.0, every_s = 5.0;
    int eye = 64;
    std::string clock = "sim", tracker = "trace";
    const bool write_docs = bench::wants_docs(argc, argv);
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has_value = i + 1 < argc;
        if (a == "--write-docs") continue;
        if (!has_value) return usage();
        const std::string v = argv[++i];
        if (a == "--minutes")
            minutes = std::atof(v.c_str());
        else if (a == "--every")
            every_s = std::atof(v.c_str());
        else if (a == "--clock")
            clock = v;
        else if (a == "--tracker")
            tracker = v;
        else if (a == "--eye")
            eye = std::atoi(v.c_str());
        else
            return usage();
    }
    if (!(minutes > 0.0 && every_s > 0.0 && eye > 0) || (clock != "sim" && clock != "real") ||
        (tracker != "trace" && tracker != "sim"))
        return usage();

    const fs::path dir = fs::temp_directory_path() / ("hmdnode_soak_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    nlohmann::json tr = {{"backend", tracker}, {"loop", true}};
    tr["trace"] = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";
    const nlohmann::json cfg = {
        {"scene", HMDNODE_DEMO_SCENE},
        {"clock", clock},
        {"tracker", tr},
        {"display", {{"eye_width", eye}, {"eye_height", eye}}},
        {"status", {{"path", (dir / "status.json").string()}, {"every_s", 1.0}}},
        {"control", {{"path", (dir / "control").string()}}}};
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    const std::string status_temporary = (dir / ".status.json.tmp.").string();

    std::string daemon = HMDNODE_DAEMON, config_arg = (dir / "hmdnoded.json").string(),
                flag = "--config";
    char* args[] = {daemon.data(), flag.data(), config_arg.data(), nullptr};
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    const std::string log = (dir / "log").string();
    posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    // note: as under systemd, the daemon starts with stdin, stdout and stderr alone (not the
    // descriptors the shell running this bench left open), so every fd counted is its own.
    posix_spawn_file_actions_addclosefrom_np(&fa, 3);
    pid_t pid = -1;
    if (posix_spawn(&pid, daemon.c_str(), &fa, nullptr, args, environ) != 0) {
        std::fprintf(stderr, "cannot start %s\n", daemon.c_str());
        return 1;
    }
    posix_spawn_file_actions_destroy(&fa);

    // Ready: the control socket answers with a presented frame.
    using Wall = std::chrono::steady_clock;
    const auto give_up = Wall::now() + std::chrono::seconds(120);
    auto frames_now = [&]() -> int64_t {
        Result<nlohmann::json> r = control_request(dir / "control", {{"cmd", "status"}}, 2000);
        (void)control_request(dir / "control", {{"cmd", "metrics"}}, 2000);
        return r.ok() && r->value("ok", false) ? r->value("frames", int64_t(0)) : -1;
    };
    while (frames_now() <= 0) {
        int st = 0;
        if (Wall::now() > give_up || waitpid(pid, &st, WNOHANG) == pid) {
            std::fprintf(stderr, "the daemon did not become ready; its log: %s\n", log.c_str());
            kill(pid, SIGTERM);
            return 1;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }

    std::printf("%8s %10s %5s %8s %10s\n", "minutes", "RSS KiB", "fds", "threads", "frames");
    std::vector<Sample> samples;
    const auto t0 = Wall::now();
    const auto end = t0 + std::chrono::duration<double>(minutes * 60.0);
    bool alive = true;
    for (auto next = t0; alive; next += std::chrono::duration_cast<Wall::duration>(
                                    std::chrono::duration<double>(every_s))) {
        std::this_thread::sleep_until(next);
        Sample s;
        s.minutes = std::chrono::duration<double>(Wall::now() - t0).count() / 60.0;
        // note: /proc first: a control client's connection is closed by the daemon at its next
        // frame, and counting it would be noise.
        alive = read_status(pid, status_temporary, &s);
        s.frames = frames_now();
        alive = alive && s.frames >= 0;
        if (!alive) break;
        samples.push_back(s);
        std::printf("%8.2f %10.0f %5.0f %8.0f %10lld\n", s.minutes, s.rss_kib, s.fds, s.threads,
                    static_cast<long long>(s.frames));
        std::fflush(stdout);
        if (next >= end) break;
    }
    kill(pid, SIGTERM);
    int st = 0;
    waitpid(pid, &st, 0);
    const bool clean = alive && WIFEXITED(st) && WEXITSTATUS(st) == 0;

    const size_t warm = std::max<size_t>(1, samples.size() / 5);
    const std::vector<Sample> steady(samples.begin() + long(std::min(warm, samples.size())),
                                     samples.end());
    if (steady.size() < 2) {
        std::fprintf(stderr, "too few samples after the warm-up (%zu); run longer\n",
                     steady.size());
        return 1;
    }
    const Sample &first = steady.front(), &last = steady.back();
    const double rss_slope = slope(steady, &Sample::rss_kib);
    const double fd_slope = slope(steady, &Sample::fds);
    // Growth: open at the last two samples, not at the first after the warm-up (a leak stays
    // open; a control connection caught open at the last sample alone does not count).
    // Transient: any other not open at the first; counted by target (samples), the
    // descriptor number left out ("socket:[inode]" stays as it is: one connection).
    const Sample& before_last = steady[steady.size() - 2];
    std::vector<std::string> stayed, grown;
    std::set_intersection(last.open.begin(), last.open.end(), before_last.open.begin(),
                          before_last.open.end(), std::back_inserter(stayed));
    std::set_difference(stayed.begin(), stayed.end(), first.open.begin(), first.open.end(),
                        std::back_inserter(grown));
    std::map<std::string, int> transient;
    int status_temporary_samples = 0;
    double fd_max = 0;
    for (const Sample& s : steady) {
        status_temporary_samples += s.status_temporary;
        fd_max = std::max(fd_max, s.fds);
        for (const std::string& f : s.open)
            if (!first.open.count(f) && !std::binary_search(grown.begin(), grown.end(), f))
                ++transient[f.substr(f.find(" -> ") + 4)];
    }
    std::string transients;
    for (const auto& [target, n] : transient)
        transients += (transients.empty() ? "" : ", ") + target + " at " + std::to_string(n);
    double thr_min = first.threads, thr_max = first.threads;
    for (const Sample& s : steady)
        thr_min = std::min(thr_min, s.threads), thr_max = std::max(thr_max, s.threads);
    const double fps = double(last.frames - first.frames) / ((last.minutes - first.minutes) * 60.0);

    char buf[1024];
    std::snprintf(buf, sizeof buf,
                  "build/release/bench/bench_soak_bench --minutes %g --every %g --clock %s "
                  "--tracker %s --eye %d",
                  minutes, every_s, clock.c_str(), tracker.c_str(), eye);
    const std::string command = buf;
    const std::string measured_by = "Measured by `" + command + "` (" + bench::build_kind() + "; " +
                                    bench::machine_facts() + "): ";
    // The results file names the command and the machine in its header: it holds the rest.
    std::string out;
    std::snprintf(buf, sizeof buf,
                  "hmdnoded on the demo scene, %zu samples, the first %zu (%.1f min) a warm-up "
                  "left out of the slopes; %.0f frames/s over the measured part; the daemon "
                  "%s.\n\n",
                  samples.size(), warm, first.minutes, fps,
                  clean ? "exited 0 on SIGTERM" : "DID NOT exit cleanly");
    out += buf;
    out += "| measure | first | last | slope | target | met |\n|---|---|---|---|---|---|\n";
    std::snprintf(buf, sizeof buf,
                  "| RSS (KiB) | %.0f | %.0f | %+.2f KiB/min | < 1 KiB/min | %s |\n", first.rss_kib,
                  last.rss_kib, rss_slope, rss_slope < 1.0 ? "yes" : "no");
    out += buf;
    std::snprintf(buf, sizeof buf,
                  "| open fds | %.0f | %.0f | %+.3f fds/min (max %.0f); %zu new at the end | 0 "
                  "growth | %s |\n",
                  first.fds, last.fds, fd_slope, fd_max, grown.size(),
                  grown.empty() ? "yes" : "no");
    out += buf;
    std::snprintf(buf, sizeof buf,
                  "| threads | %.0f | %.0f | min %.0f, max %.0f | constant | %s |\n", first.threads,
                  last.threads, thr_min, thr_max, thr_min == thr_max ? "yes" : "no");
    out += buf;
    std::snprintf(buf, sizeof buf, "| crashes | | | %d | 0 | %s |\n", clean ? 0 : 1,
                  clean ? "yes" : "no");
    out += buf;
    std::snprintf(buf, sizeof buf,
                  "\nopen fds leave out the status file's temporary (its atomic write), open at "
                  "%d of the %zu samples after the warm-up; transient (not open at the first "
                  "sample, not at the last two): %s",
                  status_temporary_samples, steady.size(), transients.empty() ? "none" : "");
    out += buf;
    out += transients.empty() ? "" : transients + " samples";
    out += ".\n";
    for (const std::string& f : grown) out += "\nnew at the end: " + f + "\n";
    std::printf("\n%s%s", measured_by.c_str(), out.c_str());
    std::printf("\nopen at the first sample after the warm-up:\n");
    for (const std::string& f : first.open) std::printf("  %s\n", f.c_str());
    if (clean)
        fs::remove_all(dir);
    else
        std::fprintf(stderr, "the daemon's log: %s\n", log.c_str());
    // One table per clock: the hour on the simulated clock, the 10 minutes on the real one.
    if (write_docs &&
        !bench::write_result(
            clock == "real" ? "soak-bench-real" : "soak-bench",
            clock == "real" ? "Soak on the real clock: memory, file descriptors and threads of "
                              "the running daemon"
                            : "Soak on the simulated clock: memory, file descriptors and threads "
                              "of the running daemon",
            command + " --write-docs", out))
        return 1;
    return clean ? 0 : 1;
}
