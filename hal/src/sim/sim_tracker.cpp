// Simulated tracker: replays a trace (optionally resampled, with gaussian orientation noise and
// arrival jitter) through the Tracker interface. All samples are generated at creation
// (O(samples) time and memory); read() is O(samples delivered) and allocation-free.
#include "hmdnode/hal/sim/sim_tracker.hpp"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <random>
#include <thread>
#include <vector>

#include "tracking/spsc_ring.hpp"

namespace hmdnode {
namespace {

class SimTracker final : public Tracker {
  public:
    SimTracker(std::vector<TrackerSample> samples, Clock& clock, const SimTrackerConfig& config,
               double rate_hz, bool has_position, bool has_imu)
        : samples_(std::move(samples)), clock_(clock), ring_(config.ring_capacity) {
        info_.name = "simulated tracker (trace replay)";
        info_.serial = "SIM-0001";
        info_.nominal_rate_hz = rate_hz;
        info_.provides_orientation = true;
        info_.provides_position = has_position;
        info_.provides_imu = has_imu;
        // Delivered as USB delivers: in arrival order, never before the measurement.
        assert(std::is_sorted(samples_.begin(), samples_.end(),
                              [](const TrackerSample& a, const TrackerSample& b) {
                                  return a.arrival_ns < b.arrival_ns;
                              }));
    }
    ~SimTracker() override { stop(); }

    TrackerInfo info() const override { return info_; }

    Status start() override {
        if (started_) return {};
        started_ = true;
        if (!clock_.is_simulated()) {
            stop_requested_ = false;
            thread_ = std::thread([this] { reader_loop(); });
        }
        return {};
    }

    void stop() override {
        stop_requested_ = true;
        if (thread_.joinable()) thread_.join();
    }

    size_t read(std::span<TrackerSample> out) override {
        if (!started_) return 0;
        size_t n = 0;
        if (clock_.is_simulated()) {
            const int64_t now = clock_.now_ns();
            while (n < out.size() && cursor_ < samples_.size() &&
                   samples_[cursor_].arrival_ns <= now)
                out[n++] = samples_[cursor_++];
            assert(cursor_ <= samples_.size());
        } else {
            while (n < out.size() && ring_.pop(&out[n])) ++n;
        }
        delivered_.fetch_add(n, std::memory_order_relaxed);
        return n;
    }

    bool finished() const override {
        if (clock_.is_simulated()) return cursor_ >= samples_.size();
        return producer_done_.load(std::memory_order_acquire) &&
               delivered_.load(std::memory_order_relaxed) +
                       dropped_.load(std::memory_order_relaxed) >=
                   samples_.size();
    }

    TrackerCounters counters() const override {
        return TrackerCounters{delivered_.load(std::memory_order_relaxed),
                               dropped_.load(std::memory_order_relaxed)};
    }

  private:
    // Reader thread (system clock only): sleeps until each arrival time, as a USB device delivers.
    void reader_loop() {
        constexpr int64_t kMaxSleepNs = 10 * kNsPerMs;  // bound the reaction time to stop()
        for (const TrackerSample& s : samples_) {
            while (!stop_requested_) {
                int64_t now = clock_.now_ns();
                if (now >= s.arrival_ns) break;
                clock_.sleep_until_ns(std::min(s.arrival_ns, now + kMaxSleepNs));
            }
            if (stop_requested_) break;
            if (!ring_.push(s)) dropped_.fetch_add(1, std::memory_order_relaxed);
        }
        producer_done_.store(true, std::memory_order_release);
    }

    std::vector<TrackerSample> samples_;
    Clock& clock_;
    TrackerInfo info_;
    SpscRing<TrackerSample> ring_;
    std::thread thread_;
    bool started_ = false;
    size_t cursor_ = 0;  // simulated mode
    std::atomic<bool> stop_requested_{false};
    std::atomic<bool> producer_done_{false};
    std::atomic<uint64_t> delivered_{0};
    std::atomic<uint64_t> dropped_{0};
};

}  // namespace

Result<std::unique_ptr<Tracker>> create_sim_tracker(std::shared_ptr<const Trace> trace,
                                                    Clock& clock, const SimTrackerConfig& config) {
    if (!trace || trace->samples.size() < 2)
        return make_error("simulated tracker: the trace needs at least two samples");
    if (config.resample_hz < 0.0 || config.noise_deg < 0.0 || config.latency_ns < 0 ||
        config.jitter_ns < 0 || config.start_offset_ns < 0 || config.duration_ns < 0)
        return make_error(
            "simulated tracker: negative rate, noise, latency, jitter, offset or duration");

    const int64_t t0 = trace->start_ns() + config.start_offset_ns;
    const int64_t t_end = config.duration_ns > 0
                              ? std::min(trace->end_ns(), t0 + config.duration_ns)
                              : trace->end_ns();
    if (t_end <= t0)
        return make_error("simulated tracker: the start offset is past the end of the trace");

    const bool has_position = trace->samples.front().position.has_value();
    const bool has_imu = trace->samples.front().gyro.has_value();

    // Measurement times (trace timeline) of the samples to deliver.
    std::vector<TraceSample> src;
    if (config.resample_hz > 0.0) {
        const double step_ns = 1e9 / config.resample_hz;
        for (double t = double(t0); t <= double(t_end); t += step_ns) {
            Pose p = trace->pose_at(int64_t(t));
            TraceSample s;
            s.time_ns = int64_t(t);
            s.orientation = p.orientation;
            if (has_position) s.position = p.position;
            src.push_back(s);
        }
    } else {
        auto lo = std::lower_bound(trace->samples.begin(), trace->samples.end(), t0,
                                   [](const TraceSample& s, int64_t t) { return s.time_ns < t; });
        for (auto it = lo; it != trace->samples.end() && it->time_ns <= t_end; ++it)
            src.push_back(*it);
    }
    if (src.size() < 2)
        return make_error("simulated tracker: fewer than two samples in the replayed range");

    std::mt19937_64 rng(config.seed);
    std::normal_distribution<double> noise(0.0, deg_to_rad(config.noise_deg));
    std::uniform_int_distribution<int64_t> jitter(0, config.jitter_ns);

    std::vector<TrackerSample> out;
    out.reserve(src.size());
    int64_t last_arrival = INT64_MIN;
    glm::dquat prev = src.front().orientation;
    for (size_t i = 0; i < src.size(); ++i) {
        const TraceSample& s = src[i];
        TrackerSample o;
        o.time_ns = config.host_start_ns + (s.time_ns - t0);
        o.sequence = i;
        o.has_orientation = true;
        o.orientation = s.orientation;
        if (config.noise_deg > 0.0)
            o.orientation = glm::normalize(
                quat_from_rotation_vector(glm::dvec3(noise(rng), noise(rng), noise(rng))) *
                o.orientation);
        o.orientation = same_hemisphere(o.orientation, prev);
        prev = o.orientation;
        o.position = s.position;
        o.gyro = s.gyro;
        o.accel = s.accel;
        // USB delivers in order: an arrival never precedes the previous one.
        o.arrival_ns = std::max(
            last_arrival, o.time_ns + config.latency_ns + (config.jitter_ns > 0 ? jitter(rng) : 0));
        assert(o.arrival_ns >= o.time_ns + config.latency_ns && o.arrival_ns >= last_arrival);
        last_arrival = o.arrival_ns;
        out.push_back(o);
    }
    const double rate_hz =
        config.resample_hz > 0.0
            ? config.resample_hz
            : double(out.size() - 1) / ns_to_s(out.back().time_ns - out.front().time_ns);
    return std::unique_ptr<Tracker>(
        new SimTracker(std::move(out), clock, config, rate_hz, has_position, has_imu));
}

}  // namespace hmdnode
