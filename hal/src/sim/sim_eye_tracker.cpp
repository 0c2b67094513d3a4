// Simulated eye tracker: replays the gaze columns of a trace through the EyeTracker interface.
// All samples are made at creation (O(samples) time and memory); read() is O(samples delivered),
// allocation-free, and compares arrival times with the clock (no thread).
#include "hmdnode/hal/sim/sim_eye_tracker.hpp"

#include <algorithm>
#include <cassert>
#include <vector>

namespace hmdnode {
namespace {

class SimEyeTracker final : public EyeTracker {
  public:
    SimEyeTracker(std::vector<GazeSample> samples, Clock& clock, double rate_hz)
        : samples_(std::move(samples)), clock_(clock) {
        info_.name = "simulated eye tracker (trace gaze replay)";
        info_.nominal_rate_hz = rate_hz;
        assert(!samples_.empty());  // create_sim_eye_tracker() refuses an empty range
    }

    EyeTrackerInfo info() const override { return info_; }
    Status start() override {
        started_ = true;
        return {};
    }
    void stop() override {}

    size_t read(std::span<GazeSample> out) override {
        if (!started_) return 0;
        const int64_t now = clock_.now_ns();
        size_t n = 0;
        while (n < out.size() && cursor_ < samples_.size() && samples_[cursor_].arrival_ns <= now) {
            counters_.samples_invalid += !samples_[cursor_].valid();
            out[n++] = samples_[cursor_++];
        }
        assert(n <= out.size() && cursor_ <= samples_.size());
        counters_.samples_delivered += n;
        return n;
    }

    bool finished() const override { return cursor_ >= samples_.size(); }
    EyeTrackerCounters counters() const override { return counters_; }

  private:
    std::vector<GazeSample> samples_;
    Clock& clock_;
    EyeTrackerInfo info_;
    bool started_ = false;
    size_t cursor_ = 0;
    EyeTrackerCounters counters_;
};

}  // namespace

Result<std::unique_ptr<EyeTracker>> create_sim_eye_tracker(std::shared_ptr<const Trace> trace,
                                                           Clock& clock,
                                                           const SimEyeTrackerConfig& config) {
    if (!trace || trace->samples.empty())
        return make_error("simulated eye tracker: the trace has no samples");
    if (!trace->samples.front().gaze)
        return make_error(
            "the trace has no gaze columns (gaze_x,gaze_y,gaze_z,gaze_conf; add synthetic ones "
            "with `hmdnode trace add-gaze`)");
    if (config.latency_ns < 0 || config.start_offset_ns < 0 || config.duration_ns < 0)
        return make_error("simulated eye tracker: negative latency, offset or duration");
    const int64_t t0 = trace->start_ns() + config.start_offset_ns;
    const int64_t t_end = config.duration_ns > 0
                              ? std::min(trace->end_ns(), t0 + config.duration_ns)
                              : trace->end_ns();
    std::vector<GazeSample> out;
    auto lo = std::lower_bound(trace->samples.begin(), trace->samples.end(), t0,
                               [](const TraceSample& s, int64_t t) { return s.time_ns < t; });
    for (auto it = lo; it != trace->samples.end() && it->time_ns <= t_end; ++it) {
        GazeSample g;
        g.time_ns = config.host_start_ns + (it->time_ns - t0);
        g.arrival_ns = g.time_ns + config.latency_ns;
        g.sequence = out.size();
        g.direction = it->gaze->direction;
        g.confidence = it->gaze->confidence;
        out.push_back(g);
    }
    if (out.empty())
        return make_error("simulated eye tracker: no gaze sample in the replayed range");
    const double rate_hz =
        out.size() > 1 ? double(out.size() - 1) / ns_to_s(out.back().time_ns - out.front().time_ns)
                       : 0.0;
    return std::unique_ptr<EyeTracker>(new SimEyeTracker(std::move(out), clock, rate_hz));
}

}  // namespace hmdnode
