// The camera observer (camera_observer.hpp): decode (YUYV: its luma), unwrap the sample's time,
// match the present, pick the vsync whose lit interval the exposure caught. Cost: per frame one
// marker decode over the frame, a binary search of the presents.
#include "hmdnode/firmware_host/camera_observer.hpp"

#include <algorithm>
#include <cmath>

#include "hmdnode/core/latency_marker.hpp"

namespace hmdnode {
namespace {

// The host time (ns) of a sample whose microseconds modulo 2^32 are `us`, at most 2^32 us before
// `capture_ns`.
int64_t unwrap_sample_ns(uint32_t us, int64_t capture_ns) {
    const int64_t capture_us = capture_ns / 1000;
    const int64_t back = int64_t(uint32_t(uint64_t(capture_us) - us));
    return (capture_us - back) * 1000;
}

// Fills the match of a decoded frame: the present of that sequence and sample, the vsync of its
// run on screen nearest the capture.
void match(ObservedFrame& f, const LatencyMarkerPayload& p,
           const std::vector<FrameRecord>& presents, int64_t period_ns) {
    // The newest present shown at or before the capture whose index and sample agree.
    auto it = std::upper_bound(presents.begin(), presents.end(), f.capture_ns,
                               [](int64_t t, const FrameRecord& r) { return t < r.vsync_ns; });
    for (int tries = 0; it != presents.begin() && tries < 65536; ++tries) {
        --it;
        if (uint16_t(it->index) != p.present_sequence) continue;
        if (make_latency_marker_payload(std::max<int64_t>(it->pose_sample_time_ns, 0), it->index) !=
            p)
            break;
        const auto next = it + 1;
        const int64_t row_offset = it->marker_photon_time_ns - it->vsync_ns;
        int64_t j = std::llround(double(f.capture_ns - (it->vsync_ns + row_offset)) / period_ns);
        j = std::max<int64_t>(j, 0);
        if (next != presents.end())
            j = std::min<int64_t>(
                j, std::max<int64_t>(0, (next->vsync_ns - it->vsync_ns - 1) / period_ns));
        f.matched = true;
        f.present = it->index;
        f.vsync_ns = it->vsync_ns + j * period_ns;
        f.observed_ms = ns_to_ms(f.capture_ns - f.sample_time_ns);
        f.node_ms = ns_to_ms(f.vsync_ns + row_offset - it->pose_sample_time_ns);
        f.difference_ms = f.observed_ms - f.node_ms;
        return;
    }
    f.reason = "decoded an id the node did not present";
}

}  // namespace

CameraSighting sight_camera_frame(const CameraFrame& cf) {
    CameraSighting s;
    s.camera_sequence = cf.sequence;
    s.capture_ns = exposure_middle_ns(cf, 0.5 * double(cf.height));
    const bool grey = cf.fourcc == kFourccGrey, yuyv = cf.fourcc == kFourccYuyv;
    const uint32_t min_stride = yuyv ? cf.width * 2 : cf.width;
    if ((!grey && !yuyv) || cf.bytes_per_line < min_stride ||
        cf.bytes.size() < size_t(cf.bytes_per_line) * cf.height) {
        s.reason = "not a GREY or YUYV frame";
        return s;
    }
    const uint8_t* pixels = cf.bytes.data();
    int stride = int(cf.bytes_per_line);
    std::vector<uint8_t> luma;
    if (yuyv) {  // Y0 U Y1 V: every other byte is a pixel's luma
        luma.resize(size_t(cf.width) * cf.height);
        for (uint32_t y = 0; y < cf.height; ++y)
            for (uint32_t x = 0; x < cf.width; ++x)
                luma[size_t(y) * cf.width + x] = cf.bytes[size_t(y) * cf.bytes_per_line + 2 * x];
        pixels = luma.data();
        stride = int(cf.width);
    }
    const LatencyMarkerDecode d =
        decode_latency_marker(pixels, int(cf.width), int(cf.height), stride);
    if (!d.ok) {
        s.reason = d.reason;
        return s;
    }
    s.decoded = true;
    s.payload = d.payload;
    s.capture_ns = exposure_middle_ns(cf, d.y - 0.5);
    return s;
}

ObserverResult match_camera_sightings(const std::vector<CameraSighting>& sightings,
                                      const std::vector<FrameRecord>& presents, int64_t period_ns) {
    ObserverResult out;
    out.frames.reserve(sightings.size());
    std::vector<double> observed, node, diff;
    bool have_last = false;
    uint64_t last = 0;
    for (const CameraSighting& s : sightings) {
        ObservedFrame f;
        f.camera_sequence = s.camera_sequence;
        f.capture_ns = s.capture_ns;
        ++out.summary.frames;
        if (!s.decoded) {
            f.reason = s.reason;
        } else {
            f.decoded = true;
            f.sample_time_ns = unwrap_sample_ns(s.payload.sample_time_us, f.capture_ns);
            match(f, s.payload, presents, period_ns);
        }
        if (!f.decoded) {
            ++out.summary.undecoded;
        } else {
            ++out.summary.decoded;
            if (!f.matched) {
                ++out.summary.unmatched;
            } else {
                if (have_last && f.present == last) f.repeat = true, ++out.summary.repeats;
                if (have_last && f.present > last + 1) out.summary.skipped += f.present - last - 1;
                have_last = true;
                last = f.present;
                observed.push_back(f.observed_ms);
                node.push_back(f.node_ms);
                diff.push_back(f.difference_ms);
            }
        }
        out.frames.push_back(std::move(f));
    }
    out.summary.observed_ms = percentiles(std::move(observed));
    out.summary.node_ms = percentiles(std::move(node));
    out.summary.difference_ms = percentiles(std::move(diff));
    return out;
}

ObserverResult observe_camera_frames(const std::vector<CameraFrame>& frames,
                                     const std::vector<FrameRecord>& presents, int64_t period_ns) {
    std::vector<CameraSighting> sightings;
    sightings.reserve(frames.size());
    for (const CameraFrame& cf : frames) sightings.push_back(sight_camera_frame(cf));
    return match_camera_sightings(sightings, presents, period_ns);
}

}  // namespace hmdnode
