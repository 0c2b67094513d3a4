// The scan-out buffers' format and modifiers (render/scanout.hpp): the first of four 8-bit RGB
// formats the display's plane accepts, in the order a KMS plane most often supports them
// (XRGB8888 is the one every atomic driver must take, after Weston's and kmscube's choice).
// O(offered formats).
#include <cstdio>

#include "hmdnode/render/scanout.hpp"

namespace hmdnode {
namespace {

constexpr uint32_t fourcc_code(char a, char b, char c, char d) {
    return uint32_t(uint8_t(a)) | uint32_t(uint8_t(b)) << 8 | uint32_t(uint8_t(c)) << 16 |
           uint32_t(uint8_t(d)) << 24;
}

}  // namespace

std::string fourcc_text(uint32_t fourcc) {
    std::string s(4, '?');
    for (int i = 0; i < 4; ++i) {
        const char c = char((fourcc >> (8 * i)) & 0xff);
        if (c >= 0x20 && c < 0x7f) s[size_t(i)] = c;
    }
    return s;
}

Result<ScanoutAllocation> choose_scanout_allocation(const std::vector<ScanoutFormat>& offered,
                                                    const std::string& device) {
    static constexpr uint32_t kPreferred[] = {
        fourcc_code('X', 'R', '2', '4'),  // XRGB8888
        fourcc_code('A', 'R', '2', '4'),  // ARGB8888
        fourcc_code('X', 'B', '2', '4'),  // XBGR8888
        fourcc_code('A', 'B', '2', '4'),  // ABGR8888
    };
    for (uint32_t want : kPreferred) {
        ScanoutAllocation a;
        a.fourcc = want;
        a.implicit_ok = false;
        bool found = false;
        for (const ScanoutFormat& f : offered) {
            if (f.fourcc != want) continue;
            found = true;
            if (f.modifier == kDrmModInvalid || f.modifier == kDrmModLinear) a.implicit_ok = true;
            if (f.modifier != kDrmModInvalid) a.modifiers.push_back(f.modifier);
        }
        if (found) return a;
    }
    std::string list;
    for (const ScanoutFormat& f : offered) {
        if (!list.empty()) list += ", ";
        list += fourcc_text(f.fourcc);
        if (f.modifier != kDrmModInvalid) {
            char m[24];
            std::snprintf(m, sizeof m, ":0x%llx", static_cast<unsigned long long>(f.modifier));
            list += m;
        }
    }
    return make_error("scan-out on " + (device.empty() ? std::string("the display") : device) +
                      ": the primary plane takes none of XR24, AR24, XB24, AB24 (offered: " +
                      (list.empty() ? std::string("none") : list) + ")");
}

}  // namespace hmdnode
