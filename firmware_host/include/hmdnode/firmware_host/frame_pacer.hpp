// The frame pacer and the pixel-cost ladder (docs/latency.md, "Pacing" and "The pixel-cost
// ladder"): what the frame loop (NodeRuntime) asks before each present, kept apart from it as
// Monado keeps its pacing (src/xrt/auxiliary/util/u_pacing_compositor.c) apart from its
// compositor.
//
// FramePacer: cost estimates read from the distribution of recent costs, a margin that follows
// the spread of the wake-ups and of the costs (not a fixed step), and the render rate: the
// integer fraction of the refresh (1/1, 1/2, 1/3) at which new frames are made, chosen with
// hysteresis from those estimates; between two new frames every vsync gets the newest frame
// re-warped.
//
// PixelLadder: the levers that cut pixel cost, in order of the quality they give up (eye-buffer
// resolution 1.0 down to 0.5 per axis, then chromatic-aberration correction off), each with its
// learned cost, choosing the least loss whose frame fits the budget of the chosen render rate.
//
// Threads: both belong to the frame thread. No allocation after construction. Cost per call:
// O(window) for a percentile.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hmdnode {

// How the frame loop plans its wake-ups (docs/latency.md).
struct PacingConfig {
    int window = 90;           // recent costs the estimates look at (<= 256)
    double percentile = 0.95;  // an estimate is this percentile of its window
    // The margin (slack between the planned end of the warp and the latch) is this percentile of
    // the recent overruns: wake-up lateness plus the cost above its estimate, never below
    // min_margin_ns nor above max_margin_ns; a missed latch adds miss_step_ns that decays by
    // half every miss_half_life vsyncs made.
    double margin_percentile = 0.98;
    int64_t margin_ns = 1'000'000;  // before any overrun was seen
    int64_t min_margin_ns = 300'000;
    int64_t max_margin_ns = 4'000'000;
    int64_t miss_step_ns = 500'000;
    int miss_half_life = 45;
    // The render rate: new frames every `divisor` vsyncs, 1..max_divisor (1: off). A slower rate
    // is chosen at once when the current one does not fit; a faster one after `rate_recover`
    // new frames in a row that fit it with `rate_spare` to spare.
    int max_divisor = 3;
    int rate_recover = 45;
    double rate_spare = 0.08;
    // The pixel-cost ladder: a finer step after `ladder_recover` new frames in a row that fit it
    // with rate_spare to spare (a cheaper one at once when the frame does not fit).
    int ladder_recover = 20;
};

// A fixed window of recent costs and percentiles over it (no allocation after construction).
class CostWindow {
  public:
    explicit CostWindow(int capacity = 90);
    void push(int64_t ns);
    bool empty() const { return count_ == 0; }
    size_t size() const { return count_; }
    void clear() { head_ = count_ = 0; }
    // The p-quantile (0..1) of the window, nearest rank as hmdnode/core/percentile.hpp defines it;
    // `fallback` while it is empty.
    int64_t percentile(double p, int64_t fallback) const;

  private:
    std::vector<int64_t> ring_;
    mutable std::vector<int64_t> scratch_;
    size_t head_ = 0, count_ = 0;
};

class FramePacer {
  public:
    FramePacer(const PacingConfig& config, int64_t period_ns, int64_t latch_ns);

    // Estimates (ns): a new frame's render, a warp with the current pass, and a new frame's
    // render + warp (the percentile of their sum: a slow render rarely meets a slow warp).
    int64_t render_estimate() const;
    int64_t warp_estimate() const;
    int64_t frame_estimate() const;
    // A typical warp (the median of the window): what re-warps cost on average, for deciding
    // whether the queue has room for them (the estimates above plan deadlines).
    int64_t warp_typical() const;
    int64_t margin() const { return margin_ns_; }
    // New frames every divisor() vsyncs.
    int divisor() const { return divisor_; }

    // Measured costs. A change of pass (chromatic aberration on or off, another scale) starts
    // the affected window anew from a predicted cost, which stands for the estimate until three
    // costs are measured: restart_warp() / restart_render().
    void seed_render(int64_t ns) { render_.push(ns); }
    void seed_warp(int64_t ns) { warp_.push(ns); }
    void restart_warp(int64_t predicted_ns) {
        warp_.clear();
        total_.clear();
        warp_predicted_ = predicted_ns;
    }
    void restart_render(int64_t predicted_ns) {
        render_.clear();
        total_.clear();
        render_predicted_ = predicted_ns;
    }
    void record_frame(int64_t render_ns, int64_t warp_ns);  // a new frame's render and warp
    // The time a frame rendered in pieces lay idle before a re-warp between two of them (its
    // next piece would not have ended before the re-warp was due).
    void record_gap(int64_t ns) { gap_.push(ns); }
    int64_t gap_estimate() const { return gap_.percentile(0.9, 0); }
    void record_warp(int64_t warp_ns);  // every warp
    // A present: on time at its target or not, and how far past its planned end (target - latch
    // - margin) its warp finished (`overrun_ns`, negative when early: wake-up lateness plus cost
    // beyond the estimates). Adapts the margin.
    void record_present(bool on_time, int64_t overrun_ns);

    // The plan of a new frame at divisor d: its render and d warps (d - 1 re-warps between, each
    // after an idle gap), each warp with the margin.
    int64_t frame_plan_ns(int64_t render_ns, int64_t warp_ns, int d) const;
    // Chooses the render rate for a render of `render_ns` and warps of `warp_ns` (the ladder's
    // bottom step): slower at once when the current rate does not fit, faster after rate_recover
    // frames that fit with room. Returns the divisor.
    int choose_divisor(int64_t render_ns, int64_t warp_ns);

  private:
    PacingConfig config_;
    int64_t period_ns_, latch_ns_;
    CostWindow render_, warp_, total_, gap_;
    CostWindow overrun_;  // per present: how far past its planned end its warp finished
    int64_t margin_ns_ = 0;
    int64_t render_predicted_ = -1, warp_predicted_ = -1;  // -1: none
    double miss_bump_ns_ = 0.0;
    int divisor_ = 1;
    int fits_faster_ = 0;
};

// One step of the pixel-cost ladder.
struct LadderStep {
    double scale = 1.0;     // eye-buffer resolution per axis
    bool chromatic = true;  // chromatic-aberration correction
    // The quality it gives up, for reports: "full", "resolution 0.8", "resolution 0.5, no CA
    // correction".
    std::string name;
};

// The steps in order of quality: 1.0, 0.9, 0.8, 0.7, 0.6, 0.5 per axis with chromatic-aberration
// correction, then 0.5 without it (only where the pass corrects any: `chromatic`). `min_scale`
// (0.5 by default) ends the resolution steps there.
std::vector<LadderStep> make_ladder(bool chromatic, double min_scale = 0.5);

class PixelLadder {
  public:
    // `steps` from make_ladder(); `enabled` false: the ladder stays on its first step.
    PixelLadder(std::vector<LadderStep> steps, bool enabled, const PacingConfig& config);
    const std::vector<LadderStep>& steps() const { return steps_; }
    int step() const { return step_; }
    const LadderStep& current() const { return steps_[size_t(step_)]; }
    // The eye-buffer scale to render at: the current step's, or 1 while the frame is found not
    // bound by its pixels (see below).
    double effective_scale() const { return not_pixel_bound_ > 0 ? 1.0 : current().scale; }
    bool enabled() const { return enabled_; }

    // A new frame's measured render at the step it was rendered at, and a warp's at its
    // chromatic setting: the learned costs.
    void record_render(int step, int64_t ns);
    void record_warp(bool chromatic, int64_t ns);
    // The learned render cost of `step` (ns): at the current step the 90th percentile of its
    // recent renders (from three on); another step's is the current one's scaled by their pixels
    // (a fill-bound frame; costs measured at other steps go stale as the scene and the view
    // change), or, where a step down saved nothing (a frame not bound by its pixels), the same.
    // `fallback_ns` stands for the cost at step `fallback_step` (default: the current one) before
    // any measurement.
    int64_t render_cost(int step, int64_t fallback_ns, int fallback_step = -1) const;
    // The learned warp cost with chromatic-aberration correction on or off (off, before any
    // measurement: half the cost with it on).
    int64_t warp_cost(bool chromatic, int64_t fallback_ns) const;

    // What a step's frames must fit: at `divisor`, a render and `divisor` warps, each with the
    // margin, within `available_ns` (divisor periods less the latch). `warp_ns` is the warp
    // estimate of the pass as it is now (chromatic-aberration correction `warp_chromatic`).
    struct Budget {
        int divisor = 1;
        int64_t available_ns = 0;
        int64_t margin_ns = 0;
        int64_t warp_ns = 0;
        bool warp_chromatic = true;
    };
    // A step's planned frame under `b`; `render_p_ns` stands for the current step's render.
    int64_t frame_cost(int step, const Budget& b, int64_t render_p_ns) const;
    // Chooses the step for the next new frame: the finest whose frame fits. Cheaper at once when
    // the current one does not fit; finer only after `recover` new frames in a row in which the
    // finer step fit with `spare` to spare. `render_p_ns`: the current step's recent render
    // percentile. Returns true when the step changed.
    bool choose(const Budget& b, int64_t render_p_ns);

  private:
    std::vector<LadderStep> steps_;
    bool enabled_;
    int recover_;
    double spare_;
    int step_ = 0;
    int fits_finer_ = 0;
    std::vector<CostWindow> render_;  // per step
    // A step down is checked once three frames are measured at the new step: a render that did
    // not get cheaper (above 95 % of the cost before the first step of the descent) marks the
    // frame as not bound by its pixels for `kNotPixelBoundFrames` new frames: resolution steps
    // are then not taken.
    static constexpr int kNotPixelBoundFrames = 300;
    int64_t cost_before_down_ = -1;
    int not_pixel_bound_ = 0;
    CostWindow warp_on_, warp_off_;
};

}  // namespace hmdnode
