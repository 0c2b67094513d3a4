// Reader of Linux usbmon captures (pcap files written by `tcpdump -i usbmonN` or Wireshark, link
// types DLT_USB_LINUX = 189 and DLT_USB_LINUX_MMAPPED = 220, optionally gzip-compressed), a
// summary of what a capture holds, and the "capture" TransportBackend that replays one device's
// interrupt-in transfers as InputReports stamped with the capture's times.
//
// The reader is pure over bytes (parse_usbmon_capture) with a file wrapper; any thread.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

// One usbmon event (pcap_usb_header fields we use, plus the data bytes captured).
struct UsbPacket {
    int64_t time_ns = 0;  // capture timestamp (the capturing host's realtime clock)
    uint64_t urb_id = 0;
    char event = 0;             // 'S' submit, 'C' complete, 'E' error
    uint8_t transfer_type = 0;  // 0 iso, 1 interrupt, 2 control, 3 bulk
    uint8_t endpoint = 0;       // bit 7 set: IN
    uint8_t device_address = 0;
    uint16_t bus = 0;
    bool setup_present = false;  // setup_flag == 0 on a control 'S'
    std::array<uint8_t, 8> setup{};
    int32_t status = 0;
    uint32_t urb_length = 0;
    std::vector<uint8_t> data;
};

// A completed, successful interrupt-IN transfer with data ('C', interrupt, endpoint bit 7 set,
// status 0, at least one byte): one report as a device's tracker reads it. The one test every
// reader of a capture uses for that (the capture backend's replay, `hmdnode capture`, the tests
// and benches); a device's own packets are those of its bus and address besides.
inline bool is_interrupt_in_completion(const UsbPacket& u) {
    return u.event == 'C' && u.transfer_type == 1 && (u.endpoint & 0x80) != 0 && u.status == 0 &&
           !u.data.empty();
}

struct UsbCapture {
    int link_type = 0;
    std::vector<UsbPacket> packets;  // in file order
    // What was read past: a file cut short (a recording stopped by a crash or a full disk) keeps
    // its whole records, with a warning naming the byte offset where the cut record starts.
    std::vector<std::string> warnings;
};

// Reads a pcap (or gzip'd pcap) held in memory. Errors name the byte offset of the bad record; a
// truncated last record (or gzip stream) is a warning, the records before it kept.
Result<UsbCapture> parse_usbmon_capture(std::span<const uint8_t> file_bytes);
// Reads a file; ".gz" or the gzip magic means gzip. Errors and warnings name the file.
Result<UsbCapture> read_usbmon_capture(const std::filesystem::path& path);

struct CaptureEndpointSummary {
    uint8_t endpoint = 0;
    uint8_t transfer_type = 0;
    uint64_t completions = 0;  // 'C' events with data
    uint64_t bytes = 0;
    std::map<uint8_t, uint64_t> report_ids;  // first data byte -> count (interrupt IN)
    int64_t first_ns = 0, last_ns = 0;
    double rate_hz() const;
};

struct CaptureDeviceSummary {
    uint16_t bus = 0;
    uint8_t address = 0;
    uint16_t vendor_id = 0, product_id = 0;  // 0:0 when unknown
    std::string id_source;                   // "descriptor", "usbdevs", "given" or "" (unknown)
    std::string label;                       // from the .usbdevs sidecar, if any
    std::vector<CaptureEndpointSummary> endpoints;
};

struct CaptureSummary {
    int link_type = 0;
    uint64_t packets = 0;
    int64_t first_ns = 0, last_ns = 0;
    std::vector<CaptureDeviceSummary> devices;  // by bus, address
};

// Devices (VID:PID from GET_DESCRIPTOR(DEVICE) answers in the capture), endpoints, report ids.
CaptureSummary summarize_capture(const UsbCapture& capture);

// The ".usbdevs" sidecar: one device a line, "VID PID BUS ADDRESS LABEL" (ids decimal). Fills in
// the ids of devices the capture did not describe. Returns the number of lines applied.
Result<size_t> apply_usbdevs_sidecar(const std::filesystem::path& sidecar, CaptureSummary* summary);

// A backend over one capture: enumerate() lists the summary's devices (path
// "capture:BUS-ADDRESS"); open() gives a Transport whose read_input() returns the device's
// completed interrupt-IN transfers in capture order, without waiting (the device tracker paces them
// on its clock), and finished() at the end. get_feature() answers with the capture's own GET_REPORT
// response for that report id, if it holds one; set_feature/write_output succeed and do nothing.
std::unique_ptr<TransportBackend> create_capture_backend(std::shared_ptr<const UsbCapture> capture,
                                                         const CaptureSummary& summary);

// One device of a capture file, as `--from FILE --device VID:PID` names it: the capture, its
// summary (the ".usbdevs" sidecar applied when there is one) and the device's bus and address.
// The device is the one the capture's descriptors or the sidecar give that VID:PID, or -- when
// none does and exactly one unidentified device sends interrupt-IN reports -- that one (its
// id_source then "given"). Errors name the file and say which devices it holds; a VID:PID:SERIAL
// never matches (a capture records no serial numbers). The reader's warnings (a file cut short)
// are in capture->warnings.
struct CaptureDevice {
    std::shared_ptr<const UsbCapture> capture;
    CaptureSummary summary;
    DeviceFilter filter;
    uint16_t bus = 0;
    uint8_t address = 0;
};
Result<CaptureDevice> find_capture_device(const std::filesystem::path& file,
                                          const std::string& vid_pid);

}  // namespace hmdnode
