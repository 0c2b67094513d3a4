// Reading a Vive/Index device's configuration over HID feature reports (0x10, then 0x11 chunks of
// a zlib stream), with no hardware: a mock transport answers those reports with the CONFIG JSON of
// the bundled Index recording (data/traces/compare-test-index.rec.gz), compressed and cut into
// chunks as a device sends them, and gives that recording's IMU reports as its input. Checked: the
// JSON comes back exactly; the codec applies the calibration read from the device exactly as the
// .rec path applies the recording's; a Vive Pro's configuration gives its own axes, no warning;
// a device that does not answer keeps the warning; broken exchanges are errors naming the report.
#include <gtest/gtest.h>
#include <zlib.h>

#include <array>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

namespace hmdnode {
namespace {

const std::string kRec = std::string(HMDNODE_SOURCE_DIR) + "/data/traces/compare-test-index.rec.gz";

// The CONFIG line's JSON of device T20, read from the recording with zlib's gz reader.
std::string recording_config_json() {
    gzFile f = gzopen(kRec.c_str(), "rb");
    EXPECT_NE(f, nullptr);
    std::string text;
    std::array<char, 65536> buf;
    int n;
    while ((n = gzread(f, buf.data(), unsigned(buf.size()))) > 0)
        text.append(buf.data(), size_t(n));
    gzclose(f);
    const size_t at = text.find(" T20 CONFIG ");
    EXPECT_NE(at, std::string::npos);
    const size_t start = text.find('{', at);
    size_t end = text.find('\n', start);
    while (end > start && (text[end - 1] == '\r' || text[end - 1] == '\n')) --end;
    return text.substr(start, end - start);
}

std::vector<uint8_t> zlib_compress(const std::string& s) {
    uLongf n = compressBound(uLong(s.size()));
    std::vector<uint8_t> out(n);
    EXPECT_EQ(compress2(out.data(), &n, reinterpret_cast<const Bytef*>(s.data()), uLong(s.size()),
                        Z_BEST_COMPRESSION),
              Z_OK);
    out.resize(n);
    return out;
}

// A device answering the configuration exchange from `compressed`, and giving `inner`'s input
// reports (when given).
class MockHid final : public Transport {
  public:
    MockHid(std::vector<uint8_t> compressed, std::string product,
            std::unique_ptr<Transport> inner = nullptr)
        : data_(std::move(compressed)), product_(std::move(product)), inner_(std::move(inner)) {}
    DeviceId id() const override {
        return DeviceId{0x28de, 0x2300, "", "mock:0", "Valve", product_, 0, ""};
    }
    Result<std::optional<InputReport>> read_input(int timeout_ms) override {
        if (inner_) return inner_->read_input(timeout_ms);
        return std::optional<InputReport>();
    }
    Result<std::vector<uint8_t>> get_feature(uint8_t id, size_t size) override {
        ++feature_reads;
        std::vector<uint8_t> r(size, 0);
        r[0] = id;
        if (id == lighthouse_config::kStartReportId) {
            if (fail_start) return make_error("mock: stalled");
            at_ = 0;
            r[1] = uint8_t(announced() >> 8);
            r[2] = uint8_t(announced() & 0xff);
            return r;
        }
        if (id == lighthouse_config::kChunkReportId) {
            const size_t n = std::min(chunk, data_.size() - at_);
            r[1] = uint8_t(bad_length ? 200 : n);
            std::copy_n(data_.begin() + long(at_), n, r.begin() + 2);
            at_ += n;
            return r;
        }
        if (inner_) return inner_->get_feature(id, size);
        return make_error("mock: no report " + std::to_string(id));
    }
    Status set_feature(std::span<const uint8_t>) override { return {}; }
    Status write_output(std::span<const uint8_t>) override { return {}; }

    size_t announced() const { return announce_more ? data_.size() + 10 : data_.size(); }
    int feature_reads = 0;
    size_t chunk = 62;
    bool fail_start = false, bad_length = false, announce_more = false;

  private:
    std::vector<uint8_t> data_;
    std::string product_;
    std::unique_ptr<Transport> inner_;
    size_t at_ = 0;
};

TEST(LighthouseConfig, TheRecordingsConfigComesBackThroughTheFeatureReports) {
    const std::string json = recording_config_json();
    ASSERT_GT(json.size(), 1000u);
    const std::vector<uint8_t> z = zlib_compress(json);
    MockHid hid(z, "Index HMD");
    auto r = read_lighthouse_config(hid);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(*r, json);
    // 0x10 once, then one 0x11 per 62 bytes and the closing empty one.
    EXPECT_EQ(hid.feature_reads, 1 + int((z.size() + 61) / 62) + 1);
    EXPECT_EQ(lighthouse_model("Utah MP"), LighthouseModel::Index);
    EXPECT_EQ(lighthouse_model("VIVE_Pro MV"), LighthouseModel::VivePro);
    EXPECT_EQ(lighthouse_model(""), LighthouseModel::Unknown);
}

// The same IMU reports through a codec that read the calibration from the (mock) device and one
// given the recording's calibration (the .rec path): identical samples.
TEST(LighthouseConfig, TheCodecAppliesTheCalibrationReadFromTheDevice) {
    const std::string json = recording_config_json();
    auto rec = read_survive_recording(kRec, "T20");
    ASSERT_TRUE(rec.ok()) << rec.error().message;
    auto shared = std::make_shared<const SurviveRecording>(std::move(*rec));
    auto open_inner = [&] {
        auto backend = create_survive_backend(shared);
        auto ids = backend->enumerate(DeviceFilter{});
        EXPECT_TRUE(ids.ok() && !ids->empty());
        auto t = backend->open(ids->front());
        EXPECT_TRUE(t.ok());
        return std::move(*t);
    };
    MockHid from_device(zlib_compress(json), "Index HMD", open_inner());
    MockHid from_file(zlib_compress(json), "Index HMD", open_inner());
    auto a = make_vive_codec(0x2300);
    auto b = make_vive_codec(0x2300);
    ASSERT_TRUE(b->set_imu_calibration(shared->calibration));
    a->configure(from_device);
    b->configure(from_file);
    EXPECT_NE(a->info().find("factory calibration and IMU axes read from the device (model "
                             "\"Utah MP\")"),
              std::string::npos)
        << a->info();
    EXPECT_EQ(a->warning(), "");
    EXPECT_EQ(from_file.feature_reads, 1);  // the range report only: the recording's calibration
    size_t compared = 0;
    for (int k = 0; k < 2000; ++k) {
        auto ra = from_device.read_input(0);
        auto rb = from_file.read_input(0);
        ASSERT_TRUE(ra.ok() && rb.ok());
        if (!*ra) break;
        std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> sa, sb;
        const size_t na = a->decode((*ra)->bytes, sa), nb = b->decode((*rb)->bytes, sb);
        ASSERT_EQ(na, nb);
        for (size_t i = 0; i < na; ++i) {
            ASSERT_TRUE(sa[i].gyro && sb[i].gyro);
            EXPECT_EQ(*sa[i].gyro, *sb[i].gyro);
            EXPECT_EQ(*sa[i].accel, *sb[i].accel);
            ++compared;
        }
    }
    EXPECT_GT(compared, 1900u);
}

TEST(LighthouseConfig, AViveProIsToldApartByItsConfigurationAndGetsItsOwnAxes) {
    std::string json = recording_config_json();
    const size_t at = json.find("\"Utah MP\"");
    ASSERT_NE(at, std::string::npos);
    json.replace(at, 9, "\"VIVE_Pro MV\"");
    MockHid hid(zlib_compress(json), "VIVE Pro");
    auto codec = make_vive_codec(0x2300);
    codec->configure(hid);
    EXPECT_EQ(codec->warning(), "");  // its own configuration's axes: nothing to guess
    EXPECT_NE(codec->info().find("a Vive Pro"), std::string::npos) << codec->info();
    // The same device answering no configuration: the Index's axes, with the warning.
    MockHid silent(zlib_compress(json), "VIVE Pro");
    silent.fail_start = true;
    auto guess = make_vive_codec(0x2300);
    guess->configure(silent);
    EXPECT_NE(guess->warning().find("a Vive Pro shares this id"), std::string::npos)
        << guess->warning();
    EXPECT_NE(guess->info().find("factory calibration not read (configuration read: feature "
                                 "report 0x10: mock: stalled)"),
              std::string::npos)
        << guess->info();
}

TEST(LighthouseConfig, BrokenExchangesAreErrorsNamingTheReport) {
    const std::vector<uint8_t> z = zlib_compress(recording_config_json());
    MockHid bad_length(z, "Index");
    bad_length.bad_length = true;
    auto r = read_lighthouse_config(bad_length);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().message,
              "configuration read: chunk 0: byte 1 gives length 200 in a report of 64 bytes");
    MockHid short_stream(std::vector<uint8_t>(z.begin(), z.begin() + long(z.size() / 2)), "Index");
    r = read_lighthouse_config(short_stream);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("cut short"), std::string::npos) << r.error().message;
    MockHid fewer(z, "Index");
    fewer.announce_more = true;
    r = read_lighthouse_config(fewer);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("fewer than the " + std::to_string(z.size() + 10) +
                                     " feature report 0x10 announced"),
              std::string::npos)
        << r.error().message;
}

}  // namespace
}  // namespace hmdnode
