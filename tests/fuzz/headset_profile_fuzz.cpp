// libFuzzer harness: the headset profile readers of render/src/lens_profile.cpp (a profile a
// config's node.headset names, and an OpenVR/lighthouse device config) on untrusted bytes; the
// first byte picks the reader. Invariant: an accepted profile passes validate_headset_profile and
// reads again from what its own JSON writer makes of it.
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hmdnode/render/lens.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    if (size == 0) return 0;
    const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
    Result<HeadsetProfile> p = (data[0] & 1) ? headset_profile_from_openvr_config(text, "fuzz")
                                             : parse_headset_profile(text, "fuzz");
    if (!p.ok()) return 0;
    if (!validate_headset_profile(*p, "fuzz").ok()) abort();
    Result<HeadsetProfile> again = parse_headset_profile(headset_profile_to_json(*p), "fuzz");
    if (!again.ok()) abort();
    return 0;
}
