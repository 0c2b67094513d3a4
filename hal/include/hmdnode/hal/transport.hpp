// The byte transport under every real tracker: one HID-class device (an input-report stream,
// feature reports, output reports), whatever carries it -- hidapi over hidraw, libusb interrupt
// transfers, a usbmon capture being replayed, or a simulated device's firmware running on the
// host. Report codecs and the tracker above see only this interface, so a recording and a
// simulated device exercise exactly the code a live device does.
//
// No backend type (hid_device, libusb_device_handle, pcap_t) appears here.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
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
    // The USB device the interface belongs to ("usb:1-4": bus and ports; a virtual device's
    // "phys:NAME", hidraw_usb_device()), shared by all its interfaces; empty when the backend
    // cannot tell (transport/interface_group.hpp groups by it).
    std::string usb_device;
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
    // True for a replayed capture: its feature reports are the first answer of each id the capture
    // holds, not a device's exchange (a multi-report read such as a configuration cannot run).
    virtual bool replayed() const { return false; }
};

// A device arriving or leaving, as a hotplug monitor saw it.
struct HotplugEvent {
    enum class Kind { arrived, left };
    Kind kind = Kind::arrived;
    DeviceId id;  // for `left`, what the monitor knew of it (at least the path)
};

// Watches one backend's devices come and go. One thread at a time calls wait().
class HotplugMonitor {
  public:
    virtual ~HotplugMonitor() = default;
    // Waits up to timeout_ms (0: poll, -1: forever) for one event matching the filter the monitor
    // was created with. nullopt on a timeout; an error when the monitor itself failed.
    virtual Result<std::optional<HotplugEvent>> wait(int timeout_ms) = 0;
};

// Discovers and opens devices of one backend. Unless a backend says otherwise, one thread at a
// time uses a backend and the transports it opened.
class TransportBackend {
  public:
    virtual ~TransportBackend() = default;
    virtual std::string name() const = 0;  // "hidapi", "libusb", "sim", "capture"
    virtual Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) = 0;
    virtual Result<std::unique_ptr<Transport>> open(const DeviceId& id) = 0;
    // Hotplug notices for devices matching `filter`; an error when the backend (or the platform)
    // cannot provide them -- the caller then polls enumerate() instead.
    virtual Result<std::unique_ptr<HotplugMonitor>> watch(const DeviceFilter& filter) {
        (void)filter;
        return make_error(name() + ": hotplug notices are not supported");
    }
};

// "28de:2000" (hex, case-insensitive, 1-4 digits each) -> a filter on that vendor/product id, or
// "28de:2000:SERIAL" with a serial too. Errors name the text and what is wrong with it.
Result<DeviceFilter> parse_vid_pid(std::string_view text);
// "28de:2000", lower-case, four digits each.
std::string format_vid_pid(uint16_t vendor_id, uint16_t product_id);

// The USB device a hidraw node ("/dev/hidraw3") belongs to, as DeviceId::usb_device has it
// ("usb:1-4"): from SYSFS/class/hidraw/hidraw3/device, which for a USB HID interface resolves to
// .../1-4/1-4:1.0/0003:28DE:2000.0004 (the HID device, under the interface, under the USB
// device). A node under no USB device (a uhid device) whose HID_PHYS (the HID device's uevent)
// ends in /inputN, as a USB interface's does, gives "phys:" and the part before it, and N as
// *interface_number. Empty otherwise (Bluetooth: its HID_PHYS is the adapter's address) or when
// sysfs does not say. The hidapi backend's enumerate() fills usb_device with it (and the
// interface number where hidapi has none); exposed so the resolution can be tested on a made-up
// sysfs tree.
std::string hidraw_usb_device(const std::string& hidraw_path, const std::string& sysfs = "/sys",
                              int* interface_number = nullptr);

// Options of the real backends.
struct TransportBackendOptions {
    // libusb: let libusb detach the kernel driver (usbhid) while the interface is claimed and
    // re-attach it on close (libusb_set_auto_detach_kernel_driver).
    bool detach_kernel_driver = true;
    // libusb: asynchronous interrupt-in transfers kept in flight (>= 1).
    int transfers_in_flight = 8;
    // hidapi hotplug: "udev" (events after udevd applied the rules; needs udevd) or "kernel"
    // (raw kernel uevents; works with no udevd, e.g. in a bare initramfs).
    std::string udev_event_source = "udev";
};

// The backend called `name`: "hidapi" (hidraw) or "libusb". ("sim" devices are made by
// create_sim_reference_backend, sim/sim_reference_device.hpp; captures by create_capture_backend,
// transport/usbmon_capture.hpp.)
Result<std::unique_ptr<TransportBackend>> create_transport_backend(
    const std::string& name, const TransportBackendOptions& options = {});
Result<std::unique_ptr<TransportBackend>> create_hidapi_backend(
    const TransportBackendOptions& options = {});
Result<std::unique_ptr<TransportBackend>> create_libusb_backend(
    const TransportBackendOptions& options = {});

// HID class-specific control requests (HID 1.11 §7.2), as the libusb backend sends them for
// feature reports. Pure functions, exposed so their bytes can be tested.
enum class HidReportType : uint8_t { input = 1, output = 2, feature = 3 };
struct UsbSetupPacket {
    uint8_t request_type = 0;  // bmRequestType
    uint8_t request = 0;       // bRequest
    uint16_t value = 0;        // wValue
    uint16_t index = 0;        // wIndex
    uint16_t length = 0;       // wLength
    // The 8 bytes on the wire (little-endian words).
    std::array<uint8_t, 8> bytes() const;
};
// GET_REPORT: bmRequestType 0xA1 (device-to-host, class, interface), bRequest 0x01,
// wValue = (type << 8) | report_id, wIndex = interface, wLength = length.
UsbSetupPacket hid_get_report_setup(HidReportType type, uint8_t report_id, uint16_t interface,
                                    uint16_t length);
// SET_REPORT: bmRequestType 0x21 (host-to-device, class, interface), bRequest 0x09.
UsbSetupPacket hid_set_report_setup(HidReportType type, uint8_t report_id, uint16_t interface,
                                    uint16_t length);

}  // namespace hmdnode
