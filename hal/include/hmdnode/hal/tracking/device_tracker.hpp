// A Tracker over a real (or replayed, or simulated) device: a TransportBackend finds and opens the
// device, a ReportCodec turns its input reports into samples on the device clock, ClockSync maps
// them to the host clock, ImuFusion gives IMU-only devices an orientation, and the samples reach
// the frame thread through a single-producer ring, as in sim_tracker.
//
// Recovery: when the transport fails (unplug), the tracker closes it, re-enumerates and re-opens
// every reopen_interval_ns, and counts the gap; the pose history holds the last pose meanwhile
// (PoseHistory bounds extrapolation to max_extrapolation_ns, then holds).
//
// One code path for live and replay: on the system clock a reader thread blocks in read_input();
// on a simulated clock there is no thread, and read() pumps the same processing step until the
// next report's host time is past clock.now_ns() -- a capture then delivers its samples at capture
// time, deterministically (replay only: that step may allocate, which the live path never does on
// the frame thread).
#pragma once

#include <array>
#include <cassert>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/tracker.hpp"
#include "hmdnode/hal/tracking/clock_sync.hpp"
#include "hmdnode/hal/tracking/imu_fusion.hpp"
#include "hmdnode/hal/tracking/light_tracking.hpp"
#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

// One decoded measurement, still on the device clock.
// A sample with gyro and accel but no orientation is fused by the tracker (IMU-only devices).
struct DeviceSample {
    uint64_t sequence = 0;
    int64_t device_time_ns = 0;  // unwrapped device clock
    bool clock_reset = false;    // the device says its clock restarted
    bool has_orientation = false;
    glm::dquat orientation{1, 0, 0, 0};
    std::optional<glm::dvec3> position;
    std::optional<glm::dvec3> gyro;   // rad/s, head frame
    std::optional<glm::dvec3> accel;  // m/s^2, head frame
    ImuSampleFlags imu_flags;         // a gyro/accel axis at its full-scale limit
};

struct CodecCounters {
    uint64_t reports = 0;    // reports decoded
    uint64_t samples = 0;    // samples produced
    uint64_t malformed = 0;  // known id, bad content: skipped
    uint64_t unknown = 0;    // unknown report id: skipped
    uint64_t sequence_gaps = 0;
    uint64_t missing_samples = 0;
    uint64_t saturated_samples = 0;    // IMU samples with an axis at full scale (not trusted)
    uint64_t stale_first_dropped = 0;  // first samples after an open whose tick was stale
};

// A device's factory IMU calibration (the OpenVR/lighthouse configuration's `imu` object), in the
// IMU's own axes: calibrated = scale * raw - bias, raw already scaled by the range to m/s^2 and
// rad/s (Monado's vive_device.c order); head_from_imu then maps the IMU axes to the head frame.
struct ImuCalibration {
    glm::dvec3 acc_bias{0.0};  // m/s^2
    glm::dvec3 acc_scale{1.0};
    glm::dvec3 gyro_bias{0.0};  // rad/s
    glm::dvec3 gyro_scale{1.0};
    glm::dmat3 head_from_imu{1.0};  // IMU axes -> hmdnode head frame (x right, y up, z backward)
    glm::dvec3 imu_position{0.0};   // the IMU's origin in the head frame (m): the lever arm
};

// Report codec of one device family. Reader thread only.
class ReportCodec {
  public:
    static constexpr size_t kMaxSamplesPerReport = 4;
    virtual ~ReportCodec() = default;
    virtual std::string name() const = 0;
    // After each open: read what the codec needs from feature reports (ranges, device info);
    // failures fall back to defaults.
    virtual void configure(Transport& transport) = 0;
    // After a reconnect: forget sequence and clock state.
    virtual void reset() = 0;
    // Decodes one input report into out (oldest first); returns how many.
    virtual size_t decode(std::span<const uint8_t> report,
                          std::span<DeviceSample, kMaxSamplesPerReport> out) = 0;
    virtual CodecCounters counters() const = 0;
    // After configure(): what the codec could not be sure of for this device (empty: nothing),
    // e.g. a product id two devices share with different IMU axes.
    virtual std::string warning() const { return {}; }
    // After configure(): where the IMU calibration came from (empty: the codec has none to read).
    virtual std::string info() const { return {}; }
    // Before the first open: the device's factory calibration (from its configuration or a
    // recording's), applied to every IMU sample from then on; its axes replace the codec's own
    // mapping. False when the codec has no IMU to calibrate.
    virtual bool set_imu_calibration(const ImuCalibration&) { return false; }
    // After configure(): the configuration JSON the codec read from the device (a Vive's or an
    // Index's feature reports 0x10/0x11; its sensor model feeds the light path), empty when it
    // read none.
    virtual std::string device_configuration() const { return {}; }
};

// HTC Vive / Valve Index IMU (report 0x20; ranges from feature report 0x01).
std::unique_ptr<ReportCodec> make_vive_codec(uint16_t product_id);
// The hmdnode reference tracker protocol (pose report 0x01, IMU report 0x02).
std::unique_ptr<ReportCodec> make_reference_codec();
// By VID:PID: 28de:2000 / 28de:2300 -> Vive/Index, 2833:0021 / 2833:0031 -> Rift DK2/CV1 IMU
// (no keep-alive yet: a live Rift stops after its keep-alive interval), anything else ->
// reference protocol.
std::unique_ptr<ReportCodec> make_codec_for(uint16_t vendor_id, uint16_t product_id);

// The device tracker's processing chain, one input report at a time: codec -> clock sync ->
// fusion (IMU-only samples). The tracker's reader thread (or, on a simulated clock, its read())
// feeds it the reports it reads; `hmdnode capture info` feeds it a capture's reports offline, so
// both take one code path. Not thread-safe: one producer.
class ReportChain {
  public:
    explicit ReportChain(std::unique_ptr<ReportCodec> codec, const ClockSyncConfig& clock = {},
                         const ImuFusionConfig& fusion = {})
        : codec_(std::move(codec)), clock_config_(clock), sync_(clock), fusion_(fusion) {
        assert(codec_ != nullptr);
    }

    // Decodes one report received at host_time_ns and calls emit(device_sample, tracker_sample)
    // for each sample, oldest first: the codec's sample on the device clock, and the tracker's on
    // the host clock (arrival = host_time_ns; fused orientation where the device sends none).
    // A sample whose device clock restarted starts the clock sync anew. Returns the count.
    template <class Emit>
    size_t feed(std::span<const uint8_t> report, int64_t host_time_ns, Emit&& emit) {
        std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> buf;
        const size_t n = codec_->decode(report, buf);
        assert(n <= buf.size());
        for (size_t i = 0; i < n; ++i) {
            const DeviceSample& d = buf[i];
            if (d.clock_reset) reset_clock();
            TrackerSample t;
            t.arrival_ns = host_time_ns;
            t.time_ns = sync_.update(d.device_time_ns, host_time_ns);
            t.sequence = d.sequence;
            t.position = d.position;
            t.accel = d.accel;
            if (d.has_orientation) {
                t.has_orientation = true;
                t.orientation = d.orientation;
                t.gyro = d.gyro;
            } else if (d.gyro && d.accel) {
                fusion_.update(d.device_time_ns, *d.gyro, *d.accel, d.imu_flags);
                t.has_orientation = fusion_.initialized();
                t.orientation = fusion_.orientation();
                t.gyro = fusion_.angular_velocity();
            }
            emit(d, t);
        }
        return n;
    }
    // A reconnect (the device may come back with a new clock), or a device clock restart.
    void reset_clock() { sync_ = ClockSync(clock_config_); }

    ReportCodec& codec() { return *codec_; }
    const ReportCodec& codec() const { return *codec_; }
    const ClockSync& clock_sync() const { return sync_; }
    const ImuFusion& fusion() const { return fusion_; }

  private:
    std::unique_ptr<ReportCodec> codec_;
    ClockSyncConfig clock_config_;
    ClockSync sync_;
    ImuFusion fusion_;
};

struct DeviceTrackerConfig {
    DeviceFilter filter;
    std::string name;  // for TrackerInfo; default: the codec's name
    int64_t reopen_interval_ns = 150 * kNsPerMs;
    int read_timeout_ms = 20;  // reader thread: bounds the reaction to stop()
    size_t ring_capacity = 4096;
    double nominal_rate_hz = 1000.0;
    ClockSyncConfig clock;
    ImuFusionConfig fusion;
    // Replay of a recording: shift report host times so the first report arrives at this host
    // time (a capture's times are the recording host's clock). Unset: times are used as they are.
    std::optional<int64_t> first_report_host_ns;
    // A lighthouse-tracked device with a stored base-station setup: its light reports (0x25,
    // 0x28) go to a lighthouse::LightDecoder (the sensor model of `light->sensors`) and
    // LightTracking, whose filter then gives every sample's orientation and, while its position
    // is tracked (FilterPose::good), its position; a sample whose position is not good carries
    // none. Their world is the node's, +y up: the setup's world turned by the shortest rotation
    // taking its up (filter.world_up) to +y. Null, or a setup with no base station and no
    // placement in the tracker (LightTrackingConfig::place): the IMU-only path (ImuFusion). With
    // placement, the base stations the setup lacks are placed from the device's first still
    // stretch (DeviceLightStatus::setup: the setup to store).
    // A config whose `sensors` is empty takes the sensor model (and the IMU's lever arm) from the
    // configuration the codec reads from the device at each open (the live path: hidapi, libusb);
    // a device that gives none keeps the IMU-only path, and DeviceLightStatus::light_error says
    // why.
    std::shared_ptr<const LightTrackingConfig> light;
};

// What the light path did (DeviceTrackerConfig::light).
struct DeviceLightStatus {
    bool enabled = false;   // light reports go to the light path (false until the sensor model is
                            // known: a live device's comes with its configuration at the open)
    uint64_t reports = 0;   // light reports given to the decoder
    uint64_t rejected = 0;  // of those, refused (light_error: the last one's message)
    std::string light_error;
    lighthouse::LightCounters decoder;
    LightTrackingCounters tracking;
    PoseFilterCounters filter;
    PositionState state = PositionState::none;  // of the newest sample
    double confidence = 0;
    uint64_t samples_with_position = 0;  // samples delivered with a (good) position
    // The base stations the light path uses: the configured setup and those placed in the
    // tracker (LightTrackingCounters::placed_in_tracker); empty until the first one is known.
    std::vector<lighthouse::BaseStationPlacement> setup;
};

struct DeviceTrackerStatus {
    bool connected = false;
    uint64_t opens = 0;          // successful opens (the first one included)
    uint64_t disconnects = 0;    // transport failures
    uint64_t open_failures = 0;  // enumerate/open attempts that found nothing
    int64_t last_gap_ns = 0;     // last disconnect -> first sample after the reopen
    int64_t total_gap_ns = 0;
    uint64_t samples = 0;
    int64_t clock_offset_ns = 0;
    double clock_drift_ppm = 0.0;
    double clock_jitter_ns = 0.0;
    uint64_t clock_resets = 0;
    CodecCounters codec;
    std::string codec_warning;  // ReportCodec::warning() after the last open
    std::string codec_info;     // ReportCodec::info() after the last open
    std::string last_error;
    DeviceLightStatus light;
};

class DeviceTracker : public Tracker {
  public:
    // Any thread (a consistent snapshot, taken under a lock off the frame path).
    virtual DeviceTrackerStatus status() const = 0;
};

Result<std::unique_ptr<DeviceTracker>> create_device_tracker(
    std::unique_ptr<TransportBackend> backend, std::unique_ptr<ReportCodec> codec, Clock& clock,
    const DeviceTrackerConfig& config);

// `hmdnode replay --capture FILE --device VID:PID`: a device tracker over one device of a usbmon
// capture (VID:PID from the capture's descriptors, its ".usbdevs" sidecar, or -- when exactly
// one unidentified device sends interrupt-IN reports -- the id given), its first report arriving
// at first_report_host_ns on `clock`. Errors name the file and say which devices it holds.
// When the capture holds the device's configuration read (feature reports 0x10 / 0x11), its
// factory IMU calibration is applied (the capture cannot replay that read to the codec).
// `setup` (a base-station setup whose world's up is `world_up`): the device's light reports go
// through the light path (6DoF, DeviceTrackerConfig::light) with the configuration's sensor
// model -- an error when the capture holds no configuration read or it has no sensor model.
// `place_base_stations`: the light path also without a setup, placing the base stations it lacks
// in the tracker (LightTrackingConfig::place).
Result<std::unique_ptr<DeviceTracker>> create_capture_tracker(
    const std::filesystem::path& capture, const std::string& vid_pid, Clock& clock,
    int64_t first_report_host_ns, std::vector<lighthouse::BaseStationPlacement> setup = {},
    const glm::dvec3& world_up = glm::dvec3(0, 0, 1), bool place_base_stations = false);

}  // namespace hmdnode
