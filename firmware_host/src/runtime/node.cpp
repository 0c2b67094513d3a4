// The frame loop (docs/latency.md; after Monado's compositor pacing, u_pacing_compositor.c).
// One call = one present:
//  1. Pick the vsync: v_new, the first vsync a new frame can make (the display's free_vsync_ns of
//     now + render + warp estimates + margin: the display says which vsyncs earlier presents
//     hold), and v_any, the first any present can make (the warp estimate alone). When they differ
//     and the warp is on, v_any gets the finished frame re-warped: at once if that ends before
//     the new frame must start, else the new frame starts now and is rendered in pieces with the
//     re-warp between two of them.
//  2. New frame: wake at v_new - latch - (render + warp estimates + margin), drain the tracker,
//     predict the head pose at v_new's photon time, select LOD (with the greedy or iga allocator:
//     coarsen it until the learned render cost fits the frame budget, docs/lod-selection.md),
//     render both eyes (in pieces into the back eye buffers). A render that overran is retargeted
//     to the first vsync still reachable (the one it was meant for is missed).
//  3. Wake at target - latch - (warp estimate + margin), drain the tracker, predict again at the
//     target's photon time, warp the eye buffers to that pose through the lens-distortion mesh,
//     present; the display reports the vsync the frame landed on. A missed latch grows the
//     margin; each vsync made shrinks it a little.
//  Wherever the loop stands (before a new frame, between pieces, after a render), a free vsync
//  before the planned one whose planned warp should already have started, but which a warp of
//  median cost started now still makes, gets that warp at once (rescue_vsync): on a jittery CPU
//  renderer the warp's estimate and margin exceed a period, and the vsync would otherwise go
//  without a present.
// Estimates are the 95th percentile of the last 90 measured costs (on a simulated clock, of the
// cost model's). Before the tracker's first sample a call renders nothing and reports
// FrameOutcome::no_pose_yet (never an unbounded wait). Cost per present: O(objects log objects)
// CPU for LOD, the allocator and sorting, O(window) for the estimates, plus the render and the
// warp.
// In the code: run_frame reads the plan (plan_levers, read_estimates), then 1. aim_new_frame
// (the vsync and wake-up, or a re-warp first) and open_frame (prediction, the LOD stage's
// selection, begin_frame); 2. render_pieces (next_piece: a re-warp between pieces or the piece's
// size; render_piece) and finish_render; 3. aim_warp and present_new_frame (warp_and_present);
// rewarp presents the finished frame again. LOD selection, the frame budget with its learned
// cost, the cross-fades and the draw list are the LOD stage's (lod_stage.hpp), which NodeRuntime
// holds.
#include "hmdnode/firmware_host/node.hpp"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>

#include "lod_stage.hpp"

namespace hmdnode {
namespace {

// A piece of a frame rendered before a re-warp gets this share of the time left until the
// re-warp's wake-up, for the per-item estimate's error (draw items differ in cost).
constexpr double kPieceShare = 0.6;

int64_t steady_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

EyeFov grown(const EyeFov& f, double margin) {
    const double w = f.tan_right - f.tan_left, h = f.tan_up - f.tan_down;
    return EyeFov{f.tan_left - margin * w, f.tan_right + margin * w, f.tan_up + margin * h,
                  f.tan_down - margin * h};
}

// The start-up calibration's estimate of a cost: the lower quartile of its samples. Another
// process or a slow start only ever adds time, so on a busy machine the median moves with the
// noise (two runs of the demo charged the warp 6.8 and 12 ms) where the lower quartile stays near
// the cost itself.
int64_t calibrated_ns(std::vector<int64_t> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[v.size() / 4];
}

}  // namespace

double registration_error(const Pose& shown, const TruthPose& truth, double distance_m) {
    if (!truth.position) return angle_between_deg(shown.orientation, truth.orientation);
    Pose t;
    t.orientation = truth.orientation;
    t.position = *truth.position;
    return registration_error_deg(shown, t, distance_m);
}

NodeRuntime::NodeRuntime(Clock& clock, Tracker& tracker, Display& display, Renderer& renderer,
                         const Scene& scene, const NodeConfig& config)
    : clock_(clock),
      tracker_(&tracker),
      display_(display),
      renderer_(renderer),
      scene_(&scene),
      config_(config),
      history_(config.history),
      pacer_(config.pacing, display.info().period_ns, display.info().latch_margin_ns),
      ladder_({LadderStep{1.0, true, "full"}}, false, config.pacing) {
    // The eye buffers' field of view: the lens's (or the rig's), grown for the late warp; the
    // panel's meshes map each panel point to the direction it shows.
    render_rig_ = config.rig;
    const double margin = config.warp ? config.warp_fov_margin : 0.0;
    const DisplayInfo info = display.info();
    int cols = config.mesh_cols, rows = config.mesh_rows;
    if (config.distortion && (cols <= 0 || rows <= 0))
        cols = rows = choose_mesh_cells(config.headset, info.eye_width, info.eye_height,
                                        config.mesh_max_error_px);
    for (int e = 0; e < 2; ++e) {
        if (config.distortion) {
            mesh_[e] = make_distortion_mesh(config.headset, e, cols, rows);
            render_rig_.eye[e] = mesh_render_fov(mesh_[e], margin);
        } else {
            // The panel shows the rig's field of view undistorted: tangents are linear in panel
            // position, so one cell is exact.
            HeadsetProfile flat;
            flat.eye[e].model = LensModel::none;
            flat.eye[e].fov = config.rig.eye[e];
            mesh_[e] = make_distortion_mesh(flat, e, 1, 1);
            render_rig_.eye[e] = grown(config.rig.eye[e], margin);
        }
    }
    lod_ = std::make_unique<LodStage>(
        render_rig_, pixels_per_radian(render_rig_.eye[0], info.eye_height), config.lod_allocator,
        config.lod_feedback, config.lod_fade_frames);
    // The control socket's setters check the range; a start value out of it (the config reader
    // refuses those) leaves the default, 0.
    (void)set_prediction_offset_ms(config.prediction_offset_ms);
    (void)set_lod_bias(config.lod_bias);
    adopt_objects(scene);
    read_buf_.resize(256);
    // The ladder: resolution steps, then the chromatic-aberration correction where the lens has
    // any to correct.
    bool chromatic = false;
    for (const DistortionMesh& m : mesh_)
        for (const DistortionVertex& v : m.vertices)
            chromatic = chromatic || v.tangent[0] != v.tangent[1] || v.tangent[2] != v.tangent[1];
    ladder_ = PixelLadder(
        make_ladder(chromatic && config.distortion, std::clamp(config.min_render_scale, 0.1, 1.0)),
        config.pixel_ladder, config.pacing);
    // Both eyes have a panel mesh and a render field; the frame loop reads into read_buf_.
    assert(!mesh_[0].vertices.empty() && !mesh_[1].vertices.empty() && !read_buf_.empty());
}

NodeRuntime::~NodeRuntime() = default;

const std::vector<SceneObject>& NodeRuntime::objects() const {
    return lod_->objects();
}

const FrameCostFit& NodeRuntime::lod_cost_fit() const {
    return lod_->cost_fit();
}

HeadsetProfile NodeRuntime::pass_profile() const {
    if (config_.distortion) return config_.headset;
    // The panel shows the rig's field of view undistorted.
    HeadsetProfile flat;
    flat.name = "flat";
    const DisplayInfo info = display_.info();
    flat.panel_width = info.eye_width;
    flat.panel_height = info.eye_height;
    for (int e = 0; e < 2; ++e) {
        flat.eye[e].model = LensModel::none;
        flat.eye[e].fov = config_.rig.eye[e];
    }
    return flat;
}

Status NodeRuntime::set_up_pass(bool fused) {
    const DisplayInfo info = display_.info();
    if (fused) return renderer_.set_lens_warp(info.eye_width, info.eye_height, pass_profile());
    return renderer_.set_warp(info.eye_width, info.eye_height, mesh_[0], mesh_[1]);
}

// The scene's objects and everything sized by them (the LOD stage's); the selector starts anew.
void NodeRuntime::adopt_objects(const Scene& scene) {
    lod_->adopt(scene, selector_params());
}

// The selector from the configured tolerance scaled by the LOD bias (2^bias), with the panel's
// persistence: the smear of a head turn lasts as long as the panel glows.
LodSelectorParams NodeRuntime::selector_params() const {
    LodSelectorParams lod = config_.lod;
    lod.tolerance_px = config_.lod.tolerance_px * std::exp2(lod_bias_);
    if (const int64_t persistence = display_.info().persistence_ns; persistence > 0)
        lod.persistence_s = double(persistence) * 1e-9;
    return lod;
}

void NodeRuntime::rebuild_selector() {
    lod_->set_selector_params(selector_params());
}

Status NodeRuntime::replace_scene(const Scene& scene) {
    if (open_) return make_error("a frame is being rendered: replace the scene between frames");
    if (Status st = renderer_.upload(scene); !st.ok()) {
        // The renderer may hold part of the new scene: the running one goes back.
        if (Status back = renderer_.upload(*scene_); !back.ok())
            return make_error(st.error().message + "; and the running scene could not be " +
                              "uploaded again: " + back.error().message);
        return st;
    }
    scene_ = &scene;
    // The objects, the selector and the learned render cost start anew.
    adopt_objects(scene);
    // The finished frame in the eye buffers is gone with the upload: the next present renders.
    has_frame_ = false;
    return {};
}

Status NodeRuntime::set_warp(bool on) {
    if (open_) return make_error("a frame is being rendered: change the warp between frames");
    if (on && !pass_enabled()) {
        // The pass was never set up (warp and distortion off at start): set it up now. The eye
        // buffers have no margin for the warp (it was off when they were sized).
        if (Status st = set_up_pass(config_.lens_pass != LensPassChoice::mesh); !st.ok()) return st;
    }
    config_.warp = on;
    return {};
}

Status NodeRuntime::set_prediction_offset_ms(double ms) {
    if (!(std::fabs(ms) <= kMaxPredictionOffsetMs))
        return make_error("prediction offset must be between -" +
                          std::to_string(int(kMaxPredictionOffsetMs)) + " and " +
                          std::to_string(int(kMaxPredictionOffsetMs)) + " ms");
    prediction_offset_ns_ = ms_to_ns(ms);
    return {};
}

Status NodeRuntime::set_lod_bias(double bias) {
    if (!(std::fabs(bias) <= kMaxLodBias))
        return make_error("LOD bias must be between -" + std::to_string(int(kMaxLodBias)) +
                          " and " + std::to_string(int(kMaxLodBias)) +
                          " (the tolerance is scaled by 2^bias)");
    lod_bias_ = bias;
    rebuild_selector();
    return {};
}

Status NodeRuntime::recentre() {
    if (history_.empty()) return make_error("no pose yet: nothing to recentre on");
    const TrackerSample& newest = history_.newest();
    // The heading (yaw about +y) of the newest sample becomes straight ahead (-z); pitch and roll
    // stay, since gravity fixes them. Its position, where the tracker has one, becomes the
    // default head position.
    const glm::dvec3 f = forward_of(newest.orientation);
    const double yaw = std::atan2(-f.x, -f.z);
    recentre_.rotation = glm::angleAxis(-yaw, glm::dvec3(0.0, 1.0, 0.0));
    recentre_.from = newest.position.value_or(glm::dvec3(0.0));
    recentre_.to = config_.default_head_position;
    return {};
}

void NodeRuntime::mark_warp(int64_t sample_ns) {
    if (config_.latency_marker_cell_px <= 0) return;
    marker_.payload = make_latency_marker_payload(std::max<int64_t>(sample_ns, 0), present_index_);
    renderer_.set_latency_marker(&marker_);
}

Status NodeRuntime::start() {
    if (Status st = renderer_.upload(*scene_); !st.ok()) return st;
    if (config_.latency_marker_cell_px > 0) {
        const DisplayInfo info = display_.info();
        marker_ = default_latency_marker_overlay(info.eye_width, info.eye_height,
                                                 config_.latency_marker_cell_px);
        renderer_.set_latency_marker(&marker_);  // the calibration's warps pay for it too
    }
    if (pass_enabled())
        if (Status st = set_up_pass(config_.lens_pass != LensPassChoice::mesh); !st.ok()) return st;
    return tracker_->start();
}

void NodeRuntime::stop() {
    tracker_->stop();
    if (eye_tracker_) eye_tracker_->stop();
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
        assert(n <= read_buf_.size());  // a tracker fills at most the span it is given
        for (size_t i = 0; i < n; ++i) history_.push(read_buf_[i]);
        if (n < read_buf_.size()) break;
    }
    if (!eye_tracker_) return;
    for (;;) {
        size_t n = eye_tracker_->read(gaze_buf_);
        assert(n <= gaze_buf_.size());
        if (n > 0) gaze_ = gaze_buf_[n - 1];
        if (n < gaze_buf_.size()) break;
    }
}

Status NodeRuntime::set_eye_tracker(EyeTracker* eye_tracker) {
    if (eye_tracker_) eye_tracker_->stop();
    eye_tracker_ = eye_tracker;
    gaze_.reset();
    gaze_buf_.resize(64);
    return eye_tracker_ ? eye_tracker_->start() : Status{};
}

const char* gaze_source_name(GazeSource s) {
    return s == GazeSource::eye_tracker ? "eye_tracker" : "lens_centre";
}

StereoViews NodeRuntime::views_for(const Pose& head) const {
    StereoViews v;
    for (int eye = 0; eye < 2; ++eye) {
        v.view[eye] = eye_view_matrix(render_rig_, head, eye);
        v.projection[eye] =
            eye_projection(render_rig_.eye[eye], render_rig_.near_m, render_rig_.far_m);
    }
    return v;
}

Pose NodeRuntime::predict(int64_t photon_time_ns) const {
    assert(!history_.empty());  // the frame loop predicts once the tracker gave a sample
    Pose head = config_.predict ? history_.pose_at(photon_time_ns + prediction_offset_ns_)
                                : history_.pose_at(history_.newest_time_ns());
    // Recentred (identity until recentre()): the heading turned, the position moved.
    head.orientation = recentre_.rotation * head.orientation;
    if (!history_.newest().position)
        head.position = config_.default_head_position;
    else
        head.position = recentre_.rotation * (head.position - recentre_.from) + recentre_.to;
    return head;
}

const GazeSample* NodeRuntime::fresh_gaze() const {
    if (gaze_ && gaze_->valid() && clock_.now_ns() - gaze_->time_ns <= config_.gaze_max_age_ns)
        return &*gaze_;
    return nullptr;
}

Status NodeRuntime::set_lod_tolerance_px(double tolerance_px) {
    if (!(tolerance_px >= 0.0) || !std::isfinite(tolerance_px))
        return make_error("LOD tolerance must be a finite number >= 0 (pixels)");
    config_.lod.tolerance_px = tolerance_px;
    rebuild_selector();
    return {};
}

Result<FrameCostModel> NodeRuntime::calibrate_frame_cost(const std::function<bool()>& go_on) {
    auto stopped = [&] { return go_on && !go_on(); };
    FrameCostModel model;
    Pose head;
    head.position = config_.default_head_position;
    StereoImage* out = !pass_enabled() && config_.read_back ? &frame_ : nullptr;
    // Renders every object at one level (0 = finest, 1 = coarsest) from four headings.
    std::vector<DrawItem> draws;
    auto time_renders = [&](bool coarsest, int rounds, uint64_t* triangles) -> Result<int64_t> {
        draws.clear();
        *triangles = 0;
        for (const SceneObject& o : lod_->objects()) {
            const LodLevel& l = coarsest ? o.levels.back() : o.levels.front();
            draws.push_back(DrawItem{l.mesh, glm::mat4(o.world)});
            *triangles += l.triangles;
        }
        std::vector<int64_t> t;
        for (int r = 0; r < rounds; ++r)
            for (int k = 0; k < 4; ++k) {
                head.orientation = glm::angleAxis(kPi / 2.0 * k, glm::dvec3(0, 1, 0));
                if (stopped()) return make_error("frame cost calibration stopped");
                const int64_t t0 = steady_ns();
                Result<RenderStats> s = renderer_.render(views_for(head), draws, out);
                if (!s.ok()) return s.error();
                t.push_back(steady_ns() - t0);
                // On the system clock these are the first frames' estimates (the coarsest levels,
                // what a moving head mostly sees, until real frames replace them).
                if (!clock_.is_simulated() && coarsest) pacer_.seed_render(t.back());
            }
        return calibrated_ns(std::move(t));
    };
    uint64_t tri_fine = 0, tri_coarse = 0;
    if (auto warm = time_renders(false, 1, &tri_fine); !warm.ok()) return warm.error();
    auto fine = time_renders(false, 4, &tri_fine);
    if (!fine.ok()) return fine.error();
    auto coarse = time_renders(true, 4, &tri_coarse);
    if (!coarse.ok()) return coarse.error();
    if (tri_fine > tri_coarse)
        model.per_triangle_ns =
            std::max(0.0, double(*fine - *coarse) / double(tri_fine - tri_coarse));
    model.base_ns =
        std::max<int64_t>(0, *coarse - int64_t(model.per_triangle_ns * double(tri_coarse)));
    // On the system clock the LOD cost model starts from these two points (the simulated clock's
    // frames cost the model, not what was measured here).
    if (!clock_.is_simulated()) {
        lod_->learn_cost(tri_coarse, ns_to_ms(*coarse));
        lod_->learn_cost(tri_fine, ns_to_ms(*fine));
    }
    model.warp_ns = 0;
    if (pass_enabled())
        if (Status st = calibrate_passes(&model, go_on); !st.ok()) return st.error();
    return model;
}

Status NodeRuntime::calibrate_passes(FrameCostModel* model, const std::function<bool()>& go_on) {
    // The passes, each timed on its own after a warm-up: the fused one (with and without the
    // chromatic-aberration correction), the mesh one when the choice is automatic (kept only
    // when at least 10 % faster), and the floor (three bilinear samples per pixel: the mesh
    // pass over a single cell, no lens model between its corners).
    const bool auto_choice = config_.lens_pass == LensPassChoice::automatic;
    int64_t fused_ns = 0, mesh_ns = 0;
    auto time_pass = [&](bool fused, int64_t* ns, double* ms) -> Status {
        if (Status st = set_up_pass(fused); !st.ok()) return st;
        auto t = time_warps(15, go_on);
        if (!t.ok()) return t.error();
        *ns = *t;
        *ms = ns_to_ms(*t);
        return Status::success();
    };
    if (config_.lens_pass != LensPassChoice::mesh)
        if (Status st = time_pass(true, &fused_ns, &pass_times_.fused_ms); !st.ok()) return st;
    if (config_.lens_pass != LensPassChoice::fused)
        if (Status st = time_pass(false, &mesh_ns, &pass_times_.mesh_ms); !st.ok()) return st;
    {
        const DisplayInfo info = display_.info();
        const HeadsetProfile p = pass_profile();
        const DistortionMesh one[2] = {make_distortion_mesh(p, 0, 1, 1),
                                       make_distortion_mesh(p, 1, 1, 1)};
        if (Status st = renderer_.set_warp(info.eye_width, info.eye_height, one[0], one[1]);
            !st.ok())
            return st;
        auto t = time_warps(15, go_on);
        if (!t.ok()) return t.error();
        pass_times_.floor_ms = ns_to_ms(*t);
    }
    const bool fused = config_.lens_pass == LensPassChoice::fused ||
                       (auto_choice && !(double(mesh_ns) <= 0.9 * double(fused_ns)));
    if (Status st = set_up_pass(fused); !st.ok()) return st;
    model->warp_ns = fused ? fused_ns : mesh_ns;
    model->warp_mono_ns = model->warp_ns;
    if (renderer_.chromatic_aberration()) {
        renderer_.set_chromatic_aberration(false);
        auto t = time_warps(15, go_on);
        renderer_.set_chromatic_aberration(true);
        if (!t.ok()) return t.error();
        // One sample per pixel never costs more than three: a mono pass timed above the full
        // one met a slower moment of the machine, not a dearer pass.
        model->warp_mono_ns = std::min(*t, model->warp_ns);
    }
    if (!clock_.is_simulated()) {
        for (int i = 0; i < 8; ++i) {
            pacer_.seed_warp(model->warp_ns);
            ladder_.record_warp(true, model->warp_ns);
            ladder_.record_warp(false, model->warp_mono_ns);
        }
    }
    return {};
}

Result<int64_t> NodeRuntime::time_warps(int n, const std::function<bool()>& go_on) {
    assert(n >= 1);
    std::vector<int64_t> t;
    for (int i = 0; i < n + 2; ++i) {
        if (go_on && !go_on()) return make_error("frame cost calibration stopped");
        const int64_t t0 = steady_ns();
        Result<WarpStats> w =
            renderer_.warp(glm::dquat(1, 0, 0, 0), config_.read_back ? &frame_ : nullptr);
        if (!w.ok()) return w.error();
        if (i >= 2) t.push_back(steady_ns() - t0);  // the first two warm the pass up
    }
    return calibrated_ns(std::move(t));
}

Status NodeRuntime::warp_and_present(int64_t target, int64_t warp_est, FrameRecord* rec,
                                     int64_t* warp_cost_ns, bool early) {
    const DisplayInfo info = display_.info();
    const int64_t photon_offset = display_.photon_offset_ns();
    const int64_t margin = pacer_.margin();
    // The planned end of the warp: the margin before the latch.
    const int64_t planned_end = target - info.latch_margin_ns - margin;
    // The schedule runs forward: the warp is planned to end before its target vsync.
    assert(margin >= 0 && info.latch_margin_ns >= 0 && planned_end <= target && warp_est >= 0);
    if (!early) clock_.sleep_until_ns(planned_end - warp_est);
    const int64_t warp_start = clock_.now_ns();
    Pose shown = frame_pose_;
    int64_t sample_ns = frame_pose_sample_ns_;
    int64_t predicted_for = frame_target_vsync_ns_ + photon_offset;
    double warp_ms = 0.0;
    if (config_.warp) {
        drain_tracker();
        shown = predict(target + photon_offset);
        sample_ns = history_.newest_time_ns();
        predicted_for = target + photon_offset;
    }
    const bool read_back = config_.read_back || read_back_once_;
    read_back_once_ = false;
    const bool chromatic = renderer_.chromatic_aberration();
    if (pass_enabled()) {
        const glm::dquat delta = glm::inverse(frame_pose_.orientation) * shown.orientation;
        mark_warp(sample_ns);
        const auto t0 = std::chrono::steady_clock::now();
        Result<WarpStats> ws = renderer_.warp(delta, read_back ? &frame_ : nullptr);
        const auto t1 = std::chrono::steady_clock::now();
        if (!ws.ok()) return ws.error();
        warp_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
        if (clock_.is_simulated())
            clock_.sleep_until_ns(warp_start + config_.sim_cost.warp_cost_ns(chromatic));
    }
    const int64_t warp_end = clock_.now_ns();
    const int64_t warp_cost = warp_end - warp_start;
    pacer_.record_warp(warp_cost);
    ladder_.record_warp(chromatic, warp_cost);
    if (warp_cost_ns) *warp_cost_ns = warp_cost;

    Result<PresentResult> pr = display_.present(read_back ? &frame_ : nullptr, target);
    if (!pr.ok()) return pr.error();
    pacer_.record_present(pr->vsync_ns == target, warp_end - planned_end);

    FrameRecord& r = *rec;
    r.index = present_index_++;
    r.frame = render_index_ - 1;
    r.render_target_vsync_ns = frame_target_vsync_ns_;
    r.target_vsync_ns = target;
    r.vsync_ns = pr->vsync_ns;
    r.render_pose_sample_time_ns = frame_pose_sample_ns_;
    r.pose_sample_time_ns = sample_ns;
    r.predicted_photon_time_ns = predicted_for;
    r.photon_time_ns = pr->photon_time_ns;
    r.latency_ms = ns_to_ms(pr->photon_time_ns - sample_ns);
    if (config_.latency_marker_cell_px > 0 && pass_enabled()) {
        r.marker_row = marker_.y + 0.5 * latency_marker_size_px(marker_.cell_px);
        r.marker_photon_time_ns = pr->vsync_ns + display_.row_photon_offset_ns(r.marker_row);
    } else {
        r.marker_photon_time_ns = 0;
        r.marker_row = std::numeric_limits<double>::quiet_NaN();
    }
    r.prediction_horizon_ms = ns_to_ms(predicted_for - sample_ns);
    r.shown_pose = shown;
    r.angular_speed_dps = rad_to_deg(glm::length(history_.angular_velocity()));
    r.on_time = pr->vsync_ns == target;
    r.missed_vsyncs_before =
        last_shown_vsync_ns_ == INT64_MIN
            ? 0
            : std::max<int64_t>(
                  0,
                  (pr->vsync_ns - last_shown_vsync_ns_ + info.period_ns / 2) / info.period_ns - 1);
    last_shown_vsync_ns_ = pr->vsync_ns;
    r.warp_ms = warp_ms;
    r.chromatic = chromatic;
    r.render_divisor = pacer_.divisor();
    return Status::success();
}

int64_t NodeRuntime::rescue_vsync(int64_t now) const {
    return display_.free_vsync_ns(now + pacer_.warp_typical());
}

void NodeRuntime::plan_levers() {
    const DisplayInfo info = display_.info();
    const int64_t warp_est = pacer_.warp_estimate();
    const bool chromatic_now = renderer_.chromatic_aberration();
    int64_t render_p = pacer_.render_estimate();
    // With a budgeted LOD allocator the geometry is the first lever: the allocator fits the
    // frame's triangles into what the frame leaves, so the ladder and the rate see the render at
    // the coarsest levels (what the allocator can reach), once its cost model has data.
    if (const std::optional<double> coarsest_ms = lod_->coarsest_render_ms())
        render_p = std::min(render_p, ms_to_ns(*coarsest_ms));
    // The rate: from the ladder's cheapest step (with the ladder off, the frame as it is).
    const int bottom = int(ladder_.steps().size()) - 1;
    PixelLadder::Budget b;
    b.margin_ns = pacer_.margin();
    b.warp_ns = warp_est;
    b.warp_chromatic = chromatic_now;
    int64_t bottom_render = render_p, bottom_warp = warp_est;
    if (ladder_.enabled()) {
        bottom_render = ladder_.step() == bottom ? render_p : ladder_.render_cost(bottom, render_p);
        const bool c = ladder_.steps()[size_t(bottom)].chromatic;
        bottom_warp = c == chromatic_now ? warp_est : ladder_.warp_cost(c, warp_est);
    }
    b.divisor = pacer_.choose_divisor(bottom_render, bottom_warp);
    assert(bottom >= 0 && b.divisor >= 1);
    b.available_ns = int64_t(b.divisor) * info.period_ns - info.latch_margin_ns;
    const int before = ladder_.step();
    ladder_.choose(b, render_p);
    // The estimates of what changed start again from the step's learned cost. (The scale can
    // change without a step: a frame found not bound by its pixels renders at full resolution.)
    const double scale = ladder_.effective_scale();
    if (scale != renderer_.render_scale()) {
        (void)renderer_.set_render_scale(scale);
        pacer_.restart_render(ladder_.render_cost(ladder_.step(), render_p, before));
    }
    const bool chromatic = ladder_.current().chromatic;
    if (ladder_.current().chromatic != ladder_.steps()[size_t(before)].chromatic) {
        renderer_.set_chromatic_aberration(chromatic);
        pacer_.restart_warp(ladder_.warp_cost(chromatic, warp_est));
    }
}

Result<FrameOutcome> NodeRuntime::run_frame(FrameRecord* rec, const TruthFn& truth) {
    FramePlan p;
    p.info = display_.info();
    p.latch = p.info.latch_margin_ns;
    p.photon_offset = display_.photon_offset_ns();

    drain_tracker();
    // Before the first sample there is nothing to show. Skip this vsync rather than wait for the
    // sample here: an absent device must not hang the caller (which checks its stop flag between
    // frames), and on a simulated clock the skipped frame advances time the same way every run.
    if (history_.empty()) {
        if (tracker_->finished()) return make_error("tracker finished before its first sample");
        clock_.sleep_until_ns(display_.next_vsync_ns(clock_.now_ns()));
        return FrameOutcome::no_pose_yet;
    }

    // The render rate and the ladder's step for a new frame, chosen before it is planned.
    if (!open_) plan_levers();
    read_estimates(&p);

    // 1. A new frame for the first vsync it can make, unless one is being rendered. When it
    // cannot make the first vsync a present can, that vsync gets the finished frame re-warped:
    // before the new frame starts if that fits, else between its pieces (it starts at once).
    if (!open_) {
        int64_t target = 0;
        if (const std::optional<Rewarp> w = aim_new_frame(p, &target))
            return rewarp(p, *w, rec, truth);
        if (Status st = open_frame(p, target, rec); !st.ok()) return st.error();
    }

    // 2. Render it in pieces, with the re-warps of the finished frame its vsyncs need between
    // them.
    Result<std::optional<Rewarp>> between = render_pieces(p);
    if (!between.ok()) return between.error();
    if (*between) return rewarp(p, **between, rec, truth);
    finish_render();

    // 3. Late warp just before the latch, then present.
    return present_new_frame(p, rec, truth);
}

void NodeRuntime::read_estimates(FramePlan* p) const {
    p->render_est = pacer_.render_estimate();
    p->warp_est = pacer_.warp_estimate();
    p->frame_est = pacer_.frame_estimate();
    p->margin = pacer_.margin();
    p->divisor = pacer_.divisor();
}

std::optional<NodeRuntime::Rewarp> NodeRuntime::aim_new_frame(const FramePlan& p, int64_t* target) {
    const int64_t now = clock_.now_ns();
    // At a render rate of 1/d the frame's time holds d - 1 re-warps of the finished frame
    // besides its own render and warp, and it aims at least d vsyncs after the previous new
    // frame's, so new frames come at a steady 1/d of the refresh.
    const int64_t need = p.frame_est + p.margin +
                         int64_t(p.divisor - 1) * (p.warp_est + p.margin + pacer_.gap_estimate());
    *target = display_.free_vsync_ns(now + need);
    if (p.divisor > 1 && has_frame_)
        *target = std::max(
            *target, display_.free_vsync_ns(last_new_vsync_ns_ + p.divisor * p.info.period_ns -
                                            p.latch - p.info.period_ns / 2));
    open_wake_ns_ = *target - p.latch - need;
    // (Never when a typical warp alone takes a period: nothing else would run.)
    if (config_.warp && has_frame_ && pacer_.warp_typical() < p.info.period_ns) {
        const int64_t v_any = display_.free_vsync_ns(now + p.warp_est + p.margin);
        // A vsync the plan cannot reach (its warp should have started already) but a typical
        // warp started now still makes is re-warped for at once: otherwise it certainly goes
        // without a present (a jittery pass whose estimate and margin exceed a period).
        if (const int64_t v_hope = rescue_vsync(now); v_hope < std::min(v_any, *target))
            return Rewarp{v_hope, true};
        if (v_any < *target) {
            if (v_any - p.latch <= open_wake_ns_) return Rewarp{v_any, false};
            open_wake_ns_ = now;
        }
    }
    return std::nullopt;
}

Status NodeRuntime::open_frame(const FramePlan& p, int64_t target, FrameRecord* rec) {
    clock_.sleep_until_ns(open_wake_ns_);
    // The set-up (prediction, selection, the draw list, begin_frame: a GPU driver records
    // and uploads there) is part of the frame's cost: left out, a frame whose set-up took
    // longer than its render missed its vsync every time, and the margin never learned it
    // because the re-aimed present was on time.
    const int64_t setup_start = clock_.now_ns();
    drain_tracker();
    open_pose_ = predict(target + p.photon_offset);
    // The render time that lets a new frame make every vsync: a frame's render and warp
    // within one period (the wake-up and the present shift by the same margin), less headroom
    // for the estimates' error.
    const double target_ms =
        ns_to_ms(std::max<int64_t>(0, p.divisor * (p.info.period_ns - p.warp_est - p.margin))) *
        (1.0 - config_.lod_budget_headroom);
    const StereoViews views = views_for(open_pose_);
    lod_->select(open_pose_, views, history_.angular_velocity(), fresh_gaze(), rec, target_ms);
    if (Status st = renderer_.begin_frame(views, lod_->draws()); !st.ok()) return st;
    open_step_ = ladder_.step();
    open_scale_ = renderer_.render_scale();
    open_ = true;
    open_cursor_ = 0;
    open_rewarps_ = 0;
    open_target_ns_ = target;
    open_render_ns_ = clock_.now_ns() - setup_start;
    open_render_ms_ = 0.0;
    open_pose_sample_ns_ = history_.newest_time_ns();
    return {};
}

// Before a vsync that the open frame cannot make, the finished frame is re-warped for that vsync
// between two pieces (one queue: a piece cannot be interrupted). A piece's cost is estimated per
// draw item, not per triangle: on a software rasteriser the pixels an object covers cost more
// than its triangles; and a piece gets 60 % of the time left, for the estimate's error (a piece
// also pays for loading the attachments).
Result<std::optional<NodeRuntime::Rewarp>> NodeRuntime::render_pieces(const FramePlan& p) {
    // The render's share of the frame estimate the target was planned with.
    const int64_t render_budget =
        p.frame_est > p.warp_est ? p.frame_est - p.warp_est : p.render_est;
    const double per_item_ns =
        double(render_budget) / double(std::max<size_t>(1, lod_->draws().size()));
    while (open_) {
        const int64_t now = clock_.now_ns();
        uint64_t max_triangles = UINT64_MAX;
        if (config_.warp && has_frame_)
            if (std::optional<Rewarp> w =
                    next_piece(p, now, render_budget, per_item_ns, &max_triangles))
                return w;
        if (Status st = render_piece(max_triangles); !st.ok()) return st.error();
    }
    return std::optional<Rewarp>{};
}

std::optional<NodeRuntime::Rewarp> NodeRuntime::next_piece(const FramePlan& p, int64_t now,
                                                           int64_t render_budget,
                                                           double per_item_ns,
                                                           uint64_t* max_triangles) {
    // The finished frame is re-warped for v_any when the open one, at its planned render
    // cost, would not make it.
    const int64_t remaining = std::max<int64_t>(0, render_budget - open_render_ns_);
    const int64_t v_any = display_.free_vsync_ns(now + p.warp_est + p.margin);
    // The frame's own warp is planned with the margin, less what a late wake-up (or a
    // set-up dearer than planned) already used of it: counting the whole margin again
    // would give the frame's vsync away after any late wake-up, and without it a frame at
    // its estimate lands a vsync after v_any, which then goes without a present.
    const int64_t used = std::clamp<int64_t>(now - open_wake_ns_ - open_render_ns_, 0, p.margin);
    const int64_t v_done = display_.free_vsync_ns(now + remaining + p.warp_est + (p.margin - used));
    // Re-warps may not starve the frame: while a warp leaves half of each period to the
    // render they are unlimited; a dearer warp (llvmpipe at large panels) interrupts one
    // frame at most twice.
    const bool affordable = 2 * pacer_.warp_typical() <= p.info.period_ns || open_rewarps_ < 2;
    // A vsync that only a warp started now can still make (see rescue_vsync), once the frame
    // has made progress since the last re-warp.
    if (const int64_t v_hope = rescue_vsync(now); v_hope < v_any && pieces_since_rewarp_ > 0) {
        pieces_since_rewarp_ = 0;
        ++open_rewarps_;
        return Rewarp{v_hope, true};
    }
    if (v_done > v_any && affordable) {
        const int64_t rewarp_wake = v_any - p.latch - (p.warp_est + p.margin);
        const size_t fit =
            rewarp_wake > now ? size_t(kPieceShare * double(rewarp_wake - now) / per_item_ns) : 0;
        // Progress: after a re-warp at least one piece, whatever the estimates say.
        // (A frame with no draw items is one piece: it re-warps once at most, never
        // forever.)
        if (fit == 0 && pieces_since_rewarp_ > 0) {
            pieces_since_rewarp_ = 0;
            ++open_rewarps_;
            // The time until the re-warp is lost to the frame: the plans count it.
            pacer_.record_gap(std::max<int64_t>(0, rewarp_wake - now));
            return Rewarp{v_any, false};
        }
        const std::vector<uint64_t>& draw_triangles = lod_->draw_triangles();
        *max_triangles = 0;
        for (size_t i = open_cursor_; i < std::min(lod_->draws().size(), open_cursor_ + fit); ++i)
            *max_triangles += draw_triangles[i];
    }
    return std::nullopt;
}

Status NodeRuntime::render_piece(uint64_t max_triangles) {
    const int64_t piece_start = clock_.now_ns();
    size_t items = 0;
    const auto t0 = std::chrono::steady_clock::now();
    Result<bool> done = renderer_.render_more(max_triangles, &items);
    const auto t1 = std::chrono::steady_clock::now();
    if (!done.ok()) {
        open_ = false;
        return done.error();
    }
    open_render_ms_ += std::chrono::duration<double, std::milli>(t1 - t0).count();
    if (clock_.is_simulated()) {
        const std::vector<uint64_t>& draw_triangles = lod_->draw_triangles();
        const size_t draws = lod_->draws().size();
        uint64_t piece_triangles = 0;
        for (size_t i = open_cursor_; i < open_cursor_ + items; ++i)
            piece_triangles += draw_triangles[i];
        // The model's base (mostly fill) spread over the draw items, as pieces are sized.
        const int64_t base = int64_t(double(config_.sim_cost.base_ns) * open_scale_ * open_scale_);
        const int64_t cost = int64_t(config_.sim_cost.per_triangle_ns * double(piece_triangles)) +
                             (draws == 0 ? base : base * int64_t(items) / int64_t(draws));
        clock_.sleep_until_ns(piece_start + cost);
    }
    open_cursor_ += items;
    ++pieces_since_rewarp_;
    open_render_ns_ += clock_.now_ns() - piece_start;
    open_ = !*done;
    return {};
}

void NodeRuntime::finish_render() {
    ladder_.record_render(open_step_, open_render_ns_);
    // The LOD stage's cost model learns from every frame at full resolution (node clock: on the
    // simulated clock, the model's); the budget's feedback from the allocator's frames.
    lod_->finish(ns_to_ms(open_render_ns_), open_scale_ == 1.0);
    has_frame_ = true;
    ++render_index_;
    frame_pose_ = open_pose_;
    frame_target_vsync_ns_ = open_target_ns_;
    frame_pose_sample_ns_ = open_pose_sample_ns_;
    frame_step_ = open_step_;
    frame_scale_ = open_scale_;
}

// A render that overran aims at the first vsync still reachable (the one it was meant for is
// missed).
int64_t NodeRuntime::aim_warp(const FramePlan& p, bool* early) const {
    int64_t target = open_target_ns_;
    const int64_t after = clock_.now_ns();
    // (Against the latch itself: the margin was the slack the wake-up was planned with.)
    if (after + p.warp_est > target - p.latch) {
        target = display_.free_vsync_ns(after + p.warp_est);
    } else if (config_.warp) {
        // Done early (a render rate below the refresh, or a cheap frame): shown at the first free
        // vsync it makes rather than left waiting while that vsync repeats the old image; the
        // warp predicts for the vsync it is shown at.
        target = std::min(target, display_.free_vsync_ns(after + p.warp_est + p.margin));
    }
    // A free vsync before the target that only a warp started now can make gets this frame now
    // rather than nothing (the frame is then shown a vsync sooner, or late at its target).
    *early = false;
    if (config_.warp)
        if (const int64_t v_hope = rescue_vsync(after); v_hope < target) {
            target = v_hope;
            *early = true;
        }
    return target;
}

Result<FrameOutcome> NodeRuntime::present_new_frame(const FramePlan& p, FrameRecord* rec,
                                                    const TruthFn& truth) {
    bool early = false;
    const int64_t target = aim_warp(p, &early);
    int64_t warp_cost = 0;
    if (Status st = warp_and_present(target, p.warp_est, rec, &warp_cost, early); !st.ok())
        return st.error();
    FrameRecord& r = *rec;
    last_new_vsync_ns_ = r.vsync_ns;
    pacer_.record_frame(open_render_ns_, warp_cost);
    const LodStage::Choice& shown = lod_->shown();
    r.ladder_step = frame_step_;
    r.render_scale = frame_scale_;
    r.kind = FrameKind::new_frame;
    r.wake_ns = open_wake_ns_;
    r.late = r.vsync_ns > frame_target_vsync_ns_;
    r.triangles = shown.triangles;
    r.render_ms = open_render_ms_;
    r.lod_budget_ms = shown.budget.budget_ms;
    r.predicted_render_ms = shown.budget.predicted_ms;
    r.lod_coarsened = shown.budget.coarsened;
    r.lod_fading = shown.fade.fading;
    r.lod_transitions = shown.fade.transitions;
    r.lod_pops = shown.fade.pops;
    r.levels.assign(shown.levels.begin(), shown.levels.end());
    r.eccentricity_deg.assign(shown.eccentricity_deg.begin(), shown.eccentricity_deg.end());
    r.frame_cost_ms = ns_to_ms(clock_.now_ns() - open_wake_ns_);
    fill_truth(rec, truth);
    return FrameOutcome::rendered;
}

// The open frame (if any) resumes on the next call.
Result<FrameOutcome> NodeRuntime::rewarp(const FramePlan& p, Rewarp w, FrameRecord* rec,
                                         const TruthFn& truth) {
    const int64_t wake = w.early ? clock_.now_ns() : w.vsync_ns - p.latch - (p.warp_est + p.margin);
    if (Status st = warp_and_present(w.vsync_ns, p.warp_est, rec, nullptr, w.early); !st.ok())
        return st.error();
    FrameRecord& r = *rec;
    const LodStage::Choice& shown = lod_->shown();
    r.ladder_step = frame_step_;
    r.render_scale = frame_scale_;
    r.kind = FrameKind::rewarp;
    r.wake_ns = wake;
    r.late = false;
    r.triangles = 0;
    r.render_ms = 0.0;
    r.lod_budget_ms = r.predicted_render_ms = std::numeric_limits<double>::quiet_NaN();
    r.lod_coarsened = 0;
    r.lod_fading = r.lod_transitions = r.lod_pops = 0;
    r.levels.assign(shown.levels.begin(), shown.levels.end());
    r.eccentricity_deg.assign(shown.eccentricity_deg.begin(), shown.eccentricity_deg.end());
    r.frame_cost_ms = ns_to_ms(clock_.now_ns() - wake);
    fill_truth(rec, truth);
    return FrameOutcome::rewarped;
}

void NodeRuntime::fill_truth(FrameRecord* rec, const TruthFn& truth) const {
    FrameRecord& r = *rec;
    r.registration_error_deg = std::numeric_limits<double>::quiet_NaN();
    if (truth)
        if (std::optional<TruthPose> t = truth(r.photon_time_ns))
            r.registration_error_deg =
                registration_error(r.shown_pose, *t, config_.registration_distance_m);
}

}  // namespace hmdnode
