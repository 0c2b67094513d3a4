// The usbmon pcap writer and the tee backend (usbmon_pcap_writer.hpp): pcap 2.4 with 64-byte
// usbmon headers (the layout usbmon_capture.cpp reads), after the kernel's
// Documentation/usb/usbmon.rst "mmapped" header.
#include "hmdnode/hal/transport/usbmon_pcap_writer.hpp"

#include <time.h>

#include <algorithm>
#include <cassert>
#include <cstring>
#include <mutex>

#include "hmdnode/core/time.hpp"

namespace hmdnode {
namespace {

void put(std::string& b, const void* p, size_t n) {
    b.append(static_cast<const char*>(p), n);
}
template <class T>
void put_le(std::string& b, T v) {
    for (size_t i = 0; i < sizeof(T); ++i) b.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

}  // namespace

UsbmonPcapWriter::UsbmonPcapWriter() {
    put_le<uint32_t>(bytes_, 0xa1b2c3d4);  // microsecond timestamps
    put_le<uint16_t>(bytes_, 2);
    put_le<uint16_t>(bytes_, 4);
    put_le<int32_t>(bytes_, 0);
    put_le<uint32_t>(bytes_, 0);
    put_le<uint32_t>(bytes_, 65535);
    put_le<uint32_t>(bytes_, 220);  // LINKTYPE_USB_LINUX_MMAPPED
}

void UsbmonPcapWriter::event(int64_t realtime_ns, uint64_t urb_id, char type, uint8_t xfer_type,
                             uint8_t endpoint, uint32_t urb_length, const uint8_t* setup,
                             std::span<const uint8_t> data) {
    // pcap stores the time as unsigned seconds since 1970: a recording is of now, not before.
    assert(realtime_ns >= 0 && (setup != nullptr || xfer_type != 2 || type != 'S'));
    std::string h;
    put_le<uint64_t>(h, urb_id);
    h.push_back(type);
    h.push_back(static_cast<char>(xfer_type));
    h.push_back(static_cast<char>(endpoint));
    h.push_back(1);                                                 // device address
    put_le<uint16_t>(h, 1);                                         // bus
    h.push_back(setup ? 0 : '-');                                   // flag_setup: 0 = setup present
    h.push_back(data.empty() ? (endpoint & 0x80 ? '<' : '>') : 0);  // flag_data: 0 = present
    put_le<int64_t>(h, realtime_ns / kNsPerSecond);
    put_le<int32_t>(h, static_cast<int32_t>((realtime_ns % kNsPerSecond) / 1000));
    put_le<int32_t>(h, 0);  // status
    put_le<uint32_t>(h, urb_length);
    put_le<uint32_t>(h, static_cast<uint32_t>(data.size()));
    uint8_t s[8] = {};
    if (setup) std::memcpy(s, setup, 8);
    put(h, s, 8);
    put_le<int32_t>(h, xfer_type == 1 ? 1 : 0);  // interval (ms)
    put_le<int32_t>(h, 0);                       // start_frame
    put_le<uint32_t>(h, 0);                      // xfer_flags
    put_le<uint32_t>(h, 0);                      // ndesc
    const uint32_t len = static_cast<uint32_t>(h.size() + data.size());
    put_le<uint32_t>(bytes_, static_cast<uint32_t>(realtime_ns / kNsPerSecond));
    put_le<uint32_t>(bytes_, static_cast<uint32_t>((realtime_ns % kNsPerSecond) / 1000));
    put_le<uint32_t>(bytes_, len);
    put_le<uint32_t>(bytes_, len);
    bytes_ += h;
    put(bytes_, data.data(), data.size());
    assert(h.size() == 64);  // the usbmon mmapped header (LINKTYPE_USB_LINUX_MMAPPED)
    ++events_;
}

void UsbmonPcapWriter::control_in(int64_t realtime_ns, const UsbSetupPacket& setup,
                                  std::span<const uint8_t> answer) {
    const auto s = setup.bytes();
    const uint64_t urb = next_urb_++;
    event(realtime_ns, urb, 'S', 2, 0x80, setup.length, s.data(), {});
    event(realtime_ns, urb, 'C', 2, 0x80, static_cast<uint32_t>(answer.size()), nullptr, answer);
}

void UsbmonPcapWriter::device_descriptor(int64_t realtime_ns, uint16_t vid, uint16_t pid) {
    // A USB device descriptor (USB 2.0 §9.6.1) with the device's ids.
    const uint8_t d[18] = {18,
                           1,
                           0x00,
                           0x02,
                           0,
                           0,
                           0,
                           64,
                           static_cast<uint8_t>(vid & 0xff),
                           static_cast<uint8_t>(vid >> 8),
                           static_cast<uint8_t>(pid & 0xff),
                           static_cast<uint8_t>(pid >> 8),
                           0x00,
                           0x01,
                           1,
                           2,
                           3,
                           1};
    control_in(realtime_ns, UsbSetupPacket{0x80, 0x06, 0x0100, 0, 18}, d);
}

void UsbmonPcapWriter::interrupt_in(int64_t realtime_ns, std::span<const uint8_t> data,
                                    uint8_t endpoint) {
    event(realtime_ns, 0x1000, 'C', 1, endpoint, static_cast<uint32_t>(data.size()), nullptr, data);
}

int64_t realtime_minus_monotonic_ns() {
    timespec rt{}, mono{};
    clock_gettime(CLOCK_REALTIME, &rt);
    clock_gettime(CLOCK_MONOTONIC, &mono);
    return (static_cast<int64_t>(rt.tv_sec) - mono.tv_sec) * kNsPerSecond +
           (rt.tv_nsec - mono.tv_nsec);
}

namespace {

// The writer and its lock, shared by the backend and the transports it opened.
struct SharedPcap {
    std::shared_ptr<UsbmonPcapWriter> pcap;
    Clock* clock = nullptr;
    std::mutex mutex;
    int64_t rt_offset_ns = 0;
};

class TeeTransport : public Transport {
  public:
    TeeTransport(std::unique_ptr<Transport> inner, std::shared_ptr<SharedPcap> out)
        : inner_(std::move(inner)), out_(std::move(out)) {}
    DeviceId id() const override { return inner_->id(); }
    Result<std::optional<InputReport>> read_input(int timeout_ms) override {
        auto r = inner_->read_input(timeout_ms);
        if (r.ok() && r->has_value()) {
            // note: interface N's reports as endpoint 0x81 + N (a Vive's light on interface 1
            // comes from endpoint 0x82, as a usbmon capture of it shows).
            const int iface = std::clamp(inner_->id().interface_number, 0, 14);
            std::lock_guard<std::mutex> lock(out_->mutex);
            out_->pcap->interrupt_in((*r)->host_time_ns + out_->rt_offset_ns, (*r)->bytes,
                                     static_cast<uint8_t>(0x81 + iface));
        }
        return r;
    }
    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t size) override {
        auto r = inner_->get_feature(report_id, size);
        if (r.ok()) {
            const int iface = std::max(0, inner_->id().interface_number);
            std::lock_guard<std::mutex> lock(out_->mutex);
            out_->pcap->control_in(
                out_->clock->now_ns() + out_->rt_offset_ns,
                hid_get_report_setup(HidReportType::feature, report_id,
                                     static_cast<uint16_t>(iface), static_cast<uint16_t>(size)),
                *r);
        }
        return r;
    }
    Status set_feature(std::span<const uint8_t> data) override { return inner_->set_feature(data); }
    Status write_output(std::span<const uint8_t> data) override {
        return inner_->write_output(data);
    }
    bool finished() const override { return inner_->finished(); }

  private:
    std::unique_ptr<Transport> inner_;
    std::shared_ptr<SharedPcap> out_;
};

class TeeBackend : public TransportBackend {
  public:
    TeeBackend(std::unique_ptr<TransportBackend> inner, std::shared_ptr<SharedPcap> out)
        : inner_(std::move(inner)), out_(std::move(out)) {}
    std::string name() const override { return inner_->name(); }
    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) override {
        return inner_->enumerate(filter);
    }
    Result<std::unique_ptr<Transport>> open(const DeviceId& id) override {
        auto t = inner_->open(id);
        if (!t.ok()) return t.error();
        {
            std::lock_guard<std::mutex> lock(out_->mutex);
            out_->pcap->device_descriptor(out_->clock->now_ns() + out_->rt_offset_ns, id.vendor_id,
                                          id.product_id);
        }
        return std::unique_ptr<Transport>(std::make_unique<TeeTransport>(std::move(*t), out_));
    }

  private:
    std::unique_ptr<TransportBackend> inner_;
    std::shared_ptr<SharedPcap> out_;
};

}  // namespace

std::unique_ptr<TransportBackend> create_pcap_tee_backend(std::unique_ptr<TransportBackend> inner,
                                                          std::shared_ptr<UsbmonPcapWriter> pcap,
                                                          Clock& clock, int64_t rt_offset_ns) {
    auto out = std::make_shared<SharedPcap>();
    out->clock = &clock;
    out->pcap = std::move(pcap);
    out->rt_offset_ns = rt_offset_ns;
    return std::make_unique<TeeBackend>(std::move(inner), std::move(out));
}

}  // namespace hmdnode
