// Lighthouse light cost per event, decode + solve on one thread, and the whole light path
// (decode, solve and light + IMU fusion), against the budget of 50 us per light event
// (decoding + solving + fusion), beside the
// accuracy of the light-only poses against libsurvive's own solved poses (POSE lines, libsurvive's
// light + IMU fusion) and how well each explains the raw angles (RMS residual of the calibrated
// model, libsurvive's pose interpolated to each angle's time). Per bundled recording:
//  1. decode: the recording's W / Y / C lines through lighthouse::LightDecoder (the same per-line
//     work a USB report's words cost);
//  2. solve: a solve per rotor turn (20 ms; lighthouse 1: 34 ms, both base stations' two axes)
//     over that window's newest angles, warm-started from the previous solve, with libsurvive's
//     base-station poses (LH_POSE, solved during the recording: look-ahead standing in for a
//     stored setup);
//  3. path: LightTracking (light_tracking.hpp) over the recording's lines in file order: each
//     light line decoded, a solve per rotor turn fed to the light + IMU filter, every IMU sample
//     (decoded beforehand by the Index codec, not timed) a filter step; per light event.
// Thread CPU time of the fastest of `reps` runs.
//
// Usage: bench_lighthouse_bench [reps=3] [--write-docs]
//   (--write-docs: also into docs/results/lighthouse-bench.md)
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/core/orientation_eval.hpp"
#include "hmdnode/core/position_eval.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/imu_fusion.hpp"
#include "hmdnode/hal/tracking/light_tracking.hpp"
#include "hmdnode/hal/tracking/lighthouse_solver.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

using namespace hmdnode;
using namespace hmdnode::lighthouse;

namespace {

std::string out;
std::string accuracy;  // the second table: the fused track against libsurvive's, aligned
std::string disagree;  // the fourth: which track the raw angles support where the two disagree
std::string placed;    // the third: no stored setup, the base stations placed in the tracker

template <typename... Args>
void appendf(const char* fmt, Args... args) {
    char line[768];
    std::snprintf(line, sizeof line, fmt, args...);
    out += line;
}

struct Case {
    const char* file;
    const char* device;
    int64_t window_ns;
    // The setup keeps each base station's calibration (the decoder's, after the whole recording:
    // look-ahead standing in for what `tracking place` stores), so the light path solves from the
    // first light instead of waiting for each calibration frame. Accuracy table only.
    bool stored_calibrations = false;
};

// libsurvive's pose of the model frame (its POSE lines are of the head frame) at recording time t.
bool reference_at(const SurviveRecording& rec, int64_t t, RigidPose* p) {
    auto it = std::lower_bound(rec.poses.begin(), rec.poses.end(), t,
                               [](const SurvivePose& a, int64_t v) { return a.host_time_ns < v; });
    if (it == rec.poses.begin() || it == rec.poses.end()) return false;
    const SurvivePose &b = *it, &a = *(it - 1);
    if (b.host_time_ns - a.host_time_ns > 50'000'000) return false;
    const double f = double(t - a.host_time_ns) / double(b.host_time_ns - a.host_time_ns);
    const glm::dquat q = glm::slerp(a.orientation, b.orientation, f);
    const glm::dquat mt = glm::quat_cast(glm::transpose(rec.sensors.model_from_head));
    p->orientation = glm::normalize(q * mt);
    p->position = glm::mix(a.position, b.position, f) - p->orientation * rec.sensors.head_origin;
    return true;
}

double rms_of(const std::vector<double>& abs_res) {
    if (abs_res.empty()) return NAN;
    // libsurvive's residuals, its outliers left out by the solver's own rule (4 robust sigmas)
    const double limit = 4 * std::max(1.4826 * bench::quantile(abs_res, 0.5), 2e-4);
    double ss = 0;
    size_t n = 0;
    for (double x : abs_res)
        if (x <= limit) ss += x * x, ++n;
    return std::sqrt(ss / double(n));
}

// |measured - predicted| of one raw angle, the device at the pose `poses` has at the angle's
// recording time (reference_at: libsurvive's POSE lines, or another track in their place);
// nullopt when its base station is not placed or the track has no pose then.
std::optional<double> angle_residual(const SurviveRecording& poses, const AngleSample& a,
                                     const std::vector<PlacedBaseStation>& stations,
                                     const SensorLayout& layout, int64_t host_minus_device) {
    RigidPose r;
    const PlacedBaseStation* st = nullptr;
    for (const PlacedBaseStation& p : stations)
        if (p.generation == a.generation && p.base_station == a.base_station) st = &p;
    if (!st || !reference_at(poses, a.device_time_ns + host_minus_device, &r)) return std::nullopt;
    const glm::dvec3 w = r.position + r.orientation * layout.points[a.sensor];
    const glm::dvec3 q =
        glm::conjugate(st->world_from_station.orientation) * (w - st->world_from_station.position);
    const PlaneCalibration cal =
        st->calibration ? st->calibration->plane[a.plane & 1] : PlaneCalibration{};
    const double p = a.generation == Generation::lh2 ? lh2_predict_angle(cal, a.plane & 1, q)
                                                     : lh1_predict_angle(cal, a.plane & 1, q);
    return std::abs(std::remainder(a.angle - p, 2 * M_PI));
}

// The recording's IMU lines through the Index codec with its calibration: (TIME, samples).
std::vector<std::pair<int64_t, std::vector<DeviceSample>>> decode_imu(
    const std::shared_ptr<const SurviveRecording>& rec) {
    std::vector<std::pair<int64_t, std::vector<DeviceSample>>> out;
    auto backend = create_survive_backend(rec);
    auto ids = backend->enumerate(DeviceFilter{vive::kVendorId, vive::kIndexProductId, ""});
    if (!ids || ids->empty()) return out;
    auto t = backend->open(ids->front());
    if (!t) return out;
    auto codec = make_vive_codec(vive::kIndexProductId);
    if (rec->has_config) codec->set_imu_calibration(rec->calibration);
    codec->configure(**t);
    for (const SurviveImuLine& l : rec->imu) {
        auto in = (*t)->read_input(0);
        if (!in || !in->has_value()) break;
        std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> buf;
        const size_t n = codec->decode((*in)->bytes, buf);
        out.push_back({l.host_time_ns, {buf.begin(), buf.begin() + long(n)}});
    }
    return out;
}

// The recording's light lines, in file order, through a decoder into LightTracking, up to a
// recording time at a time (the light path's per-line work).
struct LightFeed {
    const SurviveRecording& rec;
    LightDecoder dec;
    std::vector<LightEvent> ev;
    size_t next = 0;
    explicit LightFeed(const SurviveRecording& r) : rec(r), dec(survive_sensor_model(r)) {}
    void until(int64_t t, LightTracking& lt) {
        using K = SurviveLightLine::Kind;
        for (; next < rec.light.size() && rec.light[next].host_time_ns <= t; ++next) {
            const SurviveLightLine& l = rec.light[next];
            if (l.kind == K::sweep)
                (void)dec.add_lh2_sweep(l.channel, l.sensor, l.timecode, l.flag != 0);
            else if (l.kind == K::sync)
                (void)dec.add_lh2_sync(l.channel, l.timecode, l.flag != 0, l.gen != 0);
            else if (l.kind == K::pulse)
                (void)dec.add_lh1_pulse(l.sensor, l.timecode, l.length);
            else
                continue;
            ev.clear();
            dec.take_events(ev);
            lt.add_light(ev, dec);
        }
    }
};

// 3. The whole light path, in file order; thread CPU ms of the fastest of `reps`.
double light_path_ms(const SurviveRecording& rec, const LightTrackingConfig& cfg,
                     const std::vector<std::pair<int64_t, std::vector<DeviceSample>>>& imu,
                     int reps, LightTrackingCounters* counters) {
    double best = INFINITY;
    for (int k = 0; k < reps; ++k) {
        LightTracking lt(cfg);
        LightFeed feed(rec);
        const double t0 = bench::thread_cpu_ms();
        for (const auto& [time, samples] : imu) {
            feed.until(time, lt);
            for (const DeviceSample& d : samples)
                if (d.gyro && d.accel) lt.add_imu(d.device_time_ns, *d.gyro, *d.accel, d.imu_flags);
        }
        feed.until(INT64_MAX, lt);
        best = std::min(best, bench::thread_cpu_ms() - t0);
        *counters = lt.counters();
    }
    return best;
}

// The head pose of a solve (model frame).
TraceSample head_sample(const SurviveRecording& rec, int64_t t, const RigidPose& model) {
    const glm::dquat mt = glm::quat_cast(glm::transpose(rec.sensors.model_from_head));
    TraceSample s;
    s.time_ns = t;
    s.orientation = glm::normalize(model.orientation * glm::conjugate(mt));
    s.position = model.position + model.orientation * rec.sensors.head_origin;
    return s;
}

// Appends a sample keeping the trace's times increasing and its quaternions in one hemisphere.
void push_sample(Trace* t, TraceSample s) {
    if (!t->samples.empty()) {
        if (s.time_ns <= t->samples.back().time_ns) return;
        if (glm::dot(s.orientation, t->samples.back().orientation) < 0)
            s.orientation = -s.orientation;
    }
    t->samples.push_back(std::move(s));
}

// The fused track's accuracy against libsurvive's (constant alignment, lever arm and time offset
// fitted, libsurvive's glitches left out), as `hmdnode tracking eval --time-offset auto` fits it.
struct Accuracy {
    bool ok = false;
    std::string error;
    double pos_p50 = 0, pos_p90 = 0, rot_p50 = 0, rot_p90 = 0;
    size_t glitch_samples = 0, samples = 0;
    // The reference's times (its timeline) of the samples more than kDisagreeMm apart, aligned.
    std::vector<int64_t> disagree_ns;
};

// Where a track and libsurvive's disagree: more than the position target's p90 apart (aligned).
constexpr double kDisagreeMm = 10.0;

Accuracy accuracy_of(const Trace& reference, const Trace& estimate) {
    Accuracy a;
    OrientationEvalOptions o;
    o.fit_time_offset = true;
    auto orient = evaluate_orientation(reference, estimate, o);
    if (!orient) {
        a.error = orient.error().message;
        return a;
    }
    PositionEvalOptions po;
    po.fit_time_offset = true;
    auto pos = evaluate_position(reference, estimate, *orient, po);
    if (!pos) {
        a.error = pos.error().message;
        return a;
    }
    a.ok = true;
    a.pos_p50 = pos->p50_mm;
    a.pos_p90 = pos->p90_mm;
    a.rot_p50 = bench::quantile(orient->error_deg, 0.5);
    a.rot_p90 = bench::quantile(orient->error_deg, 0.9);
    a.glitch_samples = orient->glitches.samples_left_out;
    a.samples = orient->samples;
    for (size_t i = 0; i < pos->error_mm.size() && i < orient->time_ns.size(); ++i)
        if (pos->error_mm[i] > kDisagreeMm) a.disagree_ns.push_back(orient->time_ns[i]);
    return a;
}

// Orientation only (the IMU-only track against the light + IMU one): p50 / p95 deg.
std::pair<double, double> orientation_only(const Trace& reference, const Trace& estimate) {
    OrientationEvalOptions o;
    o.fit_time_offset = true;
    o.leave_out_reference_glitches = false;
    auto e = evaluate_orientation(reference, estimate, o);
    if (!e) return {NAN, NAN};
    return {e->error.p50, e->error.p95};
}

// The residual of a pose track (head poses by recording time) over the raw angles.
double track_residual_rms(const SurviveRecording& rec, const std::vector<SurvivePose>& track,
                          const std::vector<std::vector<AngleSample>>& windows,
                          const std::vector<PlacedBaseStation>& stations,
                          const SensorLayout& layout, int64_t host_minus_device,
                          size_t stride = 1) {
    SurviveRecording view;  // reference_at over `track`, with the recording's sensor frame
    view.sensors = rec.sensors;
    view.poses = track;
    std::vector<double> abs_res;
    for (size_t wi = 0; wi < windows.size(); wi += stride)
        for (const AngleSample& a : windows[wi]) {
            if (auto r = angle_residual(view, a, stations, layout, host_minus_device))
                abs_res.push_back(*r);
        }
    return abs_res.empty() ? NAN : rms_of(abs_res);
}

// The same with the track's time shifted by the offset (1 ms grid, +-40 ms, on every 8th window)
// that explains the angles best: a track's lag is not held against its shape. Returns the rms at
// that offset over every window, and the offset (ms).
std::pair<double, double> best_residual_rms(const SurviveRecording& rec,
                                            const std::vector<SurvivePose>& track,
                                            const std::vector<std::vector<AngleSample>>& windows,
                                            const std::vector<PlacedBaseStation>& stations,
                                            const SensorLayout& layout, int64_t host_minus_device) {
    double best = INFINITY;
    int best_ms = 0;
    for (int ms = -40; ms <= 40; ++ms) {
        const double r = track_residual_rms(rec, track, windows, stations, layout,
                                            host_minus_device + int64_t(ms) * 1'000'000, 8);
        if (r < best) best = r, best_ms = ms;
    }
    if (!std::isfinite(best)) return {NAN, NAN};
    return {track_residual_rms(rec, track, windows, stations, layout,
                               host_minus_device + int64_t(best_ms) * 1'000'000),
            double(best_ms)};
}

// The light path once more (not timed), keeping its fused pose after every IMU sample (by the
// IMU line's TIME, as libsurvive's POSE lines), while tracked; and the IMU-only track of the same
// samples (ImuFusion). first_good: the TIME of the first tracked pose (-1: none).
void fused_tracks(const SurviveRecording& rec, const LightTrackingConfig& cfg,
                  const std::vector<std::pair<int64_t, std::vector<DeviceSample>>>& imu,
                  std::vector<SurvivePose>* fused, Trace* imu_only, int64_t* first_good,
                  LightTrackingCounters* counters = nullptr) {
    LightTracking lt(cfg);
    LightFeed feed(rec);
    ImuFusion fusion;
    *first_good = -1;
    for (const auto& [time, samples] : imu) {
        feed.until(time, lt);
        for (const DeviceSample& d : samples) {
            if (!d.gyro || !d.accel) continue;
            lt.add_imu(d.device_time_ns, *d.gyro, *d.accel, d.imu_flags);
            fusion.update(d.device_time_ns, *d.gyro, *d.accel, d.imu_flags);
        }
        if (fusion.initialized()) {
            TraceSample s;
            s.time_ns = time;
            s.orientation = fusion.orientation();
            push_sample(imu_only, s);
        }
        const FilterPose p = lt.pose();
        if (!p.good()) continue;
        if (*first_good < 0) *first_good = time;
        if (!fused->empty() && time <= fused->back().host_time_ns) continue;
        fused->push_back({time, p.position, p.orientation});
    }
    if (counters) *counters = lt.counters();
}

bool bench_case(const Case& c, int reps) {
    const std::string path = std::string(HMDNODE_SOURCE_DIR) + "/data/traces/" + c.file;
    auto rec = read_survive_recording(path, c.device);
    if (!rec) {
        std::fprintf(stderr, "%s\n", rec.error().message.c_str());
        return false;
    }
    // 1. decode
    double decode_ms = INFINITY;
    std::vector<LightEvent> events;
    std::vector<BaseStationState> known;
    for (int k = 0; k < reps; ++k) {
        LightDecoder dec(survive_sensor_model(*rec));
        const double t0 = bench::thread_cpu_ms();
        Status st = replay_survive_light(*rec, dec);
        const double t1 = bench::thread_cpu_ms();
        if (!st.ok()) {
            std::fprintf(stderr, "%s\n", st.error().message.c_str());
            return false;
        }
        decode_ms = std::min(decode_ms, t1 - t0);
        events.clear();
        dec.take_events(events);
        known = dec.base_stations();
    }
    auto setup = recording_base_station_setup(*rec, known, /*allow_look_ahead=*/true);
    if (!setup) {
        std::fprintf(stderr, "%s\n", setup.error().message.c_str());
        return false;
    }
    const std::vector<PlacedBaseStation> stations = placed_stations(*setup, known);
    const SensorLayout layout{rec->sensors.points, rec->sensors.normals};
    std::sort(events.begin(), events.end(), [](const LightEvent& a, const LightEvent& b) {
        return a.device_time_ns < b.device_time_ns;
    });
    // recording time - device time: the median over the events' W / C lines
    std::map<uint32_t, int64_t> line_time;
    for (const SurviveLightLine& l : rec->light)
        if (l.kind == SurviveLightLine::Kind::sweep || l.kind == SurviveLightLine::Kind::pulse)
            line_time.emplace(l.timecode, l.host_time_ns);
    std::vector<double> offsets;
    for (const LightEvent& e : events)
        if (auto it = line_time.find(e.timecode); it != line_time.end())
            offsets.push_back(double(it->second - e.device_time_ns));
    const int64_t host_minus_device = int64_t(bench::quantile(offsets, 0.5));

    // 2. solve, each window's angles gathered first (part of the cost)
    double solve_ms = INFINITY;
    std::vector<PoseSolve> solves;
    std::vector<std::vector<AngleSample>> windows;
    for (int k = 0; k < reps; ++k) {
        solves.clear();
        windows.clear();
        std::optional<RigidPose> warm;
        size_t lo = 0, hi = 0;
        const double t0 = bench::thread_cpu_ms();
        for (int64_t t = events.front().device_time_ns + c.window_ns;
             t <= events.back().device_time_ns; t += c.window_ns) {
            while (hi < events.size() && events[hi].device_time_ns <= t) ++hi;
            while (lo < hi && events[lo].device_time_ns <= t - c.window_ns) ++lo;
            windows.push_back(
                newest_angles(std::span<const LightEvent>(events.data() + lo, hi - lo)));
            solves.push_back(solve_device_pose(layout, stations, windows.back(), warm));
            if (solves.back().ok())
                warm = solves.back().world_from_device;
            else if (solves.back().outcome == SolveOutcome::no_fit)
                warm.reset();
        }
        solve_ms = std::min(solve_ms, bench::thread_cpu_ms() - t0);
    }
    // accuracy against libsurvive's poses; residuals of both
    std::vector<double> pos_mm, rot_deg, ours, theirs_abs;
    size_t solved = 0;
    for (size_t i = 0; i < solves.size(); ++i) {
        const PoseSolve& s = solves[i];
        if (!s.ok()) continue;
        ++solved;
        RigidPose ref;
        if (!reference_at(*rec, s.device_time_ns + host_minus_device, &ref)) continue;
        pos_mm.push_back(glm::length(s.world_from_device->position - ref.position) * 1e3);
        rot_deg.push_back(
            2 *
            std::acos(std::min(
                1.0, std::abs(glm::dot(s.world_from_device->orientation, ref.orientation)))) *
            180 / M_PI);
        ours.push_back(s.residual_rms_rad * 1e3);
        for (const AngleSample& a : windows[i]) {
            if (auto r = angle_residual(*rec, a, stations, layout, host_minus_device))
                theirs_abs.push_back(*r);
        }
    }
    // 3. the whole light path
    auto shared = std::make_shared<const SurviveRecording>(*rec);
    auto cfg = survive_light_tracking_config(*rec, *setup);
    if (!cfg) {
        std::fprintf(stderr, "%s\n", cfg.error().message.c_str());
        return false;
    }
    if (c.stored_calibrations)
        for (BaseStationPlacement& p : cfg->setup)
            for (const BaseStationState& k : known)
                if (k.generation == p.generation && k.base_station == p.base_station &&
                    k.calibration) {
                    p.calibration = stored_calibration(*k.calibration);
                    p.id = k.calibration->id;
                }
    LightTrackingCounters lc;
    const auto imu = decode_imu(shared);
    const double path_ms = light_path_ms(*rec, *cfg, imu, reps, &lc);
    const double n = double(events.size());
    if (!c.stored_calibrations)
        appendf(
            "%-26s %-4s %7zu %6zu/%-6zu %7.2f %7.2f %7.2f %8.2f   %6.2f %6.2f  %6.3f %6.3f  %6.3f "
            "%6.3f\n",
            c.file, c.device, events.size(), solved, solves.size(), decode_ms * 1e3 / n,
            solve_ms * 1e3 / n, (decode_ms + solve_ms) * 1e3 / n,
            path_ms * 1e3 / double(std::max<uint64_t>(lc.events, 1)), bench::quantile(pos_mm, 0.5),
            bench::quantile(pos_mm, 0.9), bench::quantile(rot_deg, 0.5),
            bench::quantile(rot_deg, 0.9), bench::quantile(ours, 0.5), rms_of(theirs_abs) * 1e3);

    // 4. accuracy of the fused and the light-only tracks against libsurvive's, aligned
    std::vector<SurvivePose> fused;
    Trace imu_only, fused_trace, light_only, reference;
    int64_t first_good = -1;
    fused_tracks(*rec, *cfg, imu, &fused, &imu_only, &first_good);
    for (const SurvivePose& p : fused) {
        TraceSample s;
        s.time_ns = p.host_time_ns;
        s.orientation = p.orientation;
        s.position = p.position;
        push_sample(&fused_trace, s);
    }
    for (const SurvivePose& p : rec->poses) {
        TraceSample s;
        s.time_ns = p.host_time_ns;
        s.orientation = p.orientation;
        s.position = p.position;
        push_sample(&reference, s);
    }
    for (const PoseSolve& sv : solves)
        if (sv.ok())
            push_sample(&light_only, head_sample(*rec, sv.device_time_ns + host_minus_device,
                                                 *sv.world_from_device));
    const Accuracy fa = accuracy_of(reference, fused_trace);
    const Accuracy la = accuracy_of(reference, light_only);
    const auto [imu_p50, imu_p95] = orientation_only(fused_trace, imu_only);
    const auto [fused_rms, fused_lag] =
        best_residual_rms(*rec, fused, windows, stations, layout, host_minus_device);
    const auto [lib_rms, lib_lag] =
        best_residual_rms(*rec, rec->poses, windows, stations, layout, host_minus_device);
    std::vector<SurvivePose> light_track;  // the solves as a track, interpolated between them
    for (const TraceSample& t : light_only.samples)
        light_track.push_back({t.time_ns, *t.position, t.orientation});
    const double light_rms =
        best_residual_rms(*rec, light_track, windows, stations, layout, host_minus_device).first;
    int64_t first_light = rec->light.empty() ? 0 : rec->light.front().host_time_ns;
    const double ready_ours = first_good < 0 ? NAN : ns_to_s(first_good - first_light);
    const double ready_lib =
        rec->poses.empty() ? NAN : ns_to_s(rec->poses.front().host_time_ns - first_light);
    if (!fa.ok) std::fprintf(stderr, "%s %s: fused: %s\n", c.file, c.device, fa.error.c_str());
    if (!la.ok) std::fprintf(stderr, "%s %s: light-only: %s\n", c.file, c.device, la.error.c_str());
    // A figure, or "-" where the track has none (a device whose IMU is not decoded: no fused
    // track).
    auto num = [](double v, bool ok, const char* fmt, int width) {
        char b[32];
        if (!ok || !std::isfinite(v))
            std::snprintf(b, sizeof b, "%*s", width, "-");
        else
            std::snprintf(b, sizeof b, fmt, v);
        return std::string(b);
    };
    char name[64];
    std::snprintf(name, sizeof name, "%-26s %-4s", c.file,
                  (std::string(c.device) + (c.stored_calibrations ? "*" : "")).c_str());
    std::string line = name;
    line += " " + num(fa.pos_p50, fa.ok, "%6.2f", 6) + " " + num(fa.pos_p90, fa.ok, "%6.2f", 6);
    line += "  " + num(fa.rot_p50, fa.ok, "%6.3f", 6) + " " + num(fa.rot_p90, fa.ok, "%6.3f", 6);
    line += " " + num(double(fa.glitch_samples), fa.ok, "%6.0f", 6);
    line += "  " + num(la.pos_p50, la.ok, "%6.2f", 6) + " " + num(la.pos_p90, la.ok, "%6.2f", 6);
    line += "  " + num(la.rot_p50, la.ok, "%6.3f", 6) + " " + num(la.rot_p90, la.ok, "%6.3f", 6);
    line += "  " + num(light_rms * 1e3, true, "%6.3f", 6) + " " +
            num(fused_rms * 1e3, true, "%6.3f", 6) + " " + num(lib_rms * 1e3, true, "%6.3f", 6);
    line += "  " + num(fused_lag, true, "%4.0f", 4) + " " + num(lib_lag, true, "%4.0f", 4);
    line += "  " + num(imu_p50, true, "%6.3f", 6) + " " + num(imu_p95, true, "%6.3f", 6);
    line += "  " + num(ready_ours, true, "%6.2f", 6) + " " + num(ready_lib, true, "%6.2f", 6);
    accuracy += line + "\n";

    // Which track the raw angles support where the fused track and libsurvive's disagree: the
    // residuals over the windows within 5 ms of a disagreeing reference sample, and over the
    // other windows of libsurvive's span (the same windows for every track).
    if (!c.stored_calibrations && fa.ok && !rec->poses.empty()) {
        const int64_t lib_first = rec->poses.front().host_time_ns,
                      lib_last = rec->poses.back().host_time_ns;
        std::vector<std::vector<AngleSample>> apart, agree;
        for (const std::vector<AngleSample>& w : windows) {
            if (w.empty()) continue;
            const int64_t t = w.back().device_time_ns + host_minus_device;
            if (t < lib_first || t > lib_last || (first_good >= 0 && t < first_good)) continue;
            auto it = std::lower_bound(fa.disagree_ns.begin(), fa.disagree_ns.end(), t - 5'000'000);
            const bool near = it != fa.disagree_ns.end() && *it <= t + 5'000'000;
            (near ? apart : agree).push_back(w);
        }
        auto rms3 = [&](const std::vector<std::vector<AngleSample>>& ws) {
            std::string r;
            for (const std::vector<SurvivePose>* tr : {&light_track, &fused, &rec->poses}) {
                const double v = ws.empty() ? NAN
                                            : best_residual_rms(*rec, *tr, ws, stations, layout,
                                                                host_minus_device)
                                                  .first;
                r.push_back(' ');
                r.append(num(v * 1e3, true, "%6.3f", 6));
            }
            return r;
        };
        char dl[256];
        std::snprintf(
            dl, sizeof dl, "%-26s %-4s %6zu %5.1f %% %7zu %7zu", c.file, c.device,
            fa.disagree_ns.size(),
            100.0 * double(fa.disagree_ns.size()) / double(std::max<size_t>(fa.samples, 1)),
            apart.size(), agree.size());
        disagree += std::string(dl) + " " + rms3(apart) + "  " + rms3(agree) + "\n";
    }
    if (c.stored_calibrations) return true;

    // 5. No stored setup: the base stations placed inside the tracker from a still stretch.
    LightTrackingConfig pc = *cfg;
    pc.setup.clear();
    pc.place.enabled = true;
    std::vector<SurvivePose> pfused;
    Trace pimu, ptrace;
    int64_t pfirst = -1;
    LightTrackingCounters pcount;
    fused_tracks(*rec, pc, imu, &pfused, &pimu, &pfirst, &pcount);
    for (const SurvivePose& p : pfused) {
        TraceSample s;
        s.time_ns = p.host_time_ns;
        s.orientation = p.orientation;
        s.position = p.position;
        push_sample(&ptrace, s);
    }
    const Accuracy pa = accuracy_of(reference, ptrace);
    if (!pa.ok) std::fprintf(stderr, "%s %s: placed: %s\n", c.file, c.device, pa.error.c_str());
    const double pready = pfirst < 0 ? NAN : ns_to_s(pfirst - first_light);
    char pl[512];
    std::snprintf(pl, sizeof pl, "%-26s %-4s %6llu/%-3zu", c.file, c.device,
                  (unsigned long long)pcount.placed_in_tracker, setup->size());
    line = pl;
    line += "  " + num(pa.pos_p50, pa.ok, "%6.2f", 6) + " " + num(pa.pos_p90, pa.ok, "%6.2f", 6);
    line += "  " + num(pa.rot_p50, pa.ok, "%6.3f", 6) + " " + num(pa.rot_p90, pa.ok, "%6.3f", 6);
    line += " " + num(double(pa.glitch_samples), pa.ok, "%6.0f", 6);
    line += "  " + num(pready, true, "%6.2f", 6) + " " + num(ready_ours, true, "%6.2f", 6) + " " +
            num(ready_lib, true, "%6.2f", 6);
    placed += line + "\n";
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    int reps = 3;
    for (int i = 1; i < argc; ++i)
        if (std::string(argv[i]) != "--write-docs") reps = std::max(1, std::atoi(argv[i]));
    std::string command = "build/release/bench/bench_lighthouse_bench";
    if (reps != 3) command += " " + std::to_string(reps);
    if (write_docs) command += " --write-docs";
    out = "Measured by `" + command + "` (" + bench::build_kind() + "; " + bench::machine_facts() +
          "; one thread, thread CPU time, the fastest of " + std::to_string(reps) +
          " runs):\n\n```\n";
    const size_t table = out.size();
    appendf("%-26s %-4s %7s %13s %7s %7s %7s %8s   %13s  %13s  %13s\n", "recording", "dev",
            "events", "solved/turns", "dec us", "sol us", "sum us", "path us", "pos p50/p90mm",
            "rot p50/p90deg", "rms ours/lib");
    appendf("%-26s %-4s %7s %13s %32s   %13s  %13s  %13s\n", "", "", "", "",
            "per light event (50 budget)", "vs libsurvive", "vs libsurvive", "mrad");
    const Case cases[] = {
        {"compare-test-index.rec.gz", "T20", 20'000'000},
        {"lh2_test_cal.rec.gz", "T20", 20'000'000},
        {"lh1_test_cal.rec.gz", "HMD", 34'000'000},
        {"lh1_test_cal.rec.gz", "T20", 34'000'000},
        {"compare-test-index.rec.gz", "T20", 20'000'000, true},
    };
    for (const Case& c : cases)
        if (!bench_case(c, reps)) return 1;
    const size_t table_end = out.size();
    out += "```\n";
    char head[1024];
    std::snprintf(head, sizeof head,
                  "%-26s %-4s %13s  %13s %6s  %13s  %13s  %20s  %9s  %13s  %13s\n"
                  "%-26s %-4s %13s  %13s %6s  %13s  %13s  %20s  %9s  %13s  %13s\n",
                  "recording", "dev", "fused pos mm", "fused rot deg", "glitch", "light-only mm",
                  "light-only deg", "rms light/fused/lib", "lag ms", "IMU-only deg", "ready s", "",
                  "", "p50    p90", "p50    p90", "left", "p50    p90", "p50    p90", "mrad",
                  "fus  lib", "p50    p95", "ours   lib");
    const std::string accuracy_table = std::string(head) + accuracy;
    std::snprintf(head, sizeof head,
                  "%-26s %-4s %10s  %13s  %13s %6s  %20s\n%-26s %-4s %10s  %13s  %13s %6s  %20s\n",
                  "recording", "dev", "placed", "fused pos mm", "fused rot deg", "glitch",
                  "ready s", "", "", "of setup", "p50    p90", "p50    p90", "left",
                  "placed stored   lib");
    const std::string placed_table = std::string(head) + placed;
    out +=
        "\nThe tracks against libsurvive's (targets: fused position p50 <= 3 mm, p90 <= 10 mm, "
        "orientation p50 <= 0.3 deg, p90 <= 1 deg; light-only position p90 <= 15 mm):\n\n```\n" +
        accuracy_table + "```\n";
    out +=
        "path: decode, a solve per turn and the light + IMU filter (LightTracking, with every IMU "
        "sample), per light event (it solves only once a base station's calibration has arrived: "
        "fewer turns than the sol column). pos/rot: the light-only solves against libsurvive's "
        "light + "
        "IMU poses at the solve's "
        "time (no offset or alignment fitted; the tests fit them); rms: the calibrated model's "
        "residual over the raw angles, of our poses and of libsurvive's (interpolated to each "
        "angle's time, its outliers left out by the same rule).\n"
        "Second table: the light + IMU filter's track (its pose after each IMU sample, while "
        "tracked, at the sample's TIME) and the light-only solves against libsurvive's POSE "
        "lines, with a constant world alignment, lever arm and time offset fitted and "
        "libsurvive's own pose glitches (steps its gyro does not see) left out, as `hmdnode "
        "tracking eval --time-offset auto` does (glitch left: reference samples left out); rms: "
        "the residual of the light-only solves (as a track, interpolated between solves), of "
        "the fused track and of libsurvive's over the same raw angles (the "
        "calibrated model, outliers left out as above), each track at the time shift (lag, 1 ms "
        "grid, +-40 ms) that explains them best, so a track's delay is not held against its "
        "shape (a still device leaves the lag unobservable); IMU-only: "
        "ImuFusion over the same samples against the fused orientation (world and body aligned); "
        "ready: the first tracked pose and libsurvive's first POSE, seconds after the first light "
        "line. The base stations are libsurvive's LH_POSE (solved during the recording: "
        "look-ahead standing in for a stored setup); *: that setup with each base station's "
        "calibration kept (the decoder's after the whole recording, as a setup stored by "
        "`tracking place` keeps them), so the light path solves from the first light.\n";
    out +=
        "\nWithout a stored setup (LightTracking with no base station, placing them itself: "
        "InTrackerPlacement, from the device's first still stretch of 1 s, each base station once "
        "its calibration has arrived; the world is the device's levelled frame there), against "
        "libsurvive's POSE as above:\n\n```\n" +
        placed_table + "```\n";
    out +=
        "placed: base stations placed in the tracker, of the recording's LH_POSE setup; ready: "
        "the first tracked pose placed in the tracker, with the stored (look-ahead) setup of the "
        "second table, and libsurvive's first POSE, seconds after the first light line.\n";
    std::snprintf(
        head, sizeof head, "%-26s %-4s %16s %15s  %20s  %20s\n%-26s %-4s %16s %15s  %20s  %20s\n",
        "recording", "dev", "apart > 10 mm", "windows", "rms there (mrad)", "rms elsewhere", "", "",
        "samples  share", "apart  agree", "light fused   lib", "light fused   lib");
    const std::string disagree_table = std::string(head) + disagree;
    out +=
        "\nWhere the fused track and libsurvive's disagree, which one the raw angles "
        "support:\n\n```\n" +
        disagree_table + "```\n";
    out +=
        "apart: libsurvive's POSE samples more than 10 mm from the fused track (aligned as in "
        "the second table) and their share; windows: the solve windows (one rotor turn) within "
        "5 ms of such a sample, and the other windows of libsurvive's span once the fused track "
        "is tracked; rms: each track's residual over those windows' raw angles (as in the "
        "second table: calibrated model, the best lag), light-only solves, fused track, "
        "libsurvive.\n";
    std::fputs(out.c_str(), stdout);
    if (write_docs &&
        !bench::write_result(
            "lighthouse-bench", "Lighthouse decode + optical solve cost per light event", command,
            "Settings: one thread.\n\n```\n" + out.substr(table, table_end - table) +
                "```\n\nAgainst libsurvive's poses, aligned:\n\n```\n" + accuracy_table +
                "```\n\nWithout a stored setup, the base stations placed in the tracker:\n\n```\n" +
                placed_table +
                "```\n\nWhere the fused track and libsurvive's disagree (more than 10 mm apart, "
                "aligned), the residual of each over the raw angles there and elsewhere:\n\n```\n" +
                disagree_table + "```\n"))
        return 1;
    return 0;
}
