#include "render/vulkan_device.h"

#include <fmt/format.h>

#include <cstdlib>
#include <cstring>

#include "core/error.h"

namespace curvecheck {
namespace {

constexpr const char* kInstallDriver = "install mesa-vulkan-drivers (lavapipe, CPU) or your GPU's Vulkan driver";

// Why `device` cannot serve `needs` ("" if it can); sets *family to the queue family to use.
std::string Unsuitable(const vk::raii::PhysicalDevice& device, const DeviceNeeds& needs, const char* wanted,
                       uint32_t* family) {
  const vk::PhysicalDeviceProperties props = device.getProperties();
  const std::string name = props.deviceName.data();
  if (wanted && name.find(wanted) == std::string::npos) return fmt::format("not CURVECHECK_VULKAN_DEVICE='{}'", wanted);
  if (props.apiVersion < needs.min_api_version) {
    return fmt::format("Vulkan {}.{}, not {}.{}", VK_API_VERSION_MAJOR(props.apiVersion),
                       VK_API_VERSION_MINOR(props.apiVersion), VK_API_VERSION_MAJOR(needs.min_api_version),
                       VK_API_VERSION_MINOR(needs.min_api_version));
  }
  const std::vector<vk::ExtensionProperties> available = device.enumerateDeviceExtensionProperties();
  for (const char* extension : needs.extensions) {
    bool found = false;
    for (const vk::ExtensionProperties& e : available) {
      found = found || std::strcmp(e.extensionName.data(), extension) == 0;
    }
    if (!found) return std::string("no ") + extension;
  }
  const std::vector<vk::QueueFamilyProperties> families = device.getQueueFamilyProperties();
  for (uint32_t f = 0; f < families.size(); ++f) {
    if (needs.accepts_queue(device, f, families[f])) {
      *family = f;
      return "";
    }
  }
  return needs.no_queue;
}

}  // namespace

vk::raii::Instance MakeVulkanInstance(const vk::raii::Context& context, const char* application, uint32_t api_version,
                                      const std::vector<const char*>& extensions) {
  const vk::ApplicationInfo app(application, 1, "curvecheck", 1, api_version);
  try {
    return vk::raii::Instance(context, vk::InstanceCreateInfo({}, &app, {}, extensions));
  } catch (const vk::SystemError& e) {
    throw Error("Vulkan", std::string("no usable Vulkan driver (") + e.what() + ")", kInstallDriver);
  }
}

ChosenDevice ChooseDevice(const vk::raii::Instance& instance, const DeviceNeeds& needs) {
  vk::raii::PhysicalDevices devices(instance);
  if (devices.empty()) throw Error("Vulkan", "the Vulkan loader found no device", kInstallDriver);
  const char* wanted = std::getenv("CURVECHECK_VULKAN_DEVICE");
  int best = -1, best_score = -1;
  uint32_t best_family = 0;
  std::string rejected;
  for (size_t i = 0; i < devices.size(); ++i) {
    uint32_t family = 0;
    const std::string why = Unsuitable(devices[i], needs, wanted, &family);
    const vk::PhysicalDeviceProperties props = devices[i].getProperties();
    if (!why.empty()) {
      rejected += fmt::format("{}{}: {}", rejected.empty() ? "" : ", ", props.deviceName.data(), why);
      continue;
    }
    const int score = props.deviceType == vk::PhysicalDeviceType::eDiscreteGpu     ? 3
                      : props.deviceType == vk::PhysicalDeviceType::eIntegratedGpu ? 2
                                                                                    : 1;
    if (score > best_score) best = static_cast<int>(i), best_score = score, best_family = family;
  }
  if (best < 0) {
    throw Error("Vulkan", fmt::format("no Vulkan device can {} ({})", needs.purpose, rejected),
                wanted ? needs.fix + ", or set CURVECHECK_VULKAN_DEVICE to part of a name listed" : needs.fix);
  }
  ChosenDevice chosen;
  chosen.physical = std::move(devices[static_cast<size_t>(best)]);
  chosen.queue_family = best_family;
  chosen.name = chosen.physical.getProperties().deviceName.data();
  return chosen;
}

uint32_t FindMemoryType(const vk::raii::PhysicalDevice& physical, uint32_t type_bits, vk::MemoryPropertyFlags props) {
  const vk::PhysicalDeviceMemoryProperties mem = physical.getMemoryProperties();
  for (uint32_t i = 0; i < mem.memoryTypeCount; ++i) {
    if ((type_bits & (1u << i)) && (mem.memoryTypes[i].propertyFlags & props) == props) return i;
  }
  throw Error("Vulkan", fmt::format("device {} has no memory type with the properties {}",
                                    physical.getProperties().deviceName.data(), vk::to_string(props)),
              "use another Vulkan device (CURVECHECK_VULKAN_DEVICE)");
}

HostBuffer MakeHostBuffer(const vk::raii::Device& device, const vk::raii::PhysicalDevice& physical,
                          vk::DeviceSize size, vk::BufferUsageFlags usage) {
  HostBuffer b;
  b.size = size;
  b.buffer = vk::raii::Buffer(device, vk::BufferCreateInfo({}, size, usage));
  const vk::MemoryRequirements req = b.buffer.getMemoryRequirements();
  const vk::MemoryPropertyFlags props =
      vk::MemoryPropertyFlagBits::eHostVisible | vk::MemoryPropertyFlagBits::eHostCoherent;
  b.memory = vk::raii::DeviceMemory(
      device, vk::MemoryAllocateInfo(req.size, FindMemoryType(physical, req.memoryTypeBits, props)));
  b.buffer.bindMemory(*b.memory, 0);
  b.mapped = b.memory.mapMemory(0, size);
  return b;
}

}  // namespace curvecheck
