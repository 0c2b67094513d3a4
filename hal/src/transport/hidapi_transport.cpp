// The hidapi backend (hidraw): a Transport over hid_device. Input reports through
// hid_read_timeout, feature reports through hid_get/send_feature_report, output reports through
// hid_write. hidraw hands numbered reports with the id first, which is what Transport promises.
// Cost: one read(2)/ioctl(2) per call plus a copy of the report into its own vector; enumerate()
// resolves one sysfs link per node (DeviceId::usb_device, the USB device its interfaces share).
// Departs from plain hidapi use: errors carry the device path and hid_error's text, and a device
// that is gone (poll error, ENODEV) is an error, never a silent zero-length read.
#include <cstdlib>
#include <ctime>
#include <cwchar>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <vector>

#include <hidapi/hidapi.h>

#include "transport/hidapi_transport.hpp"

namespace hmdnode {
namespace detail {

int64_t monotonic_now_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::string narrow(const wchar_t* text) {
    std::string out;
    if (!text) return out;
    for (; *text; ++text) {
        const uint32_t c = static_cast<uint32_t>(*text);
        if (c < 0x80) {
            out += static_cast<char>(c);
        } else if (c < 0x800) {
            out += static_cast<char>(0xC0 | (c >> 6));
            out += static_cast<char>(0x80 | (c & 0x3F));
        } else if (c < 0x10000) {
            out += static_cast<char>(0xE0 | (c >> 12));
            out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (c & 0x3F));
        } else {
            out += static_cast<char>(0xF0 | (c >> 18));
            out += static_cast<char>(0x80 | ((c >> 12) & 0x3F));
            out += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
            out += static_cast<char>(0x80 | (c & 0x3F));
        }
    }
    return out;
}

}  // namespace detail

namespace {

std::string hid_error_text(hid_device* dev) {
    std::string t = detail::narrow(hid_error(dev));
    return t.empty() ? "unknown hidapi error" : t;
}

Status ensure_hid_init() {
    static std::once_flag once;
    static int rc = 0;
    std::call_once(once, [] { rc = hid_init(); });
    if (rc != 0) return make_error("hidapi: hid_init failed: " + hid_error_text(nullptr));
    return {};
}

DeviceId to_device_id(const hid_device_info& info) {
    DeviceId id;
    id.vendor_id = info.vendor_id;
    id.product_id = info.product_id;
    id.serial = detail::narrow(info.serial_number);
    id.path = info.path ? info.path : "";
    id.manufacturer = detail::narrow(info.manufacturer_string);
    id.product = detail::narrow(info.product_string);
    id.interface_number = info.interface_number;
    int from_phys = -1;
    id.usb_device = hidraw_usb_device(id.path, "/sys", &from_phys);
    if (id.interface_number < 0) id.interface_number = from_phys;
    return id;
}

class HidapiTransport final : public Transport {
  public:
    HidapiTransport(hid_device* dev, DeviceId id) : dev_(dev), id_(std::move(id)) {
        buffer_.resize(4096);
    }
    ~HidapiTransport() override { hid_close(dev_); }

    DeviceId id() const override { return id_; }

    Result<std::optional<InputReport>> read_input(int timeout_ms) override {
        if (gone_) return make_error(id_.path + ": device is gone (" + gone_reason_ + ")");
        const int n = hid_read_timeout(dev_, buffer_.data(), buffer_.size(), timeout_ms);
        if (n < 0) {
            gone_ = true;
            gone_reason_ = hid_error_text(dev_);
            return make_error(id_.path + ": reading an input report failed: " + gone_reason_);
        }
        if (n == 0) return std::optional<InputReport>{};
        InputReport r;
        r.host_time_ns = detail::monotonic_now_ns();
        r.bytes.assign(buffer_.begin(), buffer_.begin() + n);
        return std::optional<InputReport>{std::move(r)};
    }

    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t size) override {
        if (size < 1) size = 1;
        std::vector<uint8_t> buf(size, 0);
        buf[0] = report_id;
        const int n = hid_get_feature_report(dev_, buf.data(), buf.size());
        if (n < 0)
            return make_error(id_.path + ": getting feature report " + std::to_string(report_id) +
                              " failed: " + hid_error_text(dev_));
        buf.resize(static_cast<size_t>(n));
        return buf;
    }

    Status set_feature(std::span<const uint8_t> data) override {
        if (data.empty()) return make_error(id_.path + ": empty feature report");
        const int n = hid_send_feature_report(dev_, data.data(), data.size());
        if (n < 0)
            return make_error(id_.path + ": sending feature report " + std::to_string(data[0]) +
                              " failed: " + hid_error_text(dev_));
        return {};
    }

    Status write_output(std::span<const uint8_t> data) override {
        if (data.empty()) return make_error(id_.path + ": empty output report");
        const int n = hid_write(dev_, data.data(), data.size());
        if (n < 0)
            return make_error(id_.path + ": writing output report " + std::to_string(data[0]) +
                              " failed: " + hid_error_text(dev_));
        return {};
    }

  private:
    hid_device* dev_;
    DeviceId id_;
    std::vector<uint8_t> buffer_;
    bool gone_ = false;
    std::string gone_reason_;
};

class HidapiBackend final : public TransportBackend {
  public:
    explicit HidapiBackend(TransportBackendOptions options) : options_(std::move(options)) {}

    std::string name() const override { return "hidapi"; }

    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) override {
        if (Status s = ensure_hid_init(); !s.ok()) return s.error();
        std::vector<DeviceId> out;
        // note: hid_enumerate returns null both for "none found" and for failures; with no
        // device (the common case here) there is nothing to report, so null is an empty list.
        hid_device_info* list = hid_enumerate(filter.vendor_id, filter.product_id);
        for (hid_device_info* d = list; d; d = d->next) {
            DeviceId id = to_device_id(*d);
            if (filter.matches(id)) out.push_back(std::move(id));
        }
        hid_free_enumeration(list);
        return out;
    }

    Result<std::unique_ptr<Transport>> open(const DeviceId& id) override {
        if (Status s = ensure_hid_init(); !s.ok()) return s.error();
        if (id.path.empty())
            return make_error("hidapi: cannot open " + format_vid_pid(id.vendor_id, id.product_id) +
                              ": no device path (enumerate first)");
        hid_device* dev = hid_open_path(id.path.c_str());
        if (!dev)
            return make_error("hidapi: cannot open " + id.path + " (" +
                              format_vid_pid(id.vendor_id, id.product_id) +
                              "): " + hid_error_text(nullptr) +
                              " -- is it plugged in, and do the udev rules (docs/udev.md) give "
                              "this user access?");
        return std::unique_ptr<Transport>(new HidapiTransport(dev, id));
    }

    Result<std::unique_ptr<HotplugMonitor>> watch(const DeviceFilter& filter) override {
        return detail::create_hidraw_hotplug_monitor(filter, options_.udev_event_source);
    }

  private:
    TransportBackendOptions options_;
};

}  // namespace

std::string hidraw_usb_device(const std::string& hidraw_path, const std::string& sysfs,
                              int* interface_number) {
    namespace fs = std::filesystem;
    const std::string name = fs::path(hidraw_path).filename().string();
    if (name.rfind("hidraw", 0) != 0) return {};
    std::error_code ec;
    const fs::path link = fs::path(sysfs) / "class" / "hidraw" / name / "device";
    const fs::path hid = fs::canonical(link, ec);
    if (ec) return {};
    // The HID device's parent is the USB interface ("1-4:1.0"), whose parent is the USB device
    // ("1-4"): BUS-PORT[.PORT...], digits, '-' and '.' only.
    const std::string interface = hid.parent_path().filename().string();
    const std::string device = hid.parent_path().parent_path().filename().string();
    if (!device.empty() && interface.rfind(device + ":", 0) == 0 &&
        device.find_first_not_of("0123456789-.") == std::string::npos &&
        device.find('-') != std::string::npos)
        return "usb:" + device;
    // Not under a USB device (uhid): its HID_PHYS, when it ends in /inputN as a USB interface's
    // does ("usb-0000:00:14.0-4/input1"), names the device by the part before it.
    std::ifstream uevent(hid / "uevent");
    for (std::string line; std::getline(uevent, line);) {
        if (line.rfind("HID_PHYS=", 0) != 0) continue;
        const std::string phys = line.substr(9);
        const size_t at = phys.rfind("/input");
        if (at == std::string::npos || at == 0 || at + 6 >= phys.size() ||
            phys.find_first_not_of("0123456789", at + 6) != std::string::npos)
            return {};
        if (interface_number) *interface_number = std::atoi(phys.c_str() + at + 6);
        return "phys:" + phys.substr(0, at);
    }
    return {};
}

Result<std::unique_ptr<TransportBackend>> create_hidapi_backend(
    const TransportBackendOptions& options) {
    if (Status s = ensure_hid_init(); !s.ok()) return s.error();
    return std::unique_ptr<TransportBackend>(new HidapiBackend(options));
}

}  // namespace hmdnode
