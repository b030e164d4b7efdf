#include "render/presentation.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <string>

#include "core/error.h"

namespace curvecheck {
namespace {

constexpr uint64_t kVulkanTimeoutNs = 10'000'000'000;  // a present or copy that takes longer is an error

}  // namespace

Presentation::Presentation(const std::vector<const char*>& instance_extensions, const MakeSurface& make_surface,
                           uint32_t image_width, uint32_t image_height)
    : width(image_width), height(image_height) {
  instance = MakeVulkanInstance(context, "curvecheck present", VK_API_VERSION_1_1, instance_extensions);
  surface = vk::raii::SurfaceKHR(instance, make_surface(*instance));

  // Device: one that can present to this surface, with VK_KHR_swapchain and a queue that can copy and present.
  DeviceNeeds needs;
  needs.purpose = "present to the window";
  needs.extensions = {VK_KHR_SWAPCHAIN_EXTENSION_NAME};
  needs.accepts_queue = [&](const vk::raii::PhysicalDevice& candidate, uint32_t family,
                            const vk::QueueFamilyProperties& properties) {
    const vk::QueueFlags copy_capable =
        vk::QueueFlagBits::eGraphics | vk::QueueFlagBits::eCompute | vk::QueueFlagBits::eTransfer;
    return (properties.queueFlags & copy_capable) && candidate.getSurfaceSupportKHR(family, *surface);
  };
  needs.no_queue = "cannot present to this window";
  needs.fix = "install the Vulkan driver of the GPU that drives this output, or mesa-vulkan-drivers (lavapipe)";
  chosen = ChooseDevice(instance, needs);

  const float priority = 1.0f;
  const vk::DeviceQueueCreateInfo queue_info({}, chosen.queue_family, 1, &priority);
  device = vk::raii::Device(chosen.physical, vk::DeviceCreateInfo({}, queue_info, {}, needs.extensions));
  queue = device.getQueue(chosen.queue_family, 0);

  // Format: 8-bit UNORM, so that code values are stored and scanned out unchanged (an SRGB format would encode
  // them). The colour space SRGB_NONLINEAR says the values are already display-encoded: no conversion.
  const std::vector<vk::SurfaceFormatKHR> formats = chosen.physical.getSurfaceFormatsKHR(*surface);
  bool found = false;
  for (vk::Format wanted_format : {vk::Format::eB8G8R8A8Unorm, vk::Format::eR8G8B8A8Unorm}) {
    for (const vk::SurfaceFormatKHR& f : formats) {
      if (!found && f.format == wanted_format && f.colorSpace == vk::ColorSpaceKHR::eSrgbNonlinear) {
        format = f;
        found = true;
      }
    }
  }
  if (!found && formats.size() == 1 && formats[0].format == vk::Format::eUndefined) {
    format = vk::SurfaceFormatKHR(vk::Format::eB8G8R8A8Unorm, vk::ColorSpaceKHR::eSrgbNonlinear);
    found = true;
  }
  if (!found) {
    std::vector<std::string> names;
    for (const vk::SurfaceFormatKHR& f : formats) {
      names.push_back(vk::to_string(f.format) + "/" + vk::to_string(f.colorSpace));
    }
    throw Error("Vulkan",
                fmt::format("{} offers no B8G8R8A8_UNORM or R8G8B8A8_UNORM swapchain format for this output (only {})",
                            chosen.name, fmt::join(names, ", ")),
                "set the output to 8 bits per channel (24-bit colour depth); 10-bit outputs are not supported");
  }

  pool = vk::raii::CommandPool(device, {vk::CommandPoolCreateFlagBits::eResetCommandBuffer, chosen.queue_family});
  cmd = std::move(vk::raii::CommandBuffers(device, {*pool, vk::CommandBufferLevel::ePrimary, 1}).front());
  acquired = vk::raii::Semaphore(device, vk::SemaphoreCreateInfo());
  copy_done = vk::raii::Fence(device, vk::FenceCreateInfo());

  staging = MakeHostBuffer(device, chosen.physical, vk::DeviceSize{width} * height * 4,
                           vk::BufferUsageFlagBits::eTransferSrc);

  CreateSwapchain();
}

Presentation::~Presentation() {
  if (*device) {
    try {
      device.waitIdle();
    } catch (const vk::SystemError&) {
      // Destruction proceeds regardless; the error, if any, was reported by the call that failed first.
    }
  }
}

void Presentation::CheckSurfaceExtent() const {
  const vk::SurfaceCapabilitiesKHR caps = chosen.physical.getSurfaceCapabilitiesKHR(*surface);
  const bool any_size = caps.currentExtent.width == 0xFFFFFFFFu;
  if (!any_size && (caps.currentExtent.width != width || caps.currentExtent.height != height)) {
    throw Error("window",
                fmt::format("the window's surface is {}x{} px, not the image's {}x{} (the window system resized it)",
                            caps.currentExtent.width, caps.currentExtent.height, width, height),
                "the presenter never scales: disable desktop scaling for this output, or use exclusive fullscreen "
                "(without --windowed)");
  }
}

void Presentation::CreateSwapchain() {
  CheckSurfaceExtent();
  const vk::SurfaceCapabilitiesKHR caps = chosen.physical.getSurfaceCapabilitiesKHR(*surface);
  if (caps.currentExtent.width == 0xFFFFFFFFu &&
      (width < caps.minImageExtent.width || width > caps.maxImageExtent.width ||
       height < caps.minImageExtent.height || height > caps.maxImageExtent.height)) {
    throw Error("Vulkan", fmt::format("{} cannot make a {}x{} swapchain for this output", chosen.name, width, height),
                "use another Vulkan device (CURVECHECK_VULKAN_DEVICE)");
  }
  if (!(caps.supportedUsageFlags & vk::ImageUsageFlagBits::eTransferDst)) {
    throw Error("Vulkan", chosen.name + " cannot copy into swapchain images (no TRANSFER_DST usage)",
                "use another Vulkan device (CURVECHECK_VULKAN_DEVICE)");
  }
  if (caps.currentTransform != vk::SurfaceTransformFlagBitsKHR::eIdentity) {
    throw Error("window",
                "the output is rotated or mirrored by the window system (" + vk::to_string(caps.currentTransform) + ")",
                "set the output's rotation to normal; the presenter never resamples");
  }
  uint32_t count = std::max(caps.minImageCount, 2u);
  if (caps.maxImageCount > 0) count = std::min(count, caps.maxImageCount);
  const vk::CompositeAlphaFlagBitsKHR alpha =
      (caps.supportedCompositeAlpha & vk::CompositeAlphaFlagBitsKHR::eOpaque) ? vk::CompositeAlphaFlagBitsKHR::eOpaque
      : (caps.supportedCompositeAlpha & vk::CompositeAlphaFlagBitsKHR::eInherit)
          ? vk::CompositeAlphaFlagBitsKHR::eInherit
          : vk::CompositeAlphaFlagBitsKHR::ePostMultiplied;
  // The alpha byte is 255 anyway, so every composite-alpha mode shows the code values as they are.
  vk::SwapchainCreateInfoKHR info({}, *surface, count, format.format, format.colorSpace, vk::Extent2D(width, height),
                                  1, vk::ImageUsageFlagBits::eTransferDst, vk::SharingMode::eExclusive, {},
                                  vk::SurfaceTransformFlagBitsKHR::eIdentity, alpha, vk::PresentModeKHR::eFifo, true,
                                  *swapchain);
  vk::raii::SwapchainKHR next(device, info);
  swapchain = std::move(next);
  swapchain_images = swapchain.getImages();
  copied.clear();
  for (size_t i = 0; i < swapchain_images.size(); ++i) copied.emplace_back(device, vk::SemaphoreCreateInfo());
}

void Presentation::Present() {
  for (int attempt = 0;; ++attempt) {
    // Out of date: the window changed under us. Refuse if its size is no longer the image's (in
    // CheckSurfaceExtent), else make a new swapchain and try again.
    auto recreate = [&] {
      if (attempt >= 2) {
        throw Error("Vulkan", "the swapchain stays out of date after being re-created twice",
                    "keep the output's mode and the window unchanged while presenting");
      }
      queue.waitIdle();
      CreateSwapchain();
    };
    uint32_t index = 0;
    bool suboptimal = false;
    try {
      const auto [result, acquired_index] = swapchain.acquireNextImage(kVulkanTimeoutNs, *acquired, nullptr);
      if (result == vk::Result::eTimeout || result == vk::Result::eNotReady) {
        throw Error("Vulkan", fmt::format("{} did not hand out a swapchain image within {} s", chosen.name,
                                          kVulkanTimeoutNs / 1'000'000'000),
                    "check that the display is not locked or switched off");
      }
      // eSuboptimalKHR: the image is still presentable; the extent is checked after the present.
      suboptimal = result == vk::Result::eSuboptimalKHR;
      index = acquired_index;
    } catch (const vk::OutOfDateKHRError&) {
      recreate();
      continue;
    }

    cmd.reset();
    cmd.begin(vk::CommandBufferBeginInfo(vk::CommandBufferUsageFlagBits::eOneTimeSubmit));
    const vk::ImageSubresourceRange range(vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1);
    const vk::ImageMemoryBarrier to_copy({}, vk::AccessFlagBits::eTransferWrite, vk::ImageLayout::eUndefined,
                                         vk::ImageLayout::eTransferDstOptimal, VK_QUEUE_FAMILY_IGNORED,
                                         VK_QUEUE_FAMILY_IGNORED, swapchain_images[index], range);
    cmd.pipelineBarrier(vk::PipelineStageFlagBits::eTransfer, vk::PipelineStageFlagBits::eTransfer, {}, {}, {},
                        to_copy);
    const vk::BufferImageCopy region(0, 0, 0, {vk::ImageAspectFlagBits::eColor, 0, 0, 1}, {0, 0, 0},
                                     {width, height, 1});
    cmd.copyBufferToImage(*staging.buffer, swapchain_images[index], vk::ImageLayout::eTransferDstOptimal, region);
    const vk::ImageMemoryBarrier to_present(vk::AccessFlagBits::eTransferWrite, {},
                                            vk::ImageLayout::eTransferDstOptimal, vk::ImageLayout::ePresentSrcKHR,
                                            VK_QUEUE_FAMILY_IGNORED, VK_QUEUE_FAMILY_IGNORED,
                                            swapchain_images[index], range);
    cmd.pipelineBarrier(vk::PipelineStageFlagBits::eTransfer, vk::PipelineStageFlagBits::eBottomOfPipe, {}, {}, {},
                        to_present);
    cmd.end();

    device.resetFences(*copy_done);
    const vk::PipelineStageFlags wait_stage = vk::PipelineStageFlagBits::eTransfer;
    const vk::CommandBuffer command = *cmd;
    const vk::Semaphore signal = *copied[index];
    queue.submit(vk::SubmitInfo(*acquired, wait_stage, command, signal), *copy_done);

    const vk::SwapchainKHR chain = *swapchain;
    vk::Result presented = vk::Result::eSuccess;
    bool out_of_date = false;
    try {
      presented = queue.presentKHR(vk::PresentInfoKHR(signal, chain, index));
    } catch (const vk::OutOfDateKHRError&) {
      out_of_date = true;
    }
    if (device.waitForFences(*copy_done, true, kVulkanTimeoutNs) != vk::Result::eSuccess) {
      throw Error("Vulkan", fmt::format("copying the image to the screen took more than {} s on {}",
                                        kVulkanTimeoutNs / 1'000'000'000, chosen.name),
                  "run again; if it repeats, update the driver");
    }
    queue.waitIdle();
    if (out_of_date) {
      recreate();
      continue;
    }
    if (suboptimal || presented == vk::Result::eSuboptimalKHR) CheckSurfaceExtent();  // refuse if not exact
    return;
  }
}

}  // namespace curvecheck
