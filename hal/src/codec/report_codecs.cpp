// ReportCodec adapters: the Vive/Index IMU codec (vive_imu_codec.cpp) and the reference protocol
// codec (reference_protocol.cpp) behind the interface the device tracker uses. Glue only: the
// algorithms live in those files. O(1) per report.
#include <cassert>
#include <cctype>
#include <cmath>
#include <optional>

#include <nlohmann/json.hpp>

#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/codec/rift_imu.hpp"
#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/clock_sync.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

namespace hmdnode {
namespace {

// The counters of one IMU decoder (Vive or Rift: same fields) added to a codec's.
template <class DecoderCounters>
void accumulate(CodecCounters& c, const DecoderCounters& d) {
    c.reports += d.reports;
    c.samples += d.samples;
    c.malformed += d.malformed;
    c.unknown += d.unknown;
    c.sequence_gaps += d.sequence_gaps;
    c.missing_samples += d.missing_samples;
    if constexpr (requires { d.saturated_samples; }) c.saturated_samples += d.saturated_samples;
}

// IMU-only samples (sequence, device time, gyro, accel) as DeviceSamples.
template <class Samples>
void copy_imu_samples(const Samples& in, std::span<DeviceSample> out) {
    assert(in.size() <= out.size());
    for (size_t i = 0; i < in.size(); ++i) {
        out[i] = DeviceSample{};
        out[i].sequence = in[i].sequence;
        out[i].device_time_ns = in[i].device_time_ns;
        out[i].gyro = in[i].gyro;
        out[i].accel = in[i].accel;
        if constexpr (requires { in[i].gyro_saturated; })
            out[i].imu_flags = {in[i].gyro_saturated, in[i].accel_saturated};
    }
}

// The stale first report: after an open, an Index sends one report whose newest slot is from long
// before (its tick and sequence jump to the next report's), which would show as a phantom gap of
// ~100 samples and poison the clock estimate. So the first sample after an open is held until the
// next report: it is emitted only when the next sample follows it (1..8 sequence steps, device
// time 0 < dt <= 10 ms per step); otherwise it is dropped and counted, and the decoder restarts on
// that next report (whose newest slot is then held the same way).
class ViveCodec final : public ReportCodec {
  public:
    explicit ViveCodec(uint16_t pid) : variant_(vive::variant_for_product(pid)), dec_(variant_) {}
    std::string name() const override {
        return variant_ == vive::Variant::Index ? "Valve Index IMU" : "HTC Vive IMU";
    }
    void configure(Transport& t) override {
        warning_.clear();
        if (!calibration_from_recording_) read_device_configuration(t);
        if (variant_ == vive::Variant::Index && !calibration_) {
            // 28de:2300 is the Index's and also a Vive Pro's, whose IMU axes differ; only the
            // product string tells them apart. This codec decodes the Index's axes only, so any
            // other product string gets the warning below (docs/tracking.md: Vive Pro unsupported).
            std::string product = t.id().product;
            for (char& c : product) c = char(std::tolower(static_cast<unsigned char>(c)));
            if (product.find("index") == std::string::npos)
                warning_ = "28de:2300 with product string \"" + t.id().product +
                           "\": decoded with the Valve Index's IMU axes; a Vive Pro shares this id "
                           "with other axes (not supported), so its orientation would be wrong";
        }
        auto f = t.get_feature(vive::kRangeReportId, vive::kRangeReportSize);
        if (!f) return;  // defaults
        auto r = vive::parse_range_report(*f);
        if (r) ranges_ = *r;
        dec_.set_ranges(ranges_);
    }
    void reset() override {
        accumulate(base_, dec_.counters());
        dec_ = vive::ImuDecoder(variant_, ranges_);
        held_.reset();
        confirmed_ = false;
        empty_reports_ = 0;
    }
    size_t decode(std::span<const uint8_t> report,
                  std::span<DeviceSample, kMaxSamplesPerReport> out) override {
        const size_t n = decode_uncalibrated(report, out);
        if (calibration_)
            for (size_t i = 0; i < n; ++i) calibrate(out[i]);
        return n;
    }
    bool set_imu_calibration(const ImuCalibration& c) override {
        calibration_ = c;
        calibration_from_recording_ = true;
        return true;
    }
    std::string info() const override { return info_; }
    std::string device_configuration() const override { return configuration_; }
    CodecCounters counters() const override {
        CodecCounters c = base_;
        accumulate(c, dec_.counters());
        return c;
    }
    std::string warning() const override { return warning_; }

  private:
    // The device's own configuration (feature reports 0x10/0x11): its factory IMU calibration and
    // IMU axes, which replace the variant's fixed mapping (so a Vive Pro on 28de:2300 gets its own
    // axes, not the Index's). A device that does not answer keeps the fixed mapping (and the
    // product-string warning in configure()).
    void read_device_configuration(Transport& t) {
        calibration_.reset();
        configuration_.clear();
        if (t.replayed()) {
            info_ =
                "factory calibration not read (a capture answers each feature report with its "
                "first recorded answer: the chunked configuration read cannot be replayed)";
            return;
        }
        auto json = read_lighthouse_config(t);
        if (!json) {
            info_ = "factory calibration not read (" + json.error().message + ")";
            return;
        }
        configuration_ = *json;
        const nlohmann::json j = nlohmann::json::parse(*json, nullptr, false);
        std::string model;
        if (j.is_object() && j.contains("model_number") && j["model_number"].is_string())
            model = j["model_number"].get<std::string>();
        const LighthouseModel kind = lighthouse_model(model);
        auto cal = parse_imu_calibration_json(*json, "the device's configuration");
        if (!cal) {
            info_ = "factory calibration not applied (" + cal.error().message + ")";
            return;
        }
        const bool hmd = kind == LighthouseModel::Index || kind == LighthouseModel::VivePro;
        if (hmd && !(j.contains("head") && j["head"].is_object())) {
            info_ = "factory calibration not applied (model \"" + model +
                    "\": an HMD configuration without its \"head\" axes)";
            return;
        }
        calibration_ = *cal;
        info_ = "factory calibration and IMU axes read from the device (model \"" +
                (model.empty() ? std::string("?") : model) + "\"" +
                (kind == LighthouseModel::VivePro ? ", a Vive Pro" : "") + ")";
    }

    // The factory calibration in the IMU's own axes, then its axes (from the device's
    // configuration) to the head frame instead of the variant's fixed mapping.
    void calibrate(DeviceSample& d) const {
        const ImuCalibration& c = *calibration_;
        const glm::dvec3 a = vive::to_sensor_frame(variant_, *d.accel);
        const glm::dvec3 g = vive::to_sensor_frame(variant_, *d.gyro);
        d.accel = c.head_from_imu * (c.acc_scale * a - c.acc_bias);
        d.gyro = c.head_from_imu * (c.gyro_scale * g - c.gyro_bias);
    }

    size_t decode_uncalibrated(std::span<const uint8_t> report,
                               std::span<DeviceSample, kMaxSamplesPerReport> out) {
        std::array<vive::ImuSample, 3> s;
        if (confirmed_) {
            const size_t n = dec_.decode(report, s);
            copy_imu_samples(std::span(s).first(n), out);
            return n;
        }
        const vive::ImuDecoderCounters before = dec_.counters();
        size_t n = dec_.decode(report, s);
        if (!held_) {
            if (n > 0) held_ = s[n - 1];
            return 0;
        }
        if (dec_.counters().reports == before.reports) return 0;  // not an IMU report
        // A report with no new slot is a repeat (the report rate beats the sample rate); several
        // in a row mean the held sequence number is ahead of the stream's: stale too.
        if (n == 0 && ++empty_reports_ < 3) return 0;
        if (n > 0 && follows(*held_, s[0])) {
            confirmed_ = true;
            assert(n + 1 <= out.size());  // the held sample and this report's (3 at most)
            copy_imu_samples(std::span(&*held_, 1), out);
            copy_imu_samples(std::span(s).first(n), out.subspan(1));
            held_.reset();
            return n + 1;
        }
        // Stale: keep the counts of what came before this report, less the dropped sample, and
        // decode this report again as a stream's first.
        accumulate(base_, before);
        base_.samples -= 1;
        ++base_.stale_first_dropped;
        dec_ = vive::ImuDecoder(variant_, ranges_);
        n = dec_.decode(report, s);
        held_.reset();
        empty_reports_ = 0;
        if (n > 0) held_ = s[n - 1];
        return 0;
    }

    // Up to 10 ms of device time per sequence step: a headset's IMU runs at ~1 kHz, a controller's
    // or a tracker's at ~250 Hz (4 ms; a 2 ms bound took every first sample of theirs for stale
    // and dropped them all). A stale report is ~100 samples off: the step bound catches it.
    static bool follows(const vive::ImuSample& a, const vive::ImuSample& b) {
        const uint64_t steps = b.sequence - a.sequence;
        const int64_t dt = b.device_time_ns - a.device_time_ns;
        return steps >= 1 && steps <= 8 && dt > 0 && dt <= int64_t(steps) * 10'000'000;
    }

    vive::Variant variant_;
    vive::ImuRanges ranges_;
    vive::ImuDecoder dec_;
    CodecCounters base_;
    std::optional<vive::ImuSample> held_;  // the first sample after an open, until confirmed
    bool confirmed_ = false;
    int empty_reports_ = 0;  // IMU reports with no new slot since the held sample
    std::string warning_;
    std::string info_;
    bool calibration_from_recording_ = false;
    std::string configuration_;  // the JSON read at the last configure(), if any
    std::optional<ImuCalibration> calibration_;
};

class RiftCodec final : public ReportCodec {
  public:
    std::string name() const override { return "Oculus Rift DK2/CV1 IMU"; }
    void configure(Transport&) override {}
    void reset() override {
        accumulate(base_, dec_.counters());
        dec_ = rift::ImuDecoder();
    }
    size_t decode(std::span<const uint8_t> report,
                  std::span<DeviceSample, kMaxSamplesPerReport> out) override {
        std::array<rift::ImuSample, 2> s;
        const size_t n = dec_.decode(report, s);
        copy_imu_samples(std::span(s).first(n), out);
        return n;
    }
    CodecCounters counters() const override {
        CodecCounters c = base_;
        accumulate(c, dec_.counters());
        return c;
    }

  private:
    rift::ImuDecoder dec_;
    CodecCounters base_;
};

class ReferenceCodec final : public ReportCodec {
  public:
    std::string name() const override { return "hmdnode reference tracker"; }
    void configure(Transport& t) override {
        auto c = t.get_feature(refproto::kCalibrationReport, refproto::kCalibrationReportSize);
        if (c) {
            auto cal = refproto::decode_calibration(*c);
            if (cal) {
                gyro_bias_ = cal->gyro_bias;
                accel_bias_ = cal->accel_bias;
            }
        }
    }
    void reset() override {
        pose_seq_ = TickUnwrapper(uint64_t(1) << 32);
        imu_seq_ = TickUnwrapper(uint64_t(1) << 32);
        have_pose_ = have_imu_ = false;
    }
    size_t decode(std::span<const uint8_t> b,
                  std::span<DeviceSample, kMaxSamplesPerReport> out) override {
        if (b.empty()) {
            ++c_.unknown;
            return 0;
        }
        if (b[0] == refproto::kPoseReport) {
            auto r = refproto::decode_pose(b);
            if (!r) {
                ++c_.malformed;
                return 0;
            }
            ++c_.reports;
            const uint64_t seq = pose_seq_.unwrap(r->sequence);
            if (have_pose_ && seq <= last_pose_seq_) return 0;  // repeat
            assert(!have_pose_ || seq > last_pose_seq_);
            count_gap(have_pose_, last_pose_seq_, seq);
            have_pose_ = true;
            last_pose_seq_ = seq;
            DeviceSample& s = out[0];
            s = DeviceSample{};
            s.sequence = seq;
            s.device_time_ns = int64_t(r->device_time_us * 1000);
            s.clock_reset = (r->flags & refproto::kPoseFlagClockReset) != 0;
            s.has_orientation = (r->flags & refproto::kPoseFlagOrientationValid) != 0;
            s.orientation = r->orientation;
            if (r->flags & refproto::kPoseFlagPositionValid) s.position = r->position_m;
            if (r->flags & refproto::kPoseFlagAngularVelocityValid) s.gyro = r->angular_velocity;
            ++c_.samples;
            return 1;
        }
        if (b[0] == refproto::kImuReport) {
            auto r = refproto::decode_imu(b);
            if (!r) {
                ++c_.malformed;
                return 0;
            }
            ++c_.reports;
            size_t n = 0;
            const uint64_t first = imu_seq_.unwrap(r->first_sequence);
            for (size_t i = 0; i < r->count && n < out.size(); ++i) {
                const uint64_t seq = first + i;
                if (have_imu_ && seq <= last_imu_seq_) continue;
                assert(n < out.size() && (!have_imu_ || seq > last_imu_seq_));
                count_gap(have_imu_, last_imu_seq_, seq);
                have_imu_ = true;
                last_imu_seq_ = seq;
                const refproto::ImuSample& m = r->samples[i];
                DeviceSample& s = out[n++];
                s = DeviceSample{};
                s.sequence = seq;
                s.device_time_ns = int64_t((r->device_time_us + m.dt_us) * 1000);
                s.accel =
                    glm::dvec3(m.accel[0], m.accel[1], m.accel[2]) * r->accel_scale() - accel_bias_;
                s.gyro = glm::dvec3(m.gyro[0], m.gyro[1], m.gyro[2]) * r->gyro_scale() - gyro_bias_;
            }
            c_.samples += n;
            return n;
        }
        ++c_.unknown;
        return 0;
    }
    CodecCounters counters() const override { return c_; }

  private:
    void count_gap(bool have, uint64_t last, uint64_t seq) {
        if (have && seq > last + 1) {
            ++c_.sequence_gaps;
            c_.missing_samples += seq - last - 1;
        }
    }
    CodecCounters c_;
    TickUnwrapper pose_seq_{uint64_t(1) << 32};
    TickUnwrapper imu_seq_{uint64_t(1) << 32};
    bool have_pose_ = false, have_imu_ = false;
    uint64_t last_pose_seq_ = 0, last_imu_seq_ = 0;
    glm::dvec3 gyro_bias_{0.0}, accel_bias_{0.0};
};

}  // namespace

std::unique_ptr<ReportCodec> make_vive_codec(uint16_t product_id) {
    return std::make_unique<ViveCodec>(product_id);
}
std::unique_ptr<ReportCodec> make_reference_codec() {
    return std::make_unique<ReferenceCodec>();
}
std::unique_ptr<ReportCodec> make_codec_for(uint16_t vendor_id, uint16_t product_id) {
    if (vendor_id == vive::kVendorId &&
        (product_id == vive::kViveProductId || product_id == vive::kIndexProductId))
        return make_vive_codec(product_id);
    if (vendor_id == rift::kVendorId &&
        (product_id == rift::kDk2ProductId || product_id == rift::kCv1ProductId))
        return std::make_unique<RiftCodec>();
    return make_reference_codec();
}

}  // namespace hmdnode
