// A replay watched by a camera (observed_replay.hpp): the simulated camera as the mock display's
// watcher, polled after each present, or a camera device streamed on a capture thread; each frame
// decoded as it arrives, the sightings matched to the presents once the replay is done; and the
// observer's table and report. Cost: per camera frame one marker decode; memory one sighting per
// frame.
#include "hmdnode/firmware_host/observed_replay.hpp"

#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>
#include <utility>

#include <nlohmann/json.hpp>

namespace hmdnode {
namespace {

Status check_observed_options(const ReplayOptions& opt) {
    if (opt.node.latency_marker_cell_px <= 0)
        return make_error("the camera observer needs the latency marker (cell size > 0 px)");
    if (!opt.node.warp && !opt.node.distortion)
        return make_error("the camera observer needs the lens pass (distortion or warp on)");
    return {};
}

// The sightings of frames filmed while the node presented (from the first present's vsync to a
// period after the last's), matched; the others counted.
ObservedReplay finish_observed(ReplayResult replay, const std::vector<CameraSighting>& sightings,
                               std::string camera) {
    ObservedReplay out;
    out.camera = std::move(camera);
    std::vector<CameraSighting> inside;
    if (!replay.frames.empty()) {
        const int64_t first = replay.frames.front().vsync_ns;
        const int64_t last = replay.frames.back().vsync_ns + replay.period_ns;
        for (const CameraSighting& s : sightings)
            if (s.capture_ns >= first && s.capture_ns < last) inside.push_back(s);
    }
    out.frames_outside = sightings.size() - inside.size();
    out.observer = match_camera_sightings(inside, replay.frames, replay.period_ns);
    out.replay = std::move(replay);
    return out;
}

std::string ms_cell(double v, int width) {
    char b[32];
    if (std::isfinite(v))
        std::snprintf(b, sizeof b, "%*.2f", width, v);
    else
        std::snprintf(b, sizeof b, "%*s", width, "n/a");
    return b;
}

}  // namespace

Result<ObservedReplay> run_replay_filmed(ReplayOptions opt, const PanelCameraConfig& config) {
    if (Status st = check_observed_options(opt); !st.ok()) return st.error();
    std::unique_ptr<PanelCamera> camera;  // outlives the display, which run_replay destroys
    std::vector<CameraSighting> sightings;
    std::optional<Error> failure;
    opt.display_watcher = [&](Clock& clock,
                              const MockDisplayConfig& panel) -> Result<PanelWatcher*> {
        PanelCameraConfig c = config;
        c.display = panel;
        c.display.watcher = nullptr;
        c.display.frames_dir.clear();
        c.phase_ns += panel.vsync_epoch_ns;  // the camera's phase: from the node's first vsync
        Result<std::unique_ptr<PanelCamera>> made = create_panel_camera(clock, c);
        if (!made.ok()) return made.error();
        camera = std::move(*made);
        return static_cast<PanelWatcher*>(camera.get());
    };
    std::function<void(const FrameRecord&)> progress = opt.on_frame;
    opt.on_frame = [&](const FrameRecord& r) {
        if (progress) progress(r);
        while (camera && !failure) {
            Result<std::optional<CameraFrame>> f = camera->next_frame(0);
            if (!f.ok()) failure = f.error();
            if (!f.ok() || !f->has_value()) break;
            sightings.push_back(sight_camera_frame(**f));
        }
    };
    Result<ReplayResult> r = run_replay(opt);
    if (!r.ok()) return r.error();
    if (failure) return make_error("simulated camera: " + failure->message);
    return finish_observed(std::move(r).value(), sightings, camera ? camera->name() : "sim-panel");
}

Result<ObservedReplay> run_replay_observed(ReplayOptions opt, Camera& camera, int64_t exposure_ns) {
    if (Status st = check_observed_options(opt); !st.ok()) return st.error();
    if (opt.simulated_clock)
        return make_error("camera " + camera.name() + " runs on the real clock, not the simulated");
    if (Status st = camera.start(); !st.ok())
        return make_error("camera " + camera.name() + ": " + st.error().message);
    std::mutex mutex;
    std::vector<CameraSighting> sightings;
    std::optional<Error> failure;
    std::atomic<bool> stop{false};
    // The capture thread: each frame decoded as it arrives, the pixels dropped.
    std::thread capture([&] {
        while (!stop.load()) {
            Result<std::optional<CameraFrame>> f = camera.next_frame(50);
            if (!f.ok()) {
                std::lock_guard<std::mutex> lock(mutex);
                failure = f.error();
                return;
            }
            if (!f->has_value()) continue;
            CameraFrame& cf = **f;
            if (cf.exposure_ns == 0) cf.exposure_ns = exposure_ns;
            CameraSighting s = sight_camera_frame(cf);
            std::lock_guard<std::mutex> lock(mutex);
            sightings.push_back(std::move(s));
        }
    });
    Result<ReplayResult> r = run_replay(opt);
    stop.store(true);
    capture.join();
    camera.stop();
    if (!r.ok()) return r.error();
    if (failure) return make_error("camera " + camera.name() + ": " + failure->message);
    return finish_observed(std::move(r).value(), sightings, camera.name());
}

std::string observer_frames_table(const ObserverResult& r) {
    std::ostringstream out;
    char b[512];
    std::snprintf(b, sizeof b, "%8s %8s %12s %12s %12s\n", "camera", "present", "observed ms",
                  "node ms", "difference");
    out << b;
    for (const ObservedFrame& f : r.frames) {
        if (!f.matched) {
            std::snprintf(b, sizeof b, "%8llu %8s %s: %s\n", (unsigned long long)f.camera_sequence,
                          "-", f.decoded ? "unmatched" : "undecoded", f.reason.c_str());
        } else {
            std::snprintf(b, sizeof b, "%8llu %8llu %s %s %s%s\n",
                          (unsigned long long)f.camera_sequence, (unsigned long long)f.present,
                          ms_cell(f.observed_ms, 12).c_str(), ms_cell(f.node_ms, 12).c_str(),
                          ms_cell(f.difference_ms, 12).c_str(), f.repeat ? "  repeat" : "");
        }
        out << b;
    }
    return out.str();
}

std::string observer_summary_table(const ObserverResult& r) {
    const ObserverSummary& s = r.summary;
    std::ostringstream out;
    char b[512];
    std::snprintf(b, sizeof b,
                  "camera frames %zu: %zu decoded, %zu undecoded, %zu decoded ids never "
                  "presented, %zu repeats, %zu presents skipped\n%-28s %8s %8s %8s %8s\n",
                  s.frames, s.decoded, s.undecoded, s.unmatched, s.repeats, s.skipped, "", "p50",
                  "p95", "p99", "max");
    out << b;
    auto row = [&](const char* label, const Percentiles& p) {
        out << label;
        for (double v : {p.p50, p.p95, p.p99, p.max}) out << ' ' << ms_cell(v, 8);
        out << '\n';
    };
    row("observed MTP (ms)           ", s.observed_ms);
    row("node's, marker's row (ms)   ", s.node_ms);
    row("observed - node (ms)        ", s.difference_ms);
    return out.str();
}

nlohmann::json observer_json(const ObservedReplay& o) {
    using nlohmann::json;
    const ObserverSummary& s = o.observer.summary;
    json frames = json::array();
    for (const ObservedFrame& f : o.observer.frames) {
        json j = {{"camera_sequence", f.camera_sequence},
                  {"decoded", f.decoded},
                  {"matched", f.matched},
                  {"reason", f.reason},
                  {"capture_ns", f.capture_ns}};
        if (f.matched) {
            j["present"] = f.present;
            j["vsync_ns"] = f.vsync_ns;
            j["sample_time_ns"] = f.sample_time_ns;
            j["observed_ms"] = f.observed_ms;
            j["node_ms"] = f.node_ms;
            j["difference_ms"] = f.difference_ms;
            j["repeat"] = f.repeat;
        }
        frames.push_back(std::move(j));
    }
    return {{"camera", o.camera},
            {"frames_outside_run", o.frames_outside},
            {"summary",
             {{"frames", s.frames},
              {"decoded", s.decoded},
              {"undecoded", s.undecoded},
              {"unmatched", s.unmatched},
              {"repeats", s.repeats},
              {"skipped", s.skipped},
              {"observed_ms", percentiles_json(s.observed_ms)},
              {"node_ms", percentiles_json(s.node_ms)},
              {"difference_ms", percentiles_json(s.difference_ms)}}},
            {"frames", frames}};
}

}  // namespace hmdnode
