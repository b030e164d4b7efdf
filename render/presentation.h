// The presenter's Vulkan side (render/presenter.cc): a FIFO swapchain on a window's surface, into which the image
// in a host-visible buffer is copied byte for byte (vkCmdCopyBufferToImage: no sampler, no blit, no scaling) and
// presented. It knows no window system: the caller gives the instance extensions its surfaces need and a function
// that makes the surface. Internal to render/ (Vulkan headers stay in this folder).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>
#include <vulkan/vulkan_raii.hpp>

#include "render/vulkan_device.h"

namespace curvecheck {

struct Presentation {
  // Creates the window's surface on the instance (throws Error saying why it cannot).
  using MakeSurface = std::function<VkSurfaceKHR(VkInstance)>;

  vk::raii::Context context;
  vk::raii::Instance instance{nullptr};
  vk::raii::SurfaceKHR surface{nullptr};
  ChosenDevice chosen;
  vk::raii::Device device{nullptr};
  vk::raii::Queue queue{nullptr};
  vk::SurfaceFormatKHR format;
  vk::raii::SwapchainKHR swapchain{nullptr};
  std::vector<vk::Image> swapchain_images;
  std::vector<vk::raii::Semaphore> copied;  // per swapchain image: the copy is done, present may read
  vk::raii::Semaphore acquired{nullptr};
  vk::raii::Fence copy_done{nullptr};
  vk::raii::CommandPool pool{nullptr};
  vk::raii::CommandBuffer cmd{nullptr};
  HostBuffer staging;  // the image to show: width x height x 4 bytes in the format's byte order (bgra())
  uint32_t width = 0, height = 0;

  // instance_extensions: those the window system's surfaces need. Throws Error if no device can present to the
  // surface, if it offers no 8-bit UNORM format, or if its size is not image_width x image_height.
  Presentation(const std::vector<const char*>& instance_extensions, const MakeSurface& make_surface,
               uint32_t image_width, uint32_t image_height);
  ~Presentation();
  Presentation(const Presentation&) = delete;
  Presentation& operator=(const Presentation&) = delete;

  bool bgra() const { return format.format == vk::Format::eB8G8R8A8Unorm; }
  uint8_t* staging_bytes() const { return static_cast<uint8_t*>(staging.mapped); }
  void CheckSurfaceExtent() const;
  void CreateSwapchain();
  // Copies the staging buffer to the screen; returns when the present has returned and the queue is idle.
  void Present();
};

}  // namespace curvecheck
