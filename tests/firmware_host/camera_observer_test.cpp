// The camera observer over the simulated camera filming the mock display, on the simulated clock
// with fixed costs, against closed forms: a 240 Hz camera over a 90 Hz panel (persistence 2 ms,
// exposure 1 ms) sees differences from the node's figure quantised by the beat of the two rates
// (1/720 s) and within half the lit window (persistence + exposure) of it, each frame within a
// camera period plus its exposure; with random phases the differences' mean is the closed form's
// offset: 0 with the stamp's meaning and a rolling shutter accounted, the camera's own stamp
// delay when it has one (what the calibration measures); no decoded id is one the node did not
// present, and a frame the display repeated is matched to the vsync that showed it.
#include "hmdnode/firmware_host/camera_observer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "hmdnode/core/latency_marker.hpp"
#include "hmdnode/hal/camera/panel_camera.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {
namespace {

constexpr int kW = 360, kH = 400, kCell = 4;

struct Filmed {
    ObserverResult result;
    size_t presents = 0;
};

// Presents a marked frame 3 ms before each vsync (sample 1 ms older), except every `skip`-th
// vsync (0: none), which repeats the previous frame; the camera films it all.
Filmed film(PanelCameraConfig cam, double seconds, int skip = 0) {
    SimulatedClock clock(1'000'000'000);
    cam.display.eye_width = kW;
    cam.display.eye_height = kH;
    cam.display.vsync_epoch_ns = 0;
    auto camera = create_panel_camera(clock, cam);
    EXPECT_TRUE(camera) << (camera ? "" : camera.error().message);
    MockDisplayConfig dc = cam.display;
    dc.watcher = camera->get();
    auto display = create_mock_display(clock, dc);
    EXPECT_TRUE(display);
    const int64_t period = (*display)->info().period_ns;
    const LatencyMarkerOverlay place = default_latency_marker_overlay(kW, kH, kCell);
    const double marker_row = place.y + 0.5 * latency_marker_size_px(kCell);
    std::vector<FrameRecord> presents;
    std::vector<CameraFrame> frames;
    StereoImage image;
    for (int e = 0; e < 2; ++e) {
        image.eye[e].width = kW;
        image.eye[e].height = kH;
    }
    int64_t vsync = (*display)->next_vsync_ns(clock.now_ns() + 5'000'000);
    const int vsyncs = int(seconds * cam.display.refresh_hz);
    for (int k = 0; k < vsyncs; ++k, vsync += period) {
        if (skip > 0 && k % skip == skip - 1) continue;
        clock.sleep_until_ns(vsync - 3'000'000);
        FrameRecord r;
        r.index = presents.size();
        r.pose_sample_time_ns = clock.now_ns() - 1'000'000;
        for (int e = 0; e < 2; ++e) {
            image.eye[e].pixels.assign(size_t(kW) * kH * 4, 60);
            draw_latency_marker(image.eye[e],
                                make_latency_marker_payload(r.pose_sample_time_ns, r.index),
                                place.x, place.y, kCell);
        }
        auto pr = (*display)->present(&image, vsync);
        EXPECT_TRUE(pr);
        r.vsync_ns = pr->vsync_ns;
        r.marker_row = marker_row;
        r.marker_photon_time_ns = r.vsync_ns + (*display)->row_photon_offset_ns(marker_row);
        presents.push_back(r);
        for (;;) {
            auto f = (*camera)->next_frame(0);
            EXPECT_TRUE(f);
            if (!f->has_value()) break;
            frames.push_back(std::move(**f));
        }
    }
    Filmed run;
    run.presents = presents.size();
    run.result = observe_camera_frames(frames, presents, period);
    return run;
}

std::vector<double> differences(const ObserverResult& r) {
    std::vector<double> d;
    for (const ObservedFrame& f : r.frames)
        if (f.matched) d.push_back(f.difference_ms);
    return d;
}

std::string first_reason(const ObserverResult& r) {
    std::string out;
    for (const ObservedFrame& f : r.frames)
        if (!f.reason.empty() && f.reason.find("no marker") == std::string::npos)
            out += f.reason + "; ";
    return out.substr(0, 600);
}

double mean(const std::vector<double>& v) {
    return std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
}

PanelCameraConfig camera_240() {
    PanelCameraConfig c;
    c.fps = 240.0;
    c.exposure_ns = 1'000'000;
    c.display.persistence_ns = 2'000'000;
    c.display.refresh_hz = 90.0;
    return c;
}

TEST(CameraObserver, Beat240Over90IsQuantisedAndWithinTheLitWindow) {
    PanelCameraConfig c = camera_240();
    c.phase_ns = 300'000;
    const Filmed run = film(c, 2.0);
    const std::vector<double> d = differences(run.result);
    ASSERT_GT(d.size(), 100u);
    EXPECT_EQ(run.result.summary.unmatched, 0u);
    const double q = 1000.0 / 720.0;  // ms: the beat of 1/240 s and 1/90 s
    for (double x : d) {
        EXPECT_LE(std::abs(x), 1000.0 / 240.0 + 1.0);      // the target: a period plus the exposure
        EXPECT_LE(std::abs(x), 0.5 * (2.0 + 1.0) + 1e-3);  // the closed form's bound
        const double r = std::fmod(std::abs(x - d[0]), q);
        EXPECT_LE(std::min(r, q - r), 0.2) << x << " vs " << d[0];
    }
}

TEST(CameraObserver, RandomPhasesHaveTheClosedFormOffset) {
    PanelCameraConfig c = camera_240();
    c.jitter_ns = 2'083'333;  // half a camera period either way: phases cover the period
    c.timestamp = CameraTimestamp::exposure_end;
    const Filmed end = film(c, 4.0);
    EXPECT_EQ(end.result.summary.unmatched, 0u);
    ASSERT_GT(differences(end.result).size(), 100u);
    EXPECT_NEAR(mean(differences(end.result)), 0.0, 0.2);
    c.timestamp = CameraTimestamp::exposure_start;
    EXPECT_NEAR(mean(differences(film(c, 4.0).result)), 0.0, 0.2);
    // A stamp 3 ms late that the observer is not told of: the offset is the delay.
    c.stamp_delay_ns = 3'000'000;
    EXPECT_NEAR(mean(differences(film(c, 4.0).result)), 3.0, 0.2);
}

TEST(CameraObserver, RollingShutterIsAccountedAtTheMarkersRow) {
    PanelCameraConfig c = camera_240();
    c.jitter_ns = 2'083'333;
    c.line_time_ns = 11'111'111 / kH;  // the shutter rolls down with the scan-out
    c.exposure_ns = 2'000'000;
    const Filmed run = film(c, 4.0);
    const std::vector<double> d = differences(run.result);
    ASSERT_GT(d.size(), 100u) << first_reason(run.result) << " frames " << run.result.summary.frames
                              << " decoded " << run.result.summary.decoded;
    EXPECT_EQ(run.result.summary.unmatched, 0u);
    EXPECT_NEAR(mean(d), 0.0, 0.2);
    for (double x : d) EXPECT_LE(std::abs(x), 1000.0 / 240.0 + 2.0);
}

TEST(CameraObserver, RepeatedFramesAreMatchedToTheVsyncThatShowedThem) {
    PanelCameraConfig c = camera_240();
    c.jitter_ns = 2'083'333;
    const Filmed run = film(c, 3.0, 4);  // every 4th vsync repeats the frame before
    EXPECT_EQ(run.result.summary.unmatched, 0u);
    EXPECT_GT(run.result.summary.repeats, 0u);
    for (const ObservedFrame& f : run.result.frames) {
        if (f.matched) {
            EXPECT_LE(std::abs(f.difference_ms), 1000.0 / 240.0 + 1.0);
        }
    }
    // Every present decoded in order: a skip is a present no frame caught.
    EXPECT_LE(run.result.summary.skipped + run.result.summary.decoded, run.presents * 3);
}

TEST(CameraObserver, ADarkFrameIsReportedNotGuessed) {
    PanelCameraConfig c = camera_240();
    c.phase_ns = 300'000;
    const Filmed run = film(c, 1.0);
    size_t reported = 0;
    for (const ObservedFrame& f : run.result.frames)
        if (!f.decoded) {
            EXPECT_FALSE(f.reason.empty());
            ++reported;
        }
    EXPECT_EQ(reported, run.result.summary.undecoded);
    EXPECT_GT(reported, 0u);  // most exposures fall between lit intervals
}

}  // namespace
}  // namespace hmdnode
