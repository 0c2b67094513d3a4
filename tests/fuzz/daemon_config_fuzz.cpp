// libFuzzer harness: hmdnoded's config reader (firmware_host/src/daemon/config.cpp,
// docs/daemon.md "Config") on untrusted bytes, through the file it reads (a temporary file; paths
// in it resolve beside that file). Invariants for an accepted config: a scene, the numbers in the
// ranges the docs give (realtime priority, resample rate, noise, LOD tolerance, mesh cells, status
// period), the persistence within the refresh period when a rate is given; a failure names the
// file. The temporary directory holds a headset profile (headset.json) a config may name.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "daemon/config.hpp"
#include "hmdnode/render/lens.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    static const std::filesystem::path dir = [] {
        unsetenv("RUNTIME_DIRECTORY");
        const auto d = std::filesystem::temp_directory_path() /
                       ("daemon_config_fuzz_" + std::to_string(getpid()));
        std::filesystem::create_directories(d);
        // note: a profile a config can name ("node": {"headset": "headset.json"}), as the seed
        // does.
        std::ofstream(d / "headset.json") << headset_profile_to_json(generic_headset_profile());
        return d;
    }();
    const std::filesystem::path path = dir / "hmdnoded.json";
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(data), std::streamsize(size));
    Result<DaemonConfig> c = load_daemon_config(path);
    if (!c.ok()) {
        if (c.error().message.rfind(path.string(), 0) != 0 &&
            c.error().message.find("hmdnoded.json") == std::string::npos)
            abort();  // note: every error names the file
        return 0;
    }
    if (c->scene.empty()) abort();
    if (c->realtime_priority < 0 || c->realtime_priority > 99) abort();
    if (!(c->tracker.resample_hz >= 0.0 && c->tracker.noise_deg >= 0.0)) abort();
    if (!(c->node.lod.tolerance_px >= 0.0)) abort();
    if (c->node.mesh_cols < 0 || c->node.mesh_cols > 512) abort();
    if (!(c->status_every_s > 0.0)) abort();
    if (c->display.refresh_hz > 0.0 && !check_persistence(c->display).ok()) abort();
    return 0;
}
