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
