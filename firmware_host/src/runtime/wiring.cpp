// The one wiring place (wiring.hpp), its second half: backend specs -> clock, tracker, display,
// renderer (the names and the checks: wiring_names.cpp).
#include "hmdnode/firmware_host/wiring.hpp"

#include <chrono>
#include <filesystem>
#include <system_error>

#include <spdlog/spdlog.h>

#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"
#include "hmdnode/hal/transport/interface_group.hpp"
#include "hmdnode/render/vk_display.hpp"
#include "vk_display_pacing.hpp"

namespace hmdnode {

std::unique_ptr<Clock> make_clock(ClockKind kind, int64_t sim_start_ns) {
    if (kind == ClockKind::sim) return std::make_unique<SimulatedClock>(sim_start_ns);
    return std::make_unique<SystemClock>();
}

Result<std::unique_ptr<EyeTracker>> make_eye_tracker(const EyeTrackerSpec& spec, Clock& clock,
                                                     const WiringKeys& keys) {
    if (spec.backend == EyeTrackerBackend::none) return std::unique_ptr<EyeTracker>();
    if (!spec.trace)
        return make_error(keys.eye_tracker + " trace needs a trace (" + keys.trace + ")");
    SimEyeTrackerConfig c;
    c.host_start_ns = clock.now_ns();
    c.start_offset_ns = s_to_ns(spec.start_s);
    c.duration_ns = s_to_ns(spec.duration_s);
    c.latency_ns = spec.latency_ns;
    Result<std::unique_ptr<EyeTracker>> t = create_sim_eye_tracker(spec.trace, clock, c);
    if (!t.ok())
        return make_error(keys.eye_tracker + " trace: " + spec.trace_path.string() + ": " +
                          t.error().message);
    return t;
}

namespace {

// The stored setup of a spec: its file, or none yet when the tracker is to place the base
// stations and the file does not exist.
Result<std::vector<lighthouse::BaseStationPlacement>> load_setup(const TrackerSpec& spec) {
    std::error_code ec;
    if (spec.place_base_stations && !std::filesystem::exists(spec.base_stations, ec))
        return std::vector<lighthouse::BaseStationPlacement>{};
    auto loaded = lighthouse::load_base_station_setup(spec.base_stations);
    if (!loaded) return make_error("base stations: " + loaded.error().message);
    return std::move(*loaded);
}

}  // namespace

Result<size_t> stored_base_stations(const TrackerSpec& spec) {
    if (spec.base_stations.empty()) return size_t(0);
    auto s = load_setup(spec);
    if (!s) return s.error();
    return s->size();
}

Status save_placed_setup(const TrackerSpec& spec, const DeviceTracker& tracker, size_t* stored) {
    if (!spec.place_base_stations || spec.base_stations.empty()) return {};
    const DeviceTrackerStatus st = tracker.status();
    if (st.light.setup.size() <= *stored) return {};
    std::vector<lighthouse::BaseStationPlacement> setup = st.light.setup;
    const int64_t now = std::chrono::duration_cast<std::chrono::seconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    for (lighthouse::BaseStationPlacement& p : setup)
        if (p.solved_unix_s == 0 && p.residual_rms_rad > 0) p.solved_unix_s = now;
    if (Status w = lighthouse::save_base_station_setup(spec.base_stations, setup); !w) return w;
    *stored = setup.size();
    return {};
}

Result<WiredTracker> make_tracker(const TrackerSpec& spec, Clock& clock, const WiringKeys& keys) {
    if (Status st =
            check_tracker_spec(spec, clock.is_simulated() ? ClockKind::sim : ClockKind::real, keys);
        !st.ok())
        return st.error();
    if (spec.backend == TrackerBackend::capture || spec.backend == TrackerBackend::rec)
        if (std::error_code ec; !std::filesystem::is_regular_file(spec.from, ec))
            return make_error(keys.from + " " + spec.from.string() + ": no such file");
    const int64_t now = clock.now_ns();
    WiredTracker out;
    auto adopt = [&](Result<std::unique_ptr<DeviceTracker>> t) -> Result<WiredTracker> {
        if (!t.ok()) return t.error();
        out.device = t->get();
        out.tracker = std::move(*t);
        return std::move(out);
    };
    switch (spec.backend) {
        case TrackerBackend::trace: {
            SimTrackerConfig tc = spec.sim;
            tc.host_start_ns = now;
            tc.start_offset_ns = s_to_ns(spec.start_s);
            tc.duration_ns = s_to_ns(spec.duration_s);
            if (!spec.trace) return make_error(keys.trace + ": not loaded");
            Result<std::unique_ptr<Tracker>> t = create_sim_tracker(spec.trace, clock, tc);
            if (!t.ok()) return make_error(spec.trace_path.string() + ": " + t.error().message);
            out.tracker = std::move(*t);
            out.label = "trace " + spec.trace_path.string();
            return out;
        }
        case TrackerBackend::capture: {
            // The report start_s after the capture's first one arrives now; the earlier ones at
            // once (decoded and fused, not shown), so the pose at the start is the live one.
            out.label = spec.device + " from capture " + spec.from.string();
            std::vector<lighthouse::BaseStationPlacement> setup;
            if (!spec.base_stations.empty()) {  // 6DoF from the light
                auto loaded = load_setup(spec);
                if (!loaded) return loaded.error();
                setup = std::move(*loaded);
                out.label += " with the base stations of " + spec.base_stations.string();
            }
            return adopt(create_capture_tracker(
                spec.from, spec.device, clock, now - s_to_ns(spec.start_s), std::move(setup),
                glm::dvec3(0, 0, 1), spec.place_base_stations && !spec.base_stations.empty()));
        }
        case TrackerBackend::rec: {
            Result<SurviveRecording> r = read_survive_recording(spec.from, spec.device);
            if (!r.ok()) return r.error();
            out.label = spec.device + " from libsurvive recording " + spec.from.string();
            std::shared_ptr<const LightTrackingConfig> light;
            if (!spec.base_stations.empty()) {  // 6DoF from the light
                auto setup = load_setup(spec);
                if (!setup) return setup.error();
                auto cfg = survive_light_tracking_config(*r, std::move(*setup));
                if (!cfg)
                    return make_error(spec.base_stations.string() + ": " + cfg.error().message);
                cfg->place.enabled = spec.place_base_stations;
                light = std::make_shared<const LightTrackingConfig>(std::move(*cfg));
                out.label += " with the base stations of " + spec.base_stations.string();
            }
            return adopt(
                create_survive_tracker(std::make_shared<const SurviveRecording>(std::move(*r)),
                                       clock, now, {}, std::move(light)));
        }
        case TrackerBackend::sim:
        case TrackerBackend::hidapi:
        case TrackerBackend::libusb: {
            DeviceFilter filter;
            filter.vendor_id = refproto::kDevVendorId;
            filter.product_id = refproto::kDevProductId;
            if (!spec.device.empty()) filter = *parse_vid_pid(std::string_view(spec.device));
            std::unique_ptr<TransportBackend> backend;
            if (spec.backend == TrackerBackend::sim) {
                SimReferenceDeviceConfig sc;
                sc.vendor_id = filter.vendor_id;
                sc.product_id = filter.product_id;
                if (!filter.serial.empty()) sc.serial = filter.serial;
                backend = create_sim_reference_backend(
                    clock, sc,
                    spec.trace ? motion_from_trace(spec.trace, now) : sinusoidal_motion());
            } else {
                auto b = create_transport_backend(tracker_backend_name(spec.backend));
                if (!b.ok())
                    return make_error(keys.backend + " " + tracker_backend_name(spec.backend) +
                                      ": " + b.error().message);
                backend = std::move(*b);
            }
            if (spec.wrap_backend) backend = spec.wrap_backend(std::move(backend));
            out.label = format_vid_pid(filter.vendor_id, filter.product_id) + " via " +
                        tracker_backend_name(spec.backend);
            DeviceTrackerConfig tc;
            tc.filter = filter;
            if (!spec.base_stations.empty()) {  // 6DoF from the device's light interface
                auto setup = load_setup(spec);
                if (!setup) return setup.error();
                // The sensor model comes with the configuration the codec reads at the open; the
                // light reports from the device's other HID interface, merged with the IMU's.
                auto light = std::make_shared<LightTrackingConfig>();
                light->setup = std::move(*setup);
                light->place.enabled = spec.place_base_stations;
                light->filter.world_up = glm::dvec3(0, 0, 1);  // a setup file's world
                tc.light = std::move(light);
                backend = group_interfaces(
                    std::move(backend), interface_reading_for(tracker_backend_name(spec.backend)));
                out.label += " with the base stations of " + spec.base_stations.string();
            }
            return adopt(create_device_tracker(std::move(backend),
                                               make_codec_for(filter.vendor_id, filter.product_id),
                                               clock, tc));
        }
    }
    return make_error("unhandled tracker backend");
}

Result<std::unique_ptr<Display>> make_display(const DisplaySpec& spec, Clock& clock,
                                              const WiringKeys& keys) {
    if (Status st = check_display_spec(spec, keys); !st.ok()) return st.error();
    // One branch per display type.
    if (spec.type == "mock") {
        MockDisplayConfig dc = spec.mock;
        dc.vsync_epoch_ns = clock.now_ns();
        if (spec.mock_watcher) {
            Result<PanelWatcher*> w = spec.mock_watcher(clock, dc);
            if (!w.ok()) return w.error();
            dc.watcher = *w;
        }
        return create_mock_display(clock, dc);
    }
    if (spec.type == "kms") {
        auto k = create_kms_display(clock, spec.kms);
        if (!k.ok()) return k.error();
        spdlog::info("display: {} {}x{}@{:.3f} Hz, {} modeset{}", (*k)->info().name,
                     (*k)->mode().width, (*k)->mode().height, (*k)->mode().refresh_hz,
                     (*k)->modeset_path(),
                     (*k)->hardware_vblank() ? "" : ", no vblank interrupt: flips on a timer");
        return std::unique_ptr<Display>(std::move(*k));
    }
    if (spec.type == "vk-display") {
        VulkanDisplayOutputConfig vc;
        vc.display = spec.kms.connector;
        if (!spec.kms.mode.empty()) {
            auto m = parse_kms_mode(spec.kms.mode);
            if (!m.ok()) return m.error();
            vc.width = m->width;
            vc.height = m->height;
            vc.refresh_hz = m->refresh_hz;
        }
        auto out = create_vulkan_display_output(vc);
        if (!out.ok()) return out.error();
        const VulkanDisplayMode m = (*out)->mode();
        spdlog::info("display: vk-display \"{}\" on {} {}x{}@{:.3f} Hz, {}", (*out)->display().name,
                     (*out)->display().gpu, m.width, m.height, m.refresh_hz, (*out)->describe());
        return make_vk_display_pacing(clock, std::move(*out), spec.kms.latch_margin_ns,
                                      spec.kms.persistence_ns);
    }
    return make_error(keys.display + " \"" + spec.type + "\" is not available");
}

Result<std::unique_ptr<Renderer>> make_renderer(const RendererSpec& spec, const DisplayInfo& panel,
                                                const WiringKeys& keys) {
    RendererConfig rc = spec.config;
    if (!spec.type.empty()) rc.backend = spec.type;
    // The backend named, else HMDNODE_RENDERER's, else vulkan (render/renderer.hpp).
    if (Result<std::string> b = resolve_renderer_backend(rc); !b.ok())
        return rc.backend.empty() ? b.error()  // HMDNODE_RENDERER's: the error names it
                                  : make_error(keys.renderer + ": " + b.error().message);
    rc.eye_width = panel.eye_width;
    rc.eye_height = panel.eye_height;
    return create_renderer(rc);
}

Result<std::unique_ptr<Renderer>> make_renderer(const RendererSpec& spec, Display& display,
                                                const WiringKeys& keys, bool* zero_copy) {
    if (zero_copy) *zero_copy = false;
    auto* kms = dynamic_cast<KmsDisplay*>(&display);
    if (!kms) return make_renderer(spec, display.info(), keys);
    RendererSpec rs = spec;
    if (!spec.type.empty()) rs.config.backend = spec.type;
    Result<std::string> backend = resolve_renderer_backend(rs.config);
    if (backend.ok() && *backend == "gles") {
        rs.config.scanout = kms->scanout_target();
        auto r = make_renderer(rs, display.info(), keys);
        if (!r.ok()) return r.error();
        Renderer* renderer = r->get();
        if (Status st = kms->attach_buffers(
                renderer->scanout_buffers(),
                KmsBufferSource{[renderer] { return renderer->scanout_drawn(); },
                                [renderer](int b) { renderer->scanout_committed(b); }});
            !st.ok())
            return st.error();
        spdlog::info("display: kms scan-out: GBM zero-copy, {}", renderer->scanout_describe());
        if (zero_copy) *zero_copy = true;
        return r;
    }
    spdlog::info(
        "display: kms scan-out: dumb-buffer copy (the {} renderer's frames read back and copied; "
        "zero-copy needs renderer.backend gles)",
        backend.ok() ? *backend : std::string("default"));
    return make_renderer(spec, display.info(), keys);
}

}  // namespace hmdnode
