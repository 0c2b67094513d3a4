// libFuzzer harness: the Vive/Index IMU codec on untrusted bytes. The input is split into reports
// (first byte of each chunk = its length); every report goes through the stateful decoder and the
// range-report parser. Invariants: at most three samples per report, sequence numbers strictly
// increase, finite values within the configured range.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "hmdnode/hal/codec/vive_imu.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode::vive;
    ImuDecoder dec(size && (data[0] & 1) ? Variant::Index : Variant::Vive);
    std::array<ImuSample, 3> out;
    uint64_t last_seq = 0;
    bool have = false;
    size_t i = 0;
    while (i < size) {
        const size_t n = std::min<size_t>(data[i], size - i - 1);
        std::span<const uint8_t> report(data + i + 1, n);
        i += 1 + n;
        if (auto r = parse_range_report(report); r.ok()) dec.set_ranges(*r);
        const size_t k = dec.decode(report, out);
        if (k > 3) abort();
        for (size_t j = 0; j < k; ++j) {
            if (have && out[j].sequence <= last_seq) abort();
            have = true;
            last_seq = out[j].sequence;
            for (int a = 0; a < 3; ++a)
                if (!std::isfinite(out[j].accel[a]) ||
                    std::abs(out[j].accel[a]) > dec.ranges().accel_m_s2 * 1.0001 ||
                    std::abs(out[j].gyro[a]) > dec.ranges().gyro_rad_s * 1.0001)
                    abort();
        }
    }
    return 0;
}
