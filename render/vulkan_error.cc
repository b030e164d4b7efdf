#include "render/vulkan_error.h"

#include <string>

namespace curvecheck {

Error VulkanError(const vk::SystemError& e, VulkanUse use) {
  const bool window = use == VulkanUse::kWindow;
  const std::error_code code = e.code();
  if (code == vk::make_error_code(vk::Result::eErrorDeviceLost) ||
      (window && code == vk::make_error_code(vk::Result::eErrorSurfaceLostKHR))) {
    return Error("Vulkan", std::string(window ? "the device or the window was lost: " : "the device was lost: ") + e.what(),
                 "run again; if it repeats, update the driver or use lavapipe (CURVECHECK_VULKAN_DEVICE=llvmpipe)");
  }
  if (code == vk::make_error_code(vk::Result::eErrorOutOfDeviceMemory) ||
      code == vk::make_error_code(vk::Result::eErrorOutOfHostMemory)) {
    return Error("Vulkan", std::string("out of memory: ") + e.what(),
                 "close other programs that use the GPU and run again, or use lavapipe "
                 "(CURVECHECK_VULKAN_DEVICE=llvmpipe, which uses main memory)");
  }
  return Error("Vulkan", std::string("a Vulkan call failed: ") + e.what(),
               window ? "check the Vulkan installation (vulkaninfo) and the display"
                      : "check the Vulkan installation (vulkaninfo)");
}

}  // namespace curvecheck
