// `hmdnode tracking place`: where the base stations stand, solved from a lighthouse device's light
// while it lay still (a usbmon capture of the device, or a libsurvive recording), and written as
// the base-station setup file (docs/formats.md) that `record` / `replay --base-stations` and the
// daemon load on their next start -- a real box's setup step. The still stretch is found from the
// device's IMU (hal/tracking/device_light_log.hpp) or given with --still; the world is the
// device's frame there, levelled by its accelerometer (+z up, as libsurvive's). Docs:
// docs/tracking.md §10, docs/commands.md.
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/device_light_log.hpp"
#include "tool/cli_errors.hpp"
#include "tool/tracking_commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors place_errors{"tracking place"};

struct PlaceArgs {
    std::string backend = "capture";  // capture | rec
    std::string from, device, out;
    std::vector<double> still;  // START,END: seconds after the device's first IMU sample
    double min_still_s = 1.0;
};

std::string num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
}

std::string station_name(const lighthouse::BaseStationPlacement& p) {
    return p.generation == lighthouse::Generation::lh2
               ? "lighthouse 2 channel " + std::to_string(p.base_station)
               : "lighthouse 1 base station " + std::to_string(p.base_station);
}

void run_place(const PlaceArgs& args) {
    const CliErrors& errors = place_errors;
    if (args.from.empty()) return errors.usage("--from FILE is required");
    if (args.out.empty()) return errors.usage("--out SETUP.json is required");
    if (args.device.empty())
        return errors.usage(args.backend == "rec"
                                ? "--device NAME is required (the recording's device: HMD, T20, ..)"
                                : "--device VID:PID is required (e.g. 28de:2000)");
    if (!args.still.empty() && (args.still.size() != 2 || !(args.still[1] > args.still[0])))
        return errors.usage("--still START,END: two times in seconds, END after START");
    if (!errors.check_outputs({{"--out", args.out}})) return;
    std::error_code ec;
    if (!std::filesystem::is_regular_file(args.from, ec))
        return errors.fail("--from " + args.from + ": no such file; nothing written");
    auto log = args.backend == "rec" ? device_light_log_from_recording(args.from, args.device)
                                     : device_light_log_from_capture(args.from, args.device);
    if (!log) return errors.fail(log.error().message + "; nothing written");
    for (const std::string& w : log->warnings) errors.warning(w);
    if (log->imu.empty())
        return errors.fail(log->source +
                           ": no IMU sample, so no still stretch and no level; nothing written");
    std::printf("placing base stations from %s\n", log->source.c_str());
    std::printf("  %-22s %zu samples over %.3f s; factory calibration %s\n", "IMU", log->imu.size(),
                ns_to_s(log->imu.back().device_time_ns - log->imu.front().device_time_ns),
                log->has_calibration ? "applied" : "not read");
    std::printf("  %-22s %llu reports (%llu refused%s%s), %zu events\n", "light",
                static_cast<unsigned long long>(log->light_reports),
                static_cast<unsigned long long>(log->rejected_light_reports),
                log->first_rejection.empty() ? "" : ", the first: ", log->first_rejection.c_str(),
                log->events.size());
    const int64_t t0 = log->imu.front().device_time_ns;
    StillStretch use;
    if (!args.still.empty()) {
        use.begin_ns = t0 + s_to_ns(args.still[0]);
        use.end_ns = t0 + s_to_ns(args.still[1]);
        glm::dvec3 sum(0.0);
        size_t n = 0;
        for (const ImuReading& r : log->imu)
            if (r.device_time_ns >= use.begin_ns && r.device_time_ns <= use.end_ns)
                sum += r.accel, ++n;
        if (n == 0)
            return errors.fail("--still " + num(args.still[0]) + "," + num(args.still[1]) +
                               ": no IMU sample in it; nothing written");
        use.mean_accel = sum / double(n);
        std::printf("  %-22s %.3f .. %.3f s (given)\n", "still", args.still[0], args.still[1]);
    } else {
        StillOptions so;
        so.min_duration_s = args.min_still_s;
        const std::vector<StillStretch> found = still_stretches(*log, so);
        const std::optional<StillStretch> best = best_still_stretch(found);
        if (!best || best->light_events == 0)
            return errors.fail(
                log->source + ": " +
                (found.empty() ? "the device never lay still for " + num(args.min_still_s) + " s"
                               : std::string("no light while the device lay still")) +
                " (give --still START,END); nothing written");
        use = *best;
        std::printf(
            "  %-22s %zu stretch(es) of >= %.1f s; placing from %.3f .. %.3f s (%zu light "
            "events, %zu base station(s), gyro sd %.3f deg/s)\n",
            "still", found.size(), args.min_still_s, ns_to_s(use.begin_ns - t0),
            ns_to_s(use.end_ns - t0), use.light_events, use.base_stations,
            use.gyro_sd_rad_s * 180 / M_PI);
    }
    // Levelled by the accelerometer's direction; its size only warns (a wrong range scales it).
    const double g = glm::length(use.mean_accel);
    if (!(g > 1.0))
        return errors.fail("the accelerometer read " + num(g) +
                           " m/s^2 while still: no direction to level the world by; nothing "
                           "written");
    if (!(g > 8.8 && g < 10.8))
        errors.warning("the accelerometer read " + num(g) +
                       " m/s^2 while still, not 1 g (a wrong range or calibration?): levelled by "
                       "its direction");
    const std::optional<glm::dvec3> up = use.mean_accel;
    lighthouse::PlacementResult r = place_from_log(*log, use.begin_ns, use.end_ns, up);
    for (const std::string& why : r.not_placed) std::printf("  not placed: %s\n", why.c_str());
    if (r.placed.empty()) return errors.fail("no base station placed; nothing written");
    const int64_t now = int64_t(std::time(nullptr));
    for (lighthouse::BaseStationPlacement& p : r.placed) {
        p.solved_unix_s = now;
        const glm::dvec3& t = p.world_from_station.position;
        char id[16] = "no id";
        if (p.id) std::snprintf(id, sizeof id, "0x%08x", *p.id);
        std::printf(
            "  %-34s %s, calibration %s, at (%.3f, %.3f, %.3f) m, %.2f m away, residual "
            "%.3f mrad over %zu angles (%zu rejected)\n",
            station_name(p).c_str(), id, p.calibration ? "decoded" : "none (ideal planes)", t.x,
            t.y, t.z, glm::length(t - r.world_from_device.position), p.residual_rms_rad * 1e3,
            p.used, p.rejected);
    }
    if (Status st = lighthouse::save_base_station_setup(args.out, r.placed); !st)
        return place_errors.fail(st.error().message);
    std::printf("  %-22s %s (%zu base station(s); world: %s)\n", "setup", args.out.c_str(),
                r.placed.size(), "the device's frame there, levelled by its accelerometer, +z up");
}

}  // namespace

void add_tracking_place_command(CLI::App& tracking) {
    auto args = std::make_shared<PlaceArgs>();
    CLI::App* c = tracking.add_subcommand(
        "place",
        "Place the base stations from a lighthouse device's light while it lay still (a usbmon "
        "capture or a libsurvive recording) and write the setup file record, replay and the "
        "daemon load");
    c->add_option("--backend", args->backend,
                  "capture (a usbmon capture, --device VID:PID) or rec (a libsurvive recording, "
                  "--device NAME)")
        ->check(CLI::IsMember({"capture", "rec"}))
        ->capture_default_str();
    c->add_option("--from", args->from, "The capture (.pcap[.gz]) or recording (.rec[.gz])");
    c->add_option("--device", args->device, "VID:PID (capture) or the device's name (rec)");
    c->add_option("--out", args->out, "The base-station setup to write (JSON, docs/formats.md)");
    c->add_option("--still", args->still,
                  "START,END: the still stretch, seconds after the device's first IMU sample "
                  "(default: found from the IMU)")
        ->delimiter(',')
        ->expected(2);
    c->add_option("--min-still", args->min_still_s, "Shortest still stretch found, seconds")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    c->callback([args] { run_place(*args); });
}

}  // namespace hmdnode::tool
