// Vulkan failures as curvecheck::Error (style.md rule 7), shared by the renderer and the presenter. Vulkan-Hpp's
// RAII wrappers throw vk::SystemError for any failing VkResult; these say which failure it was and what to do.
// Internal to render/ (Vulkan headers stay in this folder).
#pragma once

#include <vulkan/vulkan_raii.hpp>

#include "core/error.h"

namespace curvecheck {

// What the call was doing: offscreen rendering, or presenting to a window (whose surface can be lost as the
// device can).
enum class VulkanUse { kOffscreen, kWindow };

// The one-line error for `e`: a lost device (or window), memory exhausted, or any other failure.
Error VulkanError(const vk::SystemError& e, VulkanUse use);

// Runs f(), turning a vk::SystemError into VulkanError(e, use).
template <typename F>
auto WithVulkanErrors(F&& f, VulkanUse use = VulkanUse::kOffscreen) {
  try {
    return f();
  } catch (const vk::SystemError& e) {
    throw VulkanError(e, use);
  }
}

}  // namespace curvecheck
