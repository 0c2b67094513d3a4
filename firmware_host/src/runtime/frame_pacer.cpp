// The frame pacer and the pixel-cost ladder (hmdnode/firmware_host/frame_pacer.hpp,
// docs/latency.md). After Monado's compositor pacing (src/xrt/auxiliary/util/
// u_pacing_compositor.c: estimates from recent frames, a margin, a present-to-display offset) and
// the dynamic resolution and half-rate reprojection of VR runtimes under load (SteamVR's motion
// smoothing and Oculus' ASW render at half the refresh and re-warp between).
//
// Margin: the percentile of how far recent presents overran their planned end (wake-up lateness
// plus cost beyond the estimate), so a jittery CPU renderer plans with room and a steady GPU does
// not wake milliseconds early; plus a bump per missed latch that halves every miss_half_life
// vsyncs made.
// Render rate: divisor d fits when render + d (warp + margin) <= d period: a new frame every d
// vsyncs with d - 1 re-warps between.
// Ladder: per step, the median of its recent renders, else fixed + per-pixel cost fitted over the
// steps measured (per pixel alone while one is); finest step that fits the render budget.
// Cost: O(window) per estimate (nth_element), O(steps) per choice.
#include "hmdnode/firmware_host/frame_pacer.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdio>

#include "hmdnode/core/percentile.hpp"

namespace hmdnode {

CostWindow::CostWindow(int capacity)
    : ring_(size_t(std::clamp(capacity, 1, 256))), scratch_(ring_.size()) {}

void CostWindow::push(int64_t ns) {
    assert(head_ < ring_.size() && count_ <= ring_.size());
    ring_[head_] = ns;
    head_ = (head_ + 1) % ring_.size();
    count_ = std::min(count_ + 1, ring_.size());
}

int64_t CostWindow::percentile(double p, int64_t fallback) const {
    assert(p >= 0.0 && p <= 1.0 && scratch_.size() == ring_.size());
    if (count_ == 0) return fallback;
    std::copy(ring_.begin(), ring_.begin() + std::ptrdiff_t(count_), scratch_.begin());
    return percentile_in_place(scratch_.begin(), scratch_.begin() + std::ptrdiff_t(count_), p);
}

FramePacer::FramePacer(const PacingConfig& config, int64_t period_ns, int64_t latch_ns)
    : config_(config),
      period_ns_(period_ns),
      latch_ns_(latch_ns),
      render_(config.window),
      warp_(config.window),
      total_(config.window),
      gap_(config.window),
      overrun_(config.window),
      margin_ns_(std::clamp(config.margin_ns, config.min_margin_ns, config.max_margin_ns)) {
    assert(period_ns > 0);
    // The estimates' percentiles and the margin's bounds (code's, not the config file's).
    assert(config.percentile >= 0.0 && config.percentile <= 1.0);
    assert(config.margin_percentile >= 0.0 && config.margin_percentile <= 1.0);
    assert(config.min_margin_ns >= 0 && config.min_margin_ns <= config.max_margin_ns);
}

namespace {

// The p-quantile of a cost window; while fewer than three costs are measured since a restart, the
// larger of the prediction and the window's `short_p`-quantile (a prediction too low is corrected
// by the first frame). `fallback` while the window is empty and nothing is predicted.
int64_t estimate(const CostWindow& w, int64_t predicted, double p, double short_p,
                 int64_t fallback) {
    if (w.size() < 3 && predicted >= 0) return std::max(predicted, w.percentile(short_p, 0));
    return w.percentile(p, fallback);
}

}  // namespace

int64_t FramePacer::render_estimate() const {
    return estimate(render_, render_predicted_, config_.percentile, 1.0, period_ns_ / 2);
}

int64_t FramePacer::warp_estimate() const {
    return estimate(warp_, warp_predicted_, config_.percentile, 1.0, period_ns_ / 10);
}

int64_t FramePacer::warp_typical() const {
    return estimate(warp_, warp_predicted_, 0.5, 0.5, period_ns_ / 10);
}

int64_t FramePacer::frame_estimate() const {
    // (The sum of the two estimates only stands in while the window is short: computing it on
    // every call would cost two more selections per frame.)
    if (total_.size() < 3) return render_estimate() + warp_estimate();
    return total_.percentile(config_.percentile, 0);
}

void FramePacer::record_frame(int64_t render_ns, int64_t warp_ns) {
    render_.push(render_ns);
    total_.push(render_ns + warp_ns);
}

void FramePacer::record_warp(int64_t warp_ns) {
    warp_.push(warp_ns);
}

void FramePacer::record_present(bool on_time, int64_t overrun_ns) {
    // The overrun is how far past its planned end (target - latch - margin) the warp finished:
    // how much of the margin it used. The margin to plan with is a high percentile of that use.
    overrun_.push(overrun_ns);
    if (on_time)
        miss_bump_ns_ *= std::exp2(-1.0 / double(std::max(1, config_.miss_half_life)));
    else
        miss_bump_ns_ =
            std::min(double(config_.max_margin_ns), miss_bump_ns_ + double(config_.miss_step_ns));
    const int64_t used = std::max<int64_t>(0, overrun_.percentile(config_.margin_percentile, 0));
    margin_ns_ = std::clamp(used + config_.min_margin_ns + int64_t(miss_bump_ns_),
                            config_.min_margin_ns, config_.max_margin_ns);
    assert(miss_bump_ns_ >= 0.0 && margin_ns_ >= config_.min_margin_ns);
}

int64_t FramePacer::frame_plan_ns(int64_t render_ns, int64_t warp_ns, int d) const {
    assert(d >= 1);  // a render and at least one warp
    return render_ns + int64_t(d) * (warp_ns + margin_ns_) + int64_t(d - 1) * gap_estimate();
}

int FramePacer::choose_divisor(int64_t render_ns, int64_t warp_ns) {
    const int max_d = std::max(1, config_.max_divisor);
    auto fits = [&](int d, double spare) {
        return double(frame_plan_ns(render_ns, warp_ns, d)) <=
               double(int64_t(d) * period_ns_ - latch_ns_) * (1.0 - spare);
    };
    if (!fits(divisor_, 0.0)) {
        // Slower at once, to the first rate that fits (the slowest when none does).
        while (divisor_ < max_d && !fits(divisor_, 0.0)) ++divisor_;
        fits_faster_ = 0;
        assert(divisor_ >= 1 && divisor_ <= max_d);
        return divisor_;
    }
    if (divisor_ > 1 && fits(divisor_ - 1, config_.rate_spare)) {
        if (++fits_faster_ >= config_.rate_recover) {
            --divisor_;
            fits_faster_ = 0;
        }
    } else {
        fits_faster_ = 0;
    }
    assert(divisor_ >= 1 && divisor_ <= max_d && fits_faster_ >= 0);
    return divisor_;
}

std::vector<LadderStep> make_ladder(bool chromatic, double min_scale) {
    assert(min_scale > 0.0 && min_scale <= 1.0);  // at least the full-resolution step
    std::vector<LadderStep> steps;
    char name[64];
    for (int i = 10; i >= 1; --i) {
        const double s = i / 10.0;
        if (s < min_scale - 1e-9) break;
        if (i == 10)
            std::snprintf(name, sizeof name, "full");
        else
            std::snprintf(name, sizeof name, "resolution %.1f", s);
        steps.push_back(LadderStep{s, chromatic, name});
    }
    if (chromatic) {
        std::snprintf(name, sizeof name, "resolution %.1f, no CA correction", steps.back().scale);
        steps.push_back(LadderStep{steps.back().scale, false, name});
    }
    // In order of quality: the scale never rises down the ladder, full resolution first.
    assert(!steps.empty() && steps.front().scale == 1.0);
    for (size_t i = 1; i < steps.size(); ++i) assert(steps[i].scale <= steps[i - 1].scale);
    return steps;
}

PixelLadder::PixelLadder(std::vector<LadderStep> steps, bool enabled, const PacingConfig& config)
    : steps_(std::move(steps)),
      enabled_(enabled),
      recover_(config.ladder_recover),
      spare_(config.rate_spare),
      warp_on_(config.window),
      warp_off_(config.window) {
    assert(!steps_.empty());
    render_.reserve(steps_.size());
    for (size_t i = 0; i < steps_.size(); ++i) render_.emplace_back(31);
}

void PixelLadder::record_render(int step, int64_t ns) {
    assert(step >= 0 && size_t(step) < steps_.size() && render_.size() == steps_.size());
    CostWindow& w = render_[size_t(step)];
    w.push(ns);
    if (not_pixel_bound_ > 0) --not_pixel_bound_;
    if (step == step_ && cost_before_down_ >= 0 && w.size() >= 3 &&
        steps_[size_t(step)].scale < 1.0) {
        if (double(w.percentile(0.5, ns)) > 0.95 * double(cost_before_down_))
            not_pixel_bound_ = kNotPixelBoundFrames;
        cost_before_down_ = -1;
    }
}

void PixelLadder::record_warp(bool chromatic, int64_t ns) {
    (chromatic ? warp_on_ : warp_off_).push(ns);
}

int64_t PixelLadder::render_cost(int step, int64_t fallback_ns, int fallback_step) const {
    if (fallback_step < 0) fallback_step = step_;
    assert(step >= 0 && size_t(step) < steps_.size() && size_t(fallback_step) < steps_.size());
    auto pixels = [&](int s) { return steps_[size_t(s)].scale * steps_[size_t(s)].scale; };
    const CostWindow& own = render_[size_t(step_)];
    const int64_t base = own.size() >= 3 ? own.percentile(0.9, fallback_ns) : fallback_ns;
    const int base_step = own.size() >= 3 ? step_ : fallback_step;
    if (not_pixel_bound_ > 0) return base;
    return int64_t(double(base) * pixels(step) / pixels(base_step));
}

int64_t PixelLadder::warp_cost(bool chromatic, int64_t fallback_ns) const {
    const CostWindow& w = chromatic ? warp_on_ : warp_off_;
    if (w.size() >= 3) return w.percentile(0.5, fallback_ns);
    if (!chromatic && warp_on_.size() >= 3) return warp_on_.percentile(0.5, fallback_ns) / 2;
    return fallback_ns;
}

int64_t PixelLadder::frame_cost(int step, const Budget& b, int64_t render_p_ns) const {
    assert(step >= 0 && size_t(step) < steps_.size() && b.divisor >= 1);
    const LadderStep& st = steps_[size_t(step)];
    const int64_t warp =
        st.chromatic == b.warp_chromatic ? b.warp_ns : warp_cost(st.chromatic, b.warp_ns);
    int64_t render = render_cost(step, render_p_ns);
    if (step == step_) render = std::max(render, render_p_ns);
    return render + int64_t(b.divisor) * (warp + b.margin_ns);
}

bool PixelLadder::choose(const Budget& b, int64_t render_p_ns) {
    if (!enabled_) return false;
    const int last = int(steps_.size()) - 1;
    auto change_to = [&](int s) {
        assert(s >= 0 && s <= last);
        // A step to another resolution starts its window anew, and a step down is checked.
        if (steps_[size_t(s)].scale != steps_[size_t(step_)].scale) {
            // (While a check is pending, its reference stays: a descent of several steps is
            // checked against the cost before the first.)
            if (s > step_ && cost_before_down_ < 0 && !render_[size_t(step_)].empty())
                cost_before_down_ = render_[size_t(step_)].percentile(0.5, 0);
            render_[size_t(s)].clear();
        }
        step_ = s;
        fits_finer_ = 0;
        return true;
    };
    if (frame_cost(step_, b, render_p_ns) > b.available_ns) {
        // Cheaper at once: the first step down whose frame fits, else the last (without
        // resolution steps while the frame is not bound by its pixels).
        int s = step_ + 1;
        while (s < last && frame_cost(s, b, render_p_ns) > b.available_ns) ++s;
        s = std::min(last, s);
        if (not_pixel_bound_ > 0)
            while (s < last && steps_[size_t(s)].chromatic == steps_[size_t(step_)].chromatic &&
                   steps_[size_t(s)].scale != steps_[size_t(step_)].scale)
                ++s;
        fits_finer_ = 0;
        if (s == step_) return false;
        return change_to(s);
    }
    // A resolution that saves nothing (a frame not bound by its pixels) is left at once, for the
    // finest step with the same chromatic setting.
    if (not_pixel_bound_ > 0 && step_ > 0 &&
        steps_[size_t(step_ - 1)].chromatic == steps_[size_t(step_)].chromatic) {
        int s = step_;
        while (s > 0 && steps_[size_t(s - 1)].chromatic == steps_[size_t(step_)].chromatic) --s;
        return change_to(s);
    }
    if (step_ > 0 &&
        double(frame_cost(step_ - 1, b, render_p_ns)) <= double(b.available_ns) * (1.0 - spare_)) {
        if (++fits_finer_ >= recover_) return change_to(step_ - 1);
    } else {
        fits_finer_ = 0;
    }
    return false;
}

}  // namespace hmdnode
