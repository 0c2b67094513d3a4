// libFuzzer harness: the Rift DK2/CV1 IMU codec on untrusted bytes (chunks prefixed by a length
// byte). Invariants: at most two samples per report, strictly increasing sequence numbers, values
// within the 21-bit range, and parse(encode(parse(x))) == parse(x) for a report that parses.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "hmdnode/hal/codec/rift_imu.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode::rift;
    ImuDecoder dec;
    std::array<ImuSample, 2> out;
    uint64_t last = 0;
    bool have = false;
    size_t i = 0;
    while (i < size) {
        const size_t n = std::min<size_t>(data[i], size - i - 1);
        std::span<const uint8_t> report(data + i + 1, n);
        i += 1 + n;
        if (auto r = parse_report(report); r.ok()) {
            auto again = parse_report(encode_report(*r));
            if (!again.ok() || again->sample_count != r->sample_count ||
                again->samples[0].accel != r->samples[0].accel ||
                again->samples[1].gyro != r->samples[1].gyro)
                abort();
        }
        const size_t k = dec.decode(report, out);
        if (k > 2) abort();
        for (size_t j = 0; j < k; ++j) {
            if (have && out[j].sequence <= last) abort();
            have = true;
            last = out[j].sequence;
            for (int a = 0; a < 3; ++a)
                if (std::abs(out[j].accel[a]) > (1 << 20) * kLsb) abort();
        }
    }
    return 0;
}
