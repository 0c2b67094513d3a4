// Hotplug notices for hidraw devices: a udev monitor (libudev, netlink) filtered on subsystem
// "hidraw". An "add" event names /dev/hidrawN; its parent "hid" device carries HID_ID
// ("0003:000028DE:00002000": bus, vendor, product), HID_UNIQ (serial) and HID_NAME. A "remove"
// event no longer has a parent in sysfs, so the monitor remembers what each node was when it
// arrived (and what was present when it started) and reports that.
// Cost: one poll(2) + recvmsg(2) per event; memory O(number of hidraw nodes seen).
#include <poll.h>

#include <cstdio>
#include <cstdlib>
#include <map>

#include <libudev.h>

#include "transport/hidapi_transport.hpp"

namespace hmdnode {
namespace detail {
namespace {

// Fills vendor/product/serial/product name of a hidraw udev device from its "hid" parent.
bool describe_hidraw(udev_device* dev, DeviceId& out) {
    const char* node = udev_device_get_devnode(dev);
    if (node) out.path = node;
    udev_device* hid = udev_device_get_parent_with_subsystem_devtype(dev, "hid", nullptr);
    if (!hid) return false;
    const char* hid_id = udev_device_get_property_value(hid, "HID_ID");
    unsigned bus = 0, vid = 0, pid = 0;
    if (!hid_id || std::sscanf(hid_id, "%x:%x:%x", &bus, &vid, &pid) != 3) return false;
    out.vendor_id = static_cast<uint16_t>(vid);
    out.product_id = static_cast<uint16_t>(pid);
    if (const char* uniq = udev_device_get_property_value(hid, "HID_UNIQ")) out.serial = uniq;
    if (const char* name = udev_device_get_property_value(hid, "HID_NAME")) out.product = name;
    udev_device* intf = udev_device_get_parent_with_subsystem_devtype(dev, "usb", "usb_interface");
    if (intf) {
        if (const char* n = udev_device_get_sysattr_value(intf, "bInterfaceNumber"))
            out.interface_number = static_cast<int>(std::strtol(n, nullptr, 16));
    }
    return true;
}

class HidrawHotplugMonitor final : public HotplugMonitor {
  public:
    HidrawHotplugMonitor(udev* u, udev_monitor* mon, DeviceFilter filter)
        : udev_(u), mon_(mon), filter_(std::move(filter)) {}
    ~HidrawHotplugMonitor() override {
        udev_monitor_unref(mon_);
        udev_unref(udev_);
    }

    void remember_present() {
        udev_enumerate* e = udev_enumerate_new(udev_);
        if (!e) return;
        udev_enumerate_add_match_subsystem(e, "hidraw");
        udev_enumerate_scan_devices(e);
        for (udev_list_entry* it = udev_enumerate_get_list_entry(e); it;
             it = udev_list_entry_get_next(it)) {
            udev_device* d = udev_device_new_from_syspath(udev_, udev_list_entry_get_name(it));
            if (!d) continue;
            DeviceId id;
            if (describe_hidraw(d, id)) known_[id.path] = id;
            udev_device_unref(d);
        }
        udev_enumerate_unref(e);
    }

    Result<std::optional<HotplugEvent>> wait(int timeout_ms) override {
        const int fd = udev_monitor_get_fd(mon_);
        const int64_t deadline =
            timeout_ms < 0 ? -1 : monotonic_now_ns() + int64_t{timeout_ms} * 1'000'000;
        for (;;) {
            int wait_ms = -1;
            if (deadline >= 0) {
                const int64_t left = deadline - monotonic_now_ns();
                wait_ms = left <= 0 ? 0 : static_cast<int>((left + 999'999) / 1'000'000);
            }
            pollfd p{fd, POLLIN, 0};
            const int rc = poll(&p, 1, wait_ms);
            if (rc < 0) return make_error("hidraw hotplug: poll on the udev monitor failed");
            if (rc == 0) return std::optional<HotplugEvent>{};
            udev_device* dev = udev_monitor_receive_device(mon_);
            if (!dev) continue;
            std::optional<HotplugEvent> ev = translate(dev);
            udev_device_unref(dev);
            if (ev) return ev;
        }
    }

  private:
    std::optional<HotplugEvent> translate(udev_device* dev) {
        const char* action = udev_device_get_action(dev);
        const char* node = udev_device_get_devnode(dev);
        if (!action || !node) return std::nullopt;
        const std::string a = action;
        HotplugEvent ev;
        if (a == "add") {
            if (!describe_hidraw(dev, ev.id)) return std::nullopt;
            known_[ev.id.path] = ev.id;
            ev.kind = HotplugEvent::Kind::arrived;
        } else if (a == "remove") {
            auto it = known_.find(node);
            if (it == known_.end()) {
                // note: unknown node: report it by path only when the filter is open.
                if (filter_.vendor_id || filter_.product_id || !filter_.serial.empty())
                    return std::nullopt;
                ev.id.path = node;
            } else {
                ev.id = it->second;
                known_.erase(it);
            }
            ev.kind = HotplugEvent::Kind::left;
        } else {
            return std::nullopt;
        }
        if (!filter_.matches(ev.id)) return std::nullopt;
        return ev;
    }

    udev* udev_;
    udev_monitor* mon_;
    DeviceFilter filter_;
    std::map<std::string, DeviceId> known_;
};

}  // namespace

Result<std::unique_ptr<HotplugMonitor>> create_hidraw_hotplug_monitor(const DeviceFilter& filter,
                                                                      const std::string& source) {
    if (source != "udev" && source != "kernel")
        return make_error("hidraw hotplug: event source \"" + source +
                          "\" is neither \"udev\" nor \"kernel\"");
    udev* u = udev_new();
    if (!u) return make_error("hidraw hotplug: udev_new failed");
    udev_monitor* mon = udev_monitor_new_from_netlink(u, source.c_str());
    if (!mon) {
        udev_unref(u);
        return make_error("hidraw hotplug: cannot open the " + source +
                          " netlink monitor (udev_monitor_new_from_netlink)");
    }
    if (udev_monitor_filter_add_match_subsystem_devtype(mon, "hidraw", nullptr) < 0 ||
        udev_monitor_enable_receiving(mon) < 0) {
        udev_monitor_unref(mon);
        udev_unref(u);
        return make_error("hidraw hotplug: cannot start receiving " + source + " events");
    }
    auto m = std::make_unique<HidrawHotplugMonitor>(u, mon, filter);
    m->remember_present();
    return std::unique_ptr<HotplugMonitor>(std::move(m));
}

}  // namespace detail
}  // namespace hmdnode
