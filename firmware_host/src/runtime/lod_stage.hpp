// The frame loop's LOD stage (docs/lod-selection.md), private to the node runtime: NodeRuntime
// (node.cpp) asks it once per new frame for the levels and the draw list, and tells it what the
// frame cost once rendered. It owns the scene's objects as flat draw items, the perceptual LOD
// selector, per-eye frustum culling, the frame-budget allocators (the greedy one of T. A.
// Funkhouser, C. H. Sequin, "Adaptive display algorithm for interactive frame rates during
// visualization of complex virtual environments", SIGGRAPH 1993, and the immune genetic one of
// He et al.; docs/references.md) with the learned render-cost model and the budget's feedback,
// the dithered cross-fades between levels, and the front-to-back draw list; and what it chose for
// the open frame (being rendered) and for the finished one (in the eye buffers).
//
// Cost per new frame: O(objects log objects) for selection, culling, the fades and the sort, plus
// the allocator's (budget.hpp). Nothing allocates after adopt() but the allocators' first frames.
// Threads: the frame thread's, as NodeRuntime.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/hal/eye_tracker.hpp"
#include "hmdnode/lod/budget.hpp"
#include "hmdnode/lod/cross_fade.hpp"
#include "hmdnode/lod/selector.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {

class LodStage {
  public:
    // What the frame budget (greedy or iga allocator) said of one frame.
    struct Budget {
        double target_ms = 0.0;  // before the feedback's scale
        double budget_ms = std::numeric_limits<double>::quiet_NaN();
        double predicted_ms = std::numeric_limits<double>::quiet_NaN();
        size_t coarsened = 0;
        bool limited = false;
        bool learning = false;  // no cost model yet: everything at its coarsest, no feedback
    };
    // One frame's level transitions (FrameRecord's lod_fading, lod_transitions, lod_pops).
    struct FadeCounts {
        size_t fading = 0, transitions = 0, pops = 0;
    };
    // What the stage chose for one frame: the triangles drawn, the level (fading in) and the
    // eccentricity per object, the budget's and the fades' counts.
    struct Choice {
        uint64_t triangles = 0;
        std::vector<int> levels;
        std::vector<double> eccentricity_deg;
        Budget budget;
        FadeCounts fade;
    };

    // rig: the field of view the eye buffers are rendered with (culled against), and their
    // pixels per radian; allocator, feedback, fade_frames: NodeConfig's lod_allocator,
    // lod_feedback and lod_fade_frames. The stage starts with no objects (adopt()).
    LodStage(const StereoRig& rig, double pixels_per_radian, LodAllocator allocator,
             const BudgetFeedbackParams& feedback, int fade_frames);

    // The scene's objects and everything sized by them: a new selector with `selector`, no
    // transitions, no learned cost.
    void adopt(const Scene& scene, const LodSelectorParams& selector);
    // A new selector (its hysteresis too) with these parameters, for the same objects.
    void set_selector_params(const LodSelectorParams& selector);

    // LOD selection for `head` seen through `views` (the frame's own, culled against), turning
    // at `omega` (rad/s), with `gaze` (the eye tracker's sample, valid and fresh; null: the lens
    // centre): fills rec's levels, eccentricity_deg, culled, gaze_source and
    // gaze_eccentricity_deg, the draw list, and open(). target_ms: the budgeted allocator's
    // render target before the feedback's scale. Returns the triangles drawn.
    uint64_t select(const Pose& head, const StereoViews& views, const glm::dvec3& omega,
                    const GazeSample* gaze, FrameRecord* rec, double target_ms);
    // The open frame is rendered: its cost teaches the cost model (when rendered at full
    // resolution) and the budget's feedback (the allocator's frames), and its choice becomes the
    // finished frame's (shown()).
    void finish(double measured_ms, bool full_resolution);

    // The open frame's draw list, nearest first (a cross-fading object twice), and each draw's
    // triangles.
    const std::vector<DrawItem>& draws() const { return draws_; }
    const std::vector<uint64_t>& draw_triangles() const { return draw_triangles_; }
    const Choice& open() const { return open_; }
    const Choice& shown() const { return frame_; }

    const std::vector<SceneObject>& objects() const { return objects_; }
    const FrameCostFit& cost_fit() const { return cost_fit_; }
    // A measured render of `triangles` for the cost model (the start-up calibration's).
    void learn_cost(uint64_t triangles, double render_ms) { cost_fit_.add(triangles, render_ms); }
    // With a budgeted allocator whose cost model has data: the predicted render with every object
    // at its coarsest level (what the allocator can reach); else nothing.
    std::optional<double> coarsest_render_ms() const;

  private:
    // The frame budget for the candidates: with a budgeted allocator, its levels in place of
    // the selector's in rec->levels.
    void allocate(double target_ms, FrameRecord* rec);
    // Level changes as cross-fades, then the draw list front to back; returns the triangles.
    uint64_t fade_and_sort(const Pose& head, FrameRecord* rec);

    StereoRig rig_;
    double pixels_per_radian_ = 0.0;
    LodAllocator allocator_kind_;
    int fade_frames_ = 0;
    LodSelector selector_;
    std::vector<SceneObject> objects_;
    std::vector<std::vector<double>> level_errors_;       // per object, per level (world metres)
    std::vector<std::vector<uint64_t>> level_triangles_;  // per object, per level
    uint64_t coarsest_triangles_ = 0;                     // every object at its coarsest level
    std::vector<DrawItem> draws_;                         // reused every frame
    std::vector<uint64_t> draw_triangles_;                // per draw
    std::vector<std::pair<double, size_t>> order_;        // front-to-back sort keys, reused
    // The frame budget: the learned cost, the budget's correction, the drawn objects as
    // candidates (reused).
    FrameCostFit cost_fit_;
    BudgetFeedback feedback_;
    GreedyLodAllocator greedy_;
    IgaLodAllocator iga_;
    std::vector<int> allocated_levels_;  // per object, the allocator's last level (-1: none)
    std::vector<BudgetCandidate> candidates_;
    std::vector<size_t> candidate_objects_;
    std::vector<int> allocated_;
    // Level changes as cross-fades.
    LodCrossFade fade_;
    std::vector<LodFadeStep> fade_steps_;  // per object, this frame's (drawn objects only)
    Choice open_, frame_;
};

}  // namespace hmdnode
