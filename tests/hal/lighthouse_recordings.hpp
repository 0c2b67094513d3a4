// The bundled libsurvive recordings for the solver and placement tests: the device's light
// events through our decoder, its sensor layout, libsurvive's poses of the device turned into the
// model frame (its POSE lines are of the head frame: LighthouseSensors::model_from_head), and
// each event's recording (host) time; and the runner both tests use: light-only solves at each
// rotor turn, compared with libsurvive's poses (time offset and a constant offset + lever arm
// fitted) and with the raw angles.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hal/lighthouse_synth.hpp"
#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/tracking/lighthouse_solver.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

namespace hmdnode::test {

struct LightRecording {
    SurviveRecording rec;
    lighthouse::SensorLayout layout;
    std::vector<lighthouse::LightEvent> events;
    std::vector<lighthouse::BaseStationState> known;  // after the whole recording (calibrations)
    int64_t host_minus_device_ns = 0;  // median over the events (recording time - device time)
    // libsurvive's poses of the device's model frame, recording time
    std::vector<std::pair<int64_t, lighthouse::RigidPose>> reference;
};

inline lighthouse::RigidPose model_pose_from_head(const LighthouseSensors& s, const glm::dvec3& t,
                                                  const glm::dquat& q) {
    // world = t + q * in_head(p) = t + q * M^T (p - o)
    const glm::dquat mt = glm::quat_cast(glm::transpose(s.model_from_head));
    const glm::dquat r = glm::normalize(q * mt);
    return {t - r * s.head_origin, r};
}

inline std::unique_ptr<LightRecording> load_light_recording(const std::string& file,
                                                            const std::string& device) {
    auto rec =
        read_survive_recording(std::string(HMDNODE_SOURCE_DIR) + "/data/traces/" + file, device);
    EXPECT_TRUE(rec.ok()) << rec.error().message;
    if (!rec) return nullptr;
    auto r = std::make_unique<LightRecording>();
    r->rec = std::move(*rec);
    r->layout.points = r->rec.sensors.points;
    r->layout.normals = r->rec.sensors.normals;
    lighthouse::LightDecoder dec(survive_sensor_model(r->rec));
    Status st = replay_survive_light(r->rec, dec);
    EXPECT_TRUE(st.ok()) << st.error().message;
    dec.take_events(r->events);
    r->known = dec.base_stations();
    // Each event's recording time: the W / C line of its timecode.
    std::map<uint32_t, int64_t> line_time;
    for (const SurviveLightLine& l : r->rec.light)
        if (l.kind == SurviveLightLine::Kind::sweep || l.kind == SurviveLightLine::Kind::pulse)
            line_time.emplace(l.timecode, l.host_time_ns);
    std::vector<int64_t> d;
    for (const lighthouse::LightEvent& e : r->events)
        if (auto it = line_time.find(e.timecode); it != line_time.end())
            d.push_back(it->second - e.device_time_ns);
    if (!d.empty()) {
        std::nth_element(d.begin(), d.begin() + long(d.size() / 2), d.end());
        r->host_minus_device_ns = d[d.size() / 2];
    }
    for (const SurvivePose& p : r->rec.poses)
        r->reference.push_back(
            {p.host_time_ns, model_pose_from_head(r->rec.sensors, p.position, p.orientation)});
    return r;
}

// libsurvive's pose at recording time t (linear / slerp between its neighbours); false outside.
inline bool reference_at(const LightRecording& r, int64_t t, lighthouse::RigidPose* out) {
    auto it = std::lower_bound(r.reference.begin(), r.reference.end(), t,
                               [](const auto& a, int64_t v) { return a.first < v; });
    if (it == r.reference.begin() || it == r.reference.end()) return false;
    const auto& b = *it;
    const auto& a = *(it - 1);
    if (b.first - a.first > 50'000'000) return false;  // a gap in libsurvive's poses
    const double f = double(t - a.first) / double(b.first - a.first);
    out->position = glm::mix(a.second.position, b.second.position, f);
    out->orientation = glm::slerp(a.second.orientation, b.second.orientation, f);
    return true;
}

inline double pct(std::vector<double> v, double f) {
    std::sort(v.begin(), v.end());
    return v.empty() ? NAN : v[std::min(v.size() - 1, size_t(f * double(v.size())))];
}

struct Solved {
    int64_t host_ns = 0;  // the solve's time on the recording's clock
    lighthouse::RigidPose pose;
    double rms = 0;      // ours, over the angles used
    double ref_rms = 0;  // libsurvive's pose (at each angle's time) over the same window's
                         // angles, its outliers left out by the same k-sigma rule
    bool moving = false;
};

struct RecordingRun {
    size_t solves = 0;
    std::vector<Solved> solved;
};

// |measured - predicted| of libsurvive's pose at each angle's own time, by our calibrated model.
inline double reference_rms(const LightRecording& r,
                            std::span<const lighthouse::PlacedBaseStation> stations,
                            std::span<const lighthouse::AngleSample> angles) {
    using namespace lighthouse;
    std::vector<double> res;
    for (const AngleSample& a : angles) {
        const PlacedBaseStation* st = nullptr;
        for (const PlacedBaseStation& s : stations)
            if (s.generation == a.generation && s.base_station == a.base_station) st = &s;
        RigidPose ref;
        if (!st || !reference_at(r, a.device_time_ns + r.host_minus_device_ns, &ref)) continue;
        const glm::dvec3 q =
            in_station(*st, ref.position + ref.orientation * r.layout.points[a.sensor]);
        const PlaneCalibration c =
            st->calibration ? st->calibration->plane[a.plane & 1] : PlaneCalibration{};
        const double p = a.generation == Generation::lh2 ? lh2_predict_angle(c, a.plane & 1, q)
                                                         : lh1_predict_angle(c, a.plane & 1, q);
        res.push_back(std::abs(std::remainder(a.angle - p, 2 * M_PI)));
    }
    if (res.empty()) return NAN;
    const double limit = 4 * std::max(1.4826 * pct(res, 0.5), 2e-4);
    double ss = 0;
    size_t n = 0;
    for (double x : res)
        if (x <= limit) ss += x * x, ++n;
    return std::sqrt(ss / double(n));
}

// Light-only solves every `window_ns` over the events of the last `window_ns` (one rotor turn,
// or a lighthouse-1 cycle of both base stations' two axes), warm-started from the previous solve,
// from libsurvive's first pose on.
inline RecordingRun run_recording(const LightRecording& r,
                                  const std::vector<lighthouse::PlacedBaseStation>& stations,
                                  int64_t window_ns) {
    using namespace lighthouse;
    RecordingRun out;
    std::vector<LightEvent> ev = r.events;
    std::sort(ev.begin(), ev.end(), [](const LightEvent& a, const LightEvent& b) {
        return a.device_time_ns < b.device_time_ns;
    });
    std::optional<RigidPose> warm;
    int64_t warm_t = 0;
    size_t lo = 0, hi = 0;
    for (int64_t t = r.reference.front().first - r.host_minus_device_ns;
         t <= ev.back().device_time_ns; t += window_ns) {
        while (hi < ev.size() && ev[hi].device_time_ns <= t) ++hi;
        while (lo < hi && ev[lo].device_time_ns <= t - window_ns) ++lo;
        if (warm && t - warm_t > 100'000'000) warm.reset();
        const std::vector<AngleSample> angles =
            newest_angles(std::span<const LightEvent>(ev.data() + lo, hi - lo));
        const PoseSolve s = solve_device_pose(r.layout, stations, angles, warm);
        ++out.solves;
        if (!s.ok()) continue;
        EXPECT_TRUE(s.world_from_device);
        warm = s.world_from_device;
        warm_t = t;
        out.solved.push_back({s.device_time_ns + r.host_minus_device_ns, *s.world_from_device,
                              s.residual_rms_rad, reference_rms(r, stations, angles), s.moving});
    }
    return out;
}

struct Errors {
    std::vector<double> pos_mm, rot_deg;
    size_t compared = 0;
};

// Our solves against libsurvive's poses `offset_ns` later, after a constant world offset w and
// lever arm d (ours = ref + w + R_ref d; least squares by alternation) when `align`.
inline Errors compare(const LightRecording& r, const std::vector<Solved>& solved, int64_t offset_ns,
                      bool align, double t0_s = 0, double t1_s = 1e9) {
    std::vector<std::pair<const Solved*, lighthouse::RigidPose>> pairs;
    for (const Solved& s : solved) {
        lighthouse::RigidPose ref;
        if (s.host_ns < t0_s * 1e9 || s.host_ns > t1_s * 1e9 ||
            !reference_at(r, s.host_ns + offset_ns, &ref))
            continue;
        pairs.push_back({&s, ref});
    }
    glm::dvec3 w(0.0), d(0.0);
    for (int it = 0; align && it < 100 && !pairs.empty(); ++it) {
        glm::dvec3 sw(0.0), sd(0.0);  // w, then d given the new w (Gauss-Seidel)
        for (auto& [s, ref] : pairs) sw += s->pose.position - ref.position - ref.orientation * d;
        w = sw / double(pairs.size());
        for (auto& [s, ref] : pairs)
            sd += glm::conjugate(ref.orientation) * (s->pose.position - ref.position - w);
        d = sd / double(pairs.size());
    }
    Errors e;
    for (auto& [s, ref] : pairs) {
        e.pos_mm.push_back(
            glm::length(s->pose.position - (ref.position + w + ref.orientation * d)) * 1e3);
        e.rot_deg.push_back(angle_between(s->pose.orientation, ref.orientation) * 180 / M_PI);
    }
    e.compared = pairs.size();
    return e;
}

// The time offset (1 ms steps in +-30 ms) that minimises the median position error.
inline int64_t fit_offset(const LightRecording& r, const std::vector<Solved>& solved) {
    int64_t best = 0;
    double best_e = INFINITY;
    for (int64_t off = -30; off <= 30; ++off) {
        const double e = pct(compare(r, solved, off * 1'000'000, false).pos_mm, 0.5);
        if (e < best_e) best_e = e, best = off * 1'000'000;
    }
    return best;
}

}  // namespace hmdnode::test
