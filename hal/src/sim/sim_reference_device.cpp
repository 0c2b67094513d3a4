// The simulated hmdnode reference tracker (firmware logic + "sim" TransportBackend); protocol in
// docs/tracker-protocol.md, behaviour in docs/hardware.md.
// Scheduling: report k after boot (or after the last rate change at index i0, time t0) is measured
// at t0 + (k - i0) * 1e9 / rate ns -- integer arithmetic, so no drift accumulates over hours at
// 1 kHz -- and arrives at measurement + latency. The device clock is
// offset_us + floor((t - boot) * (1 + drift_ppm 1e-6) / 1000).
// Cost: O(1) per report (one motion evaluation + one 64-byte encode); memory: the readers' queues,
// each at most queue_capacity reports.
// Departs from a real device: reports are produced lazily when a reader looks (equivalent, since
// their content depends only on their measurement time); each open Transport gets its own copy
// of the stream, as each open hidraw file does.
#include "hmdnode/hal/sim/sim_reference_device.hpp"

#include <algorithm>
#include <cassert>
#include <climits>
#include <cmath>
#include <deque>
#include <mutex>

namespace hmdnode {

MotionSource motion_from_trace(std::shared_ptr<const Trace> trace, int64_t host_start_ns,
                               bool loop) {
    return [trace = std::move(trace), host_start_ns, loop](int64_t t_ns) {
        const int64_t len = trace->end_ns() - trace->start_ns();
        int64_t rel = t_ns - host_start_ns;
        if (rel < 0) rel = 0;
        if (loop && len > 0) rel %= len;
        Pose p = trace->pose_at(trace->start_ns() + rel);
        p.time_ns = t_ns;
        return p;
    };
}

MotionSource sinusoidal_motion(double amplitude_deg, double frequency_hz) {
    return [amplitude_deg, frequency_hz](int64_t t_ns) {
        const double t = ns_to_s(t_ns);
        const double w = 2.0 * kPi * frequency_hz;
        const double a = deg_to_rad(amplitude_deg);
        const double yaw = a * std::sin(w * t);
        const double pitch = 0.5 * a * std::sin(0.5 * w * t);
        const double yaw_rate = a * w * std::cos(w * t);
        const double pitch_rate = 0.25 * a * w * std::cos(0.5 * w * t);
        const glm::dquat qy = glm::angleAxis(yaw, glm::dvec3(0, 1, 0));
        const glm::dquat qx = glm::angleAxis(pitch, glm::dvec3(1, 0, 0));
        Pose p;
        p.time_ns = t_ns;
        p.orientation = qy * qx;
        // world-frame rate of q = Ry(yaw) Rx(pitch): yaw' about world y plus pitch' about the
        // yaw-rotated x axis.
        p.angular_velocity = glm::dvec3(0, yaw_rate, 0) + qy * glm::dvec3(pitch_rate, 0, 0);
        return p;
    };
}

// ---- firmware ----

SimReferenceFirmware::SimReferenceFirmware(SimReferenceDeviceConfig config, MotionSource motion)
    : config_(std::move(config)), motion_(std::move(motion)) {}

void SimReferenceFirmware::boot(int64_t boot_ns) {
    boot_ns_ = boot_ns;
    next_index_ = 0;
    schedule_index_ = 0;
    schedule_origin_ns_ =
        boot_ns + (config_.pose_rate_hz ? kNsPerSecond / config_.pose_rate_hz : 0);
    clock_reset_flag_ = true;
    sync_pending_ = false;
}

uint64_t SimReferenceFirmware::device_time_us(int64_t t_ns) const {
    const int64_t elapsed = t_ns - boot_ns_;
    const int64_t adjusted =
        elapsed + static_cast<int64_t>(std::llround(static_cast<double>(elapsed) *
                                                    config_.device_clock_drift_ppm * 1e-6));
    return static_cast<uint64_t>(config_.device_clock_offset_us + adjusted / 1000);
}

int64_t SimReferenceFirmware::measure_time_ns(uint64_t index) const {
    // The schedule restarts at schedule_index_ (boot, rate change): no measurement before it.
    assert(config_.pose_rate_hz > 0 && index >= schedule_index_);
    const int64_t k = static_cast<int64_t>(index - schedule_index_);
    return schedule_origin_ns_ + k * kNsPerSecond / config_.pose_rate_hz;
}

int64_t SimReferenceFirmware::next_arrival_ns() const {
    if (!config_.pose_rate_hz) return INT64_MAX;
    return measure_time_ns(next_index_) + config_.latency_ns;
}

void SimReferenceFirmware::skip_until(int64_t t_ns) {
    if (!config_.pose_rate_hz) return;
    while (next_arrival_ns() < t_ns) {
        ++next_index_;
        clock_reset_flag_ = false;
    }
}

size_t SimReferenceFirmware::produce(int64_t until_ns, std::vector<InputReport>& out) {
    if (!config_.pose_rate_hz) return 0;
    size_t n = 0;
    while (next_arrival_ns() <= until_ns) {
        const int64_t t = measure_time_ns(next_index_);
        const Pose pose = motion_(t);
        refproto::PoseReport r;
        r.sequence = static_cast<uint32_t>(config_.first_sequence + next_index_);
        r.device_time_us = device_time_us(t);
        r.orientation = glm::normalize(pose.orientation);
        r.flags = refproto::kPoseFlagOrientationValid;
        if (pose.angular_velocity) {
            r.angular_velocity = glm::conjugate(r.orientation) * *pose.angular_velocity;
            r.flags |= refproto::kPoseFlagAngularVelocityValid;
        }
        if (config_.send_position) {
            r.position_m = pose.position;
            r.flags |= refproto::kPoseFlagPositionValid;
        }
        if (clock_reset_flag_) r.flags |= refproto::kPoseFlagClockReset;
        clock_reset_flag_ = false;
        InputReport ir;
        ir.bytes = refproto::encode(r);
        ir.host_time_ns = t + config_.latency_ns;
        // The firmware's schedule moves forward: each report after the previous one.
        assert(out.empty() || out.back().host_time_ns <= ir.host_time_ns);
        out.push_back(std::move(ir));
        ++next_index_;
        ++produced_;
        ++n;
    }
    return n;
}

Result<std::vector<uint8_t>> SimReferenceFirmware::get_feature(uint8_t report_id, int64_t now_ns) {
    switch (report_id) {
        case refproto::kDeviceInfoReport: {
            refproto::DeviceInfoReport r;
            r.firmware_major = 1;
            r.firmware_minor = 0;
            r.firmware_patch = 0;
            r.capabilities = refproto::kCapOrientation | refproto::kCapAngularVelocity |
                             refproto::kCapTimeSync | refproto::kCapSettableRate;
            if (config_.send_position) r.capabilities |= refproto::kCapPosition;
            r.pose_rate_hz = config_.pose_rate_hz;
            r.imu_rate_hz = 0;
            r.serial = config_.serial.substr(0, 16);
            r.product = config_.product.substr(0, 32);
            return refproto::encode(r);
        }
        case refproto::kCalibrationReport:
            return refproto::encode(calibration_);
        case refproto::kReportRateReport: {
            refproto::ReportRateReport r;
            r.pose_rate_hz = config_.pose_rate_hz;
            r.imu_rate_hz = 0;
            return refproto::encode(r);
        }
        case refproto::kTimeSyncReport: {
            refproto::TimeSyncReport r;
            if (sync_pending_) r = pending_sync_;
            r.device_transmit_us = device_time_us(now_ns);
            sync_pending_ = false;
            return refproto::encode(r);
        }
        default:
            return make_error("simulated reference tracker: no feature report " +
                              std::to_string(report_id));
    }
}

Status SimReferenceFirmware::set_feature(std::span<const uint8_t> data, int64_t now_ns) {
    if (data.empty()) return make_error("simulated reference tracker: empty feature report");
    switch (data[0]) {
        case refproto::kCalibrationReport: {
            Result<refproto::CalibrationReport> c = refproto::decode_calibration(data);
            if (!c.ok()) return c.error();
            calibration_ = *c;
            return {};
        }
        case refproto::kReportRateReport: {
            Result<refproto::ReportRateReport> r = refproto::decode_report_rate(data);
            if (!r.ok()) return r.error();
            if (r->pose_rate_hz > 8000)
                return make_error("simulated reference tracker: pose rate " +
                                  std::to_string(r->pose_rate_hz) + " Hz is above 8000 Hz");
            if (r->pose_rate_hz == config_.pose_rate_hz) return {};
            config_.pose_rate_hz = r->pose_rate_hz;
            schedule_index_ = next_index_;
            schedule_origin_ns_ =
                now_ns + (config_.pose_rate_hz ? kNsPerSecond / config_.pose_rate_hz : 0);
            return {};
        }
        case refproto::kTimeSyncReport: {
            Result<refproto::TimeSyncReport> r = refproto::decode_time_sync(data);
            if (!r.ok()) return r.error();
            pending_sync_ = *r;
            pending_sync_.device_receive_us = device_time_us(now_ns);
            sync_pending_ = true;
            return {};
        }
        default:
            return make_error("simulated reference tracker: feature report " +
                              std::to_string(data[0]) + " cannot be set");
    }
}

// ---- the sim backend ----

namespace {

struct Subscriber {
    std::deque<InputReport> queue;
    uint64_t generation = 0;
};

struct SimState {
    SimState(Clock& c, SimReferenceDeviceConfig config, MotionSource motion)
        : clock(c), firmware(std::move(config), std::move(motion)) {}

    Clock& clock;
    mutable std::mutex mutex;
    SimReferenceFirmware firmware;
    bool plugged = true;
    uint64_t generation = 1;  // +1 per unplug: transports of older generations are gone
    uint64_t plug_count = 1;
    uint64_t dropped = 0;
    std::vector<std::weak_ptr<Subscriber>> subscribers;
    std::vector<InputReport> scratch;

    DeviceId id() const {
        DeviceId d;
        d.vendor_id = firmware.config().vendor_id;
        d.product_id = firmware.config().product_id;
        d.serial = firmware.config().serial;
        d.path = "sim:" + firmware.config().serial;
        d.product = firmware.config().product;
        d.manufacturer = "hmdnode";
        d.interface_number = 0;
        return d;
    }

    // Requires mutex. Moves every report that has arrived by `now` into each live reader's queue.
    void pump(int64_t now) {
        subscribers.erase(
            std::remove_if(subscribers.begin(), subscribers.end(),
                           [](const std::weak_ptr<Subscriber>& w) { return w.expired(); }),
            subscribers.end());
        if (!plugged) return;
        if (subscribers.empty()) {
            firmware.skip_until(now + 1);
            return;
        }
        scratch.clear();
        firmware.produce(now, scratch);
        const size_t cap = std::max<size_t>(1, firmware.config().queue_capacity);
        for (auto& w : subscribers) {
            std::shared_ptr<Subscriber> s = w.lock();
            for (const InputReport& r : scratch) {
                if (s->queue.size() >= cap) {
                    s->queue.pop_front();
                    ++dropped;
                }
                s->queue.push_back(r);
            }
        }
    }
};

class SimTransport final : public Transport {
  public:
    SimTransport(std::shared_ptr<SimState> state, std::shared_ptr<Subscriber> sub, DeviceId id)
        : state_(std::move(state)), sub_(std::move(sub)), id_(std::move(id)) {}

    DeviceId id() const override { return id_; }

    Result<std::optional<InputReport>> read_input(int timeout_ms) override {
        Clock& clock = state_->clock;
        const int64_t start = clock.now_ns();
        const int64_t deadline =
            timeout_ms < 0 ? INT64_MAX : start + int64_t{timeout_ms} * kNsPerMs;
        for (;;) {
            int64_t next;
            {
                std::lock_guard lock(state_->mutex);
                if (gone()) return gone_error();
                const int64_t now = clock.now_ns();
                state_->pump(now);
                if (!sub_->queue.empty()) {
                    InputReport r = std::move(sub_->queue.front());
                    sub_->queue.pop_front();
                    return std::optional<InputReport>{std::move(r)};
                }
                if (now >= deadline) return std::optional<InputReport>{};
                next = state_->firmware.next_arrival_ns();
            }
            int64_t target = std::min(next, deadline);
            // note: on the system clock wake at least every 50 ms, so an unplug or a rate change
            // made by another thread is seen.
            if (!clock.is_simulated()) target = std::min(target, clock.now_ns() + 50 * kNsPerMs);
            clock.sleep_until_ns(target);
        }
    }

    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t size) override {
        std::lock_guard lock(state_->mutex);
        if (gone()) return gone_error();
        Result<std::vector<uint8_t>> r =
            state_->firmware.get_feature(report_id, state_->clock.now_ns());
        if (!r.ok()) return make_error(id_.path + ": " + r.error().message);
        if (r->size() > size) r->resize(size);  // as hidraw truncates to the caller's buffer
        return r;
    }

    Status set_feature(std::span<const uint8_t> data) override {
        std::lock_guard lock(state_->mutex);
        if (gone()) return gone_error();
        Status s = state_->firmware.set_feature(data, state_->clock.now_ns());
        if (!s.ok()) return make_error(id_.path + ": " + s.error().message);
        return {};
    }

    Status write_output(std::span<const uint8_t> data) override {
        std::lock_guard lock(state_->mutex);
        if (gone()) return gone_error();
        return make_error(id_.path + ": the reference tracker has no output report " +
                          (data.empty() ? std::string("(empty)") : std::to_string(data[0])));
    }

  private:
    bool gone() const { return !state_->plugged || sub_->generation != state_->generation; }
    Error gone_error() const { return make_error(id_.path + ": device is gone (unplugged)"); }

    std::shared_ptr<SimState> state_;
    std::shared_ptr<Subscriber> sub_;
    DeviceId id_;
};

class SimBackend final : public SimReferenceBackend {
  public:
    explicit SimBackend(std::shared_ptr<SimState> state) : state_(std::move(state)) {}

    std::string name() const override { return "sim"; }

    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) override {
        std::lock_guard lock(state_->mutex);
        std::vector<DeviceId> out;
        if (state_->plugged && filter.matches(state_->id())) out.push_back(state_->id());
        return out;
    }

    Result<std::unique_ptr<Transport>> open(const DeviceId& want) override {
        std::lock_guard lock(state_->mutex);
        const DeviceId id = state_->id();
        if (!state_->plugged || (!want.path.empty() && want.path != id.path) ||
            want.vendor_id != id.vendor_id || want.product_id != id.product_id)
            return make_error(
                "sim: cannot open " +
                (want.path.empty() ? format_vid_pid(want.vendor_id, want.product_id) : want.path) +
                ": no such device is plugged in");
        // note: bring the stream up to now first, so the new reader only sees reports that
        // arrive after it opened (hidraw queues only for readers that have the node open).
        state_->pump(state_->clock.now_ns());
        auto sub = std::make_shared<Subscriber>();
        sub->generation = state_->generation;
        state_->subscribers.push_back(sub);
        return std::unique_ptr<Transport>(new SimTransport(state_, std::move(sub), id));
    }

    void unplug() override {
        std::lock_guard lock(state_->mutex);
        if (!state_->plugged) return;
        state_->pump(state_->clock.now_ns());
        state_->plugged = false;
        ++state_->generation;
        state_->subscribers.clear();
    }

    void replug(bool reboot) override {
        std::lock_guard lock(state_->mutex);
        if (state_->plugged) return;
        const int64_t now = state_->clock.now_ns();
        if (reboot)
            state_->firmware.boot(now);
        else
            state_->firmware.skip_until(now + 1);
        state_->plugged = true;
        ++state_->plug_count;
    }

    bool plugged() const override {
        std::lock_guard lock(state_->mutex);
        return state_->plugged;
    }
    uint64_t reports_dropped() const override {
        std::lock_guard lock(state_->mutex);
        return state_->dropped;
    }
    uint64_t plug_count() const override {
        std::lock_guard lock(state_->mutex);
        return state_->plug_count;
    }

  private:
    std::shared_ptr<SimState> state_;
};

}  // namespace

std::unique_ptr<SimReferenceBackend> create_sim_reference_backend(Clock& clock,
                                                                  SimReferenceDeviceConfig config,
                                                                  MotionSource motion) {
    auto state = std::make_shared<SimState>(clock, std::move(config), std::move(motion));
    state->firmware.boot(clock.now_ns());
    return std::make_unique<SimBackend>(std::move(state));
}

}  // namespace hmdnode
