// Base-station placement inside the tracker: online still stretches from the IMU, the latest
// one's light kept, base_station_placement.cpp's placement on it (docs/tracking.md §12). Cost:
// O(1) per IMU sample and kept event; a placement as one pose solve per base station.
#include "self_placement.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "hmdnode/core/str_cat.hpp"

namespace hmdnode {
namespace {

glm::dquat shortest_rotation(const glm::dvec3& a, const glm::dvec3& b) {
    const double c = glm::dot(a, b);
    if (c < -1 + 1e-12) {
        const glm::dvec3 axis = std::abs(a.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 0, 1);
        return glm::angleAxis(3.14159265358979323846, glm::normalize(glm::cross(a, axis)));
    }
    const glm::dvec3 v = glm::cross(a, b);
    return glm::normalize(glm::dquat(1 + c, v.x, v.y, v.z));
}

}  // namespace

SelfPlacement::SelfPlacement(const InTrackerPlacement& options, lighthouse::SensorLayout layout,
                             const glm::dmat3& model_from_head, const glm::dvec3& world_up,
                             bool require_calibration)
    : o_(options),
      layout_(std::move(layout)),
      model_from_head_(model_from_head),
      world_up_(glm::normalize(world_up)),
      require_calibration_(require_calibration) {}

bool SelfPlacement::add_imu(int64_t t, const glm::dvec3& gyro, const glm::dvec3& accel) {
    const int64_t window_ns = int64_t(o_.window_s * 1e9);
    bool closed = false;
    if (in_window_ && t - window_begin_ns_ >= window_ns) {
        close_window(window_last_ns_);
        closed = true;
    }
    if (!in_window_) {
        in_window_ = true;
        window_begin_ns_ = t;
        n_ = 0;
        g_sum_ = a_sum_ = glm::dvec3(0.0);
        g_sq_ = a_sq_ = 0;
    }
    window_last_ns_ = t;
    n_ += 1;
    g_sum_ += gyro;
    a_sum_ += accel;
    g_sq_ += glm::dot(gyro, gyro);
    a_sq_ += glm::dot(accel, accel);
    return closed;
}

void SelfPlacement::close_window(int64_t end_ns) {
    in_window_ = false;
    const glm::dvec3 gm = g_sum_ / n_, am = a_sum_ / n_;
    // Sums of squares about the mean: E[x.x] - E[x].E[x] (a still accelerometer's 9.8 m/s^2
    // against a deviation of 0.02: well inside double precision).
    const double gsd = std::sqrt(std::max(0.0, g_sq_ / n_ - glm::dot(gm, gm)));
    const double asd = std::sqrt(std::max(0.0, a_sq_ / n_ - glm::dot(am, am)));
    const bool still = n_ >= 3 && gsd <= o_.max_gyro_sd_rad_s &&
                       glm::length(gm) <= o_.max_gyro_mean_rad_s && asd <= o_.max_accel_sd_m_s2;
    const int64_t window_ns = int64_t(o_.window_s * 1e9);
    if (!still) {
        open_.reset();
        window_events_.clear();
        return;
    }
    if (!open_ || window_begin_ns_ - open_->end_ns > window_ns) {
        open_ = Stretch{};
        open_->begin_ns = window_begin_ns_;
    }
    open_->end_ns = end_ns;
    open_->accel_sum += a_sum_;
    open_->accel_n += n_;
    const int64_t light_end = open_->begin_ns + int64_t(o_.max_light_s * 1e9);
    for (const lighthouse::LightEvent& e : window_events_)
        if (e.device_time_ns <= light_end) open_->events.push_back(e);
    window_events_.clear();
    if (open_->seconds() >= o_.min_still_s) {
        // The latest long-enough stretch is the one placed from (a new one replaces the kept
        // one when it first qualifies; while it grows, its light up to max_light_s joins).
        if (!kept_ || kept_->begin_ns != open_->begin_ns) ++stretches_;
        std::optional<lighthouse::RigidPose> pose;
        if (kept_ && kept_->begin_ns == open_->begin_ns) pose = kept_->world_from_device;
        kept_ = *open_;
        kept_->world_from_device = pose;
        ++kept_version_;
    }
}

void SelfPlacement::add_light(const lighthouse::LightEvent& e) {
    if (in_window_ && e.device_time_ns >= window_begin_ns_) window_events_.push_back(e);
}

void SelfPlacement::note_solve(int64_t t, const lighthouse::RigidPose& world_from_device) {
    if (kept_ && !kept_->world_from_device && t >= kept_->begin_ns && t <= kept_->end_ns)
        kept_->world_from_device = world_from_device;
    if (open_ && !open_->world_from_device && t >= open_->begin_ns && t <= open_->end_ns)
        open_->world_from_device = world_from_device;
}

std::vector<lighthouse::BaseStationPlacement> SelfPlacement::place(
    std::span<const lighthouse::BaseStationPlacement> setup,
    const lighthouse::LightDecoder& decoder, std::string* why) {
    std::vector<lighthouse::BaseStationPlacement> out;
    if (!kept_ || kept_->events.empty()) return out;
    // Tried again only when the stretch, the setup or the calibrations known have changed.
    size_t calibrated = 0;
    for (const lighthouse::BaseStationState& s : decoder.base_stations())
        calibrated += s.calibration.has_value();
    const std::array<size_t, 4> state{kept_version_, setup.size(), calibrated,
                                      size_t(kept_->world_from_device.has_value())};
    if (state == tried_) return out;
    tried_ = state;
    // The world: this stretch's pose in it, or, with nothing placed yet, defined by it.
    const bool defines_world = setup.empty();
    if (!defines_world && !kept_->world_from_device) return out;  // no solve inside it yet
    std::vector<lighthouse::LightEvent> mine;
    std::vector<lighthouse::BaseStationState> known;
    for (const lighthouse::LightEvent& e : kept_->events) {
        const bool placed = std::any_of(setup.begin(), setup.end(), [&](const auto& p) {
            return p.generation == e.generation && p.base_station == e.base_station;
        });
        if (placed) continue;
        const lighthouse::BaseStationState* s = decoder.base_station(e.generation, e.base_station);
        if (require_calibration_ && (!s || !s->calibration)) continue;  // placed when it comes
        mine.push_back(e);
    }
    if (mine.empty()) return out;
    for (const lighthouse::BaseStationState& s : decoder.base_stations()) known.push_back(s);
    lighthouse::PlacementResult r;
    if (defines_world) {
        // The device's model frame levelled (+Y up), then turned so that +Y goes to world_up.
        const glm::dvec3 up =
            glm::normalize(model_from_head_ * (kept_->accel_sum / kept_->accel_n));
        r = lighthouse::place_base_stations(layout_, mine, known, {}, up, o_.placement);
        const glm::dquat turn = shortest_rotation(glm::dvec3(0, 1, 0), world_up_);
        auto apply = [&](lighthouse::RigidPose& p) {
            p.position = turn * p.position;
            p.orientation = glm::normalize(turn * p.orientation);
        };
        apply(r.world_from_device);
        for (lighthouse::BaseStationPlacement& b : r.placed) apply(b.world_from_station);
        if (!r.placed.empty()) kept_->world_from_device = r.world_from_device;
    } else {
        r = lighthouse::place_base_stations(layout_, mine, known, *kept_->world_from_device,
                                            std::nullopt, o_.placement);
    }
    if (why) {
        why->clear();
        for (const std::string& n : r.not_placed) *why += (why->empty() ? "" : "; ") + n;
    }
    // A base station not placed now is tried again at the next still window: drop its light
    // only when it was placed.
    for (const lighthouse::BaseStationPlacement& b : r.placed)
        std::erase_if(kept_->events, [&](const lighthouse::LightEvent& e) {
            return e.generation == b.generation && e.base_station == b.base_station;
        });
    return std::move(r.placed);
}

}  // namespace hmdnode
