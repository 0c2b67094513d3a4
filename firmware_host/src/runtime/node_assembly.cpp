// The one assembly place (node_assembly.hpp): a node spec -> its parts through the factories of
// wiring.cpp -> a started NodeRuntime; the one read-back rule.
#include "hmdnode/firmware_host/node_assembly.hpp"

#include <utility>

namespace hmdnode {

ReadBack read_back_rule(const DisplaySpec& display, const NodeConfig& node, bool zero_copy) {
    if (!node.read_back) return ReadBack::none;
    // The mock display writes only every frames_every-th present; it reads no other pixels,
    // except for a watcher (a camera filming the panel), which sees every present.
    if (display.type == "mock" && (display.mock.watcher || display.mock_watcher))
        return ReadBack::every_present;
    if (display.type == "mock")
        return display.mock.frames_dir.empty() ? ReadBack::none : ReadBack::written_presents;
    // Zero-copy scan-out: the warp's output is the scanned-out buffer. Without a warp pass the
    // rendered frames are copied into it.
    if (zero_copy && (node.warp || node.distortion)) return ReadBack::none;
    return ReadBack::every_present;
}

Result<std::unique_ptr<AssembledNode>> make_node(const NodeSpec& spec, const Scene& scene,
                                                 NodePart* failed) {
    auto fail = [failed](NodePart part, const Error& e) {
        if (failed) *failed = part;
        return e;
    };
    std::unique_ptr<AssembledNode> n(new AssembledNode());
    n->spec_ = spec;
    const WiringKeys& keys = n->spec_.keys;
    n->clock_ = make_clock(spec.clock);
    // Before the renderer exists: its worker threads and the start-up calibration run with the
    // cores awake, as the frame loop will.
    if (!n->clock_->is_simulated() && spec.node.cpu_wake != CpuWake::off)
        n->cpu_wake_ = CpuWakeGuard::start(spec.node.cpu_wake);
    n->host_start_ns_ = n->clock_->now_ns();
    Result<WiredTracker> wired = make_tracker(spec.tracker, *n->clock_, keys);
    if (!wired.ok()) return fail(NodePart::tracker, wired.error());
    n->tracker_ = std::move(wired->tracker);
    n->device_tracker_ = wired->device;
    n->tracker_label_ = std::move(wired->label);
    // Made at the same clock time as the tracker: the gaze and the head replay one timeline.
    Result<std::unique_ptr<EyeTracker>> eyes = make_eye_tracker(spec.eye_tracker, *n->clock_, keys);
    if (!eyes.ok()) return fail(NodePart::eye_tracker, eyes.error());
    n->eye_tracker_ = std::move(*eyes);
    Result<std::unique_ptr<Display>> display = make_display(spec.display, *n->clock_, keys);
    if (!display.ok()) return fail(NodePart::display, display.error());
    n->display_ = std::move(*display);
    Result<std::unique_ptr<Renderer>> renderer =
        make_renderer(spec.renderer, *n->display_, keys, &n->zero_copy_);
    if (!renderer.ok()) return fail(NodePart::renderer, renderer.error());
    n->renderer_ = std::move(*renderer);

    n->read_back_ = read_back_rule(spec.display, spec.node, n->zero_copy_);
    NodeConfig nc = spec.node;
    nc.read_back = n->read_back_ == ReadBack::every_present;  // the others: run_frame asks
    n->runtime_ = std::make_unique<NodeRuntime>(*n->clock_, *n->tracker_, *n->display_,
                                                *n->renderer_, scene, nc);
    if (Status st = n->runtime_->start(); !st.ok()) return fail(NodePart::start, st.error());
    if (Status st = n->runtime_->set_eye_tracker(n->eye_tracker_.get()); !st.ok())
        return fail(NodePart::eye_tracker_start, st.error());
    return n;
}

Result<FrameOutcome> AssembledNode::run_frame(FrameRecord* record, const TruthFn& truth) {
    if (read_back_ == ReadBack::written_presents &&
        presents_ % uint64_t(spec_.display.mock.frames_every) == 0)
        runtime_->read_back_next();
    Result<FrameOutcome> r = runtime_->run_frame(record, truth);
    if (r.ok() && *r != FrameOutcome::no_pose_yet) ++presents_;
    return r;
}

Status AssembledNode::restart_trackers(NodePart* failed) {
    auto fail = [failed](NodePart part, const Error& e) {
        if (failed) *failed = part;
        return Status(e);
    };
    Result<WiredTracker> wired = make_tracker(spec_.tracker, *clock_, spec_.keys);
    if (!wired.ok()) return fail(NodePart::tracker, wired.error());
    if (Status st = runtime_->replace_tracker(*wired->tracker); !st.ok())
        return fail(NodePart::start, st.error());
    tracker_ = std::move(wired->tracker);  // the old one is stopped: nothing refers to it
    device_tracker_ = wired->device;
    tracker_label_ = std::move(wired->label);
    if (!eye_tracker_) return {};
    Result<std::unique_ptr<EyeTracker>> eyes =
        make_eye_tracker(spec_.eye_tracker, *clock_, spec_.keys);
    if (!eyes.ok()) return fail(NodePart::eye_tracker, eyes.error());
    if (Status st = runtime_->set_eye_tracker(eyes->get()); !st.ok())
        return fail(NodePart::eye_tracker_start, st.error());
    eye_tracker_ = std::move(*eyes);
    return {};
}

}  // namespace hmdnode
