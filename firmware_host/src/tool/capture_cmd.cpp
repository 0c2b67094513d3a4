// `hmdnode capture info FILE [--device VID:PID]`: what a usbmon capture (pcap or pcap.gz, link
// types 189/220) holds -- devices (bus/address, VID:PID and where it came from), endpoints, report
// ids and rates -- and, for each device hmdnode has a codec for (Vive/Index IMU, Rift DK2/CV1
// IMU, the reference protocol), the decoded figures: unique samples per second, sequence gaps,
// malformed/unknown reports, |accel| while still, the fused orientation's drift while still, and
// the clock offset; for a Vive/Index-family device with light reports (0x25, 0x28), the light
// events per base station and sensor and each base station's calibration (OOTX) status.
// Figures and formats: docs/tracking.md.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <string>

#include <CLI/CLI.hpp>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/codec/rift_imu.hpp"
#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors errors{"capture info"};

const char* transfer_name(uint8_t t) {
    switch (t) {
        case 0:
            return "isochronous";
        case 1:
            return "interrupt";
        case 2:
            return "control";
        case 3:
            return "bulk";
        default:
            return "?";
    }
}

bool has_codec(uint16_t vid, uint16_t pid) {
    return (vid == vive::kVendorId &&
            (pid == vive::kViveProductId || pid == vive::kIndexProductId)) ||
           (vid == rift::kVendorId && (pid == rift::kDk2ProductId || pid == rift::kCv1ProductId)) ||
           (vid == refproto::kDevVendorId && pid == refproto::kDevProductId);
}

// Decodes one device's interrupt-IN reports through the device tracker's own chain (codec ->
// clock sync -> fusion, hal's ReportChain, configured as a capture replay's tracker is).
void print_decoded(const UsbCapture& cap, const CaptureDeviceSummary& d) {
    const DeviceTrackerConfig tc;
    ReportChain chain(make_codec_for(d.vendor_id, d.product_id), tc.clock, tc.fusion);
    uint64_t n = 0, still = 0;
    int64_t first_dev = 0, last_dev = 0;
    double a_sum = 0.0, still_drift_deg = 0.0;
    bool have_ref = false;
    glm::dquat ref{1, 0, 0, 0};
    int64_t ref_dev = 0;
    auto sample = [&](const DeviceSample& s, const TrackerSample&) {
        if (n == 0) first_dev = s.device_time_ns;
        last_dev = s.device_time_ns;
        ++n;
        if (!s.gyro || !s.accel) return;
        // Still: |gyro| under 0.05 rad/s (3 deg/s). Drift: the largest rotation of the fused
        // orientation within 1 s of a still stretch's start (after the first second).
        const bool is_still = glm::length(*s.gyro) < 0.05;
        if (!is_still) {
            have_ref = false;
            return;
        }
        ++still;
        a_sum += glm::length(*s.accel);
        if (s.device_time_ns - first_dev < kNsPerSecond) return;
        const glm::dquat fused = chain.fusion().orientation();
        if (!have_ref || s.device_time_ns - ref_dev >= kNsPerSecond) {
            have_ref = true;
            ref = fused;
            ref_dev = s.device_time_ns;
        } else {
            const glm::dquat q = glm::conjugate(ref) * fused;
            still_drift_deg = std::max(
                still_drift_deg, 2.0 * std::acos(std::min(1.0, std::abs(q.w))) * 180.0 / M_PI);
        }
    };
    for (const UsbPacket& u : cap.packets) {
        if (u.bus != d.bus || u.device_address != d.address || !is_interrupt_in_completion(u))
            continue;
        chain.feed(u.data, u.time_ns, sample);
    }
    const ReportCodec* codec = &chain.codec();
    const ClockSync& sync = chain.clock_sync();
    const ImuFusion& fusion = chain.fusion();
    const CodecCounters c = codec->counters();
    const double span_s = ns_to_s(last_dev - first_dev);
    std::printf("    decoded (%s):\n", codec->name().c_str());
    std::printf("      unique samples        %llu over %.3f s of device time = %.1f /s\n",
                (unsigned long long)n, span_s, span_s > 0 ? double(n - 1) / span_s : 0.0);
    std::printf("      sequence gaps         %llu (%llu samples missing)\n",
                (unsigned long long)c.sequence_gaps, (unsigned long long)c.missing_samples);
    std::printf("      saturated samples     %llu; stale first report dropped: %llu\n",
                (unsigned long long)c.saturated_samples, (unsigned long long)c.stale_first_dropped);
    std::printf("      reports               %llu decoded, %llu malformed, %llu unknown id\n",
                (unsigned long long)c.reports, (unsigned long long)c.malformed,
                (unsigned long long)c.unknown);
    if (still > 0) {
        const double a = a_sum / double(still);
        std::printf("      still samples         %llu (|gyro| < 3 deg/s)\n",
                    (unsigned long long)still);
        std::printf("      |accel| while still   %.4f m/s^2 (%.2f %% from g)\n", a,
                    100.0 * std::abs(a - 9.80665) / 9.80665);
        std::printf("      fused drift, still    %.3f deg max within 1 s\n", still_drift_deg);
        const glm::dvec3 b = fusion.gyro_bias();
        std::printf("      gyro bias estimate    %.5f %.5f %.5f rad/s\n", b.x, b.y, b.z);
    }
    if (sync.valid())
        std::printf("      clock                 drift %.1f ppm, jitter %.1f us, %llu resets\n",
                    sync.drift_ppm(), sync.jitter_ns() / 1e3, (unsigned long long)sync.resets());
}

// A Vive/Index-family device's light reports (the interrupt-IN endpoints other than the IMU's
// 0x81 that carry reports 0x25 or 0x28) through the light decoder, its IMU reports giving the tick
// reference, with the device's sensor model when the capture recorded its configuration read.
void print_light(const UsbCapture& cap, const CaptureDeviceSummary& d) {
    std::set<uint8_t> light;  // the endpoints carrying light reports
    for (const CaptureEndpointSummary& e : d.endpoints)
        if (e.endpoint != 0x81 && (e.report_ids.count(lighthouse::kLh1ReportId) ||
                                   e.report_ids.count(lighthouse::kLh2ReportId)))
            light.insert(e.endpoint);
    if (light.empty()) return;
    lighthouse::SensorModel model;
    std::string model_from = "not in the capture: raw channels 0..31";
    if (auto json = capture_lighthouse_config(cap, d.bus, d.address)) {
        auto sensors = parse_lighthouse_sensors(*json, "configuration");
        if (sensors && !sensors->empty()) {
            model = {sensors->points.size(), sensors->channel_map};
            model_from = "the configuration read in the capture";
        }
    }
    lighthouse::LightDecoder dec(model);
    vive::ImuDecoder imu;
    std::array<vive::ImuSample, 3> out;
    std::string first_error;
    for (const UsbPacket& u : cap.packets) {
        if (u.bus != d.bus || u.device_address != d.address || !is_interrupt_in_completion(u))
            continue;
        if (u.endpoint == 0x81) {
            const size_t n = u.data[0] == vive::kImuReportId ? imu.decode(u.data, out) : 0;
            if (n) dec.note_imu_ticks(uint32_t(out[n - 1].ticks));
            continue;
        }
        if (!light.count(u.endpoint)) continue;
        Status st = dec.decode_report(u.data);
        if (!st && first_error.empty()) first_error = st.error().message;
    }
    dec.finish();
    std::vector<lighthouse::LightEvent> events;
    dec.take_events(events);
    const lighthouse::LightCounters& c = dec.counters();
    std::printf("    light (lighthouse):\n");
    std::printf("      sensor model          %zu sensors (%s)\n",
                model.channel_map.empty() ? model.count : model.channel_map.size(),
                model_from.c_str());
    std::printf("      reports               %llu, %llu refused%s%s\n",
                (unsigned long long)c.reports, (unsigned long long)c.rejected,
                first_error.empty() ? "" : "; first: ", first_error.c_str());
    std::printf("      events                %llu hits, %llu syncs\n", (unsigned long long)c.events,
                (unsigned long long)c.syncs);
    for (const lighthouse::BaseStationState& s : dec.base_stations()) {
        std::map<int, uint64_t> per_sensor;
        for (const lighthouse::LightEvent& e : events)
            if (e.generation == s.generation && e.base_station == s.base_station)
                ++per_sensor[e.sensor];
        std::printf("      %s %s %u: %llu syncs, %llu hits on %zu sensors; %s\n",
                    lighthouse::generation_name(s.generation),
                    s.generation == lighthouse::Generation::lh1 ? "base station" : "channel",
                    unsigned(s.base_station), (unsigned long long)s.syncs,
                    (unsigned long long)s.events, per_sensor.size(),
                    dec.calibration_status(s.generation, s.base_station).c_str());
        std::string line;
        for (auto [sensor, n] : per_sensor)
            line += " " + std::to_string(sensor) + ":" + std::to_string(n);
        if (!line.empty()) std::printf("        hits per sensor%s\n", line.c_str());
    }
    for (const std::string& w : dec.take_warnings()) std::printf("      warning: %s\n", w.c_str());
}

void run_info(const std::string& file, const std::string& device) {
    auto cap = read_usbmon_capture(file);
    if (!cap) return errors.fail(cap.error().message);
    for (const std::string& w : cap->warnings) errors.warning(w);
    CaptureSummary s = summarize_capture(*cap);
    const std::string sidecar = file + ".usbdevs";
    if (std::filesystem::exists(sidecar)) {
        auto r = apply_usbdevs_sidecar(sidecar, &s);
        if (!r) return errors.fail(r.error().message);
    }
    if (!device.empty()) {
        auto f = parse_vid_pid(device);
        if (!f) return errors.usage(f.error().message);
        size_t unknown = 0;
        for (const auto& d : s.devices) unknown += d.id_source.empty() ? 1 : 0;
        for (auto& d : s.devices)
            if (d.id_source.empty() && unknown == 1) {
                d.vendor_id = f->vendor_id;
                d.product_id = f->product_id;
                d.id_source = "given";
            }
    }
    std::printf("%s\n", file.c_str());
    std::printf("  link type %d (%s), %llu usbmon events over %.3f s\n", s.link_type,
                s.link_type == 220 ? "DLT_USB_LINUX_MMAPPED" : "DLT_USB_LINUX",
                (unsigned long long)s.packets, ns_to_s(s.last_ns - s.first_ns));
    for (const CaptureDeviceSummary& d : s.devices) {
        std::printf(
            "  device bus %u address %u: %s (%s)%s%s\n", d.bus, d.address,
            d.id_source.empty() ? "????:????" : format_vid_pid(d.vendor_id, d.product_id).c_str(),
            d.id_source.empty() ? "id unknown: give --device VID:PID"
                                : ("from " + d.id_source).c_str(),
            d.label.empty() ? "" : " ", d.label.c_str());
        for (const CaptureEndpointSummary& e : d.endpoints) {
            std::printf("    endpoint 0x%02x %-11s %s: %llu completions, %llu bytes, %.1f /s",
                        e.endpoint, transfer_name(e.transfer_type),
                        (e.endpoint & 0x80) ? "IN " : "OUT", (unsigned long long)e.completions,
                        (unsigned long long)e.bytes, e.rate_hz());
            if (!e.report_ids.empty()) {
                std::printf("; report ids");
                const double span = ns_to_s(e.last_ns - e.first_ns);
                for (const auto& [id, count] : e.report_ids)
                    std::printf(" 0x%02x x%llu (%.1f /s)", id, (unsigned long long)count,
                                span > 0 ? double(count) / span : 0.0);
            }
            std::printf("\n");
        }
        if (!d.id_source.empty() && has_codec(d.vendor_id, d.product_id)) print_decoded(*cap, d);
        if (!d.id_source.empty() && d.vendor_id == vive::kVendorId) print_light(*cap, d);
    }
}

void add_capture_command(CLI::App& app) {
    CLI::App* c = app.add_subcommand("capture", "Inspect USB captures (usbmon pcap / pcap.gz)");
    c->require_subcommand(1);
    auto file = std::make_shared<std::string>();
    auto device = std::make_shared<std::string>();
    CLI::App* info = c->add_subcommand(
        "info", "Devices, endpoints, report ids and rates, sequence gaps and decoded figures");
    info->add_option("file", *file, "Capture file (.pcap or .pcap.gz)")->required();
    info->add_option("--device", *device,
                     "VID:PID for the one device the capture does not identify");
    info->callback([=] { run_info(*file, *device); });
}

static const CommandRegistration reg{60, add_capture_command};

}  // namespace
}  // namespace hmdnode::tool
