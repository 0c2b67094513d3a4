// Private to hal: pieces the hidapi backend shares with the hidraw hotplug monitor and the libusb
// backend.
#pragma once

#include <memory>
#include <string>

#include "hmdnode/hal/transport.hpp"

namespace hmdnode::detail {

// Hotplug notices for hidraw nodes (udev monitor, subsystem hidraw); `source` is "udev" or
// "kernel" (TransportBackendOptions::udev_event_source). Defined in hidraw_hotplug.cpp.
Result<std::unique_ptr<HotplugMonitor>> create_hidraw_hotplug_monitor(const DeviceFilter& filter,
                                                                      const std::string& source);

// CLOCK_MONOTONIC in ns.
int64_t monotonic_now_ns();

// UTF-8 of a wide string (hidapi's strings and errors); null -> "".
std::string narrow(const wchar_t* text);

}  // namespace hmdnode::detail
