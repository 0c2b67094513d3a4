// Synthetic lighthouse scenes for the solver and placement tests: a device's sensors on a sphere
// (normals outward), base stations looking at it, and the light events the calibrated angle
// models (lh2_predict_angle / lh1_predict_angle) give for a known pose: closed forms to solve
// back.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/tracking/lighthouse_solver.hpp"

namespace hmdnode::test {

using namespace lighthouse;

// n sensors on a sphere of radius r (a Fibonacci lattice), normals outward.
inline SensorLayout sphere_layout(size_t n = 32, double r = 0.07) {
    SensorLayout l;
    const double golden = M_PI * (3 - std::sqrt(5.0));
    for (size_t i = 0; i < n; ++i) {
        const double y = 1 - 2 * (double(i) + 0.5) / double(n);
        const double rad = std::sqrt(1 - y * y);
        const glm::dvec3 d(std::cos(golden * double(i)) * rad, y,
                           std::sin(golden * double(i)) * rad);
        l.points.push_back(r * d);
        l.normals.push_back(d);
    }
    return l;
}

// A base station at `position` looking at `target` (its -z), y roughly up.
inline RigidPose looking_at(const glm::dvec3& position, const glm::dvec3& target) {
    const glm::dvec3 z = glm::normalize(position - target);
    const glm::dvec3 x = glm::normalize(glm::cross(glm::dvec3(0, 1, 0), z));
    const glm::dvec3 y = glm::cross(z, x);
    return {position, glm::normalize(glm::quat_cast(glm::dmat3(x, y, z)))};
}

inline BaseStationCalibration test_calibration(Generation g, double s) {
    BaseStationCalibration c;
    c.generation = g;
    c.id = 0x1000u + uint32_t(s * 100);
    for (int p = 0; p < 2; ++p) {
        PlaneCalibration& k = c.plane[size_t(p)];
        k.phase = 0.012 * s * (p ? -1 : 1);
        k.tilt = 0.006 * s;
        k.curve = 0.01 * s * (p ? 1 : -1);
        k.gibbous_phase = 0.4 + s;
        k.gibbous_mag = 0.004 * s;
        if (g == Generation::lh2) {
            k.ogee_phase = 0.3 * s;
            k.ogee_mag = 0.008 * s;
        }
    }
    return c;
}

// Four lighthouse-2 base stations (channels 1, 4, 9, 13) in the corners of a room, 2 m up,
// looking at the device near (0, 1.2, 0); calibrated.
inline std::vector<PlacedBaseStation> four_stations(Generation g = Generation::lh2) {
    const glm::dvec3 target(0, 1.1, 0);
    const glm::dvec3 at[4] = {
        {2.0, 2.2, 1.8}, {-2.1, 2.1, 1.7}, {1.9, 2.3, -2.0}, {-1.8, 2.0, -2.2}};
    const uint8_t ch[4] = {1, 4, 9, 13};
    std::vector<PlacedBaseStation> out;
    for (int i = 0; i < (g == Generation::lh2 ? 4 : 2); ++i) {
        PlacedBaseStation s;
        s.generation = g;
        s.base_station = g == Generation::lh2 ? ch[i] : uint8_t(i);
        s.world_from_station = looking_at(at[i], target);
        s.calibration = test_calibration(g, 0.5 + 0.25 * i);
        out.push_back(s);
    }
    return out;
}

inline glm::dvec3 in_station(const PlacedBaseStation& s, const glm::dvec3& world) {
    return glm::conjugate(s.world_from_station.orientation) *
           (world - s.world_from_station.position);
}

// The events of one rotor turn: both planes of every sensor facing each station (normal within
// `max_incidence` of the direction to it), at `t_ns` (+ a microsecond per event), angles from
// the calibrated models, plus gaussian noise of `sigma` rad.
inline std::vector<LightEvent> events_for(const SensorLayout& l,
                                          const std::vector<PlacedBaseStation>& stations,
                                          const RigidPose& device, int64_t t_ns, double sigma = 0,
                                          std::mt19937* rng = nullptr, double max_incidence = 1.5) {
    std::vector<LightEvent> out;
    std::normal_distribution<double> noise(0, sigma > 0 ? sigma : 1);
    for (const PlacedBaseStation& s : stations)
        for (size_t i = 0; i < l.points.size(); ++i) {
            const glm::dvec3 w = device.position + device.orientation * l.points[i];
            const glm::dvec3 n = device.orientation * l.normals[i];
            if (glm::dot(n, glm::normalize(s.world_from_station.position - w)) <
                std::cos(max_incidence))
                continue;
            const glm::dvec3 q = in_station(s, w);
            for (int p = 0; p < 2; ++p) {
                LightEvent e;
                e.generation = s.generation;
                e.base_station = s.base_station;
                e.sensor = uint8_t(i);
                e.plane = uint8_t(p);
                const PlaneCalibration c =
                    s.calibration ? s.calibration->plane[size_t(p)] : PlaneCalibration{};
                e.angle = s.generation == Generation::lh2 ? lh2_predict_angle(c, p, q)
                                                          : lh1_predict_angle(c, p, q);
                if (sigma > 0 && rng) e.angle += noise(*rng);
                e.device_time_ns = t_ns + int64_t(out.size()) * 1000;
                out.push_back(e);
            }
        }
    return out;
}

inline double angle_between(const glm::dquat& a, const glm::dquat& b) {
    const double d = std::abs(glm::dot(glm::normalize(a), glm::normalize(b)));
    return 2 * std::acos(std::min(1.0, d));
}

}  // namespace hmdnode::test
