// The one assembly place: a node spec -> the clock, the tracker, the eye tracker, the display, the
// renderer and the NodeRuntime over them, made by the factories of the one wiring place
// (wiring.hpp) and owned together. `hmdnode replay` (and latency and render-bench, through
// run_replay) and hmdnoded assemble their node here, with one read-back rule. What each does with
// the node (calibration, truth, the daemon's control socket and reload) stays with it. Cost: what
// the backends cost to open; per frame, run_frame adds a comparison.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/firmware_host/cpu_wake.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/wiring.hpp"

namespace hmdnode {

struct NodeSpec {
    WiringKeys keys = WiringKeys::config();  // the keys or flags errors name
    ClockKind clock = ClockKind::real;
    TrackerSpec tracker;
    EyeTrackerSpec eye_tracker;  // none: LOD eccentricity from the lens centre
    DisplaySpec display;
    RendererSpec renderer;
    // node.read_back: whether frames may come back to the CPU at all (read_back_rule says which).
    NodeConfig node;
};

// Which presents copy the panel image back to the CPU.
enum class ReadBack {
    none,              // the display does not need the pixels
    every_present,     // a display scanning out of CPU memory (kms dumb buffers, vk-display)
    written_presents,  // the mock display writing frames: every frames_every-th present only
};

// The one read-back rule: none when node.read_back is off; the mock display: every present when
// it has a watcher (mock.watcher or mock_watcher), else the presents it writes (none without
// display.frames_dir); kms with zero-copy scan-out (the warp draws into the
// scanned-out buffer): none while a warp pass runs (warp or distortion), else every present (the
// frames are copied); any other display: every present.
ReadBack read_back_rule(const DisplaySpec& display, const NodeConfig& node, bool zero_copy);

// The part of the assembly that failed: the daemon's exit status follows it (a part the config
// names: 2; the runtime's start, a failure of the world: 1). eye_tracker_start: the runtime
// refused the eye tracker made.
enum class NodePart { tracker, eye_tracker, display, renderer, start, eye_tracker_start };

class AssembledNode;

// Makes the clock, the tracker, the eye tracker (at the same clock time: the gaze and the head
// replay one timeline), the display, the renderer for it (wiring.hpp's, zero-copy on kms + gles)
// and the runtime over them, then starts the runtime and hands it the eye tracker. `scene` must
// outlive the runtime or its next replace_scene. Errors name the key; *failed (where given) names
// the part that failed.
Result<std::unique_ptr<AssembledNode>> make_node(const NodeSpec& spec, const Scene& scene,
                                                 NodePart* failed = nullptr);

// The assembled node. Its parts live as long as it does; the runtime is destroyed first.
class AssembledNode {
  public:
    Clock& clock() { return *clock_; }
    Tracker& tracker() { return *tracker_; }
    // The device tracker behind the tracker (every backend but trace), else null.
    DeviceTracker* device_tracker() const { return device_tracker_; }
    const std::string& tracker_label() const { return tracker_label_; }  // what it reads, for logs
    EyeTracker* eye_tracker() const { return eye_tracker_.get(); }
    Display& display() { return *display_; }
    Renderer& renderer() { return *renderer_; }
    NodeRuntime& runtime() { return *runtime_; }
    const NodeRuntime& runtime() const { return *runtime_; }
    const NodeSpec& spec() const { return spec_; }
    bool zero_copy() const { return zero_copy_; }  // kms + gles: GBM zero-copy scan-out
    ReadBack read_back() const { return read_back_; }
    // What keeps the cores awake (spec.node.cpu_wake on the system clock), or "off".
    std::string cpu_wake() const { return cpu_wake_ ? cpu_wake_->description() : "off"; }
    int64_t host_start_ns() const { return host_start_ns_; }  // the clock's now at the tracker's

    // One present (NodeRuntime::run_frame), with the read-back the rule asks for.
    Result<FrameOutcome> run_frame(FrameRecord* record, const TruthFn& truth = nullptr);

    // The tracker, and the eye tracker where there is one, made anew from the spec at the clock's
    // now (one timeline) and handed to the runtime; the old ones are freed. A file backend that
    // finished (the daemon's loop) or a replay starting its trace again after the calibration.
    // *failed (where given) names the part that failed.
    Status restart_trackers(NodePart* failed = nullptr);

  private:
    friend Result<std::unique_ptr<AssembledNode>> make_node(const NodeSpec&, const Scene&,
                                                            NodePart*);
    AssembledNode() = default;

    NodeSpec spec_;
    std::unique_ptr<Clock> clock_;
    int64_t host_start_ns_ = 0;
    std::unique_ptr<Tracker> tracker_;
    DeviceTracker* device_tracker_ = nullptr;
    std::string tracker_label_;
    std::unique_ptr<EyeTracker> eye_tracker_;
    std::unique_ptr<Display> display_;
    std::unique_ptr<Renderer> renderer_;
    bool zero_copy_ = false;
    ReadBack read_back_ = ReadBack::none;
    uint64_t presents_ = 0;  // written_presents: presents so far (the mock display's index)
    std::unique_ptr<CpuWakeGuard> cpu_wake_;  // held from before the renderer's start-up
    std::unique_ptr<NodeRuntime> runtime_;    // last: destroyed before what it refers to
};

}  // namespace hmdnode
