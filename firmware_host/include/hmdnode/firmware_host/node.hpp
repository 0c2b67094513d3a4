// The node runtime: the frame loop paced to the display's vsync. Each frame it wakes just early
// enough to render, reads the tracker, predicts the head pose at the frame's photon time, picks a
// level of detail per object, renders both eyes, presents, and records what it did.
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
#include <vector>

#include "hmdnode/core/scene.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/firmware_host/pose_history.hpp"
#include "hmdnode/hal/display.hpp"
#include "hmdnode/hal/tracker.hpp"
#include "hmdnode/lod/selector.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {

// On a simulated clock the frame's duration cannot be the measured one (that would make a replay
// depend on the machine), so the clock advances by this model of the target hardware instead.
struct FrameCostModel {
    int64_t base_ns = 1'500'000;
    double per_triangle_ns = 40.0;  // both eyes (one multiview pass)
    double per_pixel_ns = 2.0;      // both eyes
    int64_t cost_ns(uint64_t triangles, uint64_t pixels) const {
        return base_ns +
               int64_t(per_triangle_ns * double(triangles) + per_pixel_ns * double(pixels));
    }
};

struct NodeConfig {
    StereoRig rig = StereoRig::typical();
    glm::dvec3 default_head_position{0.0, 1.6, 0.0};  // used when the tracker gives no position
    bool predict = true;                              // false: render the newest sample's pose
    PoseHistoryConfig history;
    LodSelectorParams lod;
    int64_t wake_margin_ns = 1'000'000;  // wake this long before the estimated frame cost
    FrameCostModel sim_cost;
    bool read_back = true;  // copy frames back to the CPU for the display
};

struct FrameRecord {
    uint64_t index = 0;
    int64_t wake_ns = 0;
    int64_t target_vsync_ns = 0;
    int64_t vsync_ns = 0;
    int64_t pose_sample_time_ns = 0;       // newest tracker sample used
    int64_t predicted_photon_time_ns = 0;  // the time the pose was predicted for
    int64_t photon_time_ns = 0;            // actual photon time of the panel centre
    double latency_ms = 0.0;               // photon_time - pose_sample_time
    double prediction_horizon_ms = 0.0;    // predicted_photon_time - pose_sample_time
    double registration_error_deg = std::numeric_limits<double>::quiet_NaN();  // NaN: no truth
    double angular_speed_dps = 0.0;
    bool on_time = false;
    uint64_t triangles = 0;
    double render_ms = 0.0;      // measured wall time of the render call (record, GPU, read-back)
    double frame_cost_ms = 0.0;  // on the node's clock: wake to present
    std::vector<int> levels;     // LOD level per object (index as in objects())
    std::vector<double> eccentricity_deg;  // per object
};

// The truth for registration error: the true head orientation at a host time, or nothing where
// the truth is unknown (replay only: outside the recorded trace).
using TruthFn = std::function<std::optional<glm::dquat>(int64_t host_time_ns)>;

// What one run_frame call did.
enum class FrameOutcome {
    rendered,     // rendered and presented; the record is filled out
    no_pose_yet,  // the tracker has delivered no sample yet: nothing was rendered or presented,
                  // the frame's vsync has passed (so the next call aims at the one after), and
                  // the record is left as it was
};

class NodeRuntime {
  public:
    // All references must outlive the runtime. The scene is flattened and uploaded by start().
    NodeRuntime(Clock& clock, Tracker& tracker, Display& display, Renderer& renderer,
                const Scene& scene, const NodeConfig& config);

    // Uploads the scene and starts the tracker.
    Status start();
    void stop();

    // Runs one frame: waits for its wake-up time, then does the frame's work and presents, and
    // fills out_record (reused by the caller so the frame path does not allocate). Never waits
    // longer than about one display period: before the tracker's first sample there is nothing
    // to show, so the frame is skipped (FrameOutcome::no_pose_yet) and the caller can look at its
    // stop flag and call again. Returns an error when rendering or presenting fails, or when the
    // tracker finished without delivering a sample; the caller decides to go on or stop.
    Result<FrameOutcome> run_frame(FrameRecord* out_record, const TruthFn& truth = nullptr);

    // True once the tracker has delivered a sample (run_frame renders from then on).
    bool has_pose() const { return !history_.empty(); }

    // Swaps the tracker (a replugged device, or a looping replay): stops the old one, starts the
    // new one. The pose history is kept; samples older than its newest are ignored.
    Status replace_tracker(Tracker& tracker);

    // True once the tracker has no more samples and none are pending.
    bool tracker_finished() const;

    const std::vector<SceneObject>& objects() const { return objects_; }
    const Renderer& renderer() const { return renderer_; }
    const PoseHistory& history() const { return history_; }
    // The last rendered frame (empty unless config.read_back).
    const StereoImage& last_frame() const { return frame_; }

  private:
    void drain_tracker();
    StereoViews views_for(const Pose& head) const;

    Clock& clock_;
    Tracker* tracker_;
    Display& display_;
    Renderer& renderer_;
    const Scene& scene_;
    NodeConfig config_;
    PoseHistory history_;
    LodSelector selector_;
    std::vector<SceneObject> objects_;
    std::vector<std::vector<double>> level_errors_;  // per object, per level (world metres)
    std::vector<DrawItem> draws_;                    // reused every frame
    std::vector<std::pair<double, size_t>> order_;   // front-to-back sort keys, reused
    std::vector<TrackerSample> read_buf_;
    StereoImage frame_;
    int64_t cost_estimate_ns_ = 0;
    uint64_t frame_index_ = 0;
    double pixels_per_radian_ = 0.0;
};

}  // namespace hmdnode
