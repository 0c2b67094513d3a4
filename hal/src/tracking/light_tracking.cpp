// Light + IMU six degrees of freedom: light events grouped by rotor turn, one pose solve per turn
// (lighthouse_solver.cpp) against the stored setup, fed to the error-state filter (pose_filter.cpp,
// Sola 2017) as a head-frame measurement; the IMU to the filter at its rate. Learnt from
// libsurvive's Kalman tracker (survive_kalman_tracker.c: a poser solve per sweep set as a pose
// observation with its variance from the residual). Cost: O(1) per event and IMU sample, a solve
// and a late filter update per window (docs/tracking.md §12).
#include "hmdnode/hal/tracking/light_tracking.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "self_placement.hpp"

namespace hmdnode {
namespace light_tracking_detail {

// out = a * b (6x6 row-major).
std::array<double, 36> mul6(const std::array<double, 36>& a, const std::array<double, 36>& b) {
    std::array<double, 36> out{};
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) {
            double s = 0;
            for (int k = 0; k < 6; ++k) s += a[size_t(i * 6 + k)] * b[size_t(k * 6 + j)];
            out[size_t(i * 6 + j)] = s;
        }
    return out;
}

std::array<double, 36> transpose6(const std::array<double, 36>& a) {
    std::array<double, 36> out{};
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j) out[size_t(j * 6 + i)] = a[size_t(i * 6 + j)];
    return out;
}

}  // namespace light_tracking_detail

LightTracking::LightTracking(LightTrackingConfig config)
    : config_(std::move(config)), setup_(config_.setup), filter_(config_.filter) {
    layout_.points = config_.sensors.points;
    layout_.normals = config_.sensors.normals;
    sources_.assign(setup_.size(), lighthouse::CalibrationSource::none);
    if (config_.place.enabled)
        placer_ =
            std::make_unique<SelfPlacement>(config_.place, layout_, config_.sensors.model_from_head,
                                            config_.filter.world_up, config_.require_calibration);
}

LightTracking::~LightTracking() = default;

void LightTracking::take_placements(const lighthouse::LightDecoder& decoder) {
    place_due_ = false;
    std::string why;
    std::vector<lighthouse::BaseStationPlacement> placed = placer_->place(setup_, decoder, &why);
    counters_.still_stretches = placer_->stretches();
    if (!why.empty()) counters_.last_placement_note = why;
    for (lighthouse::BaseStationPlacement& p : placed) {
        if (counters_.first_placement_ns == 0) counters_.first_placement_ns = last_imu_ns_;
        ++counters_.placed_in_tracker;
        setup_.push_back(std::move(p));
        sources_.push_back(lighthouse::CalibrationSource::none);
    }
}

lighthouse::CalibrationSource LightTracking::calibration_source(lighthouse::Generation g,
                                                                uint8_t base_station) const {
    for (size_t i = 0; i < setup_.size(); ++i)
        if (setup_[i].generation == g && setup_[i].base_station == base_station) return sources_[i];
    return lighthouse::CalibrationSource::none;
}

void LightTracking::add_imu(int64_t device_time_ns, const glm::dvec3& gyro, const glm::dvec3& accel,
                            ImuSampleFlags flags) {
    ++counters_.imu_samples;
    filter_.add_imu(device_time_ns, gyro, accel, flags);
    if (placer_ && placer_->add_imu(device_time_ns, gyro, accel)) place_due_ = true;
    have_imu_ = true;
    last_imu_ns_ = device_time_ns;
}

void LightTracking::add_light(std::span<const lighthouse::LightEvent> events,
                              const lighthouse::LightDecoder& decoder) {
    if (place_due_) take_placements(decoder);
    for (lighthouse::LightEvent e : events) {
        ++counters_.events;
        // The light and the IMU unwrap the same 32-bit clock from their own first ticks.
        if (have_imu_) {
            const int64_t t = lighthouse::onto_imu_turn(e.device_time_ns, last_imu_ns_);
            counters_.wrap_moved += t != e.device_time_ns;
            e.device_time_ns = t;
        }
        const bool placed = std::any_of(
            setup_.begin(), setup_.end(), [&](const lighthouse::BaseStationPlacement& p) {
                return p.generation == e.generation && p.base_station == e.base_station;
            });
        if (!placed) {
            ++counters_.events_unplaced;
            if (placer_) placer_->add_light(e);
            continue;
        }
        const int64_t window = e.generation == lighthouse::Generation::lh1 ? config_.lh1_window_ns
                                                                           : config_.lh2_window_ns;
        if (!have_window_end_) {
            have_window_end_ = true;
            window_end_ns_ = e.device_time_ns + window;
        }
        if (e.device_time_ns > window_end_ns_) {
            solve_window(window_end_ns_, window, decoder);
            window_end_ns_ += window;
            if (e.device_time_ns > window_end_ns_)  // a gap: on to the window that holds e
                window_end_ns_ += ((e.device_time_ns - window_end_ns_) / window + 1) * window;
            while (!window_.empty() && window_.front().device_time_ns <= window_end_ns_ - window)
                window_.pop_front();
        }
        window_.push_back(e);
    }
}

void LightTracking::solve_window(int64_t end_ns, int64_t window_ns,
                                 const lighthouse::LightDecoder& decoder) {
    std::vector<lighthouse::LightEvent> in;
    in.reserve(window_.size());
    for (const lighthouse::LightEvent& e : window_)
        if (e.device_time_ns > end_ns - window_ns && e.device_time_ns <= end_ns) in.push_back(e);
    if (in.size() < config_.solver.min_angles) return;  // a window without a turn's light
    std::vector<lighthouse::BaseStationState> known;
    for (const lighthouse::BaseStationPlacement& p : setup_)
        if (const lighthouse::BaseStationState* s =
                decoder.base_station(p.generation, p.base_station))
            known.push_back(*s);
    std::vector<lighthouse::CalibrationSource> sources;
    std::vector<lighthouse::PlacedBaseStation> stations =
        lighthouse::placed_stations(setup_, known, &sources);
    // Each setup entry's source (an entry left out as swapped: none).
    for (size_t i = 0, k = 0; i < setup_.size(); ++i) {
        const bool here = k < stations.size() && stations[k].generation == setup_[i].generation &&
                          stations[k].base_station == setup_[i].base_station;
        sources_[i] = here ? sources[k++] : lighthouse::CalibrationSource::none;
    }
    if (config_.require_calibration) {
        std::erase_if(stations,
                      [](const lighthouse::PlacedBaseStation& p) { return !p.calibration; });
        if (stations.empty()) {
            ++counters_.uncalibrated_windows;
            return;
        }
    }
    for (const lighthouse::CalibrationSource src : sources) {
        counters_.stored_calibration_uses += src == lighthouse::CalibrationSource::stored;
        counters_.decoded_calibration_uses += src == lighthouse::CalibrationSource::decoded;
    }
    if (warm_ && end_ns - warm_ns_ > config_.warm_start_max_age_ns) warm_.reset();
    lighthouse::PoseSolve s = lighthouse::solve_device_pose(
        layout_, stations, std::span<const lighthouse::LightEvent>(in), warm_, config_.solver);
    ++counters_.solves;
    if (!s.ok()) {
        ++(s.outcome == lighthouse::SolveOutcome::no_fit ? counters_.no_fit
                                                         : counters_.not_enough_data);
        last_solve_ = std::move(s);
        return;
    }
    ++counters_.solved;
    counters_.last_residual_rad = s.residual_rms_rad;
    warm_ = s.world_from_device;
    warm_ns_ = end_ns;
    if (placer_) placer_->note_solve(s.device_time_ns, *s.world_from_device);
    const PoseMeasurement hm = head_measurement(s);
    // The innovation: the filter's pose at the solve's time before it takes it.
    const FilterPose before = filter_.predict(hm.device_time_ns);
    const MeasurementResult res = filter_.add_pose(hm);
    if (before.good()) {
        counters_.last_innovation_m = glm::length(before.position - hm.position);
        ++counters_.innovations;
    }
    switch (res) {
        case MeasurementResult::accepted:
            ++counters_.accepted;
            break;
        case MeasurementResult::initialised:
            ++counters_.initialised;
            break;
        case MeasurementResult::gated:
            ++counters_.gated;
            break;
        case MeasurementResult::pending:
            ++counters_.accepted;
            break;  // applied when the IMU is
        default:
            ++counters_.refused;
            break;
    }
    last_solve_ = std::move(s);
}

// The solve is of the model frame; the filter's body is the head frame: world_from_head =
// world_from_model * (M, o) with a head point h at M h + o in the model. Its covariance over
// [position (world), rotation vector (world, left)] becomes [head position (world), rotation
// vector (head frame, right)]: J = [[I, -[R o]x], [0, R_head^T]], C' = J C J^T, plus the added
// sigmas.
PoseMeasurement LightTracking::head_measurement(const lighthouse::PoseSolve& s) const {
    using namespace light_tracking_detail;
    const lighthouse::RigidPose& m = *s.world_from_device;
    const glm::dquat mq = glm::quat_cast(config_.sensors.model_from_head);
    PoseMeasurement out;
    out.device_time_ns = s.device_time_ns;
    const glm::dvec3 a = m.orientation * config_.sensors.head_origin;
    out.position = m.position + a;
    out.orientation = glm::normalize(m.orientation * mq);
    const glm::dmat3 rt = glm::transpose(glm::mat3_cast(out.orientation));
    std::array<double, 36> j{};
    for (int i = 0; i < 3; ++i) j[size_t(i * 6 + i)] = 1.0;
    // -[a]x
    const double ax[3][3] = {{0, a.z, -a.y}, {-a.z, 0, a.x}, {a.y, -a.x, 0}};
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            j[size_t(r * 6 + 3 + c)] = ax[r][c];
            j[size_t((3 + r) * 6 + 3 + c)] = rt[c][r];  // glm: column-major, rt[col][row]
        }
    std::array<double, 36> c = mul6(mul6(j, s.covariance), transpose6(j));
    for (int i = 0; i < 6; ++i)
        for (int k = 0; k < i; ++k)  // exactly symmetric
            c[size_t(i * 6 + k)] = c[size_t(k * 6 + i)] =
                0.5 * (c[size_t(i * 6 + k)] + c[size_t(k * 6 + i)]);
    const double ap = config_.added_position_sigma_m +
                      glm::length(s.velocity) * config_.motion_sigma_s,
                 ao = config_.added_orientation_sigma_rad +
                      glm::length(s.angular_velocity) * config_.motion_sigma_s;
    for (int i = 0; i < 3; ++i) {
        c[size_t(i * 7)] += ap * ap;
        c[size_t((3 + i) * 7)] += ao * ao;
    }
    out.covariance = c;
    return out;
}

}  // namespace hmdnode
