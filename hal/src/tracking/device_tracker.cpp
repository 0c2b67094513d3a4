// Device tracker: transport -> codec -> clock sync -> (fusion) -> ring, with reconnection.
// The chain from codec to fusion is ReportChain (device_tracker.hpp, shared with `hmdnode capture
// info`); it composes clock_sync.cpp (lower-envelope clock tracking) and imu_fusion.cpp
// (Mahony); the ring is the Lamport SPSC queue of spsc_ring.hpp. Reconnection follows the
// practice of public runtimes (Monado's and OpenHMD's HID drivers: on a read error close the
// device, poll enumeration at a fixed interval, reopen).
// With a lighthouse device's setup (DeviceTrackerConfig::light) its light reports go to the light
// decoder (codec/light_codec.cpp) and LightTracking (light_tracking.cpp: a solve per rotor turn
// and the light + IMU filter), which then gives the samples' pose on the device clock; the clock
// sync maps it as for every sample.
// Cost: O(1) per report plus the codec (and the light path's: light_tracking.hpp); memory O(ring
// capacity).
// Departures: on a simulated clock the processing step runs inside read() (no thread), so a replay
// is deterministic; that path may allocate (replay only).
#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <deque>
#include <mutex>
#include <thread>

#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"
#include "tracking/spsc_ring.hpp"

namespace hmdnode {
namespace {

class DeviceTrackerImpl final : public DeviceTracker {
  public:
    DeviceTrackerImpl(std::unique_ptr<TransportBackend> backend, std::unique_ptr<ReportCodec> codec,
                      Clock& clock, const DeviceTrackerConfig& config)
        : backend_(std::move(backend)),
          chain_(std::move(codec), config.clock, config.fusion),
          clock_(clock),
          config_(config),
          ring_(std::max<size_t>(config.ring_capacity, 2)) {
        info_.name = config.name.empty() ? chain_.codec().name() : config.name;
        info_.nominal_rate_hz = config.nominal_rate_hz;
        info_.provides_orientation = true;
        info_.provides_imu = true;
        if (uses_light(config)) {
            info_.provides_position = true;
            if (!config.light->sensors.empty()) {
                light_config_ = config.light;
                status_.light.enabled = true;
                reset_light();
            }
        }
    }
    ~DeviceTrackerImpl() override { stop(); }

    TrackerInfo info() const override {
        std::lock_guard lock(mutex_);
        return info_;
    }

    Status start() override {
        if (started_) return {};
        started_ = true;
        next_open_ns_ = clock_.now_ns();
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
            pump_until(now);
            // pump_until queues a sample only once the simulated clock reached its arrival.
            assert(pending_.empty() || pending_.back().arrival_ns <= now);
            while (n < out.size() && !pending_.empty() && pending_.front().arrival_ns <= now) {
                out[n++] = pending_.front();
                pending_.pop_front();
            }
        } else {
            while (n < out.size() && ring_.pop(&out[n])) ++n;
        }
        assert(n <= out.size());
        delivered_.fetch_add(n, std::memory_order_relaxed);
        return n;
    }

    bool finished() const override {
        if (clock_.is_simulated())
            return source_finished_.load(std::memory_order_acquire) && pending_.empty() &&
                   !lookahead_;
        if (!producer_done_.load(std::memory_order_acquire)) return false;
        return delivered_.load(std::memory_order_relaxed) +
                   dropped_.load(std::memory_order_relaxed) >=
               produced_.load(std::memory_order_relaxed);
    }

    TrackerCounters counters() const override {
        return TrackerCounters{delivered_.load(std::memory_order_relaxed),
                               dropped_.load(std::memory_order_relaxed)};
    }

    DeviceTrackerStatus status() const override {
        std::lock_guard lock(mutex_);
        DeviceTrackerStatus s = status_;
        s.codec = codec_counters_;
        return s;
    }

  private:
    // ---- shared steps (reader thread, or the frame thread on a simulated clock) ----

    // Tries to open the device; true when open.
    bool try_open(int64_t now) {
        if (transport_) return true;
        if (now < next_open_ns_) return false;
        next_open_ns_ = now + config_.reopen_interval_ns;
        auto ids = backend_->enumerate(config_.filter);
        std::string error;
        if (ids && !ids->empty()) {
            auto t = backend_->open(ids->front());
            if (t) {
                transport_ = std::move(*t);
                chain_.codec().reset();
                chain_.codec().configure(*transport_);
                if (uses_light(config_) && config_.light->sensors.empty()) light_from_device();
                std::lock_guard lock(mutex_);
                status_.codec_warning = chain_.codec().warning();
                status_.codec_info = chain_.codec().info();
                ++status_.opens;
                status_.connected = true;
                info_.serial = transport_->id().serial;
                return true;
            }
            error = t.error().message;
        } else {
            error = ids ? "no device matches the filter" : ids.error().message;
        }
        std::lock_guard lock(mutex_);
        ++status_.open_failures;
        status_.last_error = error;
        return false;
    }

    // The light path afresh (at the start, and after a reconnect: a new device clock).
    void reset_light() {
        lighthouse::SensorModel model;
        model.count = light_config_->sensors.points.size();
        model.channel_map = light_config_->sensors.channel_map;
        decoder_ = std::make_unique<lighthouse::LightDecoder>(std::move(model));
        light_ = std::make_unique<LightTracking>(*light_config_);
        // The node's world is +y up: the setup's world turned so its up is +y.
        node_from_setup_ =
            shortest_rotation(glm::normalize(light_config_->filter.world_up), glm::dvec3(0, 1, 0));
    }

    // After an open (configure done): the light path with the sensor model of the configuration
    // the codec read from the device, or the IMU-only path and the reason.
    void light_from_device() {
        light_.reset();
        decoder_.reset();
        light_config_.reset();
        const std::string json = chain_.codec().device_configuration();
        const std::string source = transport_->id().path + ": the device's configuration";
        std::string why;
        if (json.empty()) {
            why = "the device gave no configuration (" + chain_.codec().info() + ")";
        } else if (auto sensors = parse_lighthouse_sensors(json, source); !sensors) {
            why = sensors.error().message;
        } else if (sensors->empty()) {
            why = source + " has no lighthouse_config (sensor model)";
        } else {
            auto cfg = std::make_shared<LightTrackingConfig>(*config_.light);
            cfg->sensors = std::move(*sensors);
            if (auto cal = parse_imu_calibration_json(json, source))
                cfg->filter.imu_position = cal->imu_position;
            light_config_ = std::move(cfg);
            reset_light();
        }
        std::lock_guard lock(mutex_);
        status_.light.enabled = light_ != nullptr;
        if (!light_) status_.light.light_error = why + "; orientation only";
    }

    // The shortest rotation taking unit a onto unit b (half-way quaternion; a half turn about x
    // or z when they are opposite).
    static glm::dquat shortest_rotation(const glm::dvec3& a, const glm::dvec3& b) {
        const double c = glm::dot(a, b);
        if (c < -1 + 1e-12) {
            const glm::dvec3 axis = std::abs(a.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 0, 1);
            return glm::angleAxis(3.14159265358979323846, glm::normalize(glm::cross(a, axis)));
        }
        const glm::dvec3 v = glm::cross(a, b);
        return glm::normalize(glm::dquat(1 + c, v.x, v.y, v.z));
    }

    // The light path: a setup, or base stations to place in the tracker.
    static bool uses_light(const DeviceTrackerConfig& c) {
        return c.light && (!c.light->setup.empty() || c.light->place.enabled);
    }

    static bool is_light_report(const InputReport& r) {
        return !r.bytes.empty() &&
               (r.bytes[0] == lighthouse::kLh1ReportId || r.bytes[0] == lighthouse::kLh2ReportId);
    }

    // A light report: decoded, its events to LightTracking; no sample of its own.
    void process_light(const InputReport& report) {
        Status st = decoder_->decode_report(report.bytes);
        light_events_.clear();
        decoder_->take_events(light_events_);
        light_->add_light(light_events_, *decoder_);
        std::lock_guard lock(mutex_);
        ++status_.light.reports;
        if (!st) {
            ++status_.light.rejected;
            status_.light.light_error = st.error().message;
        }
    }

    // A sample's pose from the light + IMU filter (the setup's world); its position only when
    // tracked.
    void light_pose(const DeviceSample& d, TrackerSample* t) {
        if (!d.gyro || !d.accel) return;
        // The 32-bit tick of the sample extends the 24-bit light times (ns -> ticks, 48 MHz).
        decoder_->note_imu_ticks(lighthouse::imu_ticks(d.device_time_ns));
        light_->add_imu(d.device_time_ns, *d.gyro, *d.accel, d.imu_flags);
        const FilterPose p = light_->pose();
        t->has_orientation = light_->filter().initialized();
        t->orientation = glm::normalize(node_from_setup_ * p.orientation);
        t->gyro = *d.gyro - light_->filter().gyro_bias();
        t->position.reset();
        if (p.good()) t->position = node_from_setup_ * p.position;
        light_state_ = p.state;
        light_confidence_ = p.confidence;
        if (p.good()) ++light_positions_;
    }

    void on_transport_error(const std::string& message, int64_t now) {
        transport_.reset();
        if (light_) reset_light();  // the device's own model is read again at the reopen
        lookahead_.reset();
        gap_open_ = true;
        gap_start_ns_ = last_arrival_ns_ ? last_arrival_ns_ : now;
        next_open_ns_ = now + config_.reopen_interval_ns;
        chain_.reset_clock();  // the device may come back with a new clock
        std::lock_guard lock(mutex_);
        ++status_.disconnects;
        status_.connected = false;
        status_.last_error = message;
    }

    // Decodes one report through the chain (codec -> clock sync -> fusion) and emits its samples
    // through emit(sample); counts the reconnect gap and the status.
    template <class Emit>
    void process(const InputReport& report, Emit&& emit) {
        if (light_ && is_light_report(report)) return process_light(report);
        const size_t n = chain_.feed(report.bytes, report.host_time_ns,
                                     [&](const DeviceSample& d, const TrackerSample& fused) {
                                         TrackerSample t = fused;
                                         if (light_) light_pose(d, &t);
                                         if (gap_open_) {
                                             gap_open_ = false;
                                             const int64_t gap = t.arrival_ns - gap_start_ns_;
                                             std::lock_guard lock(mutex_);
                                             status_.last_gap_ns = gap;
                                             status_.total_gap_ns += gap;
                                         }
                                         last_arrival_ns_ = t.arrival_ns;
                                         emit(t);
                                     });
        const ClockSync& sync = chain_.clock_sync();
        std::lock_guard lock(mutex_);
        status_.samples += n;
        status_.clock_offset_ns = sync.valid() ? sync.offset_ns() : 0;
        status_.clock_drift_ppm = sync.drift_ppm();
        status_.clock_jitter_ns = sync.jitter_ns();
        status_.clock_resets += sync.resets() - seen_resets_;
        seen_resets_ = sync.resets();
        codec_counters_ = chain_.codec().counters();
        if (light_) {
            status_.light.decoder = decoder_->counters();
            status_.light.tracking = light_->counters();
            status_.light.filter = light_->filter().counters();
            status_.light.state = light_state_;
            status_.light.confidence = light_confidence_;
            status_.light.samples_with_position = light_positions_;
            if (light_->setup().size() != status_.light.setup.size())
                status_.light.setup = light_->setup();
        }
    }

    // A report's host time, rebased for a replayed recording.
    int64_t rebase(int64_t t) {
        if (!config_.first_report_host_ns) return t;
        if (!have_shift_) {
            have_shift_ = true;
            shift_ns_ = *config_.first_report_host_ns - t;
        }
        return t + shift_ns_;
    }

    // ---- simulated clock ----

    void pump_until(int64_t now) {
        while (true) {
            if (!lookahead_) {
                if (!transport_ && !try_open(now)) return;
                auto r = transport_->read_input(0);
                if (!r) {
                    on_transport_error(r.error().message, now);
                    continue;  // try_open() waits for the reopen interval
                }
                if (!r->has_value()) {
                    if (transport_->finished()) source_finished_.store(true);
                    return;
                }
                lookahead_ = std::move(**r);
                lookahead_->host_time_ns = rebase(lookahead_->host_time_ns);
            }
            if (lookahead_->host_time_ns > now) return;
            const InputReport report = std::move(*lookahead_);
            lookahead_.reset();
            process(report, [&](const TrackerSample& s) {
                pending_.push_back(s);
                produced_.fetch_add(1, std::memory_order_relaxed);
            });
        }
    }

    // ---- system clock: the reader thread ----

    void reader_loop() {
        while (!stop_requested_) {
            const int64_t now = clock_.now_ns();
            if (!transport_ && !try_open(now)) {
                clock_.sleep_until_ns(std::min(next_open_ns_, now + 10 * kNsPerMs));
                continue;
            }
            auto r = transport_->read_input(config_.read_timeout_ms);
            if (!r) {
                on_transport_error(r.error().message, clock_.now_ns());
                continue;
            }
            if (!r->has_value()) {
                if (transport_->finished()) break;
                continue;
            }
            InputReport& report = **r;
            report.host_time_ns = rebase(report.host_time_ns);
            // A recording replayed in real time: wait for the report's time.
            while (!stop_requested_ && clock_.now_ns() < report.host_time_ns)
                clock_.sleep_until_ns(
                    std::min(report.host_time_ns, clock_.now_ns() + 10 * kNsPerMs));
            process(report, [&](const TrackerSample& s) {
                produced_.fetch_add(1, std::memory_order_relaxed);
                if (!ring_.push(s)) dropped_.fetch_add(1, std::memory_order_relaxed);
            });
        }
        producer_done_.store(true, std::memory_order_release);
    }

    std::unique_ptr<TransportBackend> backend_;
    ReportChain chain_;  // the producer side's
    Clock& clock_;
    DeviceTrackerConfig config_;
    SpscRing<TrackerSample> ring_;

    // Owned by the producer side (reader thread, or the frame thread on a simulated clock).
    std::unique_ptr<Transport> transport_;
    int64_t next_open_ns_ = 0;
    bool gap_open_ = false;
    int64_t gap_start_ns_ = 0;
    int64_t last_arrival_ns_ = 0;
    uint64_t seen_resets_ = 0;
    bool have_shift_ = false;
    int64_t shift_ns_ = 0;
    std::optional<InputReport> lookahead_;  // simulated clock
    std::deque<TrackerSample> pending_;     // simulated clock
    // The light path (DeviceTrackerConfig::light with a setup), producer side; light_config_ is
    // the config's, or with the device's sensor model once read.
    std::shared_ptr<const LightTrackingConfig> light_config_;
    std::unique_ptr<lighthouse::LightDecoder> decoder_;
    std::unique_ptr<LightTracking> light_;
    std::vector<lighthouse::LightEvent> light_events_;
    glm::dquat node_from_setup_{1, 0, 0, 0};
    PositionState light_state_ = PositionState::none;
    double light_confidence_ = 0;
    uint64_t light_positions_ = 0;

    mutable std::mutex mutex_;  // guards info_, status_, codec_counters_
    TrackerInfo info_;
    DeviceTrackerStatus status_;
    CodecCounters codec_counters_;

    std::thread thread_;
    bool started_ = false;
    std::atomic<bool> stop_requested_{false};
    std::atomic<bool> producer_done_{false};
    std::atomic<bool> source_finished_{false};
    std::atomic<uint64_t> produced_{0};
    std::atomic<uint64_t> delivered_{0};
    std::atomic<uint64_t> dropped_{0};
};

}  // namespace

Result<std::unique_ptr<DeviceTracker>> create_device_tracker(
    std::unique_ptr<TransportBackend> backend, std::unique_ptr<ReportCodec> codec, Clock& clock,
    const DeviceTrackerConfig& config) {
    if (!backend) return make_error("device tracker: no transport backend");
    if (!codec) return make_error("device tracker: no report codec");
    if (config.reopen_interval_ns <= 0 || config.read_timeout_ms < 0)
        return make_error("device tracker: reopen interval and read timeout must be positive");
    return std::unique_ptr<DeviceTracker>(
        new DeviceTrackerImpl(std::move(backend), std::move(codec), clock, config));
}

Result<std::unique_ptr<DeviceTracker>> create_capture_tracker(
    const std::filesystem::path& file, const std::string& vid_pid, Clock& clock,
    int64_t first_report_host_ns, std::vector<lighthouse::BaseStationPlacement> setup,
    const glm::dvec3& world_up, bool place_base_stations) {
    auto dev = find_capture_device(file, vid_pid);
    if (!dev) return dev.error();
    // note: a truncated capture replays its whole records; the reader's warning names the cut.
    for (const std::string& w : dev->capture->warnings)
        std::fprintf(stderr, "warning: %s\n", w.c_str());
    DeviceTrackerConfig cfg;
    cfg.filter = dev->filter;
    cfg.first_report_host_ns = first_report_host_ns;
    cfg.name = "capture " + file.filename().string() + " " + vid_pid;
    auto codec = make_codec_for(dev->filter.vendor_id, dev->filter.product_id);
    // The configuration read the capture recorded: the factory IMU calibration, and for the
    // light path the sensor model.
    auto json = capture_lighthouse_config(*dev->capture, dev->bus, dev->address);
    std::optional<ImuCalibration> calibration;
    if (json)
        if (auto cal = parse_imu_calibration_json(*json, file.string() + ": the configuration"))
            if (codec->set_imu_calibration(*cal)) calibration = *cal;
    if (!setup.empty() || place_base_stations) {
        auto sensors =
            capture_sensor_model(json, file.string(), vid_pid, "to solve its light with");
        if (!sensors) return sensors.error();
        auto light = std::make_shared<LightTrackingConfig>();
        light->sensors = std::move(*sensors);
        light->setup = std::move(setup);
        light->filter.world_up = glm::normalize(world_up);
        light->place.enabled = place_base_stations;
        if (calibration) light->filter.imu_position = calibration->imu_position;
        cfg.light = std::move(light);
    }
    auto backend = create_capture_backend(dev->capture, dev->summary);
    auto t = create_device_tracker(std::move(backend), std::move(codec), clock, cfg);
    if (!t) return t.error();
    return std::move(*t);
}

}  // namespace hmdnode
