// The libusb backend: a HID-class interface driven directly over USB. enumerate() lists each HID
// interface with an interrupt-IN endpoint (path "usb:BUS-PORTS:1.N", usb_device "usb:BUS-PORTS");
// open() takes the interface the id's path names (without a path: the device's first), by VID:PID
// (+ serial), optionally lets libusb detach the kernel's usbhid driver
// (libusb_set_auto_detach_kernel_driver), claims the interface, finds its interrupt-IN (and, if
// any, interrupt-OUT) endpoint and keeps TransportBackendOptions::transfers_in_flight asynchronous
// interrupt-IN transfers submitted (libusb_fill_interrupt_transfer / libusb_submit_transfer,
// resubmitted from their callback), so a 1 kHz device never waits for the host to ask. read_input()
// runs libusb's event handling with the caller's timeout. Feature reports are HID class control
// transfers (HID 1.11 §7.2.1/§7.2.2: GET_REPORT 0xA1/0x01, SET_REPORT 0x21/0x09, wValue = (3 << 8)
// | id). Hotplug uses libusb_hotplug_register_callback where
// libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG). Cost: one transfer completion per report, one copy
// into the report's vector; memory transfers_in_flight x wMaxPacketSize plus the queue of unread
// reports (bounded: the oldest is dropped past 4096 and counted). Departs from hidapi's libusb
// backend: no reader thread -- events are handled in the caller's read, which keeps every libusb
// call on one thread; a report id 0 (unnumbered reports) is still put first, so callers see the
// same layout as from hidraw.
#include <sys/time.h>

#include <deque>
#include <memory>
#include <vector>

#include <libusb.h>

#include "transport/hidapi_transport.hpp"

namespace hmdnode {
namespace {

using ContextPtr = std::shared_ptr<libusb_context>;

std::string usb_error(int rc) {
    return std::string(libusb_error_name(rc)) + " (" + libusb_strerror(rc) + ")";
}

// "usb:BUS-PORT.PORT": the device, as every interface of it shares it (DeviceId::usb_device).
std::string usb_device_path(libusb_device* dev) {
    uint8_t ports[8];
    const int n = libusb_get_port_numbers(dev, ports, sizeof ports);
    std::string p = "usb:" + std::to_string(libusb_get_bus_number(dev)) + "-";
    for (int i = 0; i < n; ++i) {
        if (i) p += ".";
        p += std::to_string(ports[i]);
    }
    if (n <= 0) p += "0";
    return p;
}

// "usb:BUS-PORTS:1.INTERFACE": one interface (DeviceId::path).
std::string usb_path(libusb_device* dev, int interface_number) {
    return usb_device_path(dev) + ":1." +
           std::to_string(interface_number < 0 ? 0 : interface_number);
}

struct HidEndpoints {
    int interface_number = -1;
    uint8_t in_endpoint = 0;
    uint16_t in_packet_size = 0;
    uint8_t out_endpoint = 0;  // 0: none
};

// Every HID-class interface with an interrupt-IN endpoint, in descriptor order (a Vive or an
// Index: interface 0 its IMU, 1 its light sensors).
std::vector<HidEndpoints> find_hid_interfaces(libusb_device* dev) {
    libusb_config_descriptor* cfg = nullptr;
    if (libusb_get_active_config_descriptor(dev, &cfg) != 0 &&
        libusb_get_config_descriptor(dev, 0, &cfg) != 0)
        return {};
    std::vector<HidEndpoints> found;
    for (int i = 0; i < cfg->bNumInterfaces; ++i) {
        const libusb_interface& intf = cfg->interface[i];
        for (int a = 0; a < intf.num_altsetting; ++a) {
            const libusb_interface_descriptor& d = intf.altsetting[a];
            if (d.bInterfaceClass != LIBUSB_CLASS_HID) continue;
            HidEndpoints e;
            e.interface_number = d.bInterfaceNumber;
            for (int k = 0; k < d.bNumEndpoints; ++k) {
                const libusb_endpoint_descriptor& ep = d.endpoint[k];
                if ((ep.bmAttributes & 0x3) != LIBUSB_TRANSFER_TYPE_INTERRUPT) continue;
                if (ep.bEndpointAddress & LIBUSB_ENDPOINT_IN) {
                    if (!e.in_endpoint) {
                        e.in_endpoint = ep.bEndpointAddress;
                        e.in_packet_size = ep.wMaxPacketSize;
                    }
                } else if (!e.out_endpoint) {
                    e.out_endpoint = ep.bEndpointAddress;
                }
            }
            if (e.in_endpoint) {
                found.push_back(e);
                break;  // the first alternate setting of an interface that has one
            }
        }
    }
    libusb_free_config_descriptor(cfg);
    return found;
}

std::string read_string(libusb_device_handle* h, uint8_t index) {
    if (!index || !h) return {};
    unsigned char buf[256];
    const int n = libusb_get_string_descriptor_ascii(h, index, buf, sizeof buf);
    return n > 0 ? std::string(reinterpret_cast<char*>(buf), static_cast<size_t>(n)) : "";
}

// The DeviceIds of a device, one per HID interface (first: the lowest in descriptor order; none
// when it has no HID interface with an interrupt-IN endpoint); opens it briefly for the strings
// when `strings` (which may fail without permission: the strings then stay empty). `ep`, when
// given, receives each id's endpoints.
std::vector<DeviceId> describe(libusb_device* dev, bool strings,
                               std::vector<HidEndpoints>* ep = nullptr) {
    libusb_device_descriptor desc{};
    if (libusb_get_device_descriptor(dev, &desc) != 0) return {};
    const std::vector<HidEndpoints> interfaces = find_hid_interfaces(dev);
    if (ep) *ep = interfaces;
    if (interfaces.empty()) return {};
    DeviceId id;
    id.vendor_id = desc.idVendor;
    id.product_id = desc.idProduct;
    id.usb_device = usb_device_path(dev);
    if (strings) {
        libusb_device_handle* h = nullptr;
        if (libusb_open(dev, &h) == 0) {
            id.serial = read_string(h, desc.iSerialNumber);
            id.manufacturer = read_string(h, desc.iManufacturer);
            id.product = read_string(h, desc.iProduct);
            libusb_close(h);
        }
    }
    std::vector<DeviceId> out;
    for (const HidEndpoints& e : interfaces) {
        id.interface_number = e.interface_number;
        id.path = usb_path(dev, e.interface_number);
        out.push_back(id);
    }
    return out;
}

class LibusbTransport final : public Transport {
  public:
    LibusbTransport(ContextPtr ctx, libusb_device_handle* h, DeviceId id, HidEndpoints ep,
                    int in_flight)
        : ctx_(std::move(ctx)), handle_(h), id_(std::move(id)), ep_(ep) {
        const int size = ep_.in_packet_size ? ep_.in_packet_size : 64;
        transfers_.resize(static_cast<size_t>(in_flight < 1 ? 1 : in_flight));
        buffers_.resize(transfers_.size(), std::vector<uint8_t>(static_cast<size_t>(size)));
        for (size_t i = 0; i < transfers_.size(); ++i) {
            transfers_[i] = libusb_alloc_transfer(0);
            libusb_fill_interrupt_transfer(transfers_[i], handle_, ep_.in_endpoint,
                                           buffers_[i].data(), size, &LibusbTransport::on_done,
                                           this, 0);
        }
    }

    Status start() {
        for (libusb_transfer* t : transfers_) {
            const int rc = libusb_submit_transfer(t);
            if (rc != 0)
                return make_error(id_.path +
                                  ": submitting an interrupt-IN transfer failed: " + usb_error(rc));
            ++active_;
        }
        return {};
    }

    ~LibusbTransport() override {
        for (libusb_transfer* t : transfers_) libusb_cancel_transfer(t);
        // note: transfers must not be freed while libusb still owns them; wait (bounded) for
        // their cancellation callbacks.
        for (int i = 0; i < 100 && active_ > 0; ++i) {
            timeval tv{0, 10'000};
            libusb_handle_events_timeout_completed(ctx_.get(), &tv, nullptr);
        }
        if (active_ == 0)
            for (libusb_transfer* t : transfers_) libusb_free_transfer(t);
        libusb_release_interface(handle_, ep_.interface_number);
        libusb_close(handle_);
    }

    DeviceId id() const override { return id_; }

    Result<std::optional<InputReport>> read_input(int timeout_ms) override {
        const int64_t deadline =
            timeout_ms < 0 ? -1 : detail::monotonic_now_ns() + int64_t{timeout_ms} * 1'000'000;
        while (queue_.empty()) {
            if (!gone_.empty()) return make_error(id_.path + ": " + gone_);
            timeval tv{1, 0};
            if (deadline >= 0) {
                const int64_t left = deadline - detail::monotonic_now_ns();
                if (left <= 0 && timeout_ms > 0) return std::optional<InputReport>{};
                const int64_t us = left <= 0 ? 0 : left / 1000;
                tv = timeval{static_cast<time_t>(us / 1'000'000),
                             static_cast<suseconds_t>(us % 1'000'000)};
            }
            const int rc = libusb_handle_events_timeout_completed(ctx_.get(), &tv, nullptr);
            if (rc != 0 && rc != LIBUSB_ERROR_INTERRUPTED)
                return make_error(id_.path + ": libusb event handling failed: " + usb_error(rc));
            if (queue_.empty() && timeout_ms == 0) break;
        }
        if (queue_.empty()) {
            if (!gone_.empty()) return make_error(id_.path + ": " + gone_);
            return std::optional<InputReport>{};
        }
        InputReport r = std::move(queue_.front());
        queue_.pop_front();
        return std::optional<InputReport>{std::move(r)};
    }

    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t size) override {
        if (!gone_.empty()) return make_error(id_.path + ": " + gone_);
        if (size < 1) size = 1;
        std::vector<uint8_t> buf(size, 0);
        // note: with report id 0 (unnumbered) the device sends no id byte; keep one in front.
        uint8_t* data = report_id ? buf.data() : buf.data() + 1;
        const uint16_t len = static_cast<uint16_t>(report_id ? size : size - 1);
        const UsbSetupPacket s = hid_get_report_setup(
            HidReportType::feature, report_id, static_cast<uint16_t>(ep_.interface_number), len);
        const int n = libusb_control_transfer(handle_, s.request_type, s.request, s.value, s.index,
                                              data, s.length, 1000);
        if (n < 0)
            return make_error(id_.path + ": GET_REPORT(feature " + std::to_string(report_id) +
                              ") failed: " + usb_error(n));
        buf.resize(static_cast<size_t>(n) + (report_id ? 0 : 1));
        return buf;
    }

    Status set_feature(std::span<const uint8_t> data) override {
        return set_report(HidReportType::feature, data);
    }

    Status write_output(std::span<const uint8_t> data) override {
        if (data.empty()) return make_error(id_.path + ": empty output report");
        if (!ep_.out_endpoint) return set_report(HidReportType::output, data);
        // note: unnumbered reports go without their 0 id byte on the wire.
        std::vector<uint8_t> bytes(data.begin() + (data[0] ? 0 : 1), data.end());
        int sent = 0;
        const int rc = libusb_interrupt_transfer(handle_, ep_.out_endpoint, bytes.data(),
                                                 static_cast<int>(bytes.size()), &sent, 1000);
        if (rc != 0)
            return make_error(id_.path + ": interrupt-OUT transfer failed: " + usb_error(rc));
        return {};
    }

    uint64_t reports_dropped() const { return dropped_; }

  private:
    Status set_report(HidReportType type, std::span<const uint8_t> data) {
        if (data.empty()) return make_error(id_.path + ": empty report");
        if (!gone_.empty()) return make_error(id_.path + ": " + gone_);
        std::vector<uint8_t> bytes(data.begin() + (data[0] ? 0 : 1), data.end());
        const UsbSetupPacket s =
            hid_set_report_setup(type, data[0], static_cast<uint16_t>(ep_.interface_number),
                                 static_cast<uint16_t>(bytes.size()));
        const int n = libusb_control_transfer(handle_, s.request_type, s.request, s.value, s.index,
                                              bytes.data(), s.length, 1000);
        if (n < 0)
            return make_error(id_.path + ": SET_REPORT(" +
                              (type == HidReportType::feature ? "feature " : "output ") +
                              std::to_string(data[0]) + ") failed: " + usb_error(n));
        return {};
    }

    static void LIBUSB_CALL on_done(libusb_transfer* t) {
        auto* self = static_cast<LibusbTransport*>(t->user_data);
        switch (t->status) {
            case LIBUSB_TRANSFER_COMPLETED: {
                InputReport r;
                r.host_time_ns = detail::monotonic_now_ns();
                r.bytes.assign(t->buffer, t->buffer + t->actual_length);
                if (self->queue_.size() >= 4096) {
                    self->queue_.pop_front();
                    ++self->dropped_;
                }
                if (!r.bytes.empty()) self->queue_.push_back(std::move(r));
                break;
            }
            case LIBUSB_TRANSFER_CANCELLED:
                --self->active_;
                return;
            case LIBUSB_TRANSFER_NO_DEVICE:
                --self->active_;
                self->gone_ = "device is gone (unplugged)";
                return;
            default:  // timed out, stall, error: try again
                break;
        }
        const int rc = libusb_submit_transfer(t);
        if (rc != 0) {
            --self->active_;
            if (self->gone_.empty())
                self->gone_ = "resubmitting an interrupt-IN transfer failed: " + usb_error(rc);
        }
    }

    ContextPtr ctx_;
    libusb_device_handle* handle_;
    DeviceId id_;
    HidEndpoints ep_;
    std::vector<libusb_transfer*> transfers_;
    std::vector<std::vector<uint8_t>> buffers_;
    std::deque<InputReport> queue_;
    int active_ = 0;
    uint64_t dropped_ = 0;
    std::string gone_;
};

class LibusbHotplugMonitor final : public HotplugMonitor {
  public:
    LibusbHotplugMonitor(ContextPtr ctx, DeviceFilter filter)
        : ctx_(std::move(ctx)), filter_(std::move(filter)) {}
    ~LibusbHotplugMonitor() override {
        if (registered_) libusb_hotplug_deregister_callback(ctx_.get(), handle_);
    }

    Status start() {
        const int rc = libusb_hotplug_register_callback(
            ctx_.get(),
            static_cast<libusb_hotplug_event>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED |
                                              LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
            static_cast<libusb_hotplug_flag>(0),
            filter_.vendor_id ? filter_.vendor_id : LIBUSB_HOTPLUG_MATCH_ANY,
            filter_.product_id ? filter_.product_id : LIBUSB_HOTPLUG_MATCH_ANY,
            LIBUSB_HOTPLUG_MATCH_ANY, &LibusbHotplugMonitor::on_event, this, &handle_);
        if (rc != LIBUSB_SUCCESS)
            return make_error("libusb hotplug: registering the callback failed: " + usb_error(rc));
        registered_ = true;
        return {};
    }

    Result<std::optional<HotplugEvent>> wait(int timeout_ms) override {
        const int64_t deadline =
            timeout_ms < 0 ? -1 : detail::monotonic_now_ns() + int64_t{timeout_ms} * 1'000'000;
        while (events_.empty()) {
            timeval tv{1, 0};
            if (deadline >= 0) {
                const int64_t left = deadline - detail::monotonic_now_ns();
                if (left <= 0) break;
                tv = timeval{static_cast<time_t>(left / 1'000'000'000),
                             static_cast<suseconds_t>((left / 1000) % 1'000'000)};
            }
            const int rc = libusb_handle_events_timeout_completed(ctx_.get(), &tv, nullptr);
            if (rc != 0 && rc != LIBUSB_ERROR_INTERRUPTED)
                return make_error("libusb hotplug: event handling failed: " + usb_error(rc));
        }
        if (events_.empty()) return std::optional<HotplugEvent>{};
        HotplugEvent e = std::move(events_.front());
        events_.pop_front();
        return std::optional<HotplugEvent>{std::move(e)};
    }

  private:
    static int LIBUSB_CALL on_event(libusb_context*, libusb_device* dev, libusb_hotplug_event event,
                                    void* user) {
        auto* self = static_cast<LibusbHotplugMonitor*>(user);
        // note: only descriptors are safe to read here; the serial needs the device opened, so a
        // serial in the filter is checked by the caller's enumerate() after an arrival.
        std::vector<DeviceId> ids = describe(dev, false);
        if (ids.empty()) return 0;
        HotplugEvent e;
        e.kind = event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED ? HotplugEvent::Kind::arrived
                                                              : HotplugEvent::Kind::left;
        e.id = std::move(ids.front());
        self->events_.push_back(std::move(e));
        return 0;
    }

    ContextPtr ctx_;
    DeviceFilter filter_;
    libusb_hotplug_callback_handle handle_ = 0;
    bool registered_ = false;
    std::deque<HotplugEvent> events_;
};

class LibusbBackend final : public TransportBackend {
  public:
    LibusbBackend(ContextPtr ctx, TransportBackendOptions options)
        : ctx_(std::move(ctx)), options_(std::move(options)) {}

    std::string name() const override { return "libusb"; }

    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) override {
        libusb_device** list = nullptr;
        const ssize_t n = libusb_get_device_list(ctx_.get(), &list);
        if (n < 0)
            return make_error("libusb: listing USB devices failed: " +
                              usb_error(static_cast<int>(n)));
        std::vector<DeviceId> out;
        for (ssize_t i = 0; i < n; ++i) {
            libusb_device_descriptor desc{};
            if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
            if (filter.vendor_id && desc.idVendor != filter.vendor_id) continue;
            if (filter.product_id && desc.idProduct != filter.product_id) continue;
            for (DeviceId& id : describe(list[i], true))
                if (filter.matches(id)) out.push_back(std::move(id));
        }
        libusb_free_device_list(list, 1);
        return out;
    }

    Result<std::unique_ptr<Transport>> open(const DeviceId& want) override {
        const std::string what =
            want.path.empty()
                ? format_vid_pid(want.vendor_id, want.product_id)
                : want.path + " (" + format_vid_pid(want.vendor_id, want.product_id) + ")";
        libusb_device** list = nullptr;
        const ssize_t n = libusb_get_device_list(ctx_.get(), &list);
        if (n < 0)
            return make_error("libusb: listing USB devices failed: " +
                              usb_error(static_cast<int>(n)));
        libusb_device* dev = nullptr;
        DeviceId id;
        std::optional<HidEndpoints> ep;
        bool has_hid = false;
        for (ssize_t i = 0; i < n && !dev; ++i) {
            libusb_device_descriptor desc{};
            if (libusb_get_device_descriptor(list[i], &desc) != 0) continue;
            if (desc.idVendor != want.vendor_id || desc.idProduct != want.product_id) continue;
            std::vector<HidEndpoints> eps;
            std::vector<DeviceId> ids = describe(list[i], !want.serial.empty(), &eps);
            if (ids.empty()) continue;
            has_hid = true;
            for (size_t k = 0; k < ids.size() && !dev; ++k) {
                // The interface the path names; without a path the device's first one.
                if (!want.path.empty() ? ids[k].path != want.path : k != 0) continue;
                if (!want.serial.empty() && ids[k].serial != want.serial) continue;
                dev = libusb_ref_device(list[i]);
                id = std::move(ids[k]);
                ep = eps[k];
            }
        }
        libusb_free_device_list(list, 1);
        if (!dev)
            return make_error(
                "libusb: " +
                (has_hid && !want.path.empty()
                     ? "no HID interface " + what + " with an interrupt-IN endpoint is connected"
                     : "no USB device " + what +
                           (want.serial.empty() ? "" : " with serial \"" + want.serial + "\"") +
                           " is connected"));
        libusb_device_handle* h = nullptr;
        int rc = ep ? libusb_open(dev, &h) : LIBUSB_ERROR_NOT_FOUND;
        libusb_unref_device(dev);
        if (!ep)
            return make_error("libusb: " + what +
                              " has no HID interface with an interrupt-IN endpoint");
        if (rc != 0)
            return make_error("libusb: cannot open " + what + ": " + usb_error(rc) +
                              " -- do the udev rules (docs/udev.md) give this user access?");
        if (options_.detach_kernel_driver) libusb_set_auto_detach_kernel_driver(h, 1);
        rc = libusb_claim_interface(h, ep->interface_number);
        if (rc != 0) {
            libusb_close(h);
            return make_error(
                "libusb: cannot claim interface " + std::to_string(ep->interface_number) + " of " +
                what + ": " + usb_error(rc) +
                (rc == LIBUSB_ERROR_BUSY ? " -- a kernel driver holds it; allow detaching it"
                                         : ""));
        }
        auto t = std::make_unique<LibusbTransport>(ctx_, h, id, *ep, options_.transfers_in_flight);
        if (Status s = t->start(); !s.ok()) return s.error();
        return std::unique_ptr<Transport>(std::move(t));
    }

    Result<std::unique_ptr<HotplugMonitor>> watch(const DeviceFilter& filter) override {
        if (!libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG))
            return make_error("libusb: this platform has no hotplug notices; poll enumerate()");
        auto m = std::make_unique<LibusbHotplugMonitor>(ctx_, filter);
        if (Status s = m->start(); !s.ok()) return s.error();
        return std::unique_ptr<HotplugMonitor>(std::move(m));
    }

  private:
    ContextPtr ctx_;
    TransportBackendOptions options_;
};

}  // namespace

Result<std::unique_ptr<TransportBackend>> create_libusb_backend(
    const TransportBackendOptions& options) {
    libusb_context* raw = nullptr;
    const int rc = libusb_init(&raw);
    if (rc != 0) return make_error("libusb: libusb_init failed: " + usb_error(rc));
    ContextPtr ctx(raw, [](libusb_context* c) { libusb_exit(c); });
    return std::unique_ptr<TransportBackend>(new LibusbBackend(std::move(ctx), options));
}

}  // namespace hmdnode
