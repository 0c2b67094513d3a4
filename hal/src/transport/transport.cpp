// Transport helpers: device filters, VID:PID parsing, the backend factory, and the HID class
// control requests of HID 1.11 §7.2 (GET_REPORT 0x01 / SET_REPORT 0x09) as setup packets.
// Cost: all O(length of the text); no allocation beyond the returned values.
#include "hmdnode/hal/transport.hpp"

#include <cctype>
#include <cstdio>

namespace hmdnode {

bool DeviceFilter::matches(const DeviceId& id) const {
    if (vendor_id != 0 && id.vendor_id != vendor_id) return false;
    if (product_id != 0 && id.product_id != product_id) return false;
    if (!serial.empty() && id.serial != serial) return false;
    return true;
}

namespace {

Result<uint16_t> parse_hex16(std::string_view part, std::string_view text, const char* what) {
    if (part.empty() || part.size() > 4)
        return make_error("device \"" + std::string(text) + "\": the " + what +
                          " must be 1 to 4 hex digits (like 28de:2000)");
    uint32_t v = 0;
    for (char c : part) {
        int d;
        if (c >= '0' && c <= '9')
            d = c - '0';
        else if (c >= 'a' && c <= 'f')
            d = c - 'a' + 10;
        else if (c >= 'A' && c <= 'F')
            d = c - 'A' + 10;
        else
            return make_error("device \"" + std::string(text) + "\": '" + std::string(1, c) +
                              "' in the " + what + " is not a hex digit (like 28de:2000)");
        v = v * 16 + static_cast<uint32_t>(d);
    }
    return static_cast<uint16_t>(v);
}

}  // namespace

Result<DeviceFilter> parse_vid_pid(std::string_view text) {
    const size_t colon = text.find(':');
    if (colon == std::string_view::npos)
        return make_error("device \"" + std::string(text) +
                          "\": expected VID:PID in hex (like 28de:2000)");
    const size_t colon2 = text.find(':', colon + 1);
    Result<uint16_t> vid = parse_hex16(text.substr(0, colon), text, "vendor id");
    if (!vid.ok()) return vid.error();
    Result<uint16_t> pid =
        parse_hex16(text.substr(colon + 1, colon2 == std::string_view::npos ? std::string_view::npos
                                                                            : colon2 - colon - 1),
                    text, "product id");
    if (!pid.ok()) return pid.error();
    DeviceFilter f;
    f.vendor_id = *vid;
    f.product_id = *pid;
    if (colon2 != std::string_view::npos) {
        f.serial = std::string(text.substr(colon2 + 1));
        if (f.serial.empty())
            return make_error("device \"" + std::string(text) +
                              "\": empty serial after the second ':'");
    }
    return f;
}

std::string format_vid_pid(uint16_t vendor_id, uint16_t product_id) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%04x:%04x", vendor_id, product_id);
    return buf;
}

Result<std::unique_ptr<TransportBackend>> create_transport_backend(
    const std::string& name, const TransportBackendOptions& options) {
    if (name == "hidapi" || name == "hidraw") return create_hidapi_backend(options);
    if (name == "libusb") return create_libusb_backend(options);
    return make_error("unknown transport backend \"" + name + "\" (known: hidapi, libusb)");
}

std::array<uint8_t, 8> UsbSetupPacket::bytes() const {
    return {request_type,
            request,
            static_cast<uint8_t>(value & 0xff),
            static_cast<uint8_t>(value >> 8),
            static_cast<uint8_t>(index & 0xff),
            static_cast<uint8_t>(index >> 8),
            static_cast<uint8_t>(length & 0xff),
            static_cast<uint8_t>(length >> 8)};
}

UsbSetupPacket hid_get_report_setup(HidReportType type, uint8_t report_id, uint16_t interface,
                                    uint16_t length) {
    return UsbSetupPacket{0xA1, 0x01,
                          static_cast<uint16_t>((static_cast<uint16_t>(type) << 8) | report_id),
                          interface, length};
}

UsbSetupPacket hid_set_report_setup(HidReportType type, uint8_t report_id, uint16_t interface,
                                    uint16_t length) {
    return UsbSetupPacket{0x21, 0x09,
                          static_cast<uint16_t>((static_cast<uint16_t>(type) << 8) | report_id),
                          interface, length};
}

}  // namespace hmdnode
