// A USB device's HID interfaces as one Transport. A Vive or an Index sends its IMU reports (0x20)
// on interface 0 and its light reports (0x25 on a Vive, 0x28 on an Index) on interface 1, each a
// hidraw node of its own (or a USB interface of its own under libusb); the tracker's light path
// wants both in one stream, ordered as they arrived, as a usbmon capture of the device already
// holds them.
//
// merge_interfaces() reads the parts and hands their reports oldest first (by host time): the
// first part (the primary: the interface whose feature reports configure the device) is read on
// the caller's thread, and so are its feature and output reports; the other parts are read
//   - `threads`: each on a reader thread of its own (named "hmdnode-if<N>"), into a bounded queue
//     (4096 reports; the oldest dropped past it). For backends whose transports are
//     independent of each other (hidapi: one file descriptor each);
//   - `polled`: on the caller's thread too, without waiting, after each read of the primary. For
//     backends whose transports share one event loop (libusb: handling events for one transport
//     completes the others' transfers too), and for replays (deterministic order).
// While nothing is at hand the primary is read in slices of at most 2 ms, so a report of another
// part waits at most that long; each call drains what the primary holds (up to 256 reports: a
// hidraw node keeps only 64). Reports are stamped when their part reads them, so two interfaces'
// reports that arrive within a reader's scheduling delay of each other may come in either order
// (the light decoder's 24-bit times tolerate far more). A part's failure (the device unplugged)
// fails the whole transport.
//
// group_interfaces() is the backend decorator: its enumerate() lists each USB device once (the id
// of its lowest-numbered interface), its open() opens every interface of that device (the
// DeviceId::usb_device the inner backend gives them) and merges them. Ids without a usb_device
// stay single interfaces.
//
// Cost: one report copy per report (threads: plus a queue push under a lock); one thread per
// secondary interface (threads). Any thread may create them; the Transport is then used by one
// thread at a time, as every Transport.
#pragma once

#include <memory>
#include <vector>

#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

enum class InterfaceReading { threads, polled };

// The reading a backend's transports need: `polled` for "libusb" (one event loop), `threads` for
// the others.
InterfaceReading interface_reading_for(const std::string& backend_name);

// parts[0] is the primary (id(), feature and output reports). Errors: no parts, a null part.
Result<std::unique_ptr<Transport>> merge_interfaces(std::vector<std::unique_ptr<Transport>> parts,
                                                    InterfaceReading reading);

std::unique_ptr<TransportBackend> group_interfaces(std::unique_ptr<TransportBackend> inner,
                                                   InterfaceReading reading);

}  // namespace hmdnode
