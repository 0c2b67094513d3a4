// Test helper: one device of a usbmon capture through the light decoder, as a live device's
// reports would arrive (the IMU endpoint's reports 0x20 give the tick reference that extends the
// lighthouse-2 reports' 24-bit times; the light endpoint's reports are decoded), with the sensor
// model of the configuration read the capture recorded.
#pragma once

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

namespace hmdnode::test {

struct DecodedCapture {
    lighthouse::LightDecoder dec;
    size_t sensors = 0;                         // the device's model
    std::map<uint8_t, uint64_t> reports_by_id;  // light endpoint, by report id
    std::map<uint8_t, uint64_t> rejected_by_id;
    std::vector<std::string> errors;
    std::vector<lighthouse::LightEvent> events;
    std::vector<lighthouse::SyncEvent> syncs;
    std::vector<std::string> warnings;
    explicit DecodedCapture(lighthouse::SensorModel m) : dec(std::move(m)) {}
};

inline std::unique_ptr<DecodedCapture> decode_light_capture(const std::string& path, uint16_t bus,
                                                            uint8_t address,
                                                            uint8_t light_endpoint) {
    auto cap = read_usbmon_capture(path);
    EXPECT_TRUE(cap.ok()) << cap.error().message;
    if (!cap) return nullptr;
    auto json = capture_lighthouse_config(*cap, bus, address);
    EXPECT_TRUE(json.ok()) << json.error().message;
    if (!json) return nullptr;
    auto sensors = parse_lighthouse_sensors(*json, path);
    EXPECT_TRUE(sensors.ok()) << sensors.error().message;
    if (!sensors) return nullptr;
    auto d = std::make_unique<DecodedCapture>(
        lighthouse::SensorModel{sensors->points.size(), sensors->channel_map});
    d->sensors = sensors->points.size();
    vive::ImuDecoder imu;
    std::array<vive::ImuSample, 3> out;
    for (const UsbPacket& u : cap->packets) {
        if (!is_interrupt_in_completion(u) || u.bus != bus || u.device_address != address) continue;
        if (u.endpoint == 0x81 && u.data[0] == vive::kImuReportId) {
            const size_t n = imu.decode(u.data, out);
            if (n) d->dec.note_imu_ticks(uint32_t(out[n - 1].ticks));
            continue;
        }
        if (u.endpoint != light_endpoint) continue;
        ++d->reports_by_id[u.data[0]];
        Status st = d->dec.decode_report(u.data);
        if (!st) {
            ++d->rejected_by_id[u.data[0]];
            d->errors.push_back(st.error().message);
        }
    }
    d->dec.finish();
    d->dec.take_events(d->events);
    d->dec.take_syncs(d->syncs);
    d->warnings = d->dec.take_warnings();
    return d;
}

}  // namespace hmdnode::test
