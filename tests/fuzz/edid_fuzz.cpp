// libFuzzer harness: the EDID identity parser (hal/src/display/kms_display.cpp) on untrusted
// bytes -- a connector's EDID comes from the monitor. The first byte picks whether the checksum
// is fixed up (so that the parser's later fields are reached). Invariants: a parsed vendor is
// three letters A-Z; the monitor name is printable ASCII of at most 13 characters.
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "hmdnode/hal/display/kms_display.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    std::vector<uint8_t> edid(data + 1, data + size);
    if ((data[0] & 1) && edid.size() >= 128) {
        uint8_t sum = 0;
        for (int i = 0; i < 127; ++i) sum = uint8_t(sum + edid[size_t(i)]);
        edid[127] = uint8_t(256 - sum);
    }
    hmdnode::Result<hmdnode::EdidIdentity> id =
        hmdnode::parse_edid_identity(edid.data(), edid.size());
    if (!id.ok()) return 0;
    if (id->vendor.size() != 3) abort();
    for (char c : id->vendor)
        if (c < 'A' || c > 'Z') abort();
    if (id->monitor_name.size() > 13) abort();
    for (char c : id->monitor_name)
        if (c < 0x20 || c > 0x7e) abort();
    return 0;
}
