// The byte transport under every real tracker: one HID-class device (an input-report stream,
// feature reports, output reports), whatever carries it -- hidapi over hidraw, libusb interrupt
// transfers, a usbmon capture being replayed, or a simulated device's firmware running on the
// host. Report codecs and the tracker above see only this interface, so a recording and a
// simulated device exercise exactly the code a live device does.
//
// No backend type (hid_device, libusb_device_handle, pcap_t) appears here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

struct DeviceId {
    uint16_t vendor_id = 0;
    uint16_t product_id = 0;
    std::string serial;        // may be empty
    std::string path;          // backend-specific: "/dev/hidraw3", "usb:1-4:1.0", "capture:..."
    std::string manufacturer;  // may be empty
    std::string product;       // may be empty
    int interface_number = -1;
};

// Which devices to open: vendor/product id (0 = any) and serial (empty = any).
struct DeviceFilter {
    uint16_t vendor_id = 0;
    uint16_t product_id = 0;
    std::string serial;
    bool matches(const DeviceId& id) const;
};

// One input report as it arrived: the bytes (report id first, as hidraw and hidapi give them for
// devices with numbered reports) and the host time the transport received it.
struct InputReport {
    std::vector<uint8_t> bytes;
    int64_t host_time_ns = 0;  // CLOCK_MONOTONIC (or the capture's time for a replayed capture)
};

class Transport {
  public:
    virtual ~Transport() = default;

    virtual DeviceId id() const = 0;

    // Waits up to timeout_ms (0: poll, -1: forever) for one input report. Returns nullopt on a
    // timeout; an error when the device is gone (unplugged) or the transport failed -- the caller
    // then closes it and waits for the device to come back.
    virtual Result<std::optional<InputReport>> read_input(int timeout_ms) = 0;

    // Feature report `report_id`: returns its bytes, report id first. `size` is the largest
    // report expected (including the id byte).
    virtual Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t size) = 0;
    // data[0] is the report id.
    virtual Status set_feature(std::span<const uint8_t> data) = 0;
    // Output report; data[0] is the report id.
    virtual Status write_output(std::span<const uint8_t> data) = 0;

    // True once the transport has nothing more to give (end of a replayed capture); a live
    // device never finishes, it fails.
    virtual bool finished() const { return false; }
};

// Discovers and opens devices of one backend.
class TransportBackend {
  public:
    virtual ~TransportBackend() = default;
    virtual std::string name() const = 0;  // "hidapi", "libusb", "sim", "capture"
    virtual Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) = 0;
    virtual Result<std::unique_ptr<Transport>> open(const DeviceId& id) = 0;
};

}  // namespace hmdnode
