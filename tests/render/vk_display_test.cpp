// VK_KHR_display listing and choice. lavapipe exposes no display: the list is empty and choosing
// one is an error naming the displays found (none).
#include <gtest/gtest.h>

#include <string>

#include "hmdnode/render/vk_display.hpp"

using namespace hmdnode;

TEST(VkDisplay, LavapipeListsNoDisplayAndChoosingNamesNone) {
    Result<std::vector<VulkanDisplayInfo>> list = list_vulkan_displays();
    ASSERT_TRUE(list.ok()) << list.error().message;
    for (const VulkanDisplayInfo& d : *list)
        EXPECT_EQ(d.gpu.find("llvmpipe"), std::string::npos) << "lavapipe offers a display?";
    if (!list->empty()) GTEST_SKIP() << "a driver here exposes displays; the lavapipe case is moot";
    Result<VulkanDisplayInfo> d = choose_vulkan_display(*list, "");
    ASSERT_FALSE(d.ok());
    EXPECT_NE(d.error().message.find("display.type vk-display"), std::string::npos);
    EXPECT_NE(d.error().message.find("displays found: none"), std::string::npos)
        << d.error().message;
}

TEST(VkDisplay, ChoosingNamesTheDisplaysFoundWhenNoneMatches) {
    std::vector<VulkanDisplayInfo> list(2);
    list[0].gpu = "GPU A";
    list[0].name = "Valve Index";
    list[1].gpu = "GPU A";
    list[1].name = "DELL U2720Q";
    Result<VulkanDisplayInfo> hit = choose_vulkan_display(list, "Index");
    ASSERT_TRUE(hit.ok());
    EXPECT_EQ(hit->name, "Valve Index");
    Result<VulkanDisplayInfo> miss = choose_vulkan_display(list, "Vive");
    ASSERT_FALSE(miss.ok());
    EXPECT_NE(miss.error().message.find("\"Vive\""), std::string::npos);
    EXPECT_NE(miss.error().message.find("\"Valve Index\" on GPU A, \"DELL U2720Q\" on GPU A"),
              std::string::npos)
        << miss.error().message;
    EXPECT_FALSE(choose_vulkan_display(list, "").ok());  // two displays, none named
}

// The present path's error on a machine whose drivers expose no display (lavapipe): the same
// "displays found" error as choosing, before any surface or device is made.
TEST(VkDisplay, OutputOnLavapipeNamesTheDisplaysFound) {
    Result<std::vector<VulkanDisplayInfo>> list = list_vulkan_displays();
    ASSERT_TRUE(list.ok()) << list.error().message;
    if (!list->empty()) GTEST_SKIP() << "a driver here exposes displays; the lavapipe case is moot";
    VulkanDisplayOutputConfig config;
    config.display = "Index";
    auto out = create_vulkan_display_output(config);
    ASSERT_FALSE(out.ok());
    EXPECT_NE(out.error().message.find("display.connector \"Index\""), std::string::npos)
        << out.error().message;
    EXPECT_NE(out.error().message.find("displays found: none"), std::string::npos)
        << out.error().message;
}

TEST(VkDisplay, ModeChoice) {
    VulkanDisplayInfo d;
    d.gpu = "GPU A";
    d.name = "Valve Index";
    d.width = 2880;
    d.height = 1600;
    d.modes = {{1920, 1080, 60.0}, {2880, 1600, 90.0}, {2880, 1600, 144.0}, {2880, 1600, 120.0}};
    // Nothing asked: the highest refresh at the physical resolution.
    Result<size_t> m = choose_vulkan_display_mode(d, 0, 0, 0.0);
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(*m, 2u);
    m = choose_vulkan_display_mode(d, 2880, 1600, 90.0);
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(*m, 1u);
    m = choose_vulkan_display_mode(d, 2880, 1600, 119.8);  // within 0.5 Hz
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(*m, 3u);
    m = choose_vulkan_display_mode(d, 1920, 1080, 0.0);
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(*m, 0u);
    m = choose_vulkan_display_mode(d, 2880, 1600, 75.0);
    ASSERT_FALSE(m.ok());
    EXPECT_NE(m.error().message.find("\"Valve Index\" on GPU A has no mode 2880x1600@75.00"),
              std::string::npos)
        << m.error().message;
    EXPECT_NE(m.error().message.find("1920x1080@60.00, 2880x1600@90.00"), std::string::npos)
        << m.error().message;
    // A display without modes.
    VulkanDisplayInfo none = d;
    none.modes.clear();
    EXPECT_FALSE(choose_vulkan_display_mode(none, 0, 0, 0.0).ok());
    // A mode whose driver reports no refresh rate has no vsync grid to pace on: an error.
    VulkanDisplayInfo no_rate = d;
    no_rate.modes = {{2880, 1600, 0.0}};
    m = choose_vulkan_display_mode(no_rate, 0, 0, 0.0);
    ASSERT_FALSE(m.ok());
    EXPECT_NE(m.error().message.find("2880x1600 reports a refresh rate of 0.000 Hz"),
              std::string::npos)
        << m.error().message;
}
