// `hmdnode displays`: the KMS connectors of /dev/dri/card* (name, connection, EDID identity,
// non-desktop, modes) and the displays Vulkan drivers expose through VK_KHR_display: what
// display.type "kms" / "vk-display" and display.connector can name (docs/hardware.md).
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "hmdnode/hal/display/kms_display.hpp"
#include "hmdnode/render/vk_display.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors errors{"displays"};

// A listing that fails is reported (exit 1) and the other still runs.
void run_displays(const std::string& device, bool all_modes) {
    Result<std::vector<KmsConnectorInfo>> conns = list_kms_connectors(device);
    std::printf("KMS connectors (display.type \"kms\"):\n");
    if (!conns.ok()) {
        errors.fail(conns.error().message);
    } else if (conns->empty()) {
        std::printf("  none (no /dev/dri/card*: no KMS driver loaded)\n");
    }
    if (conns.ok())
        for (const KmsConnectorInfo& c : *conns) {
            std::printf("  %s %s: %s", c.device.c_str(), c.name.c_str(), c.connection.c_str());
            if (c.edid)
                std::printf(", edid:%s:%04X%s%s", c.edid->vendor.c_str(), c.edid->product,
                            c.edid->monitor_name.empty() ? "" : " ", c.edid->monitor_name.c_str());
            std::printf("%s\n", c.non_desktop ? ", non-desktop (a headset)" : "");
            const size_t shown = all_modes ? c.modes.size() : std::min<size_t>(c.modes.size(), 4);
            for (size_t i = 0; i < shown; ++i)
                std::printf("    %dx%d@%.3f%s\n", c.modes[i].width, c.modes[i].height,
                            c.modes[i].refresh_hz, c.modes[i].preferred ? " (preferred)" : "");
            if (shown < c.modes.size())
                std::printf("    ... %zu more (--all-modes)\n", c.modes.size() - shown);
        }
    Result<std::vector<VulkanDisplayInfo>> vk = list_vulkan_displays();
    std::printf("Vulkan displays (display.type \"vk-display\"):\n");
    if (!vk.ok()) {
        errors.fail(vk.error().message);
    } else if (vk->empty()) {
        std::printf("  none (no driver exposes a display through VK_KHR_display)\n");
    } else {
        for (const VulkanDisplayInfo& d : *vk) {
            std::printf("  \"%s\" on %s: %dx%d\n", d.name.c_str(), d.gpu.c_str(), d.width,
                        d.height);
            for (const VulkanDisplayMode& m : d.modes)
                std::printf("    %dx%d@%.3f\n", m.width, m.height, m.refresh_hz);
        }
    }
}

void add_displays_command(CLI::App& app) {
    CLI::App* c = app.add_subcommand(
        "displays", "List KMS connectors (EDID, non-desktop, modes) and Vulkan displays");
    auto device = std::make_shared<std::string>();
    auto all_modes = std::make_shared<bool>(false);
    c->add_option("--device", *device, "One DRM device (default: every /dev/dri/card*)");
    c->add_flag("--all-modes", *all_modes, "Every mode of every connector (default: 4 each)");
    c->callback([=] { run_displays(*device, *all_modes); });
}

static const CommandRegistration reg{85, add_displays_command};

}  // namespace
}  // namespace hmdnode::tool
