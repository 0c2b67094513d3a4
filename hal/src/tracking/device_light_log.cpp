// A device's light and IMU gathered offline, its still stretches and a placement from one
// (device_light_log.hpp; docs/tracking.md §10). The report stream is the device tracker's input
// (a capture's or a recording's backend), read to its end with no clock: IMU reports through the
// codec (factory calibration, head axes), light reports through the light decoder with the
// newest IMU tick as the reference of the 24-bit times, as the device tracker does.
#include "hmdnode/hal/tracking/device_light_log.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <utility>

#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

namespace hmdnode {
namespace {

// Reads `transport` to its end (a replayed stream: it never blocks) through `codec` and a light
// decoder of `model` into `log`.
Status gather_light_log(Transport& transport, ReportCodec& codec,
                        const lighthouse::SensorModel& model, DeviceLightLog& log) {
    codec.configure(transport);
    lighthouse::LightDecoder decoder(model);
    std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> samples;
    std::vector<lighthouse::LightEvent> events;
    bool have_imu = false;
    int64_t last_imu_ns = 0;
    while (!transport.finished()) {
        auto r = transport.read_input(0);
        if (!r) return r.error();
        if (!*r) break;
        const std::vector<uint8_t>& bytes = (*r)->bytes;
        if (bytes.empty()) continue;
        if (bytes[0] == lighthouse::kLh1ReportId || bytes[0] == lighthouse::kLh2ReportId) {
            ++log.light_reports;
            if (Status st = decoder.decode_report(bytes); !st) {
                ++log.rejected_light_reports;
                if (log.first_rejection.empty()) log.first_rejection = st.error().message;
            }
            events.clear();
            decoder.take_events(events);
            for (lighthouse::LightEvent& e : events) {
                if (have_imu)
                    e.device_time_ns = lighthouse::onto_imu_turn(e.device_time_ns, last_imu_ns);
                log.events.push_back(e);
            }
            continue;
        }
        const size_t n = codec.decode(bytes, samples);
        if (n) ++log.imu_reports;
        for (size_t i = 0; i < n; ++i) {
            const DeviceSample& d = samples[i];
            if (!d.gyro || !d.accel) continue;
            decoder.note_imu_ticks(lighthouse::imu_ticks(d.device_time_ns));
            log.imu.push_back({d.device_time_ns, *d.gyro, *d.accel});
            have_imu = true;
            last_imu_ns = d.device_time_ns;
        }
    }
    decoder.finish();
    events.clear();
    decoder.take_events(events);
    log.events.insert(log.events.end(), events.begin(), events.end());
    log.base_stations = decoder.base_stations();
    log.light = decoder.counters();
    for (std::string& w : decoder.take_warnings()) log.warnings.push_back(std::move(w));
    return {};
}

}  // namespace

Result<DeviceLightLog> device_light_log_from_capture(const std::filesystem::path& capture,
                                                     const std::string& vid_pid) {
    auto dev = find_capture_device(capture, vid_pid);
    if (!dev) return dev.error();
    DeviceLightLog log;
    log.source = "capture " + capture.filename().string() + " " + vid_pid;
    log.warnings = dev->capture->warnings;
    auto json = capture_lighthouse_config(*dev->capture, dev->bus, dev->address);
    auto sensors =
        capture_sensor_model(json, capture.string(), vid_pid, "to place the base stations with");
    if (!sensors) return sensors.error();
    log.sensors = std::move(*sensors);
    auto codec = make_codec_for(dev->filter.vendor_id, dev->filter.product_id);
    if (auto cal = parse_imu_calibration_json(*json, capture.string() + ": the configuration")) {
        log.has_calibration = codec->set_imu_calibration(*cal);
        log.calibration = *cal;
    } else {
        log.warnings.push_back(cal.error().message + ": the codec's own IMU axes, uncalibrated");
    }
    auto backend = create_capture_backend(dev->capture, dev->summary);
    auto ids = backend->enumerate(dev->filter);
    if (!ids || ids->empty()) return make_error(capture.string() + ": no device " + vid_pid);
    auto transport = backend->open(ids->front());
    if (!transport) return transport.error();
    lighthouse::SensorModel model;
    model.count = log.sensors.points.size();
    model.channel_map = log.sensors.channel_map;
    if (Status st = gather_light_log(**transport, *codec, model, log); !st)
        return make_error(capture.string() + ": " + st.error().message);
    if (log.light_reports == 0)
        return make_error(capture.string() + ": device " + vid_pid +
                          " sent no light report (0x25, 0x28)");
    return log;
}

Result<DeviceLightLog> device_light_log_from_recording(const std::filesystem::path& recording,
                                                       const std::string& device) {
    auto rec = read_survive_recording(recording, device);
    if (!rec) return rec.error();
    if (rec->light.empty())
        return make_error(recording.string() + ": " + device +
                          ": the recording has no light line (W, Y or C) of it");
    if (rec->sensors.empty())
        return make_error(recording.string() + ": " + device +
                          ": no sensor model (CONFIG lighthouse_config: modelPoints, "
                          "modelNormals) to place the base stations with");
    DeviceLightLog log;
    log.source = "recording " + recording.filename().string() + " " + device;
    log.warnings = rec->warnings;
    log.sensors = rec->sensors;
    log.has_calibration = rec->has_config;
    log.calibration = rec->calibration;
    const lighthouse::SensorModel model = survive_sensor_model(*rec);
    auto codec = make_vive_codec(vive::kIndexProductId);
    if (rec->has_config) codec->set_imu_calibration(rec->calibration);
    auto shared = std::make_shared<const SurviveRecording>(std::move(*rec));
    auto backend = create_survive_backend(shared, true);
    auto ids = backend->enumerate({});
    if (!ids || ids->empty()) return make_error(recording.string() + ": no device " + device);
    auto transport = backend->open(ids->front());
    if (!transport) return transport.error();
    if (Status st = gather_light_log(**transport, *codec, model, log); !st)
        return make_error(recording.string() + ": " + st.error().message);
    return log;
}

std::vector<StillStretch> still_stretches(const DeviceLightLog& log, const StillOptions& o) {
    std::vector<StillStretch> out;
    const std::vector<ImuReading>& s = log.imu;
    const int64_t window_ns = int64_t(o.window_s * 1e9);
    std::optional<StillStretch> open;
    glm::dvec3 accel_sum(0.0);
    size_t accel_n = 0;
    auto close = [&] {
        if (open && open->seconds() >= o.min_duration_s) {
            open->mean_accel = accel_sum / double(accel_n);
            out.push_back(*open);
        }
        open.reset();
        accel_sum = glm::dvec3(0.0);
        accel_n = 0;
    };
    for (size_t lo = 0; lo < s.size();) {
        size_t hi = lo;
        while (hi < s.size() && s[hi].device_time_ns - s[lo].device_time_ns < window_ns) ++hi;
        if (hi == s.size() && s.back().device_time_ns - s[lo].device_time_ns < window_ns / 2)
            break;  // a stub of a window at the end
        const double n = double(hi - lo);
        glm::dvec3 gm(0.0), am(0.0);
        for (size_t i = lo; i < hi; ++i) gm += s[i].gyro, am += s[i].accel;
        gm /= n;
        am /= n;
        double gv = 0, av = 0;
        for (size_t i = lo; i < hi; ++i) {
            const glm::dvec3 dg = s[i].gyro - gm, da = s[i].accel - am;
            gv += glm::dot(dg, dg);
            av += glm::dot(da, da);
        }
        const double gsd = std::sqrt(gv / n), asd = std::sqrt(av / n);
        const bool still = hi - lo >= 3 && gsd <= o.max_gyro_sd_rad_s &&
                           glm::length(gm) <= o.max_gyro_mean_rad_s && asd <= o.max_accel_sd_m_s2;
        const bool adjoins = open && s[lo].device_time_ns - open->end_ns <= window_ns;
        if (still) {
            if (!adjoins) {
                close();
                open = StillStretch{};
                open->begin_ns = s[lo].device_time_ns;
            }
            open->end_ns = s[hi - 1].device_time_ns;
            open->gyro_sd_rad_s = std::max(open->gyro_sd_rad_s, gsd);
            accel_sum += am * n;
            accel_n += hi - lo;
        } else {
            close();
        }
        lo = hi;
    }
    close();
    for (StillStretch& st : out) {
        std::vector<std::pair<int, int>> seen;
        for (const lighthouse::LightEvent& e : log.events) {
            if (e.device_time_ns < st.begin_ns || e.device_time_ns > st.end_ns) continue;
            ++st.light_events;
            const std::pair<int, int> k(int(e.generation), e.base_station);
            if (std::find(seen.begin(), seen.end(), k) == seen.end()) seen.push_back(k);
        }
        st.base_stations = seen.size();
    }
    return out;
}

std::optional<StillStretch> best_still_stretch(std::span<const StillStretch> stretches) {
    std::optional<StillStretch> best;
    for (const StillStretch& s : stretches)
        if (!best || std::pair(s.base_stations, s.light_events) >
                         std::pair(best->base_stations, best->light_events))
            best = s;
    return best;
}

lighthouse::PlacementResult place_from_log(const DeviceLightLog& log, int64_t begin_ns,
                                           int64_t end_ns,
                                           const std::optional<glm::dvec3>& mean_accel,
                                           const lighthouse::PlacementOptions& options) {
    lighthouse::SensorLayout layout;
    layout.points = log.sensors.points;
    layout.normals = log.sensors.normals;
    std::vector<lighthouse::LightEvent> still;
    for (const lighthouse::LightEvent& e : log.events)
        if (e.device_time_ns >= begin_ns && e.device_time_ns <= end_ns) still.push_back(e);
    std::optional<glm::dvec3> up;
    if (mean_accel && glm::length(*mean_accel) > 0)  // head axes -> the model's
        up = glm::normalize(log.sensors.model_from_head * *mean_accel);
    lighthouse::PlacementResult r =
        lighthouse::place_base_stations(layout, still, log.base_stations, {}, up, options);
    if (!up) return r;
    // Levelled: +Y up; turned a quarter about +X so that +Z is up, as in libsurvive's worlds
    // (the setup file's convention).
    const glm::dquat y_to_z = glm::angleAxis(M_PI / 2, glm::dvec3(1, 0, 0));
    auto turn = [&](lighthouse::RigidPose& p) {
        p.position = y_to_z * p.position;
        p.orientation = glm::normalize(y_to_z * p.orientation);
    };
    turn(r.world_from_device);
    for (lighthouse::BaseStationPlacement& b : r.placed) turn(b.world_from_station);
    return r;
}

}  // namespace hmdnode
