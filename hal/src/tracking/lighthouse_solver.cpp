// The device's optical pose from a window of lighthouse angles (lighthouse_solver.hpp): the
// newest angle per (base station, sensor, plane), as libsurvive's poser_mpfit.c gathers its
// measurements (construct_input_from_scene); a cold start seeds from the base station seeing the
// most sensors on both planes (orthogonal-iteration PnP on the ideal directions,
// lighthouse_pnp.cpp), a warm one from the previous pose; then Levenberg-Marquardt on the
// calibrated residuals over every placed base station (lighthouse_lsq.cpp).
// Cost: see the header; memory O(angles).
#include "hmdnode/hal/tracking/lighthouse_solver.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "hmdnode/core/str_cat.hpp"
#include "tracking/lighthouse_fit.hpp"

namespace hmdnode::lighthouse {
namespace {

using detail::FitAngle;

using Key = std::tuple<int, int, int, int>;  // generation, base station, sensor, plane
Key key_of(const LightEvent& e) {
    return {int(e.generation), e.base_station, e.sensor, e.plane};
}

RigidPose compose(const RigidPose& a, const RigidPose& b) {  // a * b
    return {a.position + a.orientation * b.position, glm::normalize(a.orientation * b.orientation)};
}

glm::dvec3 ideal_direction(Generation g, double a0, double a1) {
    return g == Generation::lh2 ? lh2_ideal_direction(a0, a1) : lh1_ideal_direction(a0, a1);
}

// The seed from station `s`'s sensors seen on both planes: world_from_device, if PnP finds one.
std::optional<RigidPose> seed_from(const SensorLayout& layout, const PlacedBaseStation& st,
                                   std::span<const AngleSample> mine, const SolverOptions& o) {
    std::map<int, std::array<std::optional<double>, 2>> both;
    for (const AngleSample& a : mine) both[a.sensor][a.plane & 1] = a.angle;
    std::vector<glm::dvec3> points, rays, normals;
    for (const auto& [sensor, planes] : both) {
        if (!planes[0] || !planes[1]) continue;
        points.push_back(layout.points[size_t(sensor)]);
        rays.push_back(ideal_direction(st.generation, *planes[0], *planes[1]));
        if (!layout.normals.empty()) normals.push_back(layout.normals[size_t(sensor)]);
    }
    if (points.size() < o.min_seed_sensors) return std::nullopt;
    auto station_from_device =
        detail::pnp_orthogonal_iteration(points, rays, normals, o.max_incidence_rad);
    if (!station_from_device) return std::nullopt;
    return compose(st.world_from_station, *station_from_device);
}

size_t seed_sensors(std::span<const AngleSample> mine) {
    std::map<int, int> planes;
    for (const AngleSample& a : mine) planes[a.sensor] |= 1 << (a.plane & 1);
    return size_t(
        std::count_if(planes.begin(), planes.end(), [](auto& p) { return p.second == 3; }));
}

// The static fit; where it does not explain the angles to their noise (a moving device's hits
// at different times of the window) and the options allow, the fit with the velocities from it.
detail::FitResult fit_with_motion(std::vector<FitAngle>& fit, const RigidPose& start,
                                  const SolverOptions& o) {
    detail::FitResult r = detail::fit_pose(fit, start, o, false);
    if (!o.model_velocity || !r.enough || r.rms <= o.velocity_above_rms_rad) return r;
    const std::vector<FitAngle> keep = fit;
    detail::FitResult m = detail::fit_pose(fit, r.pose, o, true);
    m.iterations += r.iterations;
    if (m.enough) return m;
    fit = keep;
    return r;
}

PoseSolve finish(PoseSolve out, const detail::FitResult& fit, const std::vector<FitAngle>& angles,
                 const SolverOptions& o) {
    out.iterations += fit.iterations;
    out.used = fit.used;
    out.rejected_outliers = fit.outliers;
    out.facing_away = fit.facing_away;
    if (!fit.enough) {
        out.outcome = SolveOutcome::not_enough_data;
        out.message = fit.why;
        return out;
    }
    out.residual_rms_rad = fit.rms;
    if (!(fit.rms <= o.max_residual_rad)) {
        out.outcome = SolveOutcome::no_fit;
        out.message = cat("the fit's residual ", fit.rms * 1e3, " mrad RMS over ", fit.used,
                          " angles exceeds ", o.max_residual_rad * 1e3, " mrad");
        return out;
    }
    std::set<int> stations;
    double t = 0;
    for (const FitAngle& a : angles)
        if (a.state == FitAngle::State::used) {
            stations.insert(a.station);
            t += double(a.device_time_ns - angles.front().device_time_ns);
        }
    // With the velocity model the pose is at the reference time set before the fit.
    if (!fit.moving)
        out.device_time_ns =
            angles.front().device_time_ns + int64_t(std::llround(t / double(fit.used)));
    out.base_stations = stations.size();
    out.covariance = fit.covariance;
    out.world_from_device = fit.pose;
    out.moving = fit.moving;
    out.velocity = fit.velocity;
    out.angular_velocity = fit.angular_velocity;
    out.outcome = SolveOutcome::solved;
    return out;
}

}  // namespace

const char* solve_outcome_name(SolveOutcome o) {
    switch (o) {
        case SolveOutcome::solved:
            return "solved";
        case SolveOutcome::not_enough_data:
            return "not enough data";
        case SolveOutcome::no_fit:
            return "no fit";
    }
    return "?";
}

std::vector<AngleSample> newest_angles(std::span<const LightEvent> window) {
    std::map<Key, const LightEvent*> newest;
    for (const LightEvent& e : window) {
        const LightEvent*& n = newest[key_of(e)];
        if (!n || e.device_time_ns >= n->device_time_ns) n = &e;
    }
    std::vector<AngleSample> out;
    out.reserve(newest.size());
    for (const auto& [k, e] : newest)
        out.push_back(
            {e->generation, e->base_station, e->sensor, e->plane, e->angle, e->device_time_ns});
    return out;
}

std::vector<AngleSample> median_angles(std::span<const LightEvent> window, size_t min_count) {
    std::map<Key, std::vector<const LightEvent*>> all;
    for (const LightEvent& e : window) all[key_of(e)].push_back(&e);
    std::vector<AngleSample> out;
    std::vector<double> v;
    std::vector<int64_t> t;
    for (const auto& [k, es] : all) {
        if (es.size() < std::max<size_t>(min_count, 1)) continue;
        v.clear();
        t.clear();
        for (const LightEvent* e : es) v.push_back(e->angle), t.push_back(e->device_time_ns);
        std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
        std::nth_element(t.begin(), t.begin() + long(t.size() / 2), t.end());
        const LightEvent& e = *es.front();
        out.push_back(
            {e.generation, e.base_station, e.sensor, e.plane, v[v.size() / 2], t[t.size() / 2]});
    }
    return out;
}

PoseSolve solve_device_pose(const SensorLayout& layout, std::span<const PlacedBaseStation> stations,
                            std::span<const LightEvent> window,
                            const std::optional<RigidPose>& warm_start, const SolverOptions& o) {
    const std::vector<AngleSample> angles = newest_angles(window);
    return solve_device_pose(layout, stations, std::span<const AngleSample>(angles), warm_start, o);
}

PoseSolve solve_device_pose(const SensorLayout& layout, std::span<const PlacedBaseStation> stations,
                            std::span<const AngleSample> angles,
                            const std::optional<RigidPose>& warm_start, const SolverOptions& o) {
    assert(layout.normals.empty() || layout.normals.size() == layout.points.size());
    PoseSolve out;
    out.angles = angles.size();
    if (!angles.empty()) out.device_time_ns = angles.back().device_time_ns;
    // The angles of placed base stations, each with its station's transform and calibration.
    std::map<std::pair<int, int>, int> index;
    for (size_t i = 0; i < stations.size(); ++i)
        index[{int(stations[i].generation), stations[i].base_station}] = int(i);
    std::vector<FitAngle> fit;
    std::vector<std::vector<AngleSample>> per_station(stations.size());
    size_t beyond_model = 0;
    for (const AngleSample& a : angles) {
        auto it = index.find({int(a.generation), a.base_station});
        if (it == index.end()) {
            ++out.unplaced;
            continue;
        }
        if (a.sensor >= layout.points.size()) {
            ++beyond_model;
            continue;
        }
        const PlacedBaseStation& st = stations[size_t(it->second)];
        FitAngle f;
        f.point = layout.points[a.sensor];
        if (!layout.normals.empty()) f.normal = layout.normals[a.sensor];
        f.outer_r = glm::mat3_cast(glm::conjugate(st.world_from_station.orientation));
        f.outer_t = -(f.outer_r * st.world_from_station.position);
        if (st.calibration) f.cal = st.calibration->plane[a.plane & 1];
        f.generation = a.generation;
        f.plane = a.plane & 1;
        f.angle = a.angle;
        f.station = it->second;
        f.sensor = a.sensor;
        f.device_time_ns = a.device_time_ns;
        fit.push_back(f);
        per_station[size_t(it->second)].push_back(a);
    }
    // The velocity model's reference time: the mean of the angles' times (the solve's time is
    // the mean of those used; the two differ by the rejected few).
    if (!fit.empty()) {
        double mean = 0;
        for (const FitAngle& f : fit) mean += double(f.device_time_ns - fit.front().device_time_ns);
        const int64_t ref =
            fit.front().device_time_ns + int64_t(std::llround(mean / double(fit.size())));
        for (FitAngle& f : fit) f.dt_s = double(f.device_time_ns - ref) * 1e-9;
        out.device_time_ns = ref;
    }
    if (fit.size() < o.min_angles) {
        out.message = cat(fit.size(), " angles from placed base stations in the window (",
                          out.unplaced, " from base stations not placed, ", beyond_model,
                          " of sensors beyond the model; need ", o.min_angles, ")");
        return out;
    }
    if (warm_start) {
        detail::FitResult r = fit_with_motion(fit, *warm_start, o);
        if (r.enough && r.rms <= o.max_warm_residual_rad) return finish(out, r, fit, o);
        out.iterations += r.iterations;
    }
    // Cold: seeds from the base stations with the most sensors on both planes, best first.
    std::vector<std::pair<size_t, size_t>> order;  // (sensors on both planes, station)
    for (size_t i = 0; i < stations.size(); ++i)
        if (size_t n = seed_sensors(per_station[i]); n >= o.min_seed_sensors)
            order.push_back({n, i});
    std::sort(order.rbegin(), order.rend());
    if (order.empty()) {
        out.message = cat("no placed base station sees ", o.min_seed_sensors,
                          " sensors on both planes (", fit.size(), " angles) for a seed");
        return out;
    }
    out.cold_seed = true;
    std::optional<PoseSolve> best;
    for (size_t k = 0; k < std::min<size_t>(order.size(), 2); ++k) {
        const size_t s = order[k].second;
        auto seed = seed_from(layout, stations[s], per_station[s], o);
        if (!seed) continue;
        detail::FitResult r = fit_with_motion(fit, *seed, o);
        PoseSolve p = finish(out, r, fit, o);
        if (p.ok() && p.residual_rms_rad <= o.max_warm_residual_rad) return p;
        if (!best || (p.ok() && (!best->ok() || p.residual_rms_rad < best->residual_rms_rad)))
            best = std::move(p);
        out.iterations += r.iterations;
    }
    if (!best) {
        out.message = "the perspective-n-point seed found no pose";
        return out;
    }
    return *best;
}

}  // namespace hmdnode::lighthouse
