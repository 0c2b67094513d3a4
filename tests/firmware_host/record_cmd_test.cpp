// `hmdnode record` with the simulated reference tracker on the simulated clock: the trace CSV
// reads back with read_trace_csv, the pcap reads back with the usbmon capture reader (link type
// 220, the device's VID:PID from its descriptor, one interrupt-IN completion per report, byte-exact
// reports with contiguous sequence numbers); tshark reads it too when installed. Bad input fails
// with a message naming it and writes nothing.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/reference_protocol.hpp"
#include "hmdnode/hal/usbmon_capture.hpp"

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
    fs::path d = fs::temp_directory_path() / ("hmdnode_record_test_" + name);
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

TEST(RecordCmd, sim_device_trace_and_pcap_read_back) {
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
        if (u.transfer_type != 1 || u.endpoint != 0x81 || u.event != 'C') continue;
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

TEST(RecordCmd, bad_device_text_names_it_and_writes_nothing) {
    const fs::path dir = temp_dir("bad");
    const ToolRun r = run("record --device 12x9:0001 --backend sim --sim-clock --out " +
                          (dir / "a.csv").string());
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("12x9:0001"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "a.csv"));
}

TEST(RecordCmd, absent_hidapi_device_fails_clearly) {
    const fs::path dir = temp_dir("absent");
    const ToolRun r = run("record --device 1209:fff7 --backend hidapi --duration 0.1 --capture " +
                          (dir / "a.pcap").string());
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("no device 1209:fff7 found by the hidapi backend"), std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(dir / "a.pcap"));
}

TEST(RecordCmd, needs_an_output) {
    const ToolRun r = run("record --device 1209:0001 --backend sim --sim-clock");
    EXPECT_EQ(r.status, 1);
    EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace hmdnode
