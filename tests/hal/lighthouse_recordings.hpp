// The bundled libsurvive recordings for the solver and placement tests: the device's light
// events through our decoder, its sensor layout, libsurvive's poses of the device turned into the
// model frame (its POSE lines are of the head frame: LighthouseSensors::model_from_head), and
// each event's recording (host) time.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <string>
#include <vector>

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

}  // namespace hmdnode::test
