// The flash calibration of a latency rig's camera (observed_replay.hpp, calibrate_camera_flash):
// the panel black, then white at known vsyncs; the camera's delay from the first frame of each
// flash that passes half way from dark to lit, after the photodiode practice of timing a
// full-field step (Di Luca, "New method to measure end-to-end delay of virtual reality",
// Presence 19(6), 2010: the light onset at a known frame against the sensor's record). Cost: per
// camera frame the mean of a sixteenth of its pixels; memory three numbers per frame.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <nlohmann/json.hpp>

#include "hmdnode/core/percentile.hpp"
#include "hmdnode/firmware_host/observed_replay.hpp"

namespace hmdnode {
namespace {

struct FrameLevel {
    uint64_t sequence = 0;
    int64_t stamp_ns = 0;
    int64_t middle_ns = 0;  // exposure middle of the row the calibration times
    double level = 0.0;     // mean grey level (every 4th pixel of every 4th row)
};

// The mean grey level of a GREY or YUYV frame (NaN for another format).
double frame_level(const CameraFrame& f) {
    const bool yuyv = f.fourcc == kFourccYuyv;
    if ((f.fourcc != kFourccGrey && !yuyv) ||
        f.bytes.size() < size_t(f.bytes_per_line) * f.height || f.width == 0 || f.height == 0)
        return std::nan("");
    const size_t step = yuyv ? 2 : 1;
    double sum = 0.0;
    size_t n = 0;
    for (uint32_t y = 0; y < f.height; y += 4)
        for (uint32_t x = 0; x < f.width; x += 4, ++n)
            sum += f.bytes[size_t(y) * f.bytes_per_line + x * step];
    return sum / double(n);
}

double median_of(std::vector<double> v) {
    if (v.empty()) return std::nan("");
    std::sort(v.begin(), v.end());
    return percentile_sorted(v, 0.5);
}

StereoImage flat_image(const DisplayInfo& info, uint8_t value) {
    StereoImage s;
    for (ImageRGBA8& e : s.eye) {
        e.width = info.eye_width;
        e.height = info.eye_height;
        e.pixels.assign(size_t(e.width) * e.height * 4, value);
        for (size_t i = 3; i < e.pixels.size(); i += 4) e.pixels[i] = 255;
    }
    return s;
}

// Takes every frame the camera has ready.
Status drain(Camera& camera, int64_t exposure_ns, std::vector<FrameLevel>* out,
             int64_t* exposure_seen, int64_t* line_time) {
    for (;;) {
        Result<std::optional<CameraFrame>> f = camera.next_frame(0);
        if (!f.ok()) return make_error("camera " + camera.name() + ": " + f.error().message);
        if (!f->has_value()) return {};
        CameraFrame& cf = **f;
        if (cf.exposure_ns == 0) cf.exposure_ns = exposure_ns;
        *exposure_seen = cf.exposure_ns;
        *line_time = cf.line_time_ns;
        FrameLevel l;
        l.sequence = cf.sequence;
        l.stamp_ns = cf.host_time_ns;
        l.middle_ns = exposure_middle_ns(cf, cf.line_time_ns > 0 ? 0.5 * double(cf.height) : 0.0);
        l.level = frame_level(cf);
        if (std::isnan(l.level))
            return make_error("camera " + camera.name() + ": frames are " +
                              fourcc_to_string(cf.fourcc) + ", not GREY or YUYV");
        out->push_back(l);
    }
}

// The camera's frame interval: the median stamp interval per sequence step.
double camera_period_ns(const std::vector<FrameLevel>& frames) {
    std::vector<double> d;
    for (size_t i = 1; i < frames.size(); ++i)
        if (frames[i].sequence > frames[i - 1].sequence)
            d.push_back(double(frames[i].stamp_ns - frames[i - 1].stamp_ns) /
                        double(frames[i].sequence - frames[i - 1].sequence));
    return median_of(std::move(d));
}

}  // namespace

Result<FlashCalibration> calibrate_camera_flash(Clock& clock, Display& display, Camera& camera,
                                                const FlashCalibrationOptions& o,
                                                int64_t exposure_ns) {
    if (o.flashes < 1 || o.dark_vsyncs < 2 || o.lit_vsyncs < 2)
        return make_error("flash calibration: at least 1 flash, 2 dark and 2 lit vsyncs");
    const DisplayInfo info = display.info();
    const int64_t period = info.period_ns;
    const StereoImage black = flat_image(info, 0), white = flat_image(info, 255);
    if (Status st = camera.start(); !st.ok())
        return make_error("camera " + camera.name() + ": " + st.error().message);
    std::vector<FrameLevel> frames;
    int64_t exposure_seen = 0, line_time = 0;
    const int64_t start = display.next_vsync_ns(clock.now_ns() + info.latch_margin_ns + period);
    const int cycle = o.dark_vsyncs + o.lit_vsyncs;
    std::vector<int64_t> flash_vsyncs;
    // One more dark phase at the end, so the last flash's frames are all taken.
    for (int k = 0; k < o.flashes * cycle + o.dark_vsyncs; ++k) {
        const int64_t v = start + int64_t(k) * period;
        const bool lit = k < o.flashes * cycle && k % cycle >= o.dark_vsyncs;
        if (lit && k % cycle == o.dark_vsyncs) flash_vsyncs.push_back(v);
        clock.sleep_until_ns(v - info.latch_margin_ns - period / 4);
        Result<PresentResult> pr = display.present(lit ? &white : &black, v);
        Status st = pr.ok() ? drain(camera, exposure_ns, &frames, &exposure_seen, &line_time)
                            : Status(make_error("display: " + pr.error().message));
        if (!st.ok()) {
            camera.stop();
            return st.error();
        }
    }
    camera.stop();

    FlashCalibration c;
    c.frames = frames.size();
    const double tc = camera_period_ns(frames);
    if (frames.size() < 8 || !std::isfinite(tc) || tc <= 0)
        return make_error("camera " + camera.name() + ": too few frames (" +
                          std::to_string(frames.size()) + ") to calibrate");
    c.camera_period_ms = ns_to_ms(int64_t(std::llround(tc)));
    std::vector<double> levels;
    for (const FrameLevel& f : frames) levels.push_back(f.level);
    std::sort(levels.begin(), levels.end());
    c.dark_level = percentile_sorted(levels, 0.2);
    c.lit_level = percentile_sorted(levels, 0.95);
    if (c.lit_level - c.dark_level < 4.0)
        return make_error("camera " + camera.name() + ": the flash does not show (dark " +
                          std::to_string(c.dark_level) + ", lit " + std::to_string(c.lit_level) +
                          " grey levels): point the camera at the panel");
    const double half = 0.5 * (c.dark_level + c.lit_level);
    // The light's half-way time of each flash: its vsync + the timed panel row's photon offset.
    const int64_t row_offset =
        display.row_photon_offset_ns(line_time > 0 ? 0.5 * info.eye_height : 0.0);
    for (int64_t v : flash_vsyncs) {
        FlashSighting s;
        s.flash_vsync_ns = v;
        c.flashes.push_back(s);
    }
    // Each rising edge goes to the latest flash at or before it (a delay below a dark phase).
    const int64_t slack = int64_t(tc) + exposure_seen;
    for (size_t i = 1; i < frames.size(); ++i) {
        if (!(frames[i].level >= half && frames[i - 1].level < half)) continue;
        const int64_t t = frames[i].middle_ns - row_offset + slack;
        auto it = std::upper_bound(flash_vsyncs.begin(), flash_vsyncs.end(), t);
        if (it == flash_vsyncs.begin()) continue;
        FlashSighting& s = c.flashes[size_t(it - flash_vsyncs.begin()) - 1];
        if (s.seen) continue;
        s.seen = true;
        s.camera_sequence = frames[i].sequence;
        s.capture_ns = frames[i].middle_ns;
        s.delay_ms =
            ns_to_ms(s.capture_ns - (s.flash_vsync_ns + row_offset)) - 0.5 * ns_to_ms(int64_t(tc));
    }
    std::vector<double> delays;
    for (const FlashSighting& s : c.flashes)
        if (s.seen) delays.push_back(s.delay_ms);
    if (delays.empty()) return make_error("camera " + camera.name() + ": no frame saw a flash");
    c.delay_ms = median_of(delays);
    c.bound_ms = 0.5 * (ns_to_ms(int64_t(tc)) + ns_to_ms(exposure_seen));
    return c;
}

std::string flash_calibration_table(const FlashCalibration& c) {
    std::ostringstream out;
    char b[256];
    std::snprintf(b, sizeof b, "%6s %16s %8s %10s\n", "flash", "vsync (ms)", "frame", "delay ms");
    out << b;
    for (size_t i = 0; i < c.flashes.size(); ++i) {
        const FlashSighting& s = c.flashes[i];
        if (s.seen)
            std::snprintf(b, sizeof b, "%6zu %16.3f %8llu %10.2f\n", i, ns_to_ms(s.flash_vsync_ns),
                          (unsigned long long)s.camera_sequence, s.delay_ms);
        else
            std::snprintf(b, sizeof b, "%6zu %16.3f %8s %10s\n", i, ns_to_ms(s.flash_vsync_ns), "-",
                          "unseen");
        out << b;
    }
    std::snprintf(b, sizeof b,
                  "camera delay %.2f ms (median of %zu flashes; each within +-%.2f ms: half a "
                  "camera period of %.2f ms plus half the exposure); %zu frames, grey levels dark "
                  "%.1f, lit %.1f\n",
                  c.delay_ms,
                  size_t(std::count_if(c.flashes.begin(), c.flashes.end(),
                                       [](const FlashSighting& s) { return s.seen; })),
                  c.bound_ms, c.camera_period_ms, c.frames, c.dark_level, c.lit_level);
    out << b;
    return out.str();
}

nlohmann::json flash_calibration_json(const FlashCalibration& c) {
    nlohmann::json flashes = nlohmann::json::array();
    for (const FlashSighting& s : c.flashes) {
        nlohmann::json j = {{"vsync_ns", s.flash_vsync_ns}, {"seen", s.seen}};
        if (s.seen) {
            j["camera_sequence"] = s.camera_sequence;
            j["capture_ns"] = s.capture_ns;
            j["delay_ms"] = s.delay_ms;
        }
        flashes.push_back(std::move(j));
    }
    return {{"format", "hmdnode-camera-calibration/1"},
            {"delay_ms", c.delay_ms},
            {"bound_ms", c.bound_ms},
            {"camera_period_ms", c.camera_period_ms},
            {"dark_level", c.dark_level},
            {"lit_level", c.lit_level},
            {"frames", c.frames},
            {"flashes", flashes}};
}

}  // namespace hmdnode
