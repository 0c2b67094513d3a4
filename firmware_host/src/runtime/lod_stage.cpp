// The frame loop's LOD stage (lod_stage.hpp; docs/lod-selection.md): per new frame, the
// selector's level per object (eccentricity from the gaze or the lens centre, head speed,
// hysteresis), per-eye frustum culling, the frame budget (the greedy allocator of Funkhouser and
// Sequin, SIGGRAPH 1993, or the immune genetic one of He et al., against the learned render-cost
// model and its feedback), level changes as dithered cross-fades, and the draw list front to
// back. Cost per new frame: O(objects log objects) plus the allocator's (budget.hpp).
#include "lod_stage.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "hmdnode/core/time.hpp"

namespace hmdnode {

LodStage::LodStage(const StereoRig& rig, double pixels_per_radian, LodAllocator allocator,
                   const BudgetFeedbackParams& feedback, int fade_frames)
    : rig_(rig),
      pixels_per_radian_(pixels_per_radian),
      allocator_kind_(allocator),
      fade_frames_(fade_frames),
      selector_(0),
      feedback_(feedback),
      fade_(0, 0) {}

void LodStage::adopt(const Scene& scene, const LodSelectorParams& selector) {
    objects_ = flatten_objects(scene);
    level_errors_.assign(objects_.size(), {});
    level_triangles_.assign(objects_.size(), {});
    coarsest_triangles_ = 0;
    for (const SceneObject& o : objects_)
        if (!o.levels.empty()) coarsest_triangles_ += o.levels.back().triangles;
    for (size_t i = 0; i < objects_.size(); ++i)
        for (const LodLevel& l : objects_[i].levels) {
            level_errors_[i].push_back(l.geometric_error_m);
            level_triangles_[i].push_back(l.triangles);
        }
    // One list of level errors and triangle counts per object, one entry per level.
    for (size_t i = 0; i < objects_.size(); ++i)
        assert(level_errors_[i].size() == objects_[i].levels.size() &&
               level_triangles_[i].size() == objects_[i].levels.size());
    set_selector_params(selector);
    // A new scene starts without transitions: its objects are not the old ones.
    fade_ = LodCrossFade(objects_.size(), fade_frames_);
    fade_steps_.assign(objects_.size(), LodFadeStep{});
    candidates_.reserve(objects_.size());
    candidate_objects_.reserve(objects_.size());
    allocated_.reserve(objects_.size());
    allocated_levels_.assign(objects_.size(), -1);
    draws_.reserve(2 * objects_.size());  // a cross-fading object is drawn twice
    draw_triangles_.reserve(2 * objects_.size());
    order_.reserve(objects_.size());
    frame_.levels.assign(objects_.size(), 0);
    frame_.eccentricity_deg.assign(objects_.size(), 0.0);
    open_.levels.assign(objects_.size(), 0);
    open_.eccentricity_deg.assign(objects_.size(), 0.0);
    // The learned cost was the old scene's.
    cost_fit_ = FrameCostFit();
}

void LodStage::set_selector_params(const LodSelectorParams& selector) {
    selector_ = LodSelector(objects_.size(), selector);
}

std::optional<double> LodStage::coarsest_render_ms() const {
    if (allocator_kind_ == LodAllocator::threshold || cost_fit_.empty()) return std::nullopt;
    return cost_fit_.predict_ms(coarsest_triangles_);
}

uint64_t LodStage::select(const Pose& head, const StereoViews& views, const glm::dvec3& omega,
                          const GazeSample* gaze, FrameRecord* rec, double target_ms) {
    LodViewer viewer;
    viewer.eye_position = head.position;
    // The gaze: the eye tracker's newest sample, in the head frame, turned with the predicted head
    // (the eye's own motion is not predicted), while it is valid and fresh; else the lens centre.
    viewer.gaze_direction = forward_of(head.orientation);
    rec->gaze_source = GazeSource::lens_centre;
    rec->gaze_eccentricity_deg = 0.0;
    if (gaze) {
        const glm::dvec3 g = glm::normalize(gaze->direction);
        viewer.gaze_direction = head.orientation * g;
        rec->gaze_source = GazeSource::eye_tracker;
        rec->gaze_eccentricity_deg =
            rad_to_deg(std::acos(std::clamp(glm::dot(g, glm::dvec3(0, 0, -1)), -1.0, 1.0)));
    }
    viewer.angular_speed_dps = rad_to_deg(glm::length(omega));
    viewer.pixels_per_radian = pixels_per_radian_;
    viewer.near_m = rig_.near_m;
    rec->levels.resize(objects_.size());
    rec->eccentricity_deg.resize(objects_.size());
    rec->culled = 0;
    order_.clear();
    // Per-eye frustum culling: an object whose bounding sphere lies outside both eyes' frusta
    // (the rendered field, warp margin included) is not drawn; it keeps its level for hysteresis.
    const glm::dmat4 view[2] = {glm::dmat4(views.view[0]), glm::dmat4(views.view[1])};
    auto in_eye = [&](int e, const glm::dvec3& c, double r) {
        return sphere_in_frustum(view[e], rig_.eye[e], rig_.near_m, c, r);
    };
    candidates_.clear();
    candidate_objects_.clear();
    for (size_t i = 0; i < objects_.size(); ++i) {
        const SceneObject& o = objects_[i];
        LodObjectView ov{o.bounds_center, o.bounds_radius, level_errors_[i]};
        LodDecision d = selector_.select(i, ov, viewer);
        rec->levels[i] = d.level;
        rec->eccentricity_deg[i] = d.eccentricity_deg;
        if (!in_eye(0, o.bounds_center, o.bounds_radius) &&
            !in_eye(1, o.bounds_center, o.bounds_radius)) {
            ++rec->culled;
            fade_.hide(i);
            continue;
        }
        candidate_objects_.push_back(i);
        candidates_.push_back(BudgetCandidate{
            level_errors_[i], level_triangles_[i],
            viewer.pixels_per_radian / (d.distance_m * std::max(d.tolerance_px, 1e-9)), d.level});
    }
    allocate(target_ms, rec);
    open_.triangles = fade_and_sort(head, rec);
    std::copy(rec->levels.begin(), rec->levels.end(), open_.levels.begin());
    std::copy(rec->eccentricity_deg.begin(), rec->eccentricity_deg.end(),
              open_.eccentricity_deg.begin());
    return open_.triangles;
}

// The frame budget: the selector's levels are the goal (the finest the eye needs); the
// allocator coarsens them, least benefit per ms first, until the predicted render fits.
void LodStage::allocate(double target_ms, FrameRecord* rec) {
    open_.budget = Budget{};
    open_.budget.target_ms = target_ms;
    if (allocator_kind_ == LodAllocator::threshold) return;
    Budget& b = open_.budget;
    b.learning = cost_fit_.empty();
    // Nothing measured yet: every object at its coarsest (the cheapest frame teaches the model
    // the most about the base cost and errs on the safe side).
    b.budget_ms =
        b.learning ? -std::numeric_limits<double>::infinity() : feedback_.scale() * target_ms;
    allocated_.resize(candidates_.size());
    const bool iga = allocator_kind_ == LodAllocator::iga;
    if (iga)  // warm start: each object's level of the last frame that drew it
        for (size_t k = 0; k < candidate_objects_.size(); ++k)
            candidates_[k].previous = allocated_levels_[candidate_objects_[k]];
    const BudgetAllocation a =
        iga ? iga_.allocate(candidates_, cost_fit_.base_ms(), cost_fit_.per_triangle_ms(),
                            b.budget_ms, allocated_)
            : greedy_.allocate(candidates_, cost_fit_.base_ms(), cost_fit_.per_triangle_ms(),
                               b.budget_ms, allocated_);
    assert(allocated_.size() == candidates_.size());  // a level per candidate
    for (size_t k = 0; k < candidate_objects_.size(); ++k) {
        assert(allocated_[k] >= 0 &&
               size_t(allocated_[k]) < objects_[candidate_objects_[k]].levels.size());
        rec->levels[candidate_objects_[k]] = allocated_[k];
        allocated_levels_[candidate_objects_[k]] = allocated_[k];
    }
    b.predicted_ms = a.predicted_ms;
    b.coarsened = a.coarsened;
    b.limited = a.limited;
}

uint64_t LodStage::fade_and_sort(const Pose& head, FrameRecord* rec) {
    // Level changes of visible objects become cross-fades (both levels drawn, complementary
    // masks) instead of pops; the record shows the level fading in.
    uint64_t triangles = 0;
    open_.fade = FadeCounts{};
    for (size_t i : candidate_objects_) {
        const SceneObject& o = objects_[i];
        const LodFadeStep& step = fade_steps_[i] = fade_.update(i, rec->levels[i]);
        rec->levels[i] = step.draws[0].level;
        for (int d = 0; d < step.count; ++d)
            triangles += o.levels[size_t(step.draws[d].level)].triangles;
        open_.fade.fading += step.count > 1;
        open_.fade.transitions += step.started;
        open_.fade.pops += step.popped;
        order_.emplace_back(glm::length(o.bounds_center - head.position) - o.bounds_radius, i);
    }
    // One record per object; the candidates are the objects not culled, each with its entry.
    assert(rec->levels.size() == objects_.size() &&
           candidates_.size() == candidate_objects_.size() &&
           order_.size() == candidate_objects_.size());
    // Front to back: nearest first saves fill on lavapipe.
    std::sort(order_.begin(), order_.end());
    draws_.clear();
    draw_triangles_.clear();
    for (const auto& [dist, i] : order_) {
        const SceneObject& o = objects_[i];
        const LodFadeStep& step = fade_steps_[i];
        for (int d = 0; d < step.count; ++d) {
            const LodLevel& l = o.levels[size_t(step.draws[d].level)];
            draws_.push_back(DrawItem{l.mesh, glm::mat4(o.world), step.draws[d].dither});
            draw_triangles_.push_back(l.triangles);
        }
    }
    // One triangle count per draw, and together the frame's triangles.
    assert(draws_.size() == draw_triangles_.size());
    return triangles;
}

void LodStage::finish(double measured_ms, bool full_resolution) {
    // The cost model learns from every frame at full resolution (a frame at a lower resolution
    // costs less for its pixels, not its triangles); the budget's feedback from the allocator's
    // frames.
    if (full_resolution) cost_fit_.add(open_.triangles, measured_ms);
    if (allocator_kind_ != LodAllocator::threshold && !open_.budget.learning)
        feedback_.update(measured_ms, open_.budget.target_ms, open_.budget.limited);
    frame_.triangles = open_.triangles;
    std::copy(open_.levels.begin(), open_.levels.end(), frame_.levels.begin());
    std::copy(open_.eccentricity_deg.begin(), open_.eccentricity_deg.end(),
              frame_.eccentricity_deg.begin());
    frame_.budget = open_.budget;
    frame_.fade = open_.fade;
}

}  // namespace hmdnode
