// The node runtime: the frame loop paced to the display's vsync. Each frame it wakes just early
// enough to render, reads the tracker, predicts the head pose at the frame's photon time, picks a
// level of detail per object, renders both eyes, then, just before the latch, reads the tracker
// again and warps the finished frame to the newest prediction through the lens-distortion mesh,
// presents, and records what it did. A vsync that a new frame cannot reach gets the previous frame
// re-warped when that does not delay the next new frame. The level-of-detail part (selection,
// frame budget, cross-fades, draw list) is a stage of its own inside the runtime
// (src/runtime/lod_stage.hpp); the steps of a frame are in src/runtime/node.cpp.
//
// Threads: a NodeRuntime belongs to one thread (the frame thread). The tracker's reader thread, if
// any, only feeds the tracker's ring.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hmdnode/core/scene.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/firmware_host/cpu_wake.hpp"
#include "hmdnode/firmware_host/frame_pacer.hpp"
#include "hmdnode/firmware_host/pose_history.hpp"
#include "hmdnode/hal/display.hpp"
#include "hmdnode/hal/eye_tracker.hpp"
#include "hmdnode/hal/tracker.hpp"
#include "hmdnode/lod/budget.hpp"
#include "hmdnode/lod/cross_fade.hpp"
#include "hmdnode/lod/selector.hpp"
#include "hmdnode/render/lens.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {

// What a frame costs on the simulated clock. A replay on a simulated clock cannot use the
// measured duration (that would make it depend on the machine), so the clock advances by this
// model instead: calibrated on the actual renderer at start-up (calibrate_frame_cost), or given
// (`--frame-cost-ms`), and printed in the report so that a run can be reproduced exactly.
struct FrameCostModel {
    int64_t base_ns = 2'000'000;   // a render of no triangles at the run's eye size (both eyes)
    double per_triangle_ns = 0.0;  // both eyes
    int64_t warp_ns = 500'000;     // the warp + distortion pass with its read-back
    // The pass with chromatic-aberration correction off (one sample per pixel); 0: half warp_ns.
    int64_t warp_mono_ns = 0;
    // At a render scale (dynamic resolution) the base, mostly fill, scales with the pixels.
    int64_t render_ns(uint64_t triangles, double scale = 1.0) const {
        return int64_t(double(base_ns) * scale * scale) +
               int64_t(per_triangle_ns * double(triangles));
    }
    int64_t warp_cost_ns(bool chromatic) const {
        return chromatic ? warp_ns : (warp_mono_ns > 0 ? warp_mono_ns : warp_ns / 2);
    }
};

// How the frame loop turns the selector's levels into the levels it draws (docs/lod-selection.md):
// `threshold` draws the selector's level (the finest the eye needs); `greedy` coarsens them, least
// benefit per millisecond first, until the render predicted by the learned cost model fits the
// frame budget left by pacing; `iga` makes the same trade with the immune genetic algorithm of He
// et al. (docs/references.md), warm-started from the previous frame's levels.
enum class LodAllocator { threshold, greedy, iga };

// Where a frame's LOD eccentricity was measured from (docs/lod-selection.md, "Gaze"): the eye
// tracker's gaze when it reported a valid one recently enough, else the lens centre (the head
// forward).
enum class GazeSource { lens_centre, eye_tracker };
const char* gaze_source_name(GazeSource s);
const char* lod_allocator_name(LodAllocator a);
// "threshold", "greedy" or "iga"; nullopt for anything else.
std::optional<LodAllocator> parse_lod_allocator(std::string_view name);

// Which late-warp pass the node uses (docs/latency.md, "The lens pass"): the fused pass (the lens
// model per pixel, one full-screen triangle per eye), the distortion-mesh pass, or `automatic`:
// the fused pass unless the start-up calibration measures the mesh pass at least 10 % faster on
// this device (so noise cannot flip the choice).
enum class LensPassChoice { automatic, fused, mesh };
const char* lens_pass_choice_name(LensPassChoice c);
// "auto", "fused" or "mesh"; nullopt for anything else.
std::optional<LensPassChoice> parse_lens_pass_choice(std::string_view name);

struct NodeConfig {
    StereoRig rig = StereoRig::typical();  // eye offsets, near/far; the field of view when
                                           // distortion is off
    glm::dvec3 default_head_position{0.0, 1.6, 0.0};  // used when the tracker gives no position
    bool predict = true;                              // false: render the newest sample's pose
    // Predict this much further ahead than the photon time (ms, may be negative; at most
    // NodeRuntime::kMaxPredictionOffsetMs either way, else 0): the control socket's
    // `prediction_ms`.
    double prediction_offset_ms = 0.0;
    // The LOD tolerance is scaled by 2^lod_bias (at most NodeRuntime::kMaxLodBias either way,
    // else 0): the control socket's `lod_bias`.
    double lod_bias = 0.0;
    PoseHistoryConfig history;
    LodSelectorParams lod;
    LodAllocator lod_allocator = LodAllocator::threshold;
    // greedy, iga: the render target is (1 - headroom) x (period - warp estimate), the render time
    // that lets a new frame make every vsync, less room for the estimates' error.
    double lod_budget_headroom = 0.1;
    BudgetFeedbackParams lod_feedback;
    // A visible object's level change is a dithered cross-fade over this many new frames (both
    // levels drawn with complementary screen-door masks; 0: off, changes pop; at most
    // kMaxLodFadeFrames). docs/lod-selection.md, "No pops".
    int lod_fade_frames = 3;
    // Late warp: the finished frame is reprojected to the newest pose just before the latch, and
    // re-warped for a vsync that gets no new frame. Off: the frame is shown as rendered.
    bool warp = true;
    // Lens distortion and chromatic aberration correction from `headset` (a distortion mesh per
    // eye of mesh_cols x mesh_rows cells; 0: the coarsest mesh whose interpolation error stays
    // within mesh_max_error_px at the panel's size, see choose_mesh_cells). Off: the panel shows
    // the rig's field of view undistorted.
    bool distortion = true;
    HeadsetProfile headset = generic_headset_profile();
    int mesh_cols = 0, mesh_rows = 0;
    double mesh_max_error_px = 0.5;
    double warp_fov_margin = 0.1;  // the eye buffers cover this much more per side (fraction of
                                   // the panel's tangent span) so a late rotation finds pixels
    LensPassChoice lens_pass = LensPassChoice::automatic;
    // The latency marker (core/latency_marker.hpp; docs/latency.md, "The observer"): > 0, the
    // lens pass draws the shown sample's time and the present's index into both eyes' panel at
    // default_latency_marker_overlay() with this many panel pixels per cell (`hmdnode latency
    // --observer`); 0, off (the default: the panel is exactly the lens pass's). Needs the lens
    // pass (distortion or the warp on).
    int latency_marker_cell_px = 0;
    // Whether the cores are kept awake while the node runs on the system clock (cpu_wake.hpp):
    // PM QoS or idle-class spinning threads, so a renderer's worker threads do not pay a core's
    // wake-up in the middle of a warp. The assembly (make_node) holds it; the simulated clock
    // never does.
    CpuWake cpu_wake = CpuWake::automatic;
    // The pixel-cost ladder (frame_pacer.hpp): eye-buffer resolution down to min_render_scale per
    // axis, then chromatic-aberration correction off, when a frame does not fit its budget. Off:
    // always full resolution with the correction on.
    bool pixel_ladder = true;
    double min_render_scale = 0.5;
    PacingConfig pacing;  // with the render rate (pacing.max_divisor; 1: every vsync)
    FrameCostModel sim_cost;
    bool read_back = true;                 // copy frames back to the CPU for the display
    double registration_distance_m = 1.0;  // position error is seen at this distance
    // The eye tracker's newest sample steers LOD while it is valid and at most this old at the
    // frame's render (older: the tracker stalled, the lens centre is used).
    int64_t gaze_max_age_ns = 100'000'000;
};

enum class FrameKind {
    new_frame,  // rendered for this present, then warped (or shown as rendered)
    rewarp,     // the previous frame warped again for a vsync that had no new frame
};

// One present. Times on the node's clock.
struct FrameRecord {
    uint64_t index = 0;  // counts presents
    FrameKind kind = FrameKind::new_frame;
    uint64_t frame = 0;                      // which rendered frame is shown (counts renders)
    int64_t wake_ns = 0;                     // render wake-up (a re-warp: warp wake-up)
    int64_t render_target_vsync_ns = 0;      // the vsync the shown frame was rendered for
    int64_t target_vsync_ns = 0;             // the vsync this present aimed at
    int64_t vsync_ns = 0;                    // the vsync it was shown at (display feedback)
    int64_t render_pose_sample_time_ns = 0;  // newest tracker sample when the frame was rendered
    int64_t pose_sample_time_ns = 0;         // newest sample that shaped the shown image (warp's)
    int64_t predicted_photon_time_ns = 0;    // the time the shown pose was predicted for
    int64_t photon_time_ns = 0;              // actual photon time of the panel centre
    double latency_ms = 0.0;                 // photon_time - pose_sample_time
    // With the latency marker on (NodeConfig::latency_marker_cell_px): the photon time of the
    // marker's centre row (the rolling scan-out reaches it at its own time,
    // Display::row_photon_offset_ns) and the row; 0 and NaN without the marker.
    int64_t marker_photon_time_ns = 0;
    double marker_row = std::numeric_limits<double>::quiet_NaN();
    double prediction_horizon_ms = 0.0;  // predicted_photon_time - pose_sample_time
    double registration_error_deg = std::numeric_limits<double>::quiet_NaN();  // NaN: no truth
    double angular_speed_dps = 0.0;
    bool on_time = false;              // shown at target_vsync_ns
    bool late = false;                 // a new frame shown after the vsync it was rendered for
    int64_t missed_vsyncs_before = 0;  // vsyncs since the previous present that showed nothing
    uint64_t triangles = 0;            // drawn (both eyes' frusta, culled objects left out)
    size_t culled = 0;                 // objects outside both eyes' frusta, not drawn
    double render_ms = 0.0;            // measured wall time of the render call (0 for a re-warp)
    double warp_ms = 0.0;              // measured wall time of the warp call (0 when there is none)
    double frame_cost_ms = 0.0;        // on the node's clock: wake to present
    // The pixel-cost ladder and the render rate when the shown frame was rendered / warped: its
    // ladder step (index into NodeRuntime::ladder().steps()), eye-buffer scale, whether the warp
    // corrected chromatic aberration, and the render rate's divisor (new frames every N vsyncs).
    int ladder_step = 0;
    double render_scale = 1.0;
    bool chromatic = true;
    int render_divisor = 1;
    // greedy or iga allocator (NaN / 0 otherwise): the render budget it allocated against, the
    // render time the learned cost model predicted for the levels chosen, and how many drawn
    // objects it left coarser than the selector wanted.
    double lod_budget_ms = std::numeric_limits<double>::quiet_NaN();
    double predicted_render_ms = std::numeric_limits<double>::quiet_NaN();
    size_t lod_coarsened = 0;
    // LOD transitions of this new frame (0 for a re-warp): objects drawn at two levels (a
    // cross-fade in progress), transitions begun, and pops (a drawn object's level changed from
    // the previous new frame's without a cross-fade; docs/lod-selection.md).
    size_t lod_fading = 0;
    size_t lod_transitions = 0;
    size_t lod_pops = 0;
    std::vector<int> levels;  // LOD level per object (index as in objects()); while an object
                              // cross-fades, the level fading in
    std::vector<double> eccentricity_deg;  // per object, from the gaze_source's direction
    GazeSource gaze_source = GazeSource::lens_centre;
    double gaze_eccentricity_deg = 0.0;  // eye tracker: the gaze's angle from the head forward
    Pose shown_pose;                     // the head pose the shown image was made for
};

// The truth for registration error: the true head pose at a host time (position only where the
// truth has one), or nothing where the truth is unknown (replay only: outside the recorded trace).
struct TruthPose {
    glm::dquat orientation{1.0, 0.0, 0.0, 0.0};
    std::optional<glm::dvec3> position;
};
using TruthFn = std::function<std::optional<TruthPose>(int64_t host_time_ns)>;

// Registration error (degrees) of a shown pose against the truth: the rotation between them, plus
// the position error seen at `distance_m` where the truth has a position.
double registration_error(const Pose& shown, const TruthPose& truth, double distance_m);

// What one run_frame call did.
enum class FrameOutcome {
    rendered,     // a new frame rendered and presented; the record is filled out
    rewarped,     // the previous frame re-warped and presented; the record is filled out
    no_pose_yet,  // the tracker has delivered no sample yet: nothing was rendered or presented,
                  // the frame's vsync has passed (so the next call aims at the one after), and
                  // the record is left as it was
};

class LodStage;  // the frame loop's LOD stage (src/runtime/lod_stage.hpp)

class NodeRuntime {
  public:
    // All references must outlive the runtime. The scene is flattened and uploaded by start().
    NodeRuntime(Clock& clock, Tracker& tracker, Display& display, Renderer& renderer,
                const Scene& scene, const NodeConfig& config);
    ~NodeRuntime();
    NodeRuntime(const NodeRuntime&) = delete;
    NodeRuntime& operator=(const NodeRuntime&) = delete;

    // Uploads the scene, sets up the warp pass and starts the tracker.
    Status start();

    // Measures the renderer on this scene at start-up (after start(), before the first frame):
    // renders at the finest and at the coarsest levels from a few head poses and times the warp,
    // and returns the model the simulated clock can use (lower quartiles, robust to a busy machine;
    // triangles of both eyes). On the system clock the measured costs also seed the pacing
    // estimates and the LOD cost model, so the first frames are not paced or budgeted on a guess.
    // Blocks for about 40 frames. `go_on`, where given, is asked before each render and warp: false
    // ends the calibration there with an error (the daemon's SIGTERM during start-up; it also
    // reports progress).
    Result<FrameCostModel> calibrate_frame_cost(const std::function<bool()>& go_on = {});
    void set_sim_cost(const FrameCostModel& model) { config_.sim_cost = model; }
    // Run-time settings (the daemon's control socket), between frames: prediction on or off; the
    // LOD pixel tolerance at the gaze point (>= 0; the selector starts anew, its hysteresis too).
    void set_predict(bool predict) { config_.predict = predict; }
    Status set_lod_tolerance_px(double tolerance_px);
    // More run-time settings. Those that change what the eye buffers hold (the scene, the warp)
    // fail while a frame is being rendered in pieces (between_frames() false: a present re-warped
    // the previous frame in the middle of it); the caller retries after the next run_frame.
    bool between_frames() const { return !open_; }
    // Uploads `scene` (which must outlive the runtime or the next replace_scene) in place of the
    // running one: the objects, the selector and the learned render cost start anew. A failed
    // upload puts the running scene back and returns the error.
    Status replace_scene(const Scene& scene);
    // The late warp on or off (on when it was off at start: the pass is set up now, with no
    // field-of-view margin for it).
    Status set_warp(bool on);
    // Predict this much further ahead (ms, may be negative; |ms| <= kMaxPredictionOffsetMs) than
    // the photon time pacing expects: a latency the model misses.
    Status set_prediction_offset_ms(double ms);
    double prediction_offset_ms() const { return ns_to_ms(prediction_offset_ns_); }
    // The LOD tolerance scaled by 2^bias (|bias| <= kMaxLodBias): +1 halves the detail needed.
    Status set_lod_bias(double bias);
    double lod_bias() const { return lod_bias_; }
    // The newest sample's heading becomes straight ahead and its position (where the tracker has
    // one) the default head position, from now on. Fails before the first sample.
    Status recentre();
    static constexpr double kMaxPredictionOffsetMs = 100.0;
    static constexpr double kMaxLodBias = 8.0;
    void stop();

    // Runs one present: waits for its wake-up time, then renders a new frame (or re-warps the
    // previous one), warps, presents, and fills out_record (reused by the caller so the frame
    // path does not allocate). Never waits longer than about two display periods: before the
    // tracker's first sample there is nothing to show, so the frame is skipped
    // (FrameOutcome::no_pose_yet) and the caller can look at its stop flag and call again. Returns
    // an error when rendering or presenting fails, or when the tracker finished without
    // delivering a sample; the caller decides to go on or stop.
    Result<FrameOutcome> run_frame(FrameRecord* out_record, const TruthFn& truth = nullptr);

    // True once the tracker has delivered a sample (run_frame renders from then on).
    bool has_pose() const { return !history_.empty(); }

    // Swaps the tracker (a replugged device, or a looping replay): stops the old one, starts the
    // new one. The pose history is kept; samples older than its newest are ignored.
    Status replace_tracker(Tracker& tracker);

    // The eye tracker whose gaze steers LOD (null: none, the lens centre). Starts it; the previous
    // one is stopped and its gaze forgotten. It must outlive the runtime or the next call.
    Status set_eye_tracker(EyeTracker* eye_tracker);

    // True once the tracker has no more samples and none are pending.
    bool tracker_finished() const;

    const std::vector<SceneObject>& objects() const;
    const NodeConfig& config() const { return config_; }
    // The field of view each eye buffer is rendered with (the lens's, grown for the warp).
    const StereoRig& render_rig() const { return render_rig_; }
    // Cells per side of the distortion mesh in use (1 without distortion).
    int mesh_cols() const { return mesh_[0].cols; }
    int mesh_rows() const { return mesh_[0].rows; }
    const Renderer& renderer() const { return renderer_; }
    const PoseHistory& history() const { return history_; }
    // The render cost model learned from the frames so far (node clock: on the simulated clock it
    // converges to the sim_cost model's render part).
    const FrameCostFit& lod_cost_fit() const;
    // The last rendered frame (empty unless config.read_back).
    const StereoImage& last_frame() const { return frame_; }
    // Reads the panel image back at the next present only (config.read_back off): a display that
    // writes only some frames asks for those.
    void read_back_next() { read_back_once_ = true; }
    const FramePacer& pacer() const { return pacer_; }
    const PixelLadder& ladder() const { return ladder_; }
    // "fused" or "mesh" (the pass in use), "" without one.
    const char* lens_pass() const { return renderer_.lens_pass_name(); }
    // What the start-up calibration measured of the passes (lower quartiles, ms; NaN where not
    // measured): the fused pass, the mesh pass, and the pass's floor (three bilinear samples per
    // pixel, no lens model, same panel).
    struct PassTimes {
        double fused_ms = std::numeric_limits<double>::quiet_NaN();
        double mesh_ms = std::numeric_limits<double>::quiet_NaN();
        double floor_ms = std::numeric_limits<double>::quiet_NaN();
    };
    const PassTimes& pass_times() const { return pass_times_; }

  private:
    // What one run_frame call plans with, read once: the display's timing and the pacer's
    // estimates.
    struct FramePlan {
        DisplayInfo info;
        int64_t latch = 0;          // info.latch_margin_ns
        int64_t photon_offset = 0;  // a vsync to its photon time (the panel centre)
        int64_t render_est = 0, warp_est = 0;
        // A new frame's render and warp together: the percentile of their sum, not the sum of
        // their percentiles (a slow render rarely meets a slow warp).
        int64_t frame_est = 0;
        int64_t margin = 0;
        int divisor = 1;  // the render rate: a new frame every `divisor` vsyncs
    };
    // A present of the finished frame re-warped for `vsync_ns` in place of a new frame; early:
    // at once rather than at its wake-up (the time until then is more than a draw item takes, and
    // would be lost to the open frame; the pose it shows is that much older).
    struct Rewarp {
        int64_t vsync_ns = 0;
        bool early = false;
    };

    void drain_tracker();
    void adopt_objects(const Scene& scene);
    // The selector's parameters: the configured tolerance scaled by the LOD bias, with the
    // panel's persistence.
    LodSelectorParams selector_params() const;
    void rebuild_selector();
    StereoViews views_for(const Pose& head) const;
    Pose predict(int64_t photon_time_ns) const;
    // The eye tracker's newest sample while it is valid and fresh (gaze_max_age_ns), else null.
    const GazeSample* fresh_gaze() const;

    // The frame loop's steps (run_frame, in this order).
    // Chooses the render rate and the ladder's step for the next new frame and applies the step.
    void plan_levers();
    // The pacer's estimates for this call (after plan_levers).
    void read_estimates(FramePlan* p) const;
    // 1. The vsync a new frame aims at (*target) and its wake-up (open_wake_ns_), or the re-warp
    // of the finished frame that comes before it.
    std::optional<Rewarp> aim_new_frame(const FramePlan& p, int64_t* target);
    // 1. Waits for the wake-up, predicts the pose, selects LOD (the LOD stage) and begins the
    // frame for `target` in the back eye buffers.
    Status open_frame(const FramePlan& p, int64_t target, FrameRecord* rec);
    // 2. Renders the open frame in pieces until it is done, or until the finished frame must be
    // re-warped first (returned; the open frame resumes on the next call).
    Result<std::optional<Rewarp>> render_pieces(const FramePlan& p);
    // 2. The re-warp that must come before the next piece, or the piece's triangle limit
    // (*max_triangles; left as it is when the piece is not limited).
    std::optional<Rewarp> next_piece(const FramePlan& p, int64_t now, int64_t render_budget,
                                     double per_item_ns, uint64_t* max_triangles);
    Status render_piece(uint64_t max_triangles);
    // 2. The open frame is done: it becomes the finished frame; the ladder and the LOD stage
    // learn its cost.
    void finish_render();
    // 3. The finished new frame's vsync (*early: warped at once, a rescued vsync), then its late
    // warp and present, and the record.
    int64_t aim_warp(const FramePlan& p, bool* early) const;
    Result<FrameOutcome> present_new_frame(const FramePlan& p, FrameRecord* rec,
                                           const TruthFn& truth);
    // The finished frame re-warped and presented for `w`, and the record.
    Result<FrameOutcome> rewarp(const FramePlan& p, Rewarp w, FrameRecord* rec,
                                const TruthFn& truth);
    // The record's registration error against the truth at its photon time (NaN without one).
    void fill_truth(FrameRecord* rec, const TruthFn& truth) const;

    // Warps the finished frame for `target` (sampling the newest pose first when the warp is on),
    // presents it and fills the record's present fields; adapts the margin.
    // early: at once, not at its wake-up (a re-warp between pieces of a frame).
    Status warp_and_present(int64_t target, int64_t warp_est, FrameRecord* rec,
                            int64_t* warp_cost_ns, bool early = false);
    bool pass_enabled() const { return config_.warp || config_.distortion; }
    // The profile the fused pass evaluates: the headset's, or the rig's field of view flat.
    HeadsetProfile pass_profile() const;
    // Sets up the pass `choice` names (fused unless mesh).
    Status set_up_pass(bool fused);
    // The first free vsync a typical warp started at `now` makes (FramePacer::warp_typical): a
    // vsync before the planned one that would otherwise go without a present.
    int64_t rescue_vsync(int64_t now) const;
    // The start-up calibration of the lens passes (pass_times_, the pass chosen, model's warp
    // costs; on the system clock the pacing and ladder estimates seeded with them).
    Status calibrate_passes(FrameCostModel* model, const std::function<bool()>& go_on);
    // Times `n` warps of the current pass (lower quartile, ns).
    Result<int64_t> time_warps(int n, const std::function<bool()>& go_on);

    Clock& clock_;
    Tracker* tracker_;
    EyeTracker* eye_tracker_ = nullptr;
    std::vector<GazeSample> gaze_buf_;
    std::optional<GazeSample> gaze_;  // the newest sample read (valid or not)
    Display& display_;
    Renderer& renderer_;
    const Scene* scene_;
    NodeConfig config_;
    int64_t prediction_offset_ns_ = 0;
    double lod_bias_ = 0.0;
    struct Recentre {
        glm::dquat rotation{1.0, 0.0, 0.0, 0.0};
        glm::dvec3 from{0.0}, to{0.0};
    } recentre_;
    PoseHistory history_;
    std::vector<TrackerSample> read_buf_;
    StereoImage frame_;
    StereoRig render_rig_;
    DistortionMesh mesh_[2];
    FramePacer pacer_;
    PixelLadder ladder_;
    PassTimes pass_times_;
    // LOD selection, the frame budget and its learned cost, the fades and the draw list; what it
    // chose for the open and the finished frame.
    std::unique_ptr<LodStage> lod_;
    bool read_back_once_ = false;
    int64_t last_new_vsync_ns_ = 0;  // the vsync the newest new frame was shown at
    uint64_t present_index_ = 0, render_index_ = 0;
    LatencyMarkerOverlay marker_;  // the latency marker's place; its payload set per warp
    // Sets the marker's payload (the sample's time, the next present's index) on the renderer.
    void mark_warp(int64_t sample_ns);
    int64_t last_shown_vsync_ns_ = INT64_MIN;
    int pieces_since_rewarp_ = 1;  // pieces of the open frames rendered since the last re-warp
    // The frame being rendered in pieces, between which the finished one may be re-warped.
    bool open_ = false;
    size_t open_cursor_ = 0;      // draws rendered so far
    int open_rewarps_ = 0;        // re-warps that interrupted it
    int64_t open_target_ns_ = 0;  // the vsync it is rendered for
    int64_t open_wake_ns_ = 0;
    int64_t open_render_ns_ = 0;   // node-clock time its set-up and pieces took
    double open_render_ms_ = 0.0;  // measured wall time of its pieces
    Pose open_pose_;
    int64_t open_pose_sample_ns_ = 0;
    int open_step_ = 0;        // the ladder step it is rendered at
    double open_scale_ = 1.0;  // the eye-buffer scale it is rendered at
    // The finished frame in the eye buffers: its pose, target, the tracker sample it used, its
    // ladder step and scale (its levels: the LOD stage's shown()).
    bool has_frame_ = false;
    Pose frame_pose_;
    int64_t frame_target_vsync_ns_ = 0;
    int64_t frame_pose_sample_ns_ = 0;
    int frame_step_ = 0;
    double frame_scale_ = 1.0;
};

}  // namespace hmdnode
