// libFuzzer harness: the libsurvive recording reader on untrusted text (as device T20), then the
// replay backend's reports through the Index codec with the recording's calibration.
#include <array>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>

#include "hmdnode/hal/codec/vive_imu.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    auto rec = parse_survive_recording(std::string(reinterpret_cast<const char*>(data), size),
                                       "fuzz.rec", "T20");
    if (!rec.ok()) return 0;
    if (rec->imu.empty()) abort();
    auto shared = std::make_shared<const SurviveRecording>(std::move(*rec));
    auto backend = create_survive_backend(shared);
    auto ids = backend->enumerate(DeviceFilter{});
    if (!ids.ok() || ids->size() != 1) abort();
    auto t = backend->open(ids->front());
    if (!t.ok()) abort();
    auto codec = make_vive_codec(vive::kIndexProductId);
    if (shared->has_config) codec->set_imu_calibration(shared->calibration);
    codec->configure(**t);
    std::array<DeviceSample, ReportCodec::kMaxSamplesPerReport> out;
    size_t reports = 0;
    while (true) {
        auto r = (*t)->read_input(0);
        if (!r.ok()) abort();
        if (!r->has_value()) break;
        ++reports;
        (void)codec->decode((*r)->bytes, out);
    }
    if (reports != shared->imu.size()) abort();
    return 0;
}
