// libFuzzer harness: the usbmon capture reader (pcap through libpcap, gzip through zlib) on
// untrusted bytes, then the summary and the capture backend's replay of every device.
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <span>

#include "hmdnode/hal/transport/usbmon_capture.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    auto cap = parse_usbmon_capture(std::span<const uint8_t>(data, size));
    if (!cap.ok()) return 0;
    const CaptureSummary s = summarize_capture(*cap);
    auto backend = create_capture_backend(std::make_shared<UsbCapture>(std::move(*cap)), s);
    auto ids = backend->enumerate(DeviceFilter{});
    if (!ids.ok()) abort();
    for (const DeviceId& id : *ids) {
        auto t = backend->open(id);
        if (!t.ok()) abort();
        int64_t last = INT64_MIN;
        (void)last;
        while (true) {
            auto r = (*t)->read_input(0);
            if (!r.ok()) abort();
            if (!r->has_value()) break;
            if ((*r)->bytes.empty()) abort();
        }
        (void)(*t)->get_feature(0x01, 64);
    }
    return 0;
}
