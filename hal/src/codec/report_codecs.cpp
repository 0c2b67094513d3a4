// ReportCodec adapters: the Vive/Index IMU codec (vive_imu_codec.cpp) and the reference protocol
// codec (reference_protocol.cpp) behind the interface the device tracker uses. Glue only: the
// algorithms live in those files. O(1) per report.
#include <cmath>

#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/codec/rift_imu.hpp"
#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/clock_sync.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

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
}

// IMU-only samples (sequence, device time, gyro, accel) as DeviceSamples.
template <class Samples>
void copy_imu_samples(const Samples& in, std::span<DeviceSample> out) {
    for (size_t i = 0; i < in.size(); ++i) {
        out[i] = DeviceSample{};
        out[i].sequence = in[i].sequence;
        out[i].device_time_ns = in[i].device_time_ns;
        out[i].gyro = in[i].gyro;
        out[i].accel = in[i].accel;
    }
}

class ViveCodec final : public ReportCodec {
  public:
    explicit ViveCodec(uint16_t pid) : variant_(vive::variant_for_product(pid)), dec_(variant_) {}
    std::string name() const override {
        return variant_ == vive::Variant::Index ? "Valve Index IMU" : "HTC Vive IMU";
    }
    void configure(Transport& t) override {
        auto f = t.get_feature(vive::kRangeReportId, vive::kRangeReportSize);
        if (!f) return;  // defaults
        auto r = vive::parse_range_report(*f);
        if (r) ranges_ = *r;
        dec_.set_ranges(ranges_);
    }
    void reset() override {
        accumulate(base_, dec_.counters());
        dec_ = vive::ImuDecoder(variant_, ranges_);
    }
    size_t decode(std::span<const uint8_t> report,
                  std::span<DeviceSample, kMaxSamplesPerReport> out) override {
        std::array<vive::ImuSample, 3> s;
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
    vive::Variant variant_;
    vive::ImuRanges ranges_;
    vive::ImuDecoder dec_;
    CodecCounters base_;
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
