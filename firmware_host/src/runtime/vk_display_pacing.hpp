// display.type "vk-display" as a hal Display: a VK_KHR_display output (render/vk_display.hpp)
// with the vsync grid, pacing feedback and photon times the frame loop reads from every display.
#pragma once

#include <memory>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/display.hpp"
#include "hmdnode/render/vk_display.hpp"

namespace hmdnode {

// Eye size = half the mode's width x its height; the grid is anchored at creation and, with
// VK_KHR_present_wait, re-anchored on each present's return (the vsync it showed at).
std::unique_ptr<Display> make_vk_display_pacing(Clock& clock,
                                                std::unique_ptr<VulkanDisplayOutput> output,
                                                int64_t latch_margin_ns, int64_t persistence_ns);

}  // namespace hmdnode
