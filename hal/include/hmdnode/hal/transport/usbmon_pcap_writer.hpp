// Writing what a device said as a Linux usbmon capture (docs/hardware.md, "Recording"): a pcap
// (file format 2.4, microsecond timestamps, link type DLT_USB_LINUX_MMAPPED = 220, 64-byte usbmon
// headers in host byte order) built in memory, which Wireshark, tshark and `hmdnode replay
// --capture` read (usbmon_capture.hpp); and a tee TransportBackend that hands everything through
// to another backend and writes each input report, and each feature report read, into such a
// capture. Written by hand: no libpcap types here or in the sources.
//
// Bus and device address are not known through hidraw: they are written as bus 1, address 1.
// Cost: one append per event (64 bytes + the report).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

class UsbmonPcapWriter {
  public:
    UsbmonPcapWriter();
    // One usbmon event. `setup` non-null: a control submission carrying the 8-byte setup packet.
    void event(int64_t realtime_ns, uint64_t urb_id, char type, uint8_t xfer_type, uint8_t endpoint,
               uint32_t urb_length, const uint8_t* setup, std::span<const uint8_t> data);
    // A control transfer: 'S' with the setup packet, 'C' with the answer (IN requests).
    void control_in(int64_t realtime_ns, const UsbSetupPacket& setup,
                    std::span<const uint8_t> answer);
    // A synthetic GET_DESCRIPTOR(DEVICE) exchange, so that readers learn the VID:PID from the
    // capture itself.
    void device_descriptor(int64_t realtime_ns, uint16_t vendor_id, uint16_t product_id);
    // One interrupt-IN completion ('C', endpoint 0x81 unless told: the tee backend writes
    // interface N's reports as 0x81 + N).
    void interrupt_in(int64_t realtime_ns, std::span<const uint8_t> data, uint8_t endpoint = 0x81);

    const std::string& bytes() const { return bytes_; }
    uint64_t events() const { return events_; }

  private:
    std::string bytes_;
    uint64_t events_ = 0;
    uint64_t next_urb_ = 0x100;
};

// CLOCK_REALTIME - CLOCK_MONOTONIC now (ns): usbmon stamps events with the realtime clock.
int64_t realtime_minus_monotonic_ns();

// Wraps `inner`: every transport it opens writes, into `pcap`, the device descriptor exchange on
// open, each input report at its host arrival time + rt_offset_ns, and each feature report read
// as a GET_REPORT exchange (those two at clock's now + rt_offset_ns). The writer is shared by the
// transports' reader threads (under a lock) and must outlive them; read it after they stopped.
std::unique_ptr<TransportBackend> create_pcap_tee_backend(std::unique_ptr<TransportBackend> inner,
                                                          std::shared_ptr<UsbmonPcapWriter> pcap,
                                                          Clock& clock, int64_t rt_offset_ns);

}  // namespace hmdnode
