// The frame loop. Per frame: wake at (target vsync - estimated frame cost - margin), drain the
// tracker into the pose history, predict the head pose at the target vsync's photon time, select
// LOD per object, render both eyes front to back, present, and record. Before the tracker's first
// sample a frame renders nothing and reports FrameOutcome::no_pose_yet (never an unbounded wait).
#include "hmdnode/firmware_host/node.hpp"

#include <algorithm>
#include <chrono>

namespace hmdnode {

NodeRuntime::NodeRuntime(Clock& clock, Tracker& tracker, Display& display, Renderer& renderer,
                         const Scene& scene, const NodeConfig& config)
    : clock_(clock),
      tracker_(&tracker),
      display_(display),
      renderer_(renderer),
      scene_(scene),
      config_(config),
      history_(config.history),
      selector_(0, config.lod) {
    objects_ = flatten_objects(scene);
    selector_ = LodSelector(objects_.size(), config.lod);
    level_errors_.resize(objects_.size());
    for (size_t i = 0; i < objects_.size(); ++i)
        for (const LodLevel& l : objects_[i].levels)
            level_errors_[i].push_back(l.geometric_error_m);
    draws_.reserve(objects_.size());
    order_.reserve(objects_.size());
    read_buf_.resize(256);
    const DisplayInfo info = display.info();
    pixels_per_radian_ = pixels_per_radian(config.rig.eye[0], info.eye_height);
    cost_estimate_ns_ = info.period_ns / 2;
}

Status NodeRuntime::start() {
    if (Status st = renderer_.upload(scene_); !st.ok()) return st;
    return tracker_->start();
}

void NodeRuntime::stop() {
    tracker_->stop();
}

Status NodeRuntime::replace_tracker(Tracker& tracker) {
    tracker_->stop();
    tracker_ = &tracker;
    return tracker_->start();
}

bool NodeRuntime::tracker_finished() const {
    return tracker_->finished();
}

void NodeRuntime::drain_tracker() {
    for (;;) {
        size_t n = tracker_->read(read_buf_);
        for (size_t i = 0; i < n; ++i) history_.push(read_buf_[i]);
        if (n < read_buf_.size()) break;
    }
}

StereoViews NodeRuntime::views_for(const Pose& head) const {
    StereoViews v;
    for (int eye = 0; eye < 2; ++eye) {
        v.view[eye] = eye_view_matrix(config_.rig, head, eye);
        v.projection[eye] =
            eye_projection(config_.rig.eye[eye], config_.rig.near_m, config_.rig.far_m);
    }
    return v;
}

Result<FrameOutcome> NodeRuntime::run_frame(FrameRecord* rec, const TruthFn& truth) {
    const DisplayInfo info = display_.info();

    // Pace: the earliest vsync we can still make, and the time to start working for it.
    const int64_t now = clock_.now_ns();
    const int64_t target_vsync =
        display_.next_vsync_ns(now + cost_estimate_ns_ + config_.wake_margin_ns);
    const int64_t wake = target_vsync - cost_estimate_ns_ - config_.wake_margin_ns;
    clock_.sleep_until_ns(wake);
    const int64_t start_ns = clock_.now_ns();

    drain_tracker();
    // Before the first sample there is nothing to show. Skip this vsync rather than wait for the
    // sample here: an absent device must not hang the caller (which checks its stop flag between
    // frames), and on a simulated clock the skipped frame advances time the same way every run.
    if (history_.empty()) {
        if (tracker_->finished()) return make_error("tracker finished before its first sample");
        clock_.sleep_until_ns(target_vsync);
        return FrameOutcome::no_pose_yet;
    }

    const int64_t predicted_photon = target_vsync + display_.photon_offset_ns();
    Pose head = config_.predict ? history_.pose_at(predicted_photon)
                                : history_.pose_at(history_.newest_time_ns());
    if (!history_.newest().position) head.position = config_.default_head_position;
    const glm::dvec3 omega = history_.angular_velocity();
    const double speed_dps = rad_to_deg(glm::length(omega));

    // LOD selection per object, then draw front to back (nearest first saves fill on lavapipe).
    LodViewer viewer;
    viewer.eye_position = head.position;
    viewer.gaze_direction = forward_of(head.orientation);
    viewer.angular_speed_dps = speed_dps;
    viewer.pixels_per_radian = pixels_per_radian_;
    viewer.near_m = config_.rig.near_m;
    rec->levels.resize(objects_.size());
    rec->eccentricity_deg.resize(objects_.size());
    order_.clear();
    uint64_t triangles = 0;
    for (size_t i = 0; i < objects_.size(); ++i) {
        const SceneObject& o = objects_[i];
        LodObjectView ov{o.bounds_center, o.bounds_radius, level_errors_[i]};
        LodDecision d = selector_.select(i, ov, viewer);
        rec->levels[i] = d.level;
        rec->eccentricity_deg[i] = d.eccentricity_deg;
        triangles += o.levels[d.level].triangles;
        order_.emplace_back(glm::length(o.bounds_center - head.position) - o.bounds_radius, i);
    }
    std::sort(order_.begin(), order_.end());
    draws_.clear();
    for (const auto& [dist, i] : order_) {
        const SceneObject& o = objects_[i];
        draws_.push_back(DrawItem{o.levels[rec->levels[i]].mesh, glm::mat4(o.world)});
    }

    const auto t0 = std::chrono::steady_clock::now();
    Result<RenderStats> stats =
        renderer_.render(views_for(head), draws_, config_.read_back ? &frame_ : nullptr);
    const auto t1 = std::chrono::steady_clock::now();
    if (!stats.ok()) return stats.error();

    if (clock_.is_simulated())
        clock_.sleep_until_ns(start_ns + config_.sim_cost.cost_ns(
                                             triangles, 2ull * info.eye_width * info.eye_height));
    const int64_t cost = clock_.now_ns() - start_ns;
    // Frame-cost estimate for pacing: fast to rise (avoid repeated misses), slow to fall.
    cost_estimate_ns_ = cost > cost_estimate_ns_ ? cost : (cost_estimate_ns_ * 7 + cost) / 8;

    Result<PresentResult> pr =
        display_.present(config_.read_back ? &frame_ : nullptr, target_vsync);
    if (!pr.ok()) return pr.error();

    rec->index = frame_index_++;
    rec->wake_ns = wake;
    rec->target_vsync_ns = target_vsync;
    rec->vsync_ns = pr->vsync_ns;
    rec->pose_sample_time_ns = history_.newest_time_ns();
    rec->predicted_photon_time_ns = predicted_photon;
    rec->photon_time_ns = pr->photon_time_ns;
    rec->latency_ms = ns_to_ms(pr->photon_time_ns - rec->pose_sample_time_ns);
    rec->prediction_horizon_ms = ns_to_ms(predicted_photon - rec->pose_sample_time_ns);
    rec->registration_error_deg = std::numeric_limits<double>::quiet_NaN();
    if (truth)
        if (std::optional<glm::dquat> q = truth(pr->photon_time_ns))
            rec->registration_error_deg = angle_between_deg(head.orientation, *q);
    rec->angular_speed_dps = speed_dps;
    rec->on_time = pr->on_time;
    rec->triangles = triangles;
    rec->render_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
    rec->frame_cost_ms = ns_to_ms(cost);
    return FrameOutcome::rendered;
}

}  // namespace hmdnode
