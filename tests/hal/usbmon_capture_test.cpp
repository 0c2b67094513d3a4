// The usbmon capture reader and capture backend, on synthetic pcap bytes (closed-form answers) and
// on the real Vive capture bundled in data/traces: ~1,000 unique samples
// per second, no sequence gaps beyond the capture's own, |a| within 2 % of g while still, and a
// fused orientation that stays still while the headset is still.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <vector>

#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/imu_fusion.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

namespace hmdnode {
namespace {

// A minimal usbmon pcap (link type 189, 48-byte headers), microsecond timestamps.
struct PcapWriter {
    std::vector<uint8_t> bytes;
    template <class T>
    void put(T v) {
        uint8_t b[sizeof v];
        std::memcpy(b, &v, sizeof v);
        bytes.insert(bytes.end(), b, b + sizeof v);
    }
    PcapWriter() {
        put<uint32_t>(0xa1b2c3d4);
        put<uint16_t>(2);
        put<uint16_t>(4);
        put<int32_t>(0);
        put<uint32_t>(0);
        put<uint32_t>(65535);
        put<uint32_t>(189);
    }
    void packet(int64_t t_us, uint64_t urb, char ev, uint8_t type, uint8_t ep, uint8_t dev,
                const std::vector<uint8_t>& data, const std::array<uint8_t, 8>* setup = nullptr) {
        put<uint32_t>(uint32_t(t_us / 1000000));
        put<uint32_t>(uint32_t(t_us % 1000000));
        put<uint32_t>(uint32_t(48 + data.size()));
        put<uint32_t>(uint32_t(48 + data.size()));
        put<uint64_t>(urb);
        put<uint8_t>(uint8_t(ev));
        put<uint8_t>(type);
        put<uint8_t>(ep);
        put<uint8_t>(dev);
        put<uint16_t>(3);  // bus
        put<uint8_t>(setup ? 0 : '-');
        put<uint8_t>(0);
        put<int64_t>(t_us / 1000000);
        put<int32_t>(int32_t(t_us % 1000000));
        put<int32_t>(0);  // status
        put<uint32_t>(uint32_t(data.size()));
        put<uint32_t>(uint32_t(data.size()));
        for (int i = 0; i < 8; ++i) put<uint8_t>(setup ? (*setup)[i] : 0);
        bytes.insert(bytes.end(), data.begin(), data.end());
    }
};

TEST(UsbmonCapture, ParsesSyntheticCaptureAndReplaysInterruptIn) {
    PcapWriter w;
    // A device descriptor answer names the device 28de:2000.
    std::vector<uint8_t> desc(18, 0);
    desc[0] = 18;
    desc[1] = 1;
    desc[8] = 0xde;
    desc[9] = 0x28;
    desc[10] = 0x00;
    desc[11] = 0x20;
    std::array<uint8_t, 8> get_desc = {0x80, 6, 0, 1, 0, 0, 18, 0};
    w.packet(1'000'000, 1, 'S', 2, 0x80, 7, {}, &get_desc);
    w.packet(1'000'100, 1, 'C', 2, 0x80, 7, desc);
    for (int i = 0; i < 10; ++i) {
        w.packet(1'001'000 + i * 1000, 100 + i, 'S', 1, 0x81, 7, {});
        w.packet(1'001'500 + i * 1000, 100 + i, 'C', 1, 0x81, 7, {0x20, uint8_t(i), 2, 3});
    }
    w.packet(1'020'000, 500, 'C', 1, 0x81, 9, {0x25, 1});  // another device
    auto cap = parse_usbmon_capture(w.bytes);
    ASSERT_TRUE(cap.ok()) << cap.error().message;
    EXPECT_EQ(cap->link_type, 189);
    EXPECT_EQ(cap->packets.size(), 23u);

    CaptureSummary s = summarize_capture(*cap);
    ASSERT_EQ(s.devices.size(), 2u);
    EXPECT_EQ(s.devices[0].address, 7);
    EXPECT_EQ(s.devices[0].vendor_id, 0x28de);
    EXPECT_EQ(s.devices[0].product_id, 0x2000);
    EXPECT_EQ(s.devices[0].id_source, "descriptor");
    const CaptureEndpointSummary* intr = nullptr;
    for (const auto& e : s.devices[0].endpoints)
        if (e.endpoint == 0x81) intr = &e;
    ASSERT_NE(intr, nullptr);
    EXPECT_EQ(intr->completions, 10u);
    EXPECT_EQ(intr->report_ids.at(0x20), 10u);
    EXPECT_NEAR(intr->rate_hz(), 1000.0, 1e-6);

    auto backend = create_capture_backend(std::make_shared<UsbCapture>(std::move(*cap)), s);
    auto ids = backend->enumerate(DeviceFilter{0x28de, 0x2000, {}});
    ASSERT_TRUE(ids.ok());
    ASSERT_EQ(ids->size(), 1u);
    auto t = backend->open(ids->front());
    ASSERT_TRUE(t.ok());
    for (int i = 0; i < 10; ++i) {
        auto r = (*t)->read_input(0);
        ASSERT_TRUE(r.ok());
        ASSERT_TRUE(r->has_value());
        EXPECT_EQ((*r)->bytes, (std::vector<uint8_t>{0x20, uint8_t(i), 2, 3}));
        EXPECT_EQ((*r)->host_time_ns, (1'001'500 + i * 1000) * int64_t(1000));
    }
    EXPECT_TRUE((*t)->finished());
    auto end = (*t)->read_input(0);
    ASSERT_TRUE(end.ok());
    EXPECT_FALSE(end->has_value());
}

// A recording cut short (a crash, a full disk) keeps its whole records, with a warning naming the
// byte offset of the cut one: the file header is 24 bytes, each record 16 + its captured bytes.
TEST(UsbmonCapture, KeepsTheWholeRecordsOfATruncatedFile) {
    PcapWriter w;
    w.packet(1000, 1, 'C', 1, 0x81, 1, {0x20, 1, 2});
    const size_t second = w.bytes.size();
    w.packet(2000, 2, 'C', 1, 0x81, 1, {0x20, 2, 2});
    for (size_t cut_at : {w.bytes.size() - 10, second + 5}) {  // in the data, in the header
        std::vector<uint8_t> cut(w.bytes.begin(), w.bytes.begin() + long(cut_at));
        auto r = parse_usbmon_capture(cut);
        ASSERT_TRUE(r.ok()) << r.error().message;
        ASSERT_EQ(r->packets.size(), 1u);
        EXPECT_EQ(r->packets[0].urb_id, 1u);
        ASSERT_EQ(r->warnings.size(), 1u);
        EXPECT_NE(r->warnings[0].find("record 1 at byte " + std::to_string(second)),
                  std::string::npos)
            << r->warnings[0];
    }
    auto whole = parse_usbmon_capture(w.bytes);
    ASSERT_TRUE(whole.ok());
    EXPECT_EQ(whole->packets.size(), 2u);
    EXPECT_TRUE(whole->warnings.empty());
}

TEST(UsbmonCapture, RejectsForeignFiles) {
    PcapWriter w;
    w.packet(1000, 1, 'C', 1, 0x81, 1, {0x20, 1, 2});
    std::vector<uint8_t> eth = w.bytes;
    eth[20] = 1;  // DLT_EN10MB
    auto r = parse_usbmon_capture(eth);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("link type 1"), std::string::npos);
    EXPECT_FALSE(parse_usbmon_capture(std::vector<uint8_t>{1, 2, 3}).ok());
}

TEST(UsbmonCapture, RealViveCaptureMeetsTheDoneWhenFigures) {
    const std::filesystem::path file =
        std::filesystem::path(HMDNODE_SOURCE_DIR) / "data/traces/vive_cal.pcap.gz";
    ASSERT_TRUE(std::filesystem::exists(file)) << file << " is missing";
    auto cap = read_usbmon_capture(file);
    ASSERT_TRUE(cap.ok()) << cap.error().message;
    EXPECT_EQ(cap->link_type, 220);
    CaptureSummary s = summarize_capture(*cap);
    auto applied = apply_usbdevs_sidecar(file.string() + ".usbdevs", &s);
    ASSERT_TRUE(applied.ok());
    auto backend = create_capture_backend(std::make_shared<UsbCapture>(std::move(*cap)), s);
    auto ids = backend->enumerate(DeviceFilter{0x28de, 0x2000, {}});
    ASSERT_TRUE(ids.ok());
    ASSERT_EQ(ids->size(), 1u);
    auto t = backend->open(ids->front());
    ASSERT_TRUE(t.ok());

    vive::ImuDecoder dec(vive::Variant::Vive);
    ImuFusion fusion;
    std::array<vive::ImuSample, 3> out;
    std::vector<vive::ImuSample> samples;
    while (true) {
        auto r = (*t)->read_input(0);
        ASSERT_TRUE(r.ok());
        if (!r->has_value()) break;
        const size_t n = dec.decode((*r)->bytes, out);
        for (size_t i = 0; i < n; ++i) samples.push_back(out[i]);
    }
    ASSERT_GT(samples.size(), 1000u);
    const double seconds = (samples.back().device_time_ns - samples.front().device_time_ns) * 1e-9;
    const double rate = double(samples.size() - 1) / seconds;
    const auto& c = dec.counters();
    // Sequence gaps: every missing sample must be a sample the capture itself lacks, i.e. the
    // device clock advanced by the same number of sample periods.
    uint64_t gap_samples_by_time = 0;
    for (size_t i = 1; i < samples.size(); ++i) {
        const uint64_t ds = samples[i].sequence - samples[i - 1].sequence;
        const double periods = (samples[i].device_time_ns - samples[i - 1].device_time_ns) / 1e6;
        if (ds > 1) gap_samples_by_time += uint64_t(std::lround(periods)) - 1;
    }
    // Still: |gyro| small. Accelerometer magnitude over those samples, and fused orientation drift.
    double a_sum = 0, a_max_dev = 0;
    size_t still = 0;
    double max_still_drift_deg = 0;
    bool have_ref = false;
    glm::dquat ref{1, 0, 0, 0};
    int64_t ref_ns = 0;
    for (const auto& smp : samples) {
        fusion.update(smp.device_time_ns, smp.gyro, smp.accel);
        const bool is_still = glm::length(smp.gyro) < 0.05;
        if (!is_still) {
            have_ref = false;
            continue;
        }
        ++still;
        const double a = glm::length(smp.accel);
        a_sum += a;
        // Drift within any 1 s after the first second (the stillness window's first fill).
        if (smp.device_time_ns - samples.front().device_time_ns < 1'000'000'000) continue;
        if (!have_ref || smp.device_time_ns - ref_ns >= 1'000'000'000) {
            have_ref = true;
            ref = fusion.orientation();
            ref_ns = smp.device_time_ns;
        } else {
            const glm::dquat d = glm::conjugate(ref) * fusion.orientation();
            const double deg = 2.0 * std::acos(std::min(1.0, std::abs(d.w))) * 180.0 / M_PI;
            max_still_drift_deg = std::max(max_still_drift_deg, deg);
        }
    }
    const double a_mean = a_sum / double(still);
    for (const auto& smp : samples)
        if (glm::length(smp.gyro) < 0.05)
            a_max_dev = std::max(a_max_dev, std::abs(glm::length(smp.accel) - a_mean));
    std::printf(
        "vive_cal: %zu unique samples over %.2f s = %.1f /s; gaps %llu (%llu missing, "
        "%llu by device time); still %zu samples, mean |a| %.4f m/s^2 (%.2f %% off g); "
        "fused drift while still %.3f deg per 1 s window; bias %.4f %.4f %.4f rad/s\n",
        samples.size(), seconds, rate, (unsigned long long)c.sequence_gaps,
        (unsigned long long)c.missing_samples, (unsigned long long)gap_samples_by_time, still,
        a_mean, 100.0 * std::abs(a_mean - 9.80665) / 9.80665, max_still_drift_deg,
        fusion.gyro_bias().x, fusion.gyro_bias().y, fusion.gyro_bias().z);
    EXPECT_NEAR(rate, 1000.0, 20.0);
    EXPECT_EQ(c.malformed, 0u);
    EXPECT_EQ(c.missing_samples, gap_samples_by_time);
    EXPECT_GT(still, samples.size() / 10);
    EXPECT_NEAR(a_mean, 9.80665, 0.02 * 9.80665);
    EXPECT_LT(max_still_drift_deg, 0.5);
}

}  // namespace
}  // namespace hmdnode
