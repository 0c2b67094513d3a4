// The simulated reference tracker through the Transport interface: byte-exact reports of the
// reference protocol at 1 kHz for minutes of simulated time with no lost sample, the feature
// reports (device info, rate, time sync) with closed-form answers, device clock offset and
// drift, and unplug / replug with the gap visible.
#include <gtest/gtest.h>

#include <cmath>

#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {
namespace {

constexpr int64_t kBootNs = 5 * kNsPerSecond;

std::unique_ptr<Transport> open_only(SimReferenceBackend& b) {
    auto list = b.enumerate(DeviceFilter{refproto::kDevVendorId, refproto::kDevProductId, ""});
    EXPECT_TRUE(list.ok());
    EXPECT_EQ(list->size(), 1u);
    if (list->empty()) return nullptr;
    auto t = b.open(list->front());
    EXPECT_TRUE(t.ok()) << t.error().message;
    return std::move(*t);
}

refproto::PoseReport read_pose(Transport& t, int timeout_ms = 100, int64_t* arrival = nullptr) {
    auto r = t.read_input(timeout_ms);
    EXPECT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(r->has_value());
    if (!r.ok() || !r->has_value()) return {};
    if (arrival) *arrival = (*r)->host_time_ns;
    auto p = refproto::decode_pose((*r)->bytes);
    EXPECT_TRUE(p.ok()) << p.error().message;
    return p.ok() ? *p : refproto::PoseReport{};
}

TEST(SimReferenceDevice, ThreeMinutesAt1kHzLoseNoSample) {
    SimulatedClock clock(kBootNs);
    auto motion = sinusoidal_motion(30.0, 0.5);
    auto backend = create_sim_reference_backend(clock, {}, motion);
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    const uint64_t n = 180'000;
    uint32_t expected_seq = 0;
    uint64_t count = 0;
    double worst_deg = 0;
    for (uint64_t i = 0; i < n; ++i) {
        int64_t arrival = 0;
        const refproto::PoseReport p = read_pose(*t, 10, &arrival);
        ASSERT_EQ(p.sequence, expected_seq) << "at report " << i;
        ++expected_seq;
        ++count;
        // Report k (from 0) is measured at boot + (k+1) ms, arrives 0.5 ms later.
        const int64_t measured = kBootNs + static_cast<int64_t>(i + 1) * kNsPerMs;
        ASSERT_EQ(arrival, measured + 500'000);
        ASSERT_EQ(p.device_time_us, static_cast<uint64_t>((i + 1) * 1000));
        EXPECT_EQ((p.flags & refproto::kPoseFlagClockReset) != 0, i == 0);
        if (i % 997 == 0)
            worst_deg =
                std::max(worst_deg, angle_between_deg(p.orientation, motion(measured).orientation));
    }
    EXPECT_EQ(count, n);
    EXPECT_LT(worst_deg, 1e-6);  // Q2.30 quaternions
    EXPECT_EQ(backend->reports_dropped(), 0u);
    // Reading never ran ahead of the clock: 180 s of simulated time went by, and no more.
    EXPECT_EQ(clock.now_ns(), kBootNs + static_cast<int64_t>(n) * kNsPerMs + 500'000);
}

TEST(SimReferenceDevice, AngularVelocityIsInTheHeadFrame) {
    SimulatedClock clock(kBootNs);
    auto motion = sinusoidal_motion(40.0, 1.0);
    auto backend = create_sim_reference_backend(clock, {}, motion);
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    for (int i = 0; i < 300; ++i) {
        const refproto::PoseReport p = read_pose(*t);
        ASSERT_TRUE(p.flags & refproto::kPoseFlagAngularVelocityValid);
        const Pose truth = motion(kBootNs + (i + 1) * kNsPerMs);
        const glm::dvec3 world = p.orientation * p.angular_velocity;
        EXPECT_NEAR(glm::length(world - *truth.angular_velocity), 0.0, 1e-5);
    }
}

TEST(SimReferenceDevice, AnswersDeviceInfoAndRateFeatureReports) {
    SimulatedClock clock(kBootNs);
    SimReferenceDeviceConfig cfg;
    cfg.serial = "UNIT-7";
    auto backend = create_sim_reference_backend(clock, cfg, sinusoidal_motion());
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    EXPECT_EQ(t->id().serial, "UNIT-7");
    EXPECT_EQ(t->id().path, "sim:UNIT-7");

    auto info_bytes = t->get_feature(refproto::kDeviceInfoReport, refproto::kDeviceInfoReportSize);
    ASSERT_TRUE(info_bytes.ok()) << info_bytes.error().message;
    auto info = refproto::decode_device_info(*info_bytes);
    ASSERT_TRUE(info.ok()) << info.error().message;
    EXPECT_EQ(info->serial, "UNIT-7");
    EXPECT_EQ(info->pose_rate_hz, 1000);
    EXPECT_TRUE(info->capabilities & refproto::kCapTimeSync);
    EXPECT_FALSE(info->capabilities & refproto::kCapPosition);

    // Rate down to 250 Hz: reports 4 ms apart from then on, sequence still contiguous.
    const refproto::PoseReport before = read_pose(*t);
    refproto::ReportRateReport rate;
    rate.pose_rate_hz = 250;
    ASSERT_TRUE(t->set_feature(refproto::encode(rate)).ok());
    auto rate_back = refproto::decode_report_rate(
        *t->get_feature(refproto::kReportRateReport, refproto::kReportRateReportSize));
    ASSERT_TRUE(rate_back.ok());
    EXPECT_EQ(rate_back->pose_rate_hz, 250);
    refproto::PoseReport prev = read_pose(*t);
    EXPECT_EQ(prev.sequence, before.sequence + 1);
    for (int i = 0; i < 20; ++i) {
        const refproto::PoseReport p = read_pose(*t);
        EXPECT_EQ(p.sequence, prev.sequence + 1);
        EXPECT_EQ(p.device_time_us - prev.device_time_us, 4000u);
        prev = p;
    }
    EXPECT_FALSE(t->get_feature(0x55, 64).ok());
    EXPECT_FALSE(t->write_output(std::vector<uint8_t>{0x20, 1}).ok());
}

TEST(SimReferenceDevice, TimeSyncRecoversTheDeviceClockOffset) {
    SimulatedClock clock(kBootNs);
    SimReferenceDeviceConfig cfg;
    cfg.device_clock_offset_us = 123'456'789;  // device clock at boot
    auto backend = create_sim_reference_backend(clock, cfg, sinusoidal_motion());
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    clock.advance_ns(2 * kNsPerSecond);
    refproto::TimeSyncReport ask;
    ask.nonce = 42;
    ask.host_send_ns = clock.now_ns();
    ASSERT_TRUE(t->set_feature(refproto::encode(ask)).ok());
    clock.advance_ns(300'000);  // the device answers 0.3 ms later
    auto got = t->get_feature(refproto::kTimeSyncReport, refproto::kTimeSyncReportSize);
    ASSERT_TRUE(got.ok()) << got.error().message;
    auto answer = refproto::decode_time_sync(*got);
    ASSERT_TRUE(answer.ok()) << answer.error().message;
    EXPECT_EQ(answer->nonce, 42u);
    EXPECT_EQ(answer->host_send_ns, ask.host_send_ns);
    EXPECT_EQ(answer->device_receive_us, 123'456'789u + 2'000'000u);
    EXPECT_EQ(answer->device_transmit_us, 123'456'789u + 2'000'300u);
    // host = device * 1000 + offset: offset = boot - 123.456789 s exactly.
    const refproto::TimeSyncEstimate e = refproto::time_sync_estimate(*answer, clock.now_ns());
    EXPECT_EQ(e.offset_ns, kBootNs - 123'456'789'000);
    EXPECT_EQ(e.round_trip_ns, 0);
}

TEST(SimReferenceDevice, DeviceClockDriftsAsConfigured) {
    SimulatedClock clock(0);
    SimReferenceDeviceConfig cfg;
    cfg.device_clock_drift_ppm = 100.0;
    cfg.pose_rate_hz = 10;
    auto backend = create_sim_reference_backend(clock, cfg, sinusoidal_motion());
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    refproto::PoseReport p{};
    for (int i = 0; i < 1000; ++i) p = read_pose(*t, 1000);  // 100 s of host time
    // 100 s host at +100 ppm = 100.01 s of device time.
    EXPECT_EQ(p.device_time_us, 100'010'000u);
}

TEST(SimReferenceDevice, ASlowReaderLosesTheOldestReportsAndTheyAreCounted) {
    SimulatedClock clock(kBootNs);
    SimReferenceDeviceConfig cfg;
    cfg.queue_capacity = 16;
    auto backend = create_sim_reference_backend(clock, cfg, sinusoidal_motion());
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    clock.advance_ns(100 * kNsPerMs);  // 100 reports have arrived (the last at 99.5 ms)
    const refproto::PoseReport first = read_pose(*t, 0);
    EXPECT_EQ(backend->reports_dropped(), 99u - 16u);
    EXPECT_EQ(first.sequence, 99u - 16u);
}

TEST(SimReferenceDevice, UnplugFailsTheTransportAndReplugResumesWithinASecond) {
    SimulatedClock clock(kBootNs);
    auto backend = create_sim_reference_backend(clock, {}, sinusoidal_motion());
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    for (int i = 0; i < 500; ++i) read_pose(*t);
    backend->unplug();
    auto r = t->read_input(10);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("gone"), std::string::npos);
    EXPECT_NE(r.error().message.find("sim:"), std::string::npos);
    EXPECT_FALSE(t->get_feature(refproto::kDeviceInfoReport, 64).ok());
    EXPECT_TRUE(backend->enumerate({})->empty());

    clock.advance_ns(700 * kNsPerMs);
    backend->replug();  // rebooted: sequence and device clock start again
    const int64_t replug_ns = clock.now_ns();
    EXPECT_EQ(backend->plug_count(), 2u);
    EXPECT_TRUE(t->read_input(0).ok() == false);  // the old handle stays dead
    auto t2 = open_only(*backend);
    ASSERT_TRUE(t2);
    int64_t arrival = 0;
    const refproto::PoseReport p = read_pose(*t2, 1000, &arrival);
    EXPECT_EQ(p.sequence, 0u);
    EXPECT_TRUE(p.flags & refproto::kPoseFlagClockReset);
    EXPECT_EQ(p.device_time_us, 1000u);
    EXPECT_LT(arrival - replug_ns, kNsPerSecond);
    EXPECT_EQ(arrival - replug_ns, 1'500'000);
}

TEST(SimReferenceDevice, ReplugWithoutRebootShowsTheGapInSequenceNumbers) {
    SimulatedClock clock(kBootNs);
    auto backend = create_sim_reference_backend(clock, {}, sinusoidal_motion());
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    refproto::PoseReport last{};
    for (int i = 0; i < 100; ++i) last = read_pose(*t);
    EXPECT_EQ(last.sequence, 99u);
    backend->unplug();
    clock.advance_ns(250 * kNsPerMs);
    backend->replug(false);
    auto t2 = open_only(*backend);
    ASSERT_TRUE(t2);
    const refproto::PoseReport p = read_pose(*t2);
    EXPECT_FALSE(p.flags & refproto::kPoseFlagClockReset);
    // Last read arrived at 100.5 ms, replug at 350.5 ms: the 250 reports that arrived meanwhile
    // (sequence 100..349) went nowhere; the device clock went on at 1 kHz.
    EXPECT_EQ(p.sequence - last.sequence - 1, 250u);
    EXPECT_EQ(p.device_time_us - last.device_time_us, 251'000u);
}

TEST(SimReferenceDevice, PlaysATraceAsMotion) {
    auto trace = std::make_shared<Trace>();
    for (int i = 0; i <= 10; ++i) {
        TraceSample s;
        s.time_ns = 1'000'000'000 + i * 100 * kNsPerMs;
        s.orientation = glm::angleAxis(deg_to_rad(i * 9.0), glm::dvec3(0, 1, 0));
        trace->samples.push_back(s);
    }
    SimulatedClock clock(kBootNs);
    SimReferenceDeviceConfig cfg;
    cfg.pose_rate_hz = 100;
    auto backend =
        create_sim_reference_backend(clock, cfg, motion_from_trace(trace, kBootNs, /*loop=*/false));
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    for (int i = 1; i <= 150; ++i) {
        const refproto::PoseReport p = read_pose(*t);
        const double want_deg = std::min(i * 0.9, 90.0);  // 9 deg per 100 ms, then held
        EXPECT_NEAR(angle_between_deg(p.orientation, glm::dquat(1, 0, 0, 0)), want_deg, 1e-6);
    }
}

TEST(SimReferenceDevice, RealClockDeliversReportsAsTheyCome) {
    SystemClock clock;
    auto backend = create_sim_reference_backend(clock, {}, sinusoidal_motion());
    auto t = open_only(*backend);
    ASSERT_TRUE(t);
    const refproto::PoseReport a = read_pose(*t, 1000);
    for (int i = 0; i < 30; ++i) read_pose(*t, 1000);
    const refproto::PoseReport b = read_pose(*t, 1000);
    EXPECT_EQ(b.sequence - a.sequence, 31u);
}

}  // namespace
}  // namespace hmdnode

// ---- through t1's DeviceTracker (reference codec, clock sync, reconnect) ----

namespace hmdnode {
namespace {

struct TrackedSim {
    SimReferenceBackend* device = nullptr;  // owned by the tracker
    std::unique_ptr<DeviceTracker> tracker;
};

TrackedSim track_sim(Clock& clock, SimReferenceDeviceConfig cfg = {}) {
    TrackedSim t;
    auto backend = create_sim_reference_backend(clock, cfg, sinusoidal_motion());
    t.device = backend.get();
    DeviceTrackerConfig tc;
    tc.filter = DeviceFilter{cfg.vendor_id, cfg.product_id, ""};
    auto tracker = create_device_tracker(std::move(backend), make_reference_codec(), clock, tc);
    EXPECT_TRUE(tracker.ok()) << tracker.error().message;
    if (tracker.ok()) t.tracker = std::move(*tracker);
    return t;
}

TEST(SimReferenceDeviceTracked, TwoMinutesAt1kHzThroughTheDeviceTrackerLoseNothing) {
    SimulatedClock clock(kBootNs);
    TrackedSim t = track_sim(clock);
    ASSERT_TRUE(t.tracker);
    ASSERT_TRUE(t.tracker->start().ok());
    std::vector<TrackerSample> buf(256);
    uint64_t count = 0, gaps = 0;
    uint64_t last_seq = 0;
    int64_t last_time = 0;
    for (int step = 0; step < 12'000; ++step) {  // 120 s in 10 ms frames
        clock.advance_ns(10 * kNsPerMs);
        const size_t n = t.tracker->read(buf);
        for (size_t i = 0; i < n; ++i) {
            if (count && buf[i].sequence != last_seq + 1) ++gaps;
            ASSERT_GT(buf[i].time_ns, last_time);
            ASSERT_LE(buf[i].time_ns, buf[i].arrival_ns);
            last_seq = buf[i].sequence;
            last_time = buf[i].time_ns;
            ++count;
        }
    }
    // Reports arrive at boot + 1.5 ms + k ms: 120 s holds 119999 of them. The tracker opens the
    // device at its first read (boot + 10 ms); the 9 that arrived before went to no reader, as
    // with hidraw.
    EXPECT_EQ(count, 119'999u - 9u);
    EXPECT_EQ(gaps, 0u);
    const DeviceTrackerStatus st = t.tracker->status();
    EXPECT_EQ(st.disconnects, 0u);
    EXPECT_EQ(st.codec.sequence_gaps, 0u);
    EXPECT_EQ(st.codec.malformed, 0u);
    EXPECT_EQ(t.tracker->counters().samples_dropped, 0u);
}

TEST(SimReferenceDeviceTracked, UnplugAndReplugResumeWithinASecondAndReportTheGap) {
    SimulatedClock clock(kBootNs);
    TrackedSim t = track_sim(clock);
    ASSERT_TRUE(t.tracker);
    ASSERT_TRUE(t.tracker->start().ok());
    std::vector<TrackerSample> buf(256);
    int64_t last_before = 0;
    for (int step = 0; step < 200; ++step) {  // 2 s
        clock.advance_ns(10 * kNsPerMs);
        const size_t n = t.tracker->read(buf);
        if (n) last_before = buf[n - 1].time_ns;
    }
    t.device->unplug();
    for (int step = 0; step < 70; ++step) {  // 700 ms unplugged: nothing arrives
        clock.advance_ns(10 * kNsPerMs);
        EXPECT_EQ(t.tracker->read(buf), 0u);
    }
    EXPECT_EQ(t.tracker->status().disconnects, 1u);
    EXPECT_FALSE(t.tracker->status().connected);
    t.device->replug();
    const int64_t replug_ns = clock.now_ns();
    int64_t first_after = 0;
    uint64_t after = 0;
    for (int step = 0; step < 200 && !first_after; ++step) {
        clock.advance_ns(10 * kNsPerMs);
        const size_t n = t.tracker->read(buf);
        if (n) {
            first_after = buf[0].arrival_ns;
            after += n;
        }
    }
    ASSERT_GT(first_after, 0) << "tracking never resumed";
    EXPECT_LT(first_after - replug_ns, kNsPerSecond);
    const DeviceTrackerStatus st = t.tracker->status();
    EXPECT_TRUE(st.connected);
    EXPECT_EQ(st.opens, 2u);
    // The reported gap spans the 700 ms unplugged plus at most one reopen interval.
    EXPECT_GE(st.last_gap_ns, 700 * kNsPerMs);
    EXPECT_LT(st.last_gap_ns, 700 * kNsPerMs + 200 * kNsPerMs);
    EXPECT_GT(last_before, 0);
}

}  // namespace
}  // namespace hmdnode
