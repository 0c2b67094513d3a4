#include "tool/commands.hpp"

#include <algorithm>
#include <utility>
#include <vector>

namespace hmdnode::tool {
namespace {
int g_exit_code = 0;

// Function-local so that registrations from static objects of other files never see it
// uninitialised (static initialisation order across files is unspecified).
std::vector<std::pair<int, void (*)(CLI::App&)>>& registry() {
    static std::vector<std::pair<int, void (*)(CLI::App&)>> r;
    return r;
}
}  // namespace

int exit_code() {
    return g_exit_code;
}
void set_exit_code(int code) {
    g_exit_code = code;
}

CommandRegistration::CommandRegistration(int order, void (*add)(CLI::App&)) {
    registry().emplace_back(order, add);
}

void register_commands(CLI::App& app) {
    auto all = registry();
    all.emplace_back(10, add_replay_command);
    all.emplace_back(20, add_trace_command);
    all.emplace_back(30, add_scene_command);
    std::stable_sort(all.begin(), all.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [order, add] : all) add(app);
}

}  // namespace hmdnode::tool
