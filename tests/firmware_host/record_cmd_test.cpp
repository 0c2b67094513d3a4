// `hmdnode record` with the simulated reference tracker on the simulated clock: the trace CSV
// reads back with read_trace_csv, the pcap reads back with the usbmon capture reader (link type
// 220, the device's VID:PID from its descriptor, one interrupt-IN completion per report, byte-exact
// reports with contiguous sequence numbers); tshark reads it too when installed. Bad input fails
// with a message naming it and writes nothing.
//
// The IMU path: `--backend capture --from` the real Vive capture (28de:2000, lying still) goes
// through the device tracker (codec, clock sync, Mahony fusion) on the simulated clock; the CSV
// reads back with ~1000 rows per second of capture, increasing times, unit quaternions, |accel|
// near g in the first second and < 0.5 deg of orientation change over any still second.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <glm/glm.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

struct ToolRun {
    int status = -1;
    std::string output;
};

ToolRun run(const std::string& args) {
    ToolRun r;
    FILE* p = popen((std::string(HMDNODE_TOOL) + " " + args + " 2>&1").c_str(), "r");
    if (!p) return r;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

fs::path temp_dir(const std::string& name) {
    return hmdnode::test::fresh_temp_dir("hmdnode_record_test_" + name);
}

TEST(RecordCmd, SimDeviceTraceAndPcapReadBack) {
    const fs::path dir = temp_dir("sim");
    const fs::path csv = dir / "rec.csv", pcap = dir / "rec.pcap";
    const ToolRun r =
        run("record --device 1209:0001 --backend sim --sim-clock --duration 2 --out " +
            csv.string() + " --capture " + pcap.string());
    ASSERT_EQ(r.status, 0) << r.output;
    // Reports arrive at 1.5 ms, 2.5 ms, ... after the start: 1999 of them before 2 s.
    constexpr size_t kReports = 1999;
    EXPECT_NE(r.output.find("sequence gaps            0"), std::string::npos) << r.output;

    Result<Trace> trace = read_trace_csv(csv);
    ASSERT_TRUE(trace.ok()) << trace.error().message;
    EXPECT_EQ(trace->samples.size(), kReports);
    EXPECT_EQ(trace->samples[1].time_ns - trace->samples[0].time_ns, 1'000'000);
    EXPECT_TRUE(trace->samples.front().gyro.has_value());

    Result<UsbCapture> cap = read_usbmon_capture(pcap);
    ASSERT_TRUE(cap.ok()) << cap.error().message;
    EXPECT_EQ(cap->link_type, 220);
    const CaptureSummary s = summarize_capture(*cap);
    ASSERT_EQ(s.devices.size(), 1u);
    EXPECT_EQ(s.devices[0].vendor_id, 0x1209);
    EXPECT_EQ(s.devices[0].product_id, 0x0001);
    EXPECT_EQ(s.devices[0].id_source, "descriptor");
    size_t interrupt_in = 0;
    uint32_t next_seq = 0;
    for (const UsbPacket& u : cap->packets) {
        if (!is_interrupt_in_completion(u) || u.endpoint != 0x81) continue;
        ++interrupt_in;
        ASSERT_EQ(u.data.size(), refproto::kPoseReportSize);
        auto p = refproto::decode_pose(u.data);
        ASSERT_TRUE(p.ok()) << p.error().message;
        ASSERT_EQ(p->sequence, next_seq++);
    }
    EXPECT_EQ(interrupt_in, kReports);
    // Same times in both files: report k at 1.5 ms + k ms (µs resolution in the pcap).
    int64_t first_c = -1;
    for (const UsbPacket& u : cap->packets)
        if (u.transfer_type == 1 && first_c < 0) first_c = u.time_ns;
    EXPECT_EQ(first_c, 1'001'500'000);

    if (std::system("command -v tshark >/dev/null 2>&1") == 0) {
        const std::string cmd =
            "tshark -r " + pcap.string() + " -T fields -e usb.src 2>/dev/null | wc -l";
        FILE* p = popen(cmd.c_str(), "r");
        char buf[64] = {};
        ASSERT_TRUE(fgets(buf, sizeof buf, p));
        pclose(p);
        EXPECT_EQ(std::stoul(buf), kReports + 4);
    }
}

TEST(RecordCmd, BadDeviceTextNamesItAndWritesNothing) {
    const fs::path dir = temp_dir("bad");
    const ToolRun r = run("record --device 12x9:0001 --backend sim --sim-clock --out " +
                          (dir / "a.csv").string());
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("12x9:0001"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "a.csv"));
}

TEST(RecordCmd, AbsentHidapiDeviceFailsClearly) {
    const fs::path dir = temp_dir("absent");
    const ToolRun r = run("record --device 1209:fff7 --backend hidapi --duration 0.1 --capture " +
                          (dir / "a.pcap").string());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("no device 1209:fff7 found by the hidapi backend"), std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(dir / "a.pcap"));
}

const fs::path kViveCapture = fs::path(HMDNODE_SOURCE_DIR) / "data/traces/vive_cal.pcap.gz";

double angle_deg(const glm::dquat& a, const glm::dquat& b) {
    const glm::dquat d = glm::conjugate(a) * b;
    return 2.0 * std::acos(std::min(1.0, std::abs(d.w))) * 180.0 / M_PI;
}

TEST(RecordCmd, ViveCaptureToTraceThroughTheDeviceTracker) {
    ASSERT_TRUE(fs::exists(kViveCapture)) << kViveCapture << " is missing";
    const fs::path dir = temp_dir("vive");
    const fs::path csv = dir / "vive.csv";
    const ToolRun r = run("record --device 28de:2000 --backend capture --from " +
                          kViveCapture.string() + " --out " + csv.string());
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("malformed reports        0"), std::string::npos) << r.output;

    Result<Trace> trace = read_trace_csv(csv);
    ASSERT_TRUE(trace.ok()) << trace.error().message;
    const std::vector<TraceSample>& s = trace->samples;
    ASSERT_GT(s.size(), 1000u);
    ASSERT_TRUE(s.front().gyro.has_value());
    ASSERT_TRUE(s.front().accel.has_value());
    EXPECT_FALSE(s.front().position.has_value());
    // 22,073 unique samples over 22.35 s of device time (docs/tracking.md): ~987 rows/s.
    const double seconds = (trace->end_ns() - trace->start_ns()) * 1e-9;
    EXPECT_GT(seconds, 22.0);
    EXPECT_LT(seconds, 23.0);
    EXPECT_NEAR(s.size() / seconds, 987.0, 30.0);
    EXPECT_EQ(trace->start_ns(), 0);
    for (size_t i = 1; i < s.size(); ++i) ASSERT_GT(s[i].time_ns, s[i - 1].time_ns) << i;
    for (const TraceSample& x : s) ASSERT_NEAR(glm::length(x.orientation), 1.0, 1e-6);
    // Still: |accel| near g over the first second (docs/tracking.md: 0.38 % off; limit 2 %).
    double sum = 0;
    size_t n = 0;
    for (const TraceSample& x : s) {
        if (x.time_ns >= 1'000'000'000) break;
        sum += glm::length(*x.accel);
        ++n;
    }
    ASSERT_GT(n, 800u);  // 863: the capture lacks 137 samples of its first second
    EXPECT_NEAR(sum / n, 9.80665, 0.02 * 9.80665);
    // The fused orientation moves less than 0.5 deg within any second after the first.
    double worst = 0;
    size_t j = 0;
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i].time_ns < 1'000'000'000) continue;
        if (j < i) j = i;
        while (j + 1 < s.size() && s[j + 1].time_ns - s[i].time_ns <= 1'000'000'000) ++j;
        worst = std::max(worst, angle_deg(s[i].orientation, s[j].orientation));
    }
    EXPECT_LT(worst, 0.5);
    std::printf(
        "vive_cal -> %zu rows over %.3f s = %.1f /s; |accel| %.4f m/s^2 in the first s; "
        "worst 1 s orientation change %.4f deg\n",
        s.size(), seconds, s.size() / seconds, sum / n, worst);

    // --duration cuts the capture; the same run twice gives the same bytes (simulated clock).
    const fs::path a = dir / "a.csv", b = dir / "b.csv";
    ASSERT_EQ(run("record --device 28de:2000 --backend capture --duration 2 --from " +
                  kViveCapture.string() + " --out " + a.string())
                  .status,
              0);
    ASSERT_EQ(run("record --device 28de:2000 --backend capture --duration 2 --from " +
                  kViveCapture.string() + " --out " + b.string())
                  .status,
              0);
    Result<Trace> ta = read_trace_csv(a);
    ASSERT_TRUE(ta.ok()) << ta.error().message;
    // The first 2 s of the capture: 863 + ~1000 rows, the same rows as the whole run's first.
    ASSERT_GT(ta->samples.size(), 1800u);
    ASSERT_LT(ta->samples.size(), 2000u);
    for (size_t i = 0; i < ta->samples.size(); ++i) {
        ASSERT_EQ(ta->samples[i].time_ns, s[i].time_ns) << i;
        ASSERT_EQ(ta->samples[i].orientation, s[i].orientation) << i;
    }
    std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
    const std::string ca((std::istreambuf_iterator<char>(fa)), {});
    const std::string cb((std::istreambuf_iterator<char>(fb)), {});
    EXPECT_EQ(ca, cb);
}

// A reference-device recording's pcap, decoded again with --backend capture: the same poses
// (to 1e-4 deg: acos near 1 resolves no finer).
TEST(RecordCmd, ReferencePcapBackToTheSameTrace) {
    const fs::path dir = temp_dir("ref_roundtrip");
    const fs::path csv = dir / "rec.csv", pcap = dir / "rec.pcap", again = dir / "again.csv";
    ToolRun r = run("record --device 1209:0001 --backend sim --sim-clock --duration 1 --out " +
                    csv.string() + " --capture " + pcap.string());
    ASSERT_EQ(r.status, 0) << r.output;
    r = run("record --device 1209:0001 --backend capture --from " + pcap.string() + " --out " +
            again.string());
    ASSERT_EQ(r.status, 0) << r.output;
    Result<Trace> a = read_trace_csv(csv), b = read_trace_csv(again);
    ASSERT_TRUE(a.ok()) << a.error().message;
    ASSERT_TRUE(b.ok()) << b.error().message;
    ASSERT_EQ(a->samples.size(), b->samples.size());
    for (size_t i = 0; i < a->samples.size(); ++i)
        ASSERT_LT(angle_deg(a->samples[i].orientation, b->samples[i].orientation), 1e-4) << i;
}

TEST(RecordCmd, CaptureErrorsNameTheFileOrDeviceAndWriteNothing) {
    const fs::path dir = temp_dir("capture_errors");
    const fs::path csv = dir / "a.csv";
    ToolRun r = run("record --device 28de:2000 --backend capture --from " +
                    (dir / "missing.pcap.gz").string() + " --out " + csv.string());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find((dir / "missing.pcap.gz").string()), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(csv));

    // Options that do not go together are usage errors: exit 2.
    r = run("record --device 28de:2000 --backend capture --out " + csv.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.output.find("--from"), std::string::npos) << r.output;

    r = run("record --device 28de:2000 --from x.pcap --out " + csv.string());
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.output.find("--backend capture"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(csv));

    if (fs::exists(kViveCapture)) {
        r = run("record --device 2833:0031 --backend capture --from " + kViveCapture.string() +
                " --out " + csv.string());
        EXPECT_EQ(r.status, 1);
        EXPECT_NE(r.output.find("2833:0031"), std::string::npos) << r.output;
        EXPECT_FALSE(fs::exists(csv));
    }
}

// A capture records no serial numbers: --device VID:PID:SERIAL used to leave the tracker retrying
// the open forever (a busy loop on the simulated clock). Now it is an error naming the devices the
// capture holds, at once.
TEST(RecordCmd, CaptureSelectorWithASerialIsAnErrorNamingTheDevices) {
    if (!fs::exists(kViveCapture)) GTEST_SKIP() << kViveCapture << " is missing";
    const fs::path dir = temp_dir("capture_serial");
    const fs::path csv = dir / "a.csv";
    const ToolRun r = run("record --device 28de:2000:LHR-0001 --backend capture --from " +
                          kViveCapture.string() + " --out " + csv.string());
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("1-62=28de:2000"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("no serial numbers"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(csv));
}

// A libsurvive recording of a controller written by hand (the properties of recordings the
// project has not seen): IMU lines with sequence number 0 at 247 Hz, its IMU_SCALES 3 2 (8 g: 4096
// counts are 1 g), and, after every fourth IMU line, one `extra` line with TIME 1 ms later.
std::string controller_recording(const std::string& extra, bool ticks_move = true) {
    std::string s = "0.5 KN0 IMU_SCALES 3 2\r\n";
    char b[256];
    for (int k = 0; k < 600; ++k) {
        const double t = 1.0 + k * 0.004049;
        std::snprintf(b, sizeof b,
                      "%.6f KN0 i 3 %u 0.000000 0.000000 4096.000000 1.000000 -2.000000 1.000000  "
                      "0.000000 0.000000 0.000000 0\r\n",
                      t, ticks_move ? 5'000'000u + uint32_t(k) * 194'332u : 5'000'000u);
        s += b;
        if (k % 4 == 0 && !extra.empty()) {
            std::snprintf(b, sizeof b, "%.6f %s 0.1 0.2 %.4f 1 0 0 0\n", t + 0.001, extra.c_str(),
                          0.3 + k * 1e-4);
            s += b;
        }
    }
    return s;
}

void write_text(const fs::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
}

std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// libsurvive's replay output names the device's solved poses EXTERNAL_POSE replay_KN0: they are
// the reference, each at its IMU neighbours' instant; the controller's sequence-0 stream tracks,
// with the ranges of its IMU_SCALES line; both traces say their time base.
TEST(RecordCmd, AControllerRecordingWithExternalPosesTracksAndWritesItsReference) {
    const fs::path dir = temp_dir("rec_controller");
    const fs::path rec = dir / "kn.rec", out = dir / "o.csv", ref = dir / "r.csv";
    write_text(rec, controller_recording("replay_KN0 EXTERNAL_POSE"));
    const ToolRun r = run("record --backend rec --from " + rec.string() + " --device KN0 --out " +
                          out.string() + " --reference-out " + ref.string());
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("IMU_SCALES: 2000 deg/s, 8 g"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("all carry sequence number 0"), std::string::npos) << r.output;
    // The first pose (1 ms after the first IMU line) has no IMU line before it with a row of its
    // own: the codec holds a stream's first sample until the next report confirms it, so it
    // arrives with the second line's TIME. Skipped and counted.
    EXPECT_NE(r.output.find("149 lighthouse poses from EXTERNAL_POSE lines named replay_KN0"),
              std::string::npos)
        << r.output;
    auto fused = read_trace_csv(out);
    ASSERT_TRUE(fused.ok()) << fused.error().message;
    EXPECT_GE(fused->samples.size(), 598u);  // 600 samples (the first's before the fusion aligns)
    // 1 g on the IMU's z axis at the 8 g range (4 g would read 2 g).
    ASSERT_TRUE(fused->samples[10].accel);
    EXPECT_NEAR(glm::length(*fused->samples[10].accel), 9.80665, 0.05);
    auto lh = read_trace_csv(ref);
    ASSERT_TRUE(lh.ok()) << lh.error().message;
    EXPECT_NE(r.output.find("1 with no IMU sample in the 50 ms before"), std::string::npos);
    ASSERT_EQ(lh->samples.size(), 149u);
    EXPECT_DOUBLE_EQ(lh->samples[2].position->z, 0.3 + 12 * 1e-4);
    // Each pose 1 ms after its IMU line, at that line's row time + 1 ms (interpolated between the
    // IMU rows around it).
    for (size_t k = 0; k + 1 < lh->samples.size(); ++k)
        EXPECT_NEAR(double(lh->samples[k + 1].time_ns - lh->samples[k].time_ns), 4 * 4.049e6, 0.5e6)
            << k;
    const std::string base = "time_base recording_time libsurvive kn.rec";
    EXPECT_NE(slurp(out).find(base), std::string::npos);
    EXPECT_NE(slurp(ref).find(base), std::string::npos);
    EXPECT_NE(slurp(ref).find("EXTERNAL_POSE lines named replay_KN0"), std::string::npos);
}

// A reference that cannot be written fails the command with exit 1 and leaves neither output
// (--out was written before the reference was looked at); the message lists the pose names the
// recording holds. A device whose IMU lines give no sample says why.
TEST(RecordCmd, AFailedReferenceOrNoSampleLeavesNoOutputAndSaysWhy) {
    const fs::path dir = temp_dir("rec_failures");
    const fs::path rec = dir / "kn.rec", out = dir / "o.csv", ref = dir / "r.csv";
    write_text(rec, controller_recording("KN0-raw-obs EXTERNAL_POSE"));
    ToolRun r = run("record --backend rec --from " + rec.string() + " --device KN0 --out " +
                    out.string() + " --reference-out " + ref.string());
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("no POSE line of KN0 and no EXTERNAL_POSE line named replay_KN0 or "
                            "KN0 (EXTERNAL_POSE names: KN0-raw-obs (150))"),
              std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(ref));
    // Every line on one tick: no sample follows another.
    write_text(rec, controller_recording("", false));
    r = run("record --backend rec --from " + rec.string() + " --device KN0 --out " + out.string() +
            " --reference-out " + ref.string());
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("KN0: 0 trace row(s) from 600 IMU lines"), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("every IMU line has the same TICK: no sample follows another"),
              std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(ref));
}

TEST(RecordCmd, NeedsAnOutput) {
    const ToolRun r = run("record --device 1209:0001 --backend sim --sim-clock");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace hmdnode
