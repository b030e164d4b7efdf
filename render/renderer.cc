// Vulkan implementation of the Renderer (render/renderer.h). Offscreen only: MakeDrawPlan (render/draw_plan.h)
// computes what to draw; Record draws any plan into an image with dynamic rendering, copies it to a host-visible
// buffer and reads it. Every Vulkan call is checked: Vulkan-Hpp's RAII wrappers throw vk::SystemError on any
// failing VkResult, which is turned into curvecheck::Error here.
#include "render/renderer.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>
#include <vulkan/vulkan_raii.hpp>

#include "core/error.h"
#include "core/stopwatch.h"
#include "render/draw_plan.h"
#include "render/vulkan_device.h"
#include "render/vulkan_error.h"

namespace curvecheck {
namespace {

// SPIR-V compiled at build time by glslc (render/CMakeLists.txt).
constexpr uint32_t kFullscreenVert[] =
#include "fullscreen.vert.spv.inc"
    ;
constexpr uint32_t kExactVert[] =
#include "exact.vert.spv.inc"
    ;
constexpr uint32_t kExactFrag[] =
#include "exact.frag.spv.inc"
    ;
constexpr uint32_t kProjectQuadVert[] =
#include "project_quad.vert.spv.inc"
    ;
constexpr uint32_t kShadeAbFrag[] =
#include "shade_ab.frag.spv.inc"
    ;
constexpr uint32_t kWarpGridVert[] =
#include "warp_grid.vert.spv.inc"
    ;
constexpr uint32_t kWarpFrag[] =
#include "warp.frag.spv.inc"
    ;
constexpr uint32_t kMeshVert[] =
#include "mesh.vert.spv.inc"
    ;
constexpr uint32_t kMeshTesc[] =
#include "mesh.tesc.spv.inc"
    ;
constexpr uint32_t kMeshTese[] =
#include "mesh.tese.spv.inc"
    ;

vk::Format VulkanFormat(TexelFormat f) {
  switch (f) {
    case TexelFormat::kShade8: return vk::Format::eR8Unorm;
    case TexelFormat::kLinear32: return vk::Format::eR32Sfloat;
    case TexelFormat::kCoordinates: return vk::Format::eR32G32Sfloat;
  }
  return vk::Format::eUndefined;
}

size_t TexelBytes(TexelFormat f) {
  switch (f) {
    case TexelFormat::kShade8: return 1;
    case TexelFormat::kLinear32: return 4;
    case TexelFormat::kCoordinates: return 8;
  }
  return 0;
}

struct Image {
  vk::raii::Image image{nullptr};
  vk::raii::DeviceMemory memory{nullptr};
  vk::raii::ImageView view{nullptr};
  uint32_t width = 0, height = 0;
};

void Transition(vk::raii::CommandBuffer& cmd, const Image& img, vk::ImageLayout from, vk::ImageLayout to,
                vk::AccessFlags src_access, vk::AccessFlags dst_access, vk::PipelineStageFlags src_stage,
                vk::PipelineStageFlags dst_stage) {
  const vk::ImageMemoryBarrier barrier(src_access, dst_access, from, to, VK_QUEUE_FAMILY_IGNORED,
                                       VK_QUEUE_FAMILY_IGNORED, *img.image,
                                       {vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1});
  cmd.pipelineBarrier(src_stage, dst_stage, {}, {}, {}, barrier);
}

}  // namespace

struct Renderer::Impl {
  vk::raii::Context context;
  vk::raii::Instance instance{nullptr};
  ChosenDevice chosen;
  vk::raii::Device device{nullptr};
  vk::raii::Queue queue{nullptr};
  vk::raii::CommandPool pool{nullptr};
  vk::raii::DescriptorSetLayout set_layout{nullptr};
  vk::raii::PipelineLayout pipeline_layout{nullptr};
  vk::raii::Sampler sampler{nullptr};
  // Pipelines by kind, target format and specialization (supersample n, cubic filter).
  std::map<std::tuple<PipelineKind, TexelFormat, int, int>, vk::raii::Pipeline> pipelines;
  DeviceLimits limits;
  double setup_ms = 0;

  Impl();
  HostBuffer Upload(const void* data, size_t bytes, vk::BufferUsageFlags usage) const;
  Image MakeImage(ImageSize size, vk::Format format, vk::ImageUsageFlags usage) const;
  const vk::raii::Pipeline& Pipeline(PipelineKind kind, TexelFormat format, const DrawPlan& plan);
  // Records, submits and waits; returns the time from submit to completion (ms).
  double Submit(const std::function<void(vk::raii::CommandBuffer&)>& record);
  // Draws the plan and returns the display image's bytes. upload_watch runs since the frame began.
  std::vector<uint8_t> Record(const DrawPlan& plan, const Stopwatch& upload_watch, RenderTiming* timing);
  std::vector<uint8_t> Draw(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                            const RenderOptions& options, RenderOutput output, RenderTiming* timing);
};

Renderer::Impl::Impl() {
  const Stopwatch watch;
  instance = MakeVulkanInstance(context, "curvecheck", VK_API_VERSION_1_3);
  DeviceNeeds needs;
  needs.purpose = "render offscreen";
  needs.min_api_version = VK_API_VERSION_1_3;
  needs.accepts_queue = [](const vk::raii::PhysicalDevice&, uint32_t, const vk::QueueFamilyProperties& family) {
    return static_cast<bool>(family.queueFlags & vk::QueueFlagBits::eGraphics);
  };
  needs.no_queue = "no graphics queue";
  needs.fix = "install mesa-vulkan-drivers 22+ (lavapipe) or a newer GPU driver";
  chosen = ChooseDevice(instance, needs);

  const auto supported =
      chosen.physical.getFeatures2<vk::PhysicalDeviceFeatures2, vk::PhysicalDeviceVulkan13Features>();
  if (!supported.get<vk::PhysicalDeviceVulkan13Features>().dynamicRendering) {
    throw Error("Vulkan", "device " + chosen.name + " lacks dynamic rendering", "update the Vulkan driver");
  }
  const vk::PhysicalDeviceLimits device_limits = chosen.physical.getProperties().limits;
  limits.max_image_px =
      std::min<uint64_t>(device_limits.maxImageDimension2D,
                         std::min(device_limits.maxFramebufferWidth, device_limits.maxFramebufferHeight));
  limits.tessellation = supported.get<vk::PhysicalDeviceFeatures2>().features.tessellationShader;
  limits.device_name = chosen.name;
  vk::PhysicalDeviceFeatures features;
  features.tessellationShader = limits.tessellation;
  vk::PhysicalDeviceVulkan13Features features13;
  features13.dynamicRendering = true;
  const float priority = 1.0f;
  const vk::DeviceQueueCreateInfo queue_info({}, chosen.queue_family, 1, &priority);
  vk::DeviceCreateInfo device_info({}, queue_info, {}, {}, &features);
  device_info.pNext = &features13;
  device = vk::raii::Device(chosen.physical, device_info);
  queue = device.getQueue(chosen.queue_family, 0);
  pool = vk::raii::CommandPool(device, {vk::CommandPoolCreateFlagBits::eResetCommandBuffer, chosen.queue_family});

  // The bindings of shaders/common.glsl.
  const auto all = vk::ShaderStageFlagBits::eAllGraphics;
  const std::array<vk::DescriptorSetLayoutBinding, 5> bindings = {
      vk::DescriptorSetLayoutBinding(0, vk::DescriptorType::eUniformBuffer, 1, all),
      vk::DescriptorSetLayoutBinding(1, vk::DescriptorType::eStorageBuffer, 1, all),
      vk::DescriptorSetLayoutBinding(2, vk::DescriptorType::eStorageBuffer, 1, all),
      vk::DescriptorSetLayoutBinding(3, vk::DescriptorType::eCombinedImageSampler, 1, all),
      vk::DescriptorSetLayoutBinding(4, vk::DescriptorType::eCombinedImageSampler, 1, all)};
  set_layout = vk::raii::DescriptorSetLayout(device, vk::DescriptorSetLayoutCreateInfo({}, bindings));
  const vk::PushConstantRange push(vk::ShaderStageFlagBits::eVertex, 0, 64);
  const vk::DescriptorSetLayout layouts[] = {*set_layout};
  pipeline_layout = vk::raii::PipelineLayout(device, vk::PipelineLayoutCreateInfo({}, layouts, push));
  sampler = vk::raii::Sampler(device, vk::SamplerCreateInfo({}, vk::Filter::eNearest, vk::Filter::eNearest,
                                                            vk::SamplerMipmapMode::eNearest,
                                                            vk::SamplerAddressMode::eClampToEdge,
                                                            vk::SamplerAddressMode::eClampToEdge,
                                                            vk::SamplerAddressMode::eClampToEdge));
  setup_ms = watch.Ms();
}

HostBuffer Renderer::Impl::Upload(const void* data, size_t bytes, vk::BufferUsageFlags usage) const {
  HostBuffer b = MakeHostBuffer(device, chosen.physical, bytes, usage);
  std::memcpy(b.mapped, data, bytes);
  return b;
}

Image Renderer::Impl::MakeImage(ImageSize size, vk::Format format, vk::ImageUsageFlags usage) const {
  Image img;
  img.width = size.width;
  img.height = size.height;
  img.image = vk::raii::Image(
      device, vk::ImageCreateInfo({}, vk::ImageType::e2D, format, vk::Extent3D(size.width, size.height, 1), 1, 1,
                                  vk::SampleCountFlagBits::e1, vk::ImageTiling::eOptimal, usage));
  const auto req = img.image.getMemoryRequirements();
  img.memory = vk::raii::DeviceMemory(
      device, vk::MemoryAllocateInfo(req.size, FindMemoryType(chosen.physical, req.memoryTypeBits,
                                                              vk::MemoryPropertyFlagBits::eDeviceLocal)));
  img.image.bindMemory(*img.memory, 0);
  img.view = vk::raii::ImageView(device, vk::ImageViewCreateInfo({}, *img.image, vk::ImageViewType::e2D, format, {},
                                                                 {vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1}));
  return img;
}

const vk::raii::Pipeline& Renderer::Impl::Pipeline(PipelineKind kind, TexelFormat format, const DrawPlan& plan) {
  const int32_t supersample = kind == PipelineKind::kExact ? plan.exact_supersample : 0;
  const int32_t cubic = plan.warp_cubic ? 1 : 0;
  const auto key = std::make_tuple(kind, format, supersample, cubic);
  if (auto it = pipelines.find(key); it != pipelines.end()) return it->second;
  const Stopwatch watch;

  std::vector<vk::raii::ShaderModule> modules;
  std::vector<vk::PipelineShaderStageCreateInfo> stages;
  // Specialization constants of the shaders (ids as in shaders/*.frag, common.glsl).
  const int32_t per_fragment = kind == PipelineKind::kWarpPerFragment ? 1 : 0;
  const int32_t linear_output = kind == PipelineKind::kQuadLinear ? 1 : 0;
  const int32_t coordinates = format == TexelFormat::kCoordinates ? 1 : 0;
  const vk::SpecializationMapEntry entries[] = {{0, 0, 4}, {1, 4, 4}, {2, 8, 4}, {3, 12, 4}, {4, 16, 4}};
  const int32_t spec_data[] = {per_fragment, linear_output, supersample, cubic, coordinates};
  const vk::SpecializationInfo spec(5, entries, sizeof(spec_data), spec_data);
  auto add = [&](vk::ShaderStageFlagBits stage, const uint32_t* code, size_t bytes) {
    modules.emplace_back(device, vk::ShaderModuleCreateInfo({}, bytes, code));
    stages.emplace_back(vk::PipelineShaderStageCreateFlags{}, stage, *modules.back(), "main", &spec);
  };
  vk::PrimitiveTopology topology = vk::PrimitiveTopology::eTriangleList;
  std::vector<vk::VertexInputBindingDescription> vertex_bindings;
  std::vector<vk::VertexInputAttributeDescription> attributes;
  switch (kind) {
    case PipelineKind::kExact:  // vertices: render/draw_plan.cc ExactDraws
      add(vk::ShaderStageFlagBits::eVertex, kExactVert, sizeof(kExactVert));
      add(vk::ShaderStageFlagBits::eFragment, kExactFrag, sizeof(kExactFrag));
      vertex_bindings.emplace_back(0, 36, vk::VertexInputRate::eVertex);
      attributes.emplace_back(0, 0, vk::Format::eR32G32Sfloat, 0);
      attributes.emplace_back(1, 0, vk::Format::eR32G32B32Sfloat, 8);
      attributes.emplace_back(2, 0, vk::Format::eR32Sfloat, 20);
      attributes.emplace_back(3, 0, vk::Format::eR32G32B32Sfloat, 24);
      break;
    case PipelineKind::kQuad:
    case PipelineKind::kQuadLinear:
      add(vk::ShaderStageFlagBits::eVertex, kProjectQuadVert, sizeof(kProjectQuadVert));
      add(vk::ShaderStageFlagBits::eFragment, kShadeAbFrag, sizeof(kShadeAbFrag));
      topology = vk::PrimitiveTopology::eTriangleStrip;
      vertex_bindings.emplace_back(0, 8, vk::VertexInputRate::eVertex);
      attributes.emplace_back(0, 0, vk::Format::eR32G32Sfloat, 0);
      break;
    case PipelineKind::kWarpPerFragment:
      add(vk::ShaderStageFlagBits::eVertex, kFullscreenVert, sizeof(kFullscreenVert));
      add(vk::ShaderStageFlagBits::eFragment, kWarpFrag, sizeof(kWarpFrag));
      break;
    case PipelineKind::kWarpGrid:
      add(vk::ShaderStageFlagBits::eVertex, kWarpGridVert, sizeof(kWarpGridVert));
      add(vk::ShaderStageFlagBits::eFragment, kWarpFrag, sizeof(kWarpFrag));
      vertex_bindings.emplace_back(0, 16, vk::VertexInputRate::eVertex);
      attributes.emplace_back(0, 0, vk::Format::eR32G32Sfloat, 0);
      attributes.emplace_back(1, 0, vk::Format::eR32G32Sfloat, 8);
      break;
    case PipelineKind::kMesh:
      add(vk::ShaderStageFlagBits::eVertex, kMeshVert, sizeof(kMeshVert));
      add(vk::ShaderStageFlagBits::eTessellationControl, kMeshTesc, sizeof(kMeshTesc));
      add(vk::ShaderStageFlagBits::eTessellationEvaluation, kMeshTese, sizeof(kMeshTese));
      add(vk::ShaderStageFlagBits::eFragment, kShadeAbFrag, sizeof(kShadeAbFrag));
      topology = vk::PrimitiveTopology::ePatchList;
      vertex_bindings.emplace_back(0, 8, vk::VertexInputRate::eVertex);
      attributes.emplace_back(0, 0, vk::Format::eR32G32Sfloat, 0);
      break;
  }
  const vk::PipelineVertexInputStateCreateInfo vertex_input({}, vertex_bindings, attributes);
  const vk::PipelineInputAssemblyStateCreateInfo assembly({}, topology);
  const vk::PipelineTessellationStateCreateInfo tessellation({}, 4);
  const vk::PipelineViewportStateCreateInfo viewport({}, 1, nullptr, 1, nullptr);
  vk::PipelineRasterizationStateCreateInfo raster;
  raster.cullMode = vk::CullModeFlagBits::eNone;
  raster.lineWidth = 1.0f;
  const vk::PipelineMultisampleStateCreateInfo multisample;
  vk::PipelineColorBlendAttachmentState blend;
  blend.colorWriteMask = vk::ColorComponentFlagBits::eR | vk::ColorComponentFlagBits::eG |
                         vk::ColorComponentFlagBits::eB | vk::ColorComponentFlagBits::eA;
  const vk::PipelineColorBlendStateCreateInfo blend_state({}, false, vk::LogicOp::eCopy, blend);
  const std::array<vk::DynamicState, 2> dynamic = {vk::DynamicState::eViewport, vk::DynamicState::eScissor};
  const vk::PipelineDynamicStateCreateInfo dynamic_state({}, dynamic);
  const vk::Format vk_format = VulkanFormat(format);
  const vk::PipelineRenderingCreateInfo rendering(0, vk_format);
  vk::GraphicsPipelineCreateInfo info({}, stages, &vertex_input, &assembly,
                                      kind == PipelineKind::kMesh ? &tessellation : nullptr, &viewport, &raster,
                                      &multisample, nullptr, &blend_state, &dynamic_state, *pipeline_layout);
  info.pNext = &rendering;
  auto [it, inserted] = pipelines.emplace(key, vk::raii::Pipeline(device, nullptr, info));
  setup_ms += watch.Ms();
  return it->second;
}

double Renderer::Impl::Submit(const std::function<void(vk::raii::CommandBuffer&)>& record) {
  vk::raii::CommandBuffers cmds(device, vk::CommandBufferAllocateInfo(*pool, vk::CommandBufferLevel::ePrimary, 1));
  vk::raii::CommandBuffer& cmd = cmds[0];
  cmd.begin(vk::CommandBufferBeginInfo(vk::CommandBufferUsageFlagBits::eOneTimeSubmit));
  record(cmd);
  cmd.end();
  vk::raii::Fence fence(device, vk::FenceCreateInfo());
  const vk::CommandBuffer raw = *cmd;
  const Stopwatch watch;
  queue.submit(vk::SubmitInfo({}, {}, raw), *fence);
  if (device.waitForFences(*fence, true, UINT64_MAX) != vk::Result::eSuccess) {
    throw Error("Vulkan", "waiting for the GPU failed", "check the device");
  }
  return watch.Ms();
}

std::vector<uint8_t> Renderer::Impl::Record(const DrawPlan& plan, const Stopwatch& upload_watch, RenderTiming* timing) {
  // Shader inputs (shaders/common.glsl).
  const HostBuffer params = Upload(&plan.params, sizeof(plan.params), vk::BufferUsageFlagBits::eUniformBuffer);
  const HostBuffer columns = Upload(plan.surface_xz.data(), sizeof(float) * plan.surface_xz.size(),
                                    vk::BufferUsageFlagBits::eStorageBuffer);
  const HostBuffer rows = Upload(plan.surface_y.data(), sizeof(float) * plan.surface_y.size(),
                                 vk::BufferUsageFlagBits::eStorageBuffer);
  const Image cells = MakeImage(plan.cells.size, vk::Format::eR8Uint,
                                vk::ImageUsageFlagBits::eSampled | vk::ImageUsageFlagBits::eTransferDst);
  const HostBuffer cell_staging = Upload(plan.cells.labels.data(), plan.cells.labels.size(),
                                         vk::BufferUsageFlagBits::eTransferSrc);
  std::vector<HostBuffer> vertices;  // per pass; empty for passes without vertex data
  for (const Pass& pass : plan.passes) {
    vertices.push_back(pass.vertices.empty() ? HostBuffer{}
                                             : Upload(pass.vertices.data(), sizeof(float) * pass.vertices.size(),
                                                      vk::BufferUsageFlagBits::eVertexBuffer));
  }

  // Images.
  const Image display = MakeImage(plan.display, VulkanFormat(plan.display_format),
                                  vk::ImageUsageFlagBits::eColorAttachment | vk::ImageUsageFlagBits::eTransferSrc);
  const Image intermediate = MakeImage(plan.intermediate, VulkanFormat(plan.intermediate_format),
                                       vk::ImageUsageFlagBits::eColorAttachment | vk::ImageUsageFlagBits::eSampled);
  const HostBuffer readback =
      MakeHostBuffer(device, chosen.physical,
                     vk::DeviceSize{plan.display.width} * plan.display.height * TexelBytes(plan.display_format),
                     vk::BufferUsageFlagBits::eTransferDst);

  // Descriptors.
  const vk::DescriptorPoolSize sizes[] = {{vk::DescriptorType::eUniformBuffer, 1},
                                          {vk::DescriptorType::eStorageBuffer, 2},
                                          {vk::DescriptorType::eCombinedImageSampler, 2}};
  const vk::raii::DescriptorPool descriptor_pool(
      device, vk::DescriptorPoolCreateInfo(vk::DescriptorPoolCreateFlagBits::eFreeDescriptorSet, 1, sizes));
  const vk::raii::DescriptorSets sets(device, vk::DescriptorSetAllocateInfo(*descriptor_pool, *set_layout));
  const vk::DescriptorSet set = *sets[0];
  const vk::DescriptorBufferInfo params_info(*params.buffer, 0, params.size),
      columns_info(*columns.buffer, 0, columns.size), rows_info(*rows.buffer, 0, rows.size);
  const vk::DescriptorImageInfo cells_info(*sampler, *cells.view, vk::ImageLayout::eShaderReadOnlyOptimal),
      intermediate_info(*sampler, *intermediate.view, vk::ImageLayout::eShaderReadOnlyOptimal);
  const std::array<vk::WriteDescriptorSet, 5> writes = {
      vk::WriteDescriptorSet(set, 0, 0, vk::DescriptorType::eUniformBuffer, {}, params_info),
      vk::WriteDescriptorSet(set, 1, 0, vk::DescriptorType::eStorageBuffer, {}, columns_info),
      vk::WriteDescriptorSet(set, 2, 0, vk::DescriptorType::eStorageBuffer, {}, rows_info),
      vk::WriteDescriptorSet(set, 3, 0, vk::DescriptorType::eCombinedImageSampler, cells_info),
      vk::WriteDescriptorSet(set, 4, 0, vk::DescriptorType::eCombinedImageSampler, intermediate_info)};
  device.updateDescriptorSets(writes, {});

  // Pipelines (created once per kind and format; counted as set-up).
  std::vector<vk::Pipeline> pipeline_of_pass;
  bool intermediate_drawn = false;
  for (const Pass& pass : plan.passes) {
    const bool to_intermediate = pass.target == PassTarget::kIntermediate;
    intermediate_drawn = intermediate_drawn || to_intermediate;
    pipeline_of_pass.push_back(
        *Pipeline(pass.pipeline, to_intermediate ? plan.intermediate_format : plan.display_format, plan));
  }

  // Upload the cells (also makes the intermediate image readable when no pass draws it).
  Submit([&](vk::raii::CommandBuffer& cmd) {
    Transition(cmd, cells, vk::ImageLayout::eUndefined, vk::ImageLayout::eTransferDstOptimal, {},
               vk::AccessFlagBits::eTransferWrite, vk::PipelineStageFlagBits::eTopOfPipe,
               vk::PipelineStageFlagBits::eTransfer);
    const vk::BufferImageCopy region(0, 0, 0, {vk::ImageAspectFlagBits::eColor, 0, 0, 1}, {0, 0, 0},
                                     {cells.width, cells.height, 1});
    cmd.copyBufferToImage(*cell_staging.buffer, *cells.image, vk::ImageLayout::eTransferDstOptimal, region);
    Transition(cmd, cells, vk::ImageLayout::eTransferDstOptimal, vk::ImageLayout::eShaderReadOnlyOptimal,
               vk::AccessFlagBits::eTransferWrite, vk::AccessFlagBits::eShaderRead,
               vk::PipelineStageFlagBits::eTransfer, vk::PipelineStageFlagBits::eAllGraphics);
    if (!intermediate_drawn) {
      Transition(cmd, intermediate, vk::ImageLayout::eUndefined, vk::ImageLayout::eShaderReadOnlyOptimal, {},
                 vk::AccessFlagBits::eShaderRead, vk::PipelineStageFlagBits::eTopOfPipe,
                 vk::PipelineStageFlagBits::eAllGraphics);
    }
  });
  const double upload_ms = upload_watch.Ms();

  // Each pass clears its target and draws into it; the intermediate image is then made readable by later passes.
  const double render_ms = Submit([&](vk::raii::CommandBuffer& cmd) {
    for (size_t p = 0; p < plan.passes.size(); ++p) {
      const Pass& pass = plan.passes[p];
      const Image& target = pass.target == PassTarget::kIntermediate ? intermediate : display;
      Transition(cmd, target, vk::ImageLayout::eUndefined, vk::ImageLayout::eColorAttachmentOptimal, {},
                 vk::AccessFlagBits::eColorAttachmentWrite, vk::PipelineStageFlagBits::eTopOfPipe,
                 vk::PipelineStageFlagBits::eColorAttachmentOutput);
      const vk::RenderingAttachmentInfo attachment(*target.view, vk::ImageLayout::eColorAttachmentOptimal, {}, {}, {},
                                                   vk::AttachmentLoadOp::eClear, vk::AttachmentStoreOp::eStore,
                                                   vk::ClearColorValue(pass.clear_colour));
      cmd.beginRendering(vk::RenderingInfo({}, vk::Rect2D({0, 0}, {target.width, target.height}), 1, 0, attachment));
      cmd.bindPipeline(vk::PipelineBindPoint::eGraphics, pipeline_of_pass[p]);
      cmd.bindDescriptorSets(vk::PipelineBindPoint::eGraphics, *pipeline_layout, 0, set, {});
      if (!pass.vertices.empty()) cmd.bindVertexBuffers(0, *vertices[p].buffer, {0});
      for (const DrawCall& d : pass.draws) {
        if (d.clip_from_ab) {
          cmd.pushConstants<float>(*pipeline_layout, vk::ShaderStageFlagBits::eVertex, 0,
                                   ColumnMajorFloats(*d.clip_from_ab));
        }
        cmd.setViewport(0, vk::Viewport(static_cast<float>(d.viewport.x), static_cast<float>(d.viewport.y),
                                        static_cast<float>(d.viewport.width), static_cast<float>(d.viewport.height),
                                        0, 1));
        cmd.setScissor(0, vk::Rect2D({d.scissor.x, d.scissor.y}, {d.scissor.width, d.scissor.height}));
        cmd.draw(d.vertex_count, 1, d.first_vertex, 0);
      }
      cmd.endRendering();
      if (pass.target == PassTarget::kIntermediate) {
        Transition(cmd, intermediate, vk::ImageLayout::eColorAttachmentOptimal, vk::ImageLayout::eShaderReadOnlyOptimal,
                   vk::AccessFlagBits::eColorAttachmentWrite, vk::AccessFlagBits::eShaderRead,
                   vk::PipelineStageFlagBits::eColorAttachmentOutput, vk::PipelineStageFlagBits::eFragmentShader);
      }
    }
  });

  const Stopwatch read_watch;
  Submit([&](vk::raii::CommandBuffer& cmd) {
    Transition(cmd, display, vk::ImageLayout::eColorAttachmentOptimal, vk::ImageLayout::eTransferSrcOptimal,
               vk::AccessFlagBits::eColorAttachmentWrite, vk::AccessFlagBits::eTransferRead,
               vk::PipelineStageFlagBits::eColorAttachmentOutput, vk::PipelineStageFlagBits::eTransfer);
    const vk::BufferImageCopy region(0, 0, 0, {vk::ImageAspectFlagBits::eColor, 0, 0, 1}, {0, 0, 0},
                                     {display.width, display.height, 1});
    cmd.copyImageToBuffer(*display.image, vk::ImageLayout::eTransferSrcOptimal, *readback.buffer, region);
    const vk::BufferMemoryBarrier host(vk::AccessFlagBits::eTransferWrite, vk::AccessFlagBits::eHostRead,
                                       VK_QUEUE_FAMILY_IGNORED, VK_QUEUE_FAMILY_IGNORED, *readback.buffer, 0,
                                       VK_WHOLE_SIZE);
    cmd.pipelineBarrier(vk::PipelineStageFlagBits::eTransfer, vk::PipelineStageFlagBits::eHost, {}, {}, host, {});
  });
  std::vector<uint8_t> bytes(readback.size);
  std::memcpy(bytes.data(), readback.mapped, bytes.size());
  if (timing) {
    timing->upload_ms = upload_ms;
    timing->render_ms = render_ms;
    timing->readback_ms = read_watch.Ms();
  }
  return bytes;
}

std::vector<uint8_t> Renderer::Impl::Draw(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                                          const RenderOptions& options, RenderOutput output, RenderTiming* timing) {
  const Stopwatch upload_watch;  // the plan's tables and meshes count as per-frame uploads
  return Record(MakeDrawPlan(m, viewpoint, pattern, options, output, limits), upload_watch, timing);
}

void RenderOptions::Check(const std::string& where) const {
  method.Check(where);
  if (!(std::isfinite(display_gamma) && display_gamma >= 1 && display_gamma <= 3)) {
    throw Error(where, fmt::format("display gamma {} is out of range", display_gamma), "use 1..3 (2.2 is typical)");
  }
  if (surround_code < 0 || surround_code > 255) {
    throw Error(where, fmt::format("surround grey {} is not a code value", surround_code), "use 0..255");
  }
}

Renderer::Renderer() : impl_(WithVulkanErrors([] { return std::make_unique<Impl>(); })) {}
Renderer::~Renderer() = default;

std::string Renderer::device_name() const { return impl_->chosen.name; }
double Renderer::setup_ms() const { return impl_->setup_ms; }

GrayImage Renderer::Render(const Monitor& monitor, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                           const RenderOptions& options, RenderTiming* timing) {
  GrayImage img;
  img.width = monitor.width_px;
  img.height = monitor.height_px;
  img.pixels = WithVulkanErrors(
      [&] { return impl_->Draw(monitor, viewpoint, pattern, options, RenderOutput::kShade, timing); });
  return img;
}

CoordinateImage Renderer::RenderCoordinates(const Monitor& monitor, const Eigen::Vector3d& viewpoint,
                                            const Pattern& pattern, const RenderOptions& options,
                                            RenderTiming* timing) {
  CoordinateImage img;
  img.width = monitor.width_px;
  img.height = monitor.height_px;
  const std::vector<uint8_t> bytes = WithVulkanErrors(
      [&] { return impl_->Draw(monitor, viewpoint, pattern, options, RenderOutput::kCoordinates, timing); });
  img.ab.resize(bytes.size() / sizeof(float));
  std::memcpy(img.ab.data(), bytes.data(), bytes.size());
  return img;
}

}  // namespace curvecheck
