// Vulkan set-up shared by the renderer (render/renderer.cc) and the presenter (render/presenter.cc): the instance,
// the choice of device and queue family (CURVECHECK_VULKAN_DEVICE), memory types and host-visible buffers.
// Internal to render/ (Vulkan headers stay in this folder). Failures throw Error saying what to install or set.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>
#include <vulkan/vulkan_raii.hpp>

namespace curvecheck {

// The instance for `application` with the instance extensions given (e.g. a window system's). Throws Error naming
// the drivers to install if the loader has no usable driver.
vk::raii::Instance MakeVulkanInstance(const vk::raii::Context& context, const char* application, uint32_t api_version,
                                      const std::vector<const char*>& extensions = {});

// What a caller needs of a physical device.
struct DeviceNeeds {
  std::string purpose;                          // what the device is for, in errors: "render offscreen"
  uint32_t min_api_version = VK_API_VERSION_1_0;
  std::vector<const char*> extensions;          // device extensions that must be present
  // The queue family to use: the first one this accepts (family index, its properties).
  std::function<bool(const vk::raii::PhysicalDevice&, uint32_t, const vk::QueueFamilyProperties&)> accepts_queue;
  std::string no_queue;                         // why a device with no such family is passed over
  std::string fix;                              // what to do when no device qualifies
};

struct ChosenDevice {
  vk::raii::PhysicalDevice physical{nullptr};
  uint32_t queue_family = 0;
  std::string name;
};

// Chooses among the devices that meet `needs` a discrete GPU first, then an integrated one, then any other
// (lavapipe). The environment variable CURVECHECK_VULKAN_DEVICE, if set, admits only devices whose name contains
// it. Throws Error if the loader lists no device, or listing each device with the reason it was passed over.
ChosenDevice ChooseDevice(const vk::raii::Instance& instance, const DeviceNeeds& needs);

// A buffer in host-visible, host-coherent memory, mapped for its lifetime (uploads and readbacks).
struct HostBuffer {
  vk::raii::Buffer buffer{nullptr};
  vk::raii::DeviceMemory memory{nullptr};
  void* mapped = nullptr;
  vk::DeviceSize size = 0;
};

// The first memory type among `type_bits` with all of `props`. Throws Error naming the device if there is none
// (rather than fall back to memory of other properties).
uint32_t FindMemoryType(const vk::raii::PhysicalDevice& physical, uint32_t type_bits, vk::MemoryPropertyFlags props);

HostBuffer MakeHostBuffer(const vk::raii::Device& device, const vk::raii::PhysicalDevice& physical,
                          vk::DeviceSize size, vk::BufferUsageFlags usage);

}  // namespace curvecheck
