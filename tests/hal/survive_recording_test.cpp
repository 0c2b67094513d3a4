// The libsurvive recording reader on the bundled Index recording (line counts, the CONFIG's factory
// calibration and axes), the calibration applied by the Index codec to the recording's samples
// replayed as report 0x20, and bad input: a malformed line is an error naming the file and line,
// a cut last line is skipped with a warning, an absent device names those present. Recordings the
// bundled one does not show, by hand-made lines: a controller's IMU stream without sequence
// numbers at 247 Hz with its IMU_SCALES ranges, and libsurvive's replay output (EXTERNAL_POSE).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

namespace hmdnode {
namespace {

const std::string kIndexRec =
    std::string(HMDNODE_SOURCE_DIR) + "/data/traces/compare-test-index.rec.gz";

// A CONFIG with the Index's IMU block (as the bundled recording's, rounded) and a head block.
const std::string kConfig =
    R"(0.1 T20 CONFIG {"model_number":"Utah MP","device_class":"hmd","head":{"plus_x":[-1,0,0],"plus_z":[0,0,-1]},)"
    R"("imu":{"acc_bias":[-0.003,-0.072,0.275],"acc_scale":[1.0017,1.0018,0.9992],)"
    R"("gyro_bias":[-0.0164,0.0227,0.0243],"plus_x":[0,-1,0],"plus_z":[0,0,1]}})"
    "\r\n";

std::string imu_line(double t, uint32_t tick, int ax, int seq) {
    return std::to_string(t) + " T20 i 3 " + std::to_string(tick) + " " + std::to_string(ax) +
           ".000000 -438.000000 4052.000000 26.000000 94.000000 66.000000  0.000000 0.000000 "
           "0.000000 " +
           std::to_string(seq) + "\r\n";
}

TEST(SurviveRecording, ReadsTheBundledIndexRecording) {
    auto r = read_survive_recording(kIndexRec, "T20");
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->imu.size(), 25059u);
    EXPECT_EQ(r->poses.size(), 4680u);
    EXPECT_EQ(r->lines, 261747u);
    EXPECT_TRUE(r->warnings.empty());
    const SurviveImuLine& first = r->imu.front();
    EXPECT_EQ(first.host_time_ns, 221'879'000);
    EXPECT_EQ(first.ticks, 3144688562u);
    EXPECT_EQ(first.accel, (std::array<int16_t, 3>{-7166, -438, 4052}));
    EXPECT_EQ(first.gyro, (std::array<int16_t, 3>{26, 94, 66}));
    EXPECT_EQ(first.sequence, 1);
    EXPECT_EQ(r->poses.front().host_time_ns, 16'089'040'000);
    EXPECT_NEAR(r->poses.front().orientation.w, -0.383924, 1e-5);
    ASSERT_TRUE(r->has_config);
    EXPECT_EQ(r->model, "Utah MP");
    const ImuCalibration& c = r->calibration;
    EXPECT_DOUBLE_EQ(c.acc_bias.z, 0.274579704);
    EXPECT_DOUBLE_EQ(c.acc_scale.x, 1.00170946);
    EXPECT_DOUBLE_EQ(c.gyro_bias.y, 0.0227181744);
    // The CONFIG's IMU and head axes give the same mapping as the Index's fixed one (Monado's).
    for (const glm::dvec3 v : {glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0), glm::dvec3(0, 0, 1)}) {
        const glm::dvec3 want = vive::to_head_frame(vive::Variant::Index, v);
        const glm::dvec3 got = c.head_from_imu * v;
        EXPECT_NEAR(glm::length(got - want), 0.0, 1e-6);
    }
}

TEST(SurviveRecording, TheCodecAppliesTheFactoryCalibration) {
    const std::string text = "0.05 INFO LOG starting\n" + kConfig +
                             imu_line(0.200, 1000, -7166, 1) + imu_line(0.201, 49000, -7170, 2) +
                             imu_line(0.202, 97000, -7180, 3);
    auto r = parse_survive_recording(text, "t.rec", "T20");
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->imu.size(), 3u);
    EXPECT_EQ(r->other_lines, 1u);
    auto rec = std::make_shared<const SurviveRecording>(*r);
    auto backend = create_survive_backend(rec);
    auto ids = backend->enumerate(DeviceFilter{vive::kVendorId, vive::kIndexProductId, ""});
    ASSERT_TRUE(ids.ok());
    ASSERT_EQ(ids->size(), 1u);
    auto t = backend->open(ids->front());
    ASSERT_TRUE(t.ok());
    auto codec = make_vive_codec(vive::kIndexProductId);
    ASSERT_TRUE(codec->set_imu_calibration(rec->calibration));
    codec->configure(**t);
    EXPECT_EQ(codec->warning(), "");  // the axes come from the device's configuration
    std::vector<DeviceSample> got;
    for (int k = 0; k < 3; ++k) {
        auto in = (*t)->read_input(0);
        ASSERT_TRUE(in.ok() && in->has_value());
        EXPECT_EQ((*in)->host_time_ns, rec->imu[size_t(k)].host_time_ns);
        std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> out;
        const size_t n = codec->decode((*in)->bytes, out);
        got.insert(got.end(), out.begin(), out.begin() + long(n));
    }
    EXPECT_TRUE((*t)->finished());
    ASSERT_EQ(got.size(), 3u);
    // By hand: counts x range / 32768 in the IMU's axes, scale x value - bias, then the Index
    // mapping head = (-y, -x, -z). The ranges: libsurvive's defaults for a headset (no IMU_SCALES
    // line; CONFIG device_class "hmd"), 4 g and 500 deg/s.
    const double acc_lsb = 4 * 9.80665 / 32768, gyro_lsb = 500 * M_PI / 180 / 32768;
    const ImuCalibration& c = rec->calibration;
    const glm::dvec3 a_imu(1.0017 * -7170 * acc_lsb + 0.003, 1.0018 * -438 * acc_lsb + 0.072,
                           0.9992 * 4052 * acc_lsb - 0.275);
    const glm::dvec3 g_imu(26 * gyro_lsb + 0.0164, 94 * gyro_lsb - 0.0227, 66 * gyro_lsb - 0.0243);
    (void)c;
    EXPECT_NEAR(got[1].accel->x, -a_imu.y, 1e-12);
    EXPECT_NEAR(got[1].accel->y, -a_imu.x, 1e-12);
    EXPECT_NEAR(got[1].accel->z, -a_imu.z, 1e-12);
    EXPECT_NEAR(got[1].gyro->x, -g_imu.y, 1e-12);
    EXPECT_NEAR(got[1].gyro->y, -g_imu.x, 1e-12);
    EXPECT_NEAR(got[1].gyro->z, -g_imu.z, 1e-12);
    EXPECT_EQ(got[2].device_time_ns - got[1].device_time_ns, 1'000'000);  // 48,000 ticks
}

TEST(SurviveRecording, AMalformedLineIsAnErrorNamingTheLine) {
    std::string bad = imu_line(0.201, 49000, -7170, 2);
    bad.replace(bad.find("-438.000000"), 11, "-438.5");
    const std::string text = kConfig + imu_line(0.200, 1000, -7166, 1) + bad;
    auto r = parse_survive_recording(text, "bad.rec", "T20");
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("bad.rec:3: ay \"-438.5\""), std::string::npos)
        << r.error().message;
    auto pose = parse_survive_recording(
        kConfig + imu_line(0.2, 1, 1, 1) + "0.3 T20 POSE 0 0 0 0.5 0.5 0.5\n", "p.rec", "T20");
    ASSERT_FALSE(pose.ok());
    EXPECT_NE(pose.error().message.find("p.rec:3: a POSE line has 10 fields"), std::string::npos)
        << pose.error().message;
    auto cfg = parse_survive_recording("0.1 T20 CONFIG {\"imu\":{}}\n", "c.rec", "T20");
    ASSERT_FALSE(cfg.ok());
    EXPECT_NE(cfg.error().message.find("c.rec:1: CONFIG: imu.acc_bias: missing"), std::string::npos)
        << cfg.error().message;
}

TEST(SurviveRecording, ACutLastLineIsSkippedWithAWarning) {
    std::string text = kConfig + imu_line(0.200, 1000, -7166, 1) + imu_line(0.201, 49000, -7170, 2);
    const size_t cut_at = text.size();
    text += "0.202 T20 i 3 97000 -7180.000000 -43";  // the recorder stopped mid-line
    auto r = parse_survive_recording(text, "cut.rec", "T20");
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->imu.size(), 2u);
    ASSERT_EQ(r->warnings.size(), 1u);
    EXPECT_NE(r->warnings[0].find("cut.rec:4: the last line (at byte " + std::to_string(cut_at) +
                                  ") is cut short"),
              std::string::npos)
        << r->warnings[0];
}

// A controller's IMU line (device KN0): SEQ as given (0: a controller through its radio).
std::string kn_line(double t, uint32_t tick, int gx, int seq, bool magnetometer = true) {
    return std::to_string(t) + " KN0 i 3 " + std::to_string(tick) + " 0 0 4096.000000 " +
           std::to_string(gx) + ".000000 0 0" + (magnetometer ? " 0 0 0" : "") + " " +
           std::to_string(seq) + "\n";
}

// Decodes every report of the recording's backend through a fresh Vive/Index codec (with the
// recording's factory calibration when `calibrated`).
std::vector<DeviceSample> decode_all(std::shared_ptr<const SurviveRecording> rec,
                                     bool calibrated = false) {
    auto backend = create_survive_backend(rec);
    auto ids = backend->enumerate(DeviceFilter{vive::kVendorId, vive::kIndexProductId, ""});
    EXPECT_TRUE(ids.ok() && ids->size() == 1);
    auto t = backend->open(ids->front());
    EXPECT_TRUE(t.ok());
    auto codec = make_vive_codec(vive::kIndexProductId);
    if (calibrated) {
        EXPECT_TRUE(codec->set_imu_calibration(rec->calibration));
    }
    codec->configure(**t);
    std::vector<DeviceSample> got;
    while (!(*t)->finished()) {
        auto in = (*t)->read_input(0);
        EXPECT_TRUE(in.ok() && in->has_value());
        std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> out;
        const size_t n = codec->decode((*in)->bytes, out);
        got.insert(got.end(), out.begin(), out.begin() + long(n));
    }
    return got;
}

// A controller: sequence number 0 on every line at 247 Hz (194,332 ticks apart), the IMU_SCALES
// line libsurvive writes from the device's feature report 0x01, and the older 12-field lines.
TEST(SurviveRecording, AControllersStreamWithoutSequenceNumbersAndItsImuScales) {
    std::string text = "0.01 KN0 IMU_SCALES 3 2\r\n";
    const uint32_t step = 194'332;  // 48 MHz / 247 Hz
    for (int k = 0; k < 40; ++k)
        text += kn_line(0.1 + k * 0.00405, 1'000'000u + uint32_t(k) * step, 100, 0, k % 2 == 0);
    text += kn_line(0.1 + 40 * 0.00405, 1'000'000u + 39 * step, 100, 0);  // a repeat: same tick
    auto r = parse_survive_recording(text, "kn.rec", "KN0");
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->imu.size(), 41u);
    EXPECT_TRUE(r->imu_sequence_numbered);
    EXPECT_EQ(r->imu[39].sequence, 39);
    EXPECT_EQ(r->imu[40].sequence, 39);  // the repeated tick: the same sample
    ASSERT_TRUE(r->imu_scales.has_value());
    EXPECT_EQ((*r->imu_scales)[0], 3);
    EXPECT_EQ((*r->imu_scales)[1], 2);
    ASSERT_EQ(r->notes.size(), 2u);
    EXPECT_NE(r->notes[0].find("kn.rec:1: IMU_SCALES 3 2: gyro range 2000 deg/s, accelerometer "
                               "range 8 g"),
              std::string::npos)
        << r->notes[0];
    EXPECT_NE(r->notes[1].find("all carry sequence number 0"), std::string::npos) << r->notes[1];
    auto rec = std::make_shared<const SurviveRecording>(*r);
    const std::vector<DeviceSample> got = decode_all(rec);
    // Every sample once (the first one held until the second confirms it: 4 ms per step).
    ASSERT_EQ(got.size(), 40u);
    for (size_t k = 1; k < got.size(); ++k)
        EXPECT_NEAR(double(got[k].device_time_ns - got[k - 1].device_time_ns), step * 1000.0 / 48,
                    1.0)
            << k;
    // The ranges of IMU_SCALES 3 2: 100 counts of 2000 deg/s, 4096 of 8 g (magnitudes: the axes
    // are the Index's).
    EXPECT_NEAR(glm::length(*got[5].gyro), 100 * 2000.0 / 32768 * M_PI / 180, 1e-12);
    EXPECT_NEAR(glm::length(*got[5].accel), 4096 * 8 * 9.80665 / 32768, 1e-9);
    // Without the line: libsurvive's defaults (survive_default_devices.c), for a device that is
    // not the HMD 2000 deg/s and 8 g; for the HMD 500 deg/s and 4 g. (Before: the Index's 500
    // deg/s and 4 g for every device, which halved a controller's accelerometer.)
    const std::string no_scales = text.substr(text.find('\n') + 1);
    auto d = parse_survive_recording(no_scales, "kn.rec", "KN0");
    ASSERT_TRUE(d.ok());
    EXPECT_FALSE(d->imu_scales.has_value());
    EXPECT_EQ(describe_survive_imu_scales(*d),
              "2000 deg/s, 8 g (no IMU_SCALES line: libsurvive's default for a device that is not "
              "a headset, by its codename KN0)");
    const std::vector<DeviceSample> def = decode_all(std::make_shared<const SurviveRecording>(*d));
    ASSERT_EQ(def.size(), 40u);
    EXPECT_NEAR(glm::length(*def[5].gyro), 100 * 2000.0 / 32768 * M_PI / 180, 1e-12);
    EXPECT_NEAR(glm::length(*def[5].accel), 4096 * 8 * 9.80665 / 32768, 1e-9);
    std::string hmd_text = no_scales;
    for (size_t at = hmd_text.find(" KN0 "); at != std::string::npos;
         at = hmd_text.find(" KN0 ", at))
        hmd_text.replace(at, 5, " HMD ");
    auto h = parse_survive_recording(hmd_text, "hmd.rec", "HMD");
    ASSERT_TRUE(h.ok()) << h.error().message;
    EXPECT_EQ(describe_survive_imu_scales(*h),
              "500 deg/s, 4 g (no IMU_SCALES line: libsurvive's default for a headset, by its "
              "codename HMD)");
    const std::vector<DeviceSample> hd = decode_all(std::make_shared<const SurviveRecording>(*h));
    ASSERT_EQ(hd.size(), 40u);
    EXPECT_NEAR(glm::length(*hd[5].gyro), 100 * 500.0 / 32768 * M_PI / 180, 1e-12);
    EXPECT_NEAR(glm::length(*hd[5].accel), 4096 * 4 * 9.80665 / 32768, 1e-9);
    // A mode libsurvive does not know is a warning naming the line; a bad one an error.
    auto w = parse_survive_recording("0.01 KN0 IMU_SCALES 4 2\n" + kn_line(0.1, 1, 1, 0), "w.rec",
                                     "KN0");
    ASSERT_TRUE(w.ok());
    EXPECT_FALSE(w->imu_scales.has_value());
    ASSERT_EQ(w->warnings.size(), 1u);
    EXPECT_NE(w->warnings[0].find("w.rec:1: IMU_SCALES 4 2"), std::string::npos) << w->warnings[0];
    auto b =
        parse_survive_recording("0.01 KN0 IMU_SCALES 3\n" + kn_line(0.1, 1, 1, 0), "b.rec", "KN0");
    ASSERT_FALSE(b.ok());
    EXPECT_NE(b.error().message.find("b.rec:1: an IMU_SCALES line has 5 fields"), std::string::npos)
        << b.error().message;
}

// The bundled lighthouse recordings have no IMU_SCALES line: through libsurvive's default ranges
// every device reads g when still (before, the controllers read half of it through the Index's
// 4 g: 4.79 and 4.80 m/s^2); the Index headset of compare-test-index (T20, device_class "hmd")
// keeps its 4 g. Still: the samples turning under 0.05 rad/s (every one of the lighthouse
// recordings: their devices lie still throughout). Measured: 9.779, 9.783, 9.777 m/s^2.
TEST(SurviveRecording, EveryBundledLighthouseDeviceReadsGravityWhenStill) {
    struct Case {
        const char* file;
        const char* device;
    };
    for (const Case c :
         {Case{"lh2_test_cal.rec.gz", "T20"}, Case{"lh1_test_cal.rec.gz", "T20"},
          Case{"lh1_test_cal.rec.gz", "HMD"}, Case{"compare-test-index.rec.gz", "T20"}}) {
        SCOPED_TRACE(std::string(c.file) + " " + c.device);
        auto loaded = read_survive_recording(
            std::string(HMDNODE_SOURCE_DIR) + "/data/traces/" + c.file, c.device);
        ASSERT_TRUE(loaded.ok()) << loaded.error().message;
        EXPECT_FALSE(loaded->imu_scales.has_value());
        const std::vector<DeviceSample> got =
            decode_all(std::make_shared<const SurviveRecording>(std::move(*loaded)), true);
        double sum = 0;
        size_t n = 0;
        for (const DeviceSample& d : got)
            if (d.accel && d.gyro && glm::length(*d.gyro) < 0.05) sum += glm::length(*d.accel), ++n;
        ASSERT_GT(n, 1000u);
        const double mean = sum / double(n);
        std::printf("%s %s: mean |accel| %.3f m/s^2 over %zu still samples of %zu\n", c.file,
                    c.device, mean, n, got.size());
        EXPECT_NEAR(mean, 9.80665, 0.03 * 9.80665);
    }
}

// A Vive HMD (lighthouse 1) keeps its factory calibration at the top level of its CONFIG, its
// IMU's pose as trackref_from_imu and its head's as trackref_from_head ([qx, qy, qz, qw, x, y,
// z]): read from there (lh1_test_cal's HMD: "Vive MV"), its head axes a rotation that puts the
// still accelerometer along the head's up as the light solves have it; a malformed pose is an
// error naming the field.
TEST(SurviveRecording, AViveHmdsTopLevelCalibrationAndImuPoseAreRead) {
    auto rec = read_survive_recording(
        std::string(HMDNODE_SOURCE_DIR) + "/data/traces/lh1_test_cal.rec.gz", "HMD");
    ASSERT_TRUE(rec.ok()) << rec.error().message;
    ASSERT_TRUE(rec->has_config);
    EXPECT_EQ(rec->model, "Vive MV");
    const ImuCalibration& c = rec->calibration;
    EXPECT_NEAR(c.acc_bias.x, 0.04207, 1e-9);
    EXPECT_NEAR(c.acc_bias.z, -0.08301, 1e-9);
    EXPECT_NEAR(c.acc_scale.x, 1.001, 1e-9);
    EXPECT_NEAR(c.gyro_bias.y, -0.02049, 1e-9);
    // head <- trackref <- IMU: a rotation.
    const glm::dmat3 m = c.head_from_imu;
    EXPECT_NEAR(glm::determinant(m), 1.0, 1e-9);
    const glm::dmat3 mtm = glm::transpose(m) * m;
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(mtm[i][k], i == k ? 1.0 : 0.0, 1e-9);
    EXPECT_LT(glm::length(c.imu_position), 0.2);  // within the headset
    for (const std::string& w : rec->warnings)
        EXPECT_EQ(w.find("no \"imu\" object"), std::string::npos) << w;

    const std::string bad =
        R"({"acc_bias":[0,0,0],"acc_scale":[1,1,1],"gyro_bias":[0,0,0],"gyro_scale":[1,1,1],)"
        R"("trackref_from_imu":[0,0,-1,0,0.01]})";
    auto e = parse_imu_calibration_json(bad, "hmd.json");
    ASSERT_FALSE(e.ok());
    EXPECT_NE(e.error().message.find("hmd.json.trackref_from_imu: not [qx, qy, qz, qw, x, y, z]"),
              std::string::npos)
        << e.error().message;
}

// libsurvive's replay output: the device's solved poses as EXTERNAL_POSE lines named replay_DEV
// (its playback re-emits POSE lines so), other names beside them.
TEST(SurviveRecording, ExternalPoseLinesAreTheDevicesPosesWhenItHasNoPoseLine) {
    const std::string text =
        kConfig + imu_line(0.200, 1000, -7166, 1) +
        "0.2005 replay_T20 EXTERNAL_POSE 0.1 0.2 0.3 1 0 0 0\n"
        "0.2006 previous_LH0 EXTERNAL_POSE 1 2 3 0 1 0 0\n" +
        imu_line(0.201, 49000, -7170, 2) +
        "0.2015 replay_T20 EXTERNAL_POSE 0.1 0.2 0.4 0.7071068 0.7071068 0 0\n";
    auto r = parse_survive_recording(text, "x.rec", "T20");
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(r->poses.empty());
    ASSERT_EQ(r->external_poses.size(), 2u);
    std::string what;
    const std::vector<SurvivePose>* p = survive_device_poses(*r, &what);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(what, "EXTERNAL_POSE lines named replay_T20");
    ASSERT_EQ(p->size(), 2u);
    EXPECT_EQ((*p)[1].host_time_ns, 201'500'000);
    EXPECT_DOUBLE_EQ((*p)[1].position.z, 0.4);
    EXPECT_NEAR((*p)[1].orientation.x, std::sqrt(0.5), 1e-7);
    // POSE lines come first; with neither, the names present are listed.
    auto none = parse_survive_recording(
        kConfig + imu_line(0.2, 1, 1, 1) + "0.3 T20-raw-obs EXTERNAL_POSE 0 0 0 1 0 0 0\n", "n.rec",
        "T20");
    ASSERT_TRUE(none.ok());
    EXPECT_EQ(survive_device_poses(*none, &what), nullptr);
    EXPECT_EQ(what,
              "no POSE line of T20 and no EXTERNAL_POSE line named replay_T20 or T20 "
              "(EXTERNAL_POSE names: T20-raw-obs (1))");
    auto bad = parse_survive_recording(
        kConfig + imu_line(0.2, 1, 1, 1) + "0.3 replay_T20 EXTERNAL_POSE 0 0 0 1 0 0\n", "b.rec",
        "T20");
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("b.rec:3: an EXTERNAL_POSE line has 10 fields"),
              std::string::npos)
        << bad.error().message;
}

TEST(SurviveRecording, AnAbsentDeviceNamesTheDevicesPresent) {
    auto r = parse_survive_recording(kConfig + imu_line(0.2, 1, 1, 1), "d.rec", "WM0");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().message, "d.rec: no IMU line (i) of device WM0 (devices: T20)");
}

}  // namespace
}  // namespace hmdnode
