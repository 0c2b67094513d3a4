// usbmon capture reader and replay backend. Format: the Linux kernel's usbmon binary interface
// (Documentation/usb/usbmon.rst, "Raw binary format and API": the 48-byte pcap_usb_header, 64 bytes
// with the mmapped link type) inside pcap records, read with libpcap; gzip inflated with zlib.
// Cost: O(file) time; memory O(inflated file) while parsing plus the packets kept.
// Departures: the usbmon header is read in the capture's byte order (pcap_is_swapped), records
// shorter than the header are an error rather than skipped, and VID:PID comes from any completed
// GET_DESCRIPTOR(DEVICE) answer without matching its submission. A file cut short (its last record
// or its gzip stream truncated) keeps the whole records before the cut, with a warning naming the
// byte offset of the cut record (of the inflated stream for a .gz).
#include "hmdnode/hal/transport/usbmon_capture.hpp"

#include <pcap/pcap.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "transport/gunzip.hpp"

namespace hmdnode {
namespace {

constexpr int kDltUsbLinux = 189;
constexpr int kDltUsbLinuxMmapped = 220;

template <class T>
T rd(const uint8_t* p, bool swapped) {
    T v;
    std::memcpy(&v, p, sizeof v);
    if (swapped) {
        uint8_t b[sizeof v];
        std::memcpy(b, &v, sizeof v);
        std::reverse(b, b + sizeof v);
        std::memcpy(&v, b, sizeof v);
    }
    return v;
}

}  // namespace

Result<UsbCapture> parse_usbmon_capture(std::span<const uint8_t> bytes) {
    std::vector<uint8_t> inflated;
    std::vector<std::string> warnings;
    if (bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b) {
        bool truncated = false;
        auto r = gunzip(bytes, &truncated);
        if (!r) return r.error();
        inflated = std::move(*r);
        bytes = inflated;
        if (truncated)
            warnings.push_back("gzip: truncated stream, " + std::to_string(bytes.size()) +
                               " bytes inflated");
    }
    if (bytes.size() < 24)
        return make_error("pcap: " + std::to_string(bytes.size()) +
                          " bytes, shorter than the 24-byte file header");
    FILE* f = fmemopen(const_cast<uint8_t*>(bytes.data()), bytes.size(), "rb");
    if (!f) return make_error("pcap: fmemopen failed");
    char errbuf[PCAP_ERRBUF_SIZE] = {};
    pcap_t* p = pcap_fopen_offline_with_tstamp_precision(f, PCAP_TSTAMP_PRECISION_NANO, errbuf);
    if (!p) {
        fclose(f);
        return make_error(std::string("pcap: ") + errbuf);
    }
    struct Closer {
        pcap_t* p;
        ~Closer() { pcap_close(p); }  // closes f too
    } closer{p};

    UsbCapture cap;
    cap.link_type = pcap_datalink(p);
    if (cap.link_type != kDltUsbLinux && cap.link_type != kDltUsbLinuxMmapped)
        return make_error("pcap: link type " + std::to_string(cap.link_type) +
                          " is not usbmon (189 DLT_USB_LINUX or 220 DLT_USB_LINUX_MMAPPED)");
    const size_t header = cap.link_type == kDltUsbLinux ? 48 : 64;
    const bool sw = pcap_is_swapped(p) != 0;
    cap.warnings = std::move(warnings);
    size_t index = 0;
    size_t offset = 24;  // of the record being read: the file header, then 16 + caplen a record
    while (true) {
        pcap_pkthdr* h = nullptr;
        const u_char* d = nullptr;
        const int rc = pcap_next_ex(p, &h, &d);
        if (rc == PCAP_ERROR_BREAK) break;  // end of file
        if (rc != 1) {
            const std::string why = pcap_geterr(p);
            // libpcap: "truncated dump file; tried to read N header/captured bytes, only got M".
            if (why.find("truncated") != std::string::npos) {
                cap.warnings.push_back(
                    "pcap: record " + std::to_string(index) + " at byte " + std::to_string(offset) +
                    " is cut short (" + std::to_string(bytes.size() - offset) + " of its bytes " +
                    "present); kept the " + std::to_string(index) + " records before it");
                break;
            }
            return make_error("pcap: record " + std::to_string(index) + " at byte " +
                              std::to_string(offset) + ": " + why);
        }
        offset += 16 + h->caplen;
        if (h->caplen < header)
            return make_error("pcap: record " + std::to_string(index) + ": " +
                              std::to_string(h->caplen) + " bytes, shorter than the " +
                              std::to_string(header) + "-byte usbmon header");
        UsbPacket u;
        u.time_ns = int64_t(h->ts.tv_sec) * 1'000'000'000 + int64_t(h->ts.tv_usec);  // nano prec.
        u.urb_id = rd<uint64_t>(d, sw);
        u.event = char(d[8]);
        u.transfer_type = d[9];
        u.endpoint = d[10];
        u.device_address = d[11];
        u.bus = rd<uint16_t>(d + 12, sw);
        u.setup_present = d[14] == 0;
        u.status = rd<int32_t>(d + 28, sw);
        u.urb_length = rd<uint32_t>(d + 32, sw);
        std::memcpy(u.setup.data(), d + 40, 8);
        u.data.assign(d + header, d + h->caplen);
        cap.packets.push_back(std::move(u));
        ++index;
    }
    return cap;
}

Result<UsbCapture> read_usbmon_capture(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return make_error(path.string() + ": cannot open");
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                               std::istreambuf_iterator<char>());
    auto r = parse_usbmon_capture(bytes);
    if (!r) return make_error(path.string() + ": " + r.error().message);
    for (std::string& w : r->warnings) w = path.string() + ": " + w;
    return r;
}

double CaptureEndpointSummary::rate_hz() const {
    if (completions < 2 || last_ns <= first_ns) return 0.0;
    return double(completions - 1) * 1e9 / double(last_ns - first_ns);
}

CaptureSummary summarize_capture(const UsbCapture& cap) {
    CaptureSummary s;
    s.link_type = cap.link_type;
    s.packets = cap.packets.size();
    if (!cap.packets.empty()) {
        s.first_ns = cap.packets.front().time_ns;
        s.last_ns = cap.packets.back().time_ns;
    }
    std::map<std::pair<uint16_t, uint8_t>, CaptureDeviceSummary> devs;
    for (const UsbPacket& u : cap.packets) {
        CaptureDeviceSummary& d = devs[{u.bus, u.device_address}];
        d.bus = u.bus;
        d.address = u.device_address;
        if (u.event != 'C' || u.data.empty()) continue;
        // GET_DESCRIPTOR(DEVICE) answer: bLength 18, bDescriptorType 1.
        if (u.transfer_type == 2 && u.data.size() >= 12 && u.data[0] == 18 && u.data[1] == 1) {
            d.vendor_id = uint16_t(u.data[8] | (u.data[9] << 8));
            d.product_id = uint16_t(u.data[10] | (u.data[11] << 8));
            d.id_source = "descriptor";
        }
        auto it = std::find_if(d.endpoints.begin(), d.endpoints.end(), [&](const auto& e) {
            return e.endpoint == u.endpoint && e.transfer_type == u.transfer_type;
        });
        if (it == d.endpoints.end()) {
            d.endpoints.push_back({});
            it = d.endpoints.end() - 1;
            it->endpoint = u.endpoint;
            it->transfer_type = u.transfer_type;
            it->first_ns = u.time_ns;
        }
        ++it->completions;
        it->bytes += u.data.size();
        it->last_ns = u.time_ns;
        if (u.transfer_type == 1 && (u.endpoint & 0x80)) ++it->report_ids[u.data[0]];
    }
    for (auto& [key, d] : devs) {
        std::sort(d.endpoints.begin(), d.endpoints.end(), [](const auto& a, const auto& b) {
            return std::pair(a.endpoint, a.transfer_type) < std::pair(b.endpoint, b.transfer_type);
        });
        s.devices.push_back(std::move(d));
    }
    return s;
}

Result<size_t> apply_usbdevs_sidecar(const std::filesystem::path& path, CaptureSummary* s) {
    std::ifstream in(path);
    if (!in) return make_error(path.string() + ": cannot open");
    std::string line;
    size_t applied = 0, lineno = 0;
    while (std::getline(in, line)) {
        ++lineno;
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        long vid, pid, bus, addr;
        std::string label;
        if (!(ls >> vid >> pid >> bus >> addr) || vid < 0 || vid > 0xffff || pid < 0 ||
            pid > 0xffff || bus < 0 || bus > 0xffff || addr < 0 || addr > 127)
            return make_error(path.string() + ": line " + std::to_string(lineno) +
                              ": expected \"VID PID BUS ADDRESS LABEL\" (decimal)");
        std::getline(ls >> std::ws, label);
        for (CaptureDeviceSummary& d : s->devices) {
            if (d.bus != bus || d.address != addr) continue;
            d.label = label;
            if (d.id_source.empty()) {
                d.vendor_id = uint16_t(vid);
                d.product_id = uint16_t(pid);
                d.id_source = "usbdevs";
            }
            ++applied;
        }
    }
    return applied;
}

namespace {

class CaptureTransport final : public Transport {
  public:
    CaptureTransport(std::shared_ptr<const UsbCapture> cap, DeviceId id, uint16_t bus,
                     uint8_t address)
        : cap_(std::move(cap)), id_(std::move(id)), bus_(bus), address_(address) {
        advance();
    }
    DeviceId id() const override { return id_; }

    Result<std::optional<InputReport>> read_input(int) override {
        if (cursor_ >= cap_->packets.size()) return std::optional<InputReport>();
        const UsbPacket& u = cap_->packets[cursor_];
        InputReport r{u.data, u.time_ns};
        ++cursor_;
        advance();
        return std::optional<InputReport>(std::move(r));
    }

    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t size) override {
        // A completed control-IN transfer answering GET_REPORT (bmRequestType 0xA1, bRequest 1,
        // wValue 0x03xx = feature report xx) to this device.
        std::map<uint64_t, bool> wanted;
        for (const UsbPacket& u : cap_->packets) {
            if (u.bus != bus_ || u.device_address != address_ || u.transfer_type != 2) continue;
            if (u.event == 'S' && u.setup_present && u.setup[0] == 0xA1 && u.setup[1] == 0x01 &&
                u.setup[3] == 0x03 && u.setup[2] == report_id)
                wanted[u.urb_id] = true;
            else if (u.event == 'C' && wanted.count(u.urb_id) && u.status == 0 && !u.data.empty()) {
                std::vector<uint8_t> b = u.data;
                if (b.size() > size) b.resize(size);
                return b;
            }
        }
        return make_error("capture: no GET_REPORT answer for feature report " +
                          std::to_string(report_id) + " of this device");
    }
    Status set_feature(std::span<const uint8_t>) override { return {}; }
    Status write_output(std::span<const uint8_t>) override { return {}; }
    bool finished() const override { return cursor_ >= cap_->packets.size(); }
    bool replayed() const override { return true; }

  private:
    // Moves the cursor to the next completed, successful interrupt-IN transfer with data.
    void advance() {
        while (cursor_ < cap_->packets.size()) {
            const UsbPacket& u = cap_->packets[cursor_];
            if (u.bus == bus_ && u.device_address == address_ && is_interrupt_in_completion(u))
                return;
            ++cursor_;
        }
    }

    std::shared_ptr<const UsbCapture> cap_;
    DeviceId id_;
    uint16_t bus_;
    uint8_t address_;
    size_t cursor_ = 0;
};

class CaptureBackend final : public TransportBackend {
  public:
    CaptureBackend(std::shared_ptr<const UsbCapture> cap, const CaptureSummary& s)
        : cap_(std::move(cap)) {
        for (const CaptureDeviceSummary& d : s.devices) {
            DeviceId id;
            id.vendor_id = d.vendor_id;
            id.product_id = d.product_id;
            id.path = "capture:" + std::to_string(d.bus) + "-" + std::to_string(d.address);
            id.product = d.label;
            devices_.push_back({id, d.bus, d.address});
        }
    }
    std::string name() const override { return "capture"; }
    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) override {
        std::vector<DeviceId> out;
        for (const auto& d : devices_)
            if (filter.matches(d.id)) out.push_back(d.id);
        return out;
    }
    Result<std::unique_ptr<Transport>> open(const DeviceId& id) override {
        for (const auto& d : devices_)
            if (d.id.path == id.path)
                return std::unique_ptr<Transport>(
                    new CaptureTransport(cap_, d.id, d.bus, d.address));
        return make_error("capture: no device " + id.path);
    }

  private:
    struct Dev {
        DeviceId id;
        uint16_t bus;
        uint8_t address;
    };
    std::shared_ptr<const UsbCapture> cap_;
    std::vector<Dev> devices_;
};

}  // namespace

std::unique_ptr<TransportBackend> create_capture_backend(std::shared_ptr<const UsbCapture> capture,
                                                         const CaptureSummary& summary) {
    return std::make_unique<CaptureBackend>(std::move(capture), summary);
}

Result<CaptureDevice> find_capture_device(const std::filesystem::path& file,
                                          const std::string& vid_pid) {
    auto filter = parse_vid_pid(vid_pid);
    if (!filter) return filter.error();
    auto cap = read_usbmon_capture(file);
    if (!cap) return cap.error();
    CaptureDevice out;
    out.filter = *filter;
    out.summary = summarize_capture(*cap);
    const std::filesystem::path sidecar = file.string() + ".usbdevs";
    if (std::filesystem::exists(sidecar)) {
        auto applied = apply_usbdevs_sidecar(sidecar, &out.summary);
        if (!applied) return applied.error();
    }
    auto held_devices = [&out] {
        std::string held;
        for (const auto& d : out.summary.devices) {
            held.append(" ").append(std::to_string(d.bus)).append("-");
            held.append(std::to_string(d.address)).append("=");
            held.append(d.id_source.empty() ? std::string("unknown")
                                            : format_vid_pid(d.vendor_id, d.product_id));
        }
        if (held.empty()) held = " no device";
        return held;
    };
    auto has_intr_in = [](const CaptureDeviceSummary& d) {
        for (const auto& e : d.endpoints)
            if (e.transfer_type == 1 && (e.endpoint & 0x80) && e.completions > 0) return true;
        return false;
    };
    size_t matching = 0, unknown_with_reports = 0;
    for (const auto& d : out.summary.devices) {
        if (d.vendor_id == filter->vendor_id && d.product_id == filter->product_id) ++matching;
        if (d.id_source.empty() && has_intr_in(d)) ++unknown_with_reports;
    }
    if (matching == 0 && unknown_with_reports == 1)
        for (auto& d : out.summary.devices)
            if (d.id_source.empty() && has_intr_in(d)) {
                d.vendor_id = filter->vendor_id;
                d.product_id = filter->product_id;
                d.id_source = "given";
            }
    const CaptureDeviceSummary* found = nullptr;
    for (const auto& d : out.summary.devices)
        if (!found && d.vendor_id == filter->vendor_id && d.product_id == filter->product_id)
            found = &d;
    if (!found || !filter->serial.empty()) {
        std::string msg = file.string() + ": no device " + vid_pid + " in the capture (it holds";
        msg.append(held_devices());
        if (found) msg.append("; a capture has no serial numbers: give VID:PID");
        return make_error(msg + ")");
    }
    out.bus = found->bus;
    out.address = found->address;
    out.capture = std::make_shared<UsbCapture>(std::move(*cap));
    return out;
}

}  // namespace hmdnode
