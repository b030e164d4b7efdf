// Vulkan implementation of the Renderer (render/renderer.h). Offscreen only: draw into an image with dynamic
// rendering, copy it to a host-visible buffer, read it. Every Vulkan call is checked: Vulkan-Hpp's RAII
// wrappers throw vk::SystemError on any failing VkResult, which is turned into curvecheck::Error here.
#include "render/renderer.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <vulkan/vulkan_raii.hpp>

#include "core/error.h"
#include "core/off_axis_projection.h"
#include "core/screen_geometry.h"
#include "render/vulkan_error.h"

namespace curvecheck {
namespace {

// SPIR-V compiled at build time by glslc (render/CMakeLists.txt).
constexpr uint32_t kFullscreenVert[] =
#include "fullscreen.vert.spv.inc"
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

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

constexpr vk::Format kShadeFormat = vk::Format::eR8Unorm;
constexpr int kMaxTessLevel = 32;  // see the mesh vertices in Draw(); also the clamp in shaders/mesh.tesc
// lavapipe (Mesa 22.3) silently drops primitives when one tessellated draw emits more than about 1e5 triangles
// (measured: 138k triangles in one draw left 91% of a 2560x720 frame undrawn; 61k drew every pixel). Mesh
// patches are therefore drawn in batches of at most this many triangles.
constexpr int kMaxTrianglesPerDraw = 32768;
constexpr vk::Format kLinearFormat = vk::Format::eR32Sfloat;
constexpr vk::Format kCoordFormat = vk::Format::eR32G32Sfloat;

// std140 layout of the Params block in shaders/common.glsl.
struct alignas(16) Params {
  float monitor[4];
  float monitor2[4];
  float viewpoint[4];
  float plane_origin[4];
  float plane_x[4];
  float plane_y[4];
  float plane_n[4];
  float cells[4];
  int32_t cells_size[4];
  float clip_from_centre[16];  // column-major
  float warp[4];
  float mesh[4];
};

void Put(float* dst, const Eigen::Vector3d& v, double w = 0) {
  dst[0] = static_cast<float>(v.x());
  dst[1] = static_cast<float>(v.y());
  dst[2] = static_cast<float>(v.z());
  dst[3] = static_cast<float>(w);
}

std::array<float, 16> ColumnMajor(const Eigen::Matrix4d& m) {
  std::array<float, 16> out;
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) out[static_cast<size_t>(c * 4 + r)] = static_cast<float>(m(r, c));
  }
  return out;
}

// Vulkan clip space has y pointing down; the core's projections have y up.
Eigen::Matrix4d FlipY() {
  Eigen::Matrix4d f = Eigen::Matrix4d::Identity();
  f(1, 1) = -1;
  return f;
}

// Generalized perspective projection (Kooima, as used by thesis Eq 4.6) onto the planar rectangle with
// lower-left pa, lower-right pb and upper-left pc, from eye pe (all in the centre frame), to Vulkan clip space
// (y down, depth 0..1). Throws if the eye is not in front of the rectangle's plane.
Eigen::Matrix4d RectangleProjection(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& pc,
                                    const Eigen::Vector3d& pe, const std::string& what) {
  const Eigen::Vector3d vr = (pb - pa).normalized(), vu = (pc - pa).normalized(), vn = vr.cross(vu).normalized();
  const Eigen::Vector3d va = pa - pe, vb = pb - pe, vc = pc - pe;
  const double d = -va.dot(vn);
  if (!(d > 1e-3)) {
    throw Error("viewpoint", fmt::format("the viewpoint is {:.3f} mm in front of the plane of {}", d, what),
                "a perspective projection onto that plane cannot show it; use more strips or the exact method");
  }
  const double n = 1.0, f = 1e7;
  const double l = vr.dot(va) * n / d, r = vr.dot(vb) * n / d, b = vu.dot(va) * n / d, t = vu.dot(vc) * n / d;
  Eigen::Matrix4d proj;
  proj << 2 * n / (r - l), 0, (r + l) / (r - l), 0,  //
      0, 2 * n / (t - b), (t + b) / (t - b), 0,       //
      0, 0, -f / (f - n), -f * n / (f - n),           //
      0, 0, -1, 0;
  Eigen::Matrix4d rot = Eigen::Matrix4d::Identity();
  rot.block<1, 3>(0, 0) = vr.transpose();
  rot.block<1, 3>(1, 0) = vu.transpose();
  rot.block<1, 3>(2, 0) = vn.transpose();
  Eigen::Matrix4d trans = Eigen::Matrix4d::Identity();
  trans.block<3, 1>(0, 3) = -pe;
  return FlipY() * proj * rot * trans;
}

// Affine map from plane coordinates (a, b, 0, 1) to centre-frame points.
Eigen::Matrix4d CentreFromAb(const PatternPlane& plane, const Eigen::Vector3d& origin_in_centre) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.block<3, 1>(0, 0) = plane.x_axis_in_screen;
  m.block<3, 1>(0, 1) = plane.y_axis_in_screen;
  m.block<3, 1>(0, 3) = origin_in_centre;
  m(3, 3) = 1;
  return m;
}

struct Buffer {
  vk::raii::Buffer buffer{nullptr};
  vk::raii::DeviceMemory memory{nullptr};
  void* mapped = nullptr;
  vk::DeviceSize size = 0;
};

struct Image {
  vk::raii::Image image{nullptr};
  vk::raii::DeviceMemory memory{nullptr};
  vk::raii::ImageView view{nullptr};
  vk::Format format = vk::Format::eUndefined;
  uint32_t width = 0, height = 0;
};

enum class PipelineKind { kExact, kQuad, kQuadLinear, kWarpPerFragment, kWarpGrid, kMesh };

}  // namespace

struct Renderer::Impl {
  vk::raii::Context context;
  vk::raii::Instance instance{nullptr};
  vk::raii::PhysicalDevice physical{nullptr};
  vk::raii::Device device{nullptr};
  vk::raii::Queue queue{nullptr};
  uint32_t queue_family = 0;
  vk::raii::CommandPool pool{nullptr};
  vk::raii::DescriptorSetLayout set_layout{nullptr};
  vk::raii::PipelineLayout pipeline_layout{nullptr};
  vk::raii::Sampler sampler{nullptr};
  // Pipelines by kind, target format and specialization (supersample n, cubic filter).
  std::map<std::tuple<PipelineKind, vk::Format, int, int>, vk::raii::Pipeline> pipelines;
  std::string device_name;
  bool has_tessellation = false;
  double setup_ms = 0;

  Impl();
  uint32_t MemoryType(uint32_t type_bits, vk::MemoryPropertyFlags props) const;
  Buffer MakeBuffer(vk::DeviceSize size, vk::BufferUsageFlags usage);
  Image MakeImage(uint32_t w, uint32_t h, vk::Format format, vk::ImageUsageFlags usage);
  vk::raii::ShaderModule Module(const uint32_t* code, size_t bytes) const;
  const vk::raii::Pipeline& Pipeline(PipelineKind kind, vk::Format format, const MethodOptions& options);
  double Submit(const std::function<void(vk::raii::CommandBuffer&)>& record);

  // Renders into an image of `format` (kShadeFormat or kCoordFormat) and returns its bytes.
  std::vector<uint8_t> Draw(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                            const RenderOptions& options, bool coordinates, RenderTiming* timing);
};

Renderer::Impl::Impl() {
  const auto t0 = Clock::now();
  const vk::ApplicationInfo app("curvecheck", 1, "curvecheck", 1, VK_API_VERSION_1_3);
  try {
    instance = vk::raii::Instance(context, vk::InstanceCreateInfo({}, &app));
  } catch (const vk::SystemError& e) {
    throw Error("Vulkan", std::string("no usable Vulkan driver (") + e.what() + ")",
                "install mesa-vulkan-drivers (lavapipe, CPU) or your GPU's Vulkan driver");
  }
  vk::raii::PhysicalDevices devices(instance);
  if (devices.empty()) {
    throw Error("Vulkan", "the Vulkan loader found no device",
                "install mesa-vulkan-drivers (lavapipe, CPU) or your GPU's Vulkan driver");
  }
  const char* wanted = std::getenv("CURVECHECK_VULKAN_DEVICE");
  int best = -1, best_score = -1;
  std::string names;
  for (size_t i = 0; i < devices.size(); ++i) {
    const vk::PhysicalDeviceProperties props = devices[i].getProperties();
    const std::string name = props.deviceName.data();
    names += (names.empty() ? "" : ", ") + name;
    if (props.apiVersion < VK_API_VERSION_1_3) continue;
    int score = props.deviceType == vk::PhysicalDeviceType::eDiscreteGpu   ? 3
                : props.deviceType == vk::PhysicalDeviceType::eIntegratedGpu ? 2
                                                                              : 1;
    if (wanted && name.find(wanted) == std::string::npos) score = -1;
    if (score > best_score) best = static_cast<int>(i), best_score = score;
  }
  if (best < 0) {
    throw Error("Vulkan",
                wanted ? fmt::format("no Vulkan 1.3 device matches CURVECHECK_VULKAN_DEVICE='{}' (found: {})", wanted,
                                     names)
                       : fmt::format("no Vulkan 1.3 device (found: {})", names),
                "install mesa-vulkan-drivers 22+ (lavapipe) or a newer GPU driver");
  }
  physical = std::move(devices[static_cast<size_t>(best)]);
  device_name = physical.getProperties().deviceName.data();

  const auto families = physical.getQueueFamilyProperties();
  bool found = false;
  for (uint32_t i = 0; i < families.size(); ++i) {
    if (families[i].queueFlags & vk::QueueFlagBits::eGraphics) {
      queue_family = i;
      found = true;
      break;
    }
  }
  if (!found) throw Error("Vulkan", "device " + device_name + " has no graphics queue", "use another device");

  const auto supported = physical.getFeatures2<vk::PhysicalDeviceFeatures2, vk::PhysicalDeviceVulkan13Features>();
  if (!supported.get<vk::PhysicalDeviceVulkan13Features>().dynamicRendering) {
    throw Error("Vulkan", "device " + device_name + " lacks dynamic rendering", "update the Vulkan driver");
  }
  has_tessellation = supported.get<vk::PhysicalDeviceFeatures2>().features.tessellationShader;
  vk::PhysicalDeviceFeatures features;
  features.tessellationShader = has_tessellation;
  vk::PhysicalDeviceVulkan13Features features13;
  features13.dynamicRendering = true;
  const float priority = 1.0f;
  const vk::DeviceQueueCreateInfo queue_info({}, queue_family, 1, &priority);
  vk::DeviceCreateInfo device_info({}, queue_info, {}, {}, &features);
  device_info.pNext = &features13;
  device = vk::raii::Device(physical, device_info);
  queue = device.getQueue(queue_family, 0);
  pool = vk::raii::CommandPool(device, {vk::CommandPoolCreateFlagBits::eResetCommandBuffer, queue_family});

  std::array<vk::DescriptorSetLayoutBinding, 5> bindings = {
      vk::DescriptorSetLayoutBinding(0, vk::DescriptorType::eUniformBuffer, 1, vk::ShaderStageFlagBits::eAllGraphics),
      vk::DescriptorSetLayoutBinding(1, vk::DescriptorType::eStorageBuffer, 1, vk::ShaderStageFlagBits::eAllGraphics),
      vk::DescriptorSetLayoutBinding(2, vk::DescriptorType::eStorageBuffer, 1, vk::ShaderStageFlagBits::eAllGraphics),
      vk::DescriptorSetLayoutBinding(3, vk::DescriptorType::eCombinedImageSampler, 1,
                                     vk::ShaderStageFlagBits::eAllGraphics),
      vk::DescriptorSetLayoutBinding(4, vk::DescriptorType::eCombinedImageSampler, 1,
                                     vk::ShaderStageFlagBits::eAllGraphics)};
  set_layout = vk::raii::DescriptorSetLayout(device, vk::DescriptorSetLayoutCreateInfo({}, bindings));
  const vk::PushConstantRange push(vk::ShaderStageFlagBits::eVertex, 0, 64);
  const vk::DescriptorSetLayout layouts[] = {*set_layout};
  pipeline_layout = vk::raii::PipelineLayout(device, vk::PipelineLayoutCreateInfo({}, layouts, push));
  sampler = vk::raii::Sampler(device, vk::SamplerCreateInfo({}, vk::Filter::eNearest, vk::Filter::eNearest,
                                                            vk::SamplerMipmapMode::eNearest,
                                                            vk::SamplerAddressMode::eClampToEdge,
                                                            vk::SamplerAddressMode::eClampToEdge,
                                                            vk::SamplerAddressMode::eClampToEdge));
  setup_ms = MsSince(t0);
}

uint32_t Renderer::Impl::MemoryType(uint32_t type_bits, vk::MemoryPropertyFlags props) const {
  const auto mem = physical.getMemoryProperties();
  for (uint32_t i = 0; i < mem.memoryTypeCount; ++i) {
    if ((type_bits & (1u << i)) && (mem.memoryTypes[i].propertyFlags & props) == props) return i;
  }
  throw Error("Vulkan", fmt::format("device {} has no memory type with the properties {}", device_name,
                                    vk::to_string(props)),
              "use another Vulkan device");
}

Buffer Renderer::Impl::MakeBuffer(vk::DeviceSize size, vk::BufferUsageFlags usage) {
  Buffer b;
  b.size = size;
  b.buffer = vk::raii::Buffer(device, vk::BufferCreateInfo({}, size, usage));
  const auto req = b.buffer.getMemoryRequirements();
  b.memory = vk::raii::DeviceMemory(
      device, vk::MemoryAllocateInfo(req.size, MemoryType(req.memoryTypeBits, vk::MemoryPropertyFlagBits::eHostVisible |
                                                                                   vk::MemoryPropertyFlagBits::eHostCoherent)));
  b.buffer.bindMemory(*b.memory, 0);
  b.mapped = b.memory.mapMemory(0, size);
  return b;
}

Image Renderer::Impl::MakeImage(uint32_t w, uint32_t h, vk::Format format, vk::ImageUsageFlags usage) {
  Image img;
  img.format = format;
  img.width = w;
  img.height = h;
  img.image = vk::raii::Image(device, vk::ImageCreateInfo({}, vk::ImageType::e2D, format, vk::Extent3D(w, h, 1), 1, 1,
                                                          vk::SampleCountFlagBits::e1, vk::ImageTiling::eOptimal, usage));
  const auto req = img.image.getMemoryRequirements();
  img.memory = vk::raii::DeviceMemory(
      device, vk::MemoryAllocateInfo(req.size, MemoryType(req.memoryTypeBits, vk::MemoryPropertyFlagBits::eDeviceLocal)));
  img.image.bindMemory(*img.memory, 0);
  img.view = vk::raii::ImageView(device, vk::ImageViewCreateInfo({}, *img.image, vk::ImageViewType::e2D, format, {},
                                                                 {vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1}));
  return img;
}

vk::raii::ShaderModule Renderer::Impl::Module(const uint32_t* code, size_t bytes) const {
  return vk::raii::ShaderModule(device, vk::ShaderModuleCreateInfo({}, bytes, code));
}

const vk::raii::Pipeline& Renderer::Impl::Pipeline(PipelineKind kind, vk::Format format,
                                                   const MethodOptions& options) {
  const int32_t supersample =
      kind == PipelineKind::kExact && options.antialiasing == AntiAliasing::kSupersample ? options.supersample : 0;
  const int32_t cubic = options.warp_filter == WarpFilter::kCubic ? 1 : 0;
  const auto key = std::make_tuple(kind, format, supersample, cubic);
  if (auto it = pipelines.find(key); it != pipelines.end()) return it->second;
  const auto t0 = Clock::now();

  std::vector<vk::raii::ShaderModule> modules;
  std::vector<vk::PipelineShaderStageCreateInfo> stages;
  // Specialization constants of the shaders (ids as in shaders/*.frag, common.glsl).
  const int32_t per_fragment = kind == PipelineKind::kWarpPerFragment ? 1 : 0;
  const int32_t linear_output = kind == PipelineKind::kQuadLinear ? 1 : 0;
  const int32_t coordinates = format == kCoordFormat ? 1 : 0;
  const vk::SpecializationMapEntry entries[] = {{0, 0, 4}, {1, 4, 4}, {2, 8, 4}, {3, 12, 4}, {4, 16, 4}};
  const int32_t spec_data[] = {per_fragment, linear_output, supersample, cubic, coordinates};
  const vk::SpecializationInfo spec(5, entries, sizeof(spec_data), spec_data);
  auto add = [&](vk::ShaderStageFlagBits stage, const uint32_t* code, size_t bytes) {
    modules.push_back(Module(code, bytes));
    stages.emplace_back(vk::PipelineShaderStageCreateFlags{}, stage, *modules.back(), "main", &spec);
  };
  vk::PrimitiveTopology topology = vk::PrimitiveTopology::eTriangleList;
  std::vector<vk::VertexInputBindingDescription> vertex_bindings;
  std::vector<vk::VertexInputAttributeDescription> attributes;
  switch (kind) {
    case PipelineKind::kExact:
      add(vk::ShaderStageFlagBits::eVertex, kFullscreenVert, sizeof(kFullscreenVert));
      add(vk::ShaderStageFlagBits::eFragment, kExactFrag, sizeof(kExactFrag));
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
  const vk::PipelineRenderingCreateInfo rendering(0, format);
  vk::GraphicsPipelineCreateInfo info({}, stages, &vertex_input, &assembly,
                                      kind == PipelineKind::kMesh ? &tessellation : nullptr, &viewport, &raster,
                                      &multisample, nullptr, &blend_state, &dynamic_state, *pipeline_layout);
  info.pNext = &rendering;
  auto [it, inserted] = pipelines.emplace(key, vk::raii::Pipeline(device, nullptr, info));
  setup_ms += MsSince(t0);
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
  const auto t0 = Clock::now();
  queue.submit(vk::SubmitInfo({}, {}, raw), *fence);
  if (device.waitForFences(*fence, true, UINT64_MAX) != vk::Result::eSuccess) {
    throw Error("Vulkan", "waiting for the GPU failed", "check the device");
  }
  return MsSince(t0);
}

namespace {

void Transition(vk::raii::CommandBuffer& cmd, const Image& img, vk::ImageLayout from, vk::ImageLayout to,
                vk::AccessFlags src_access, vk::AccessFlags dst_access, vk::PipelineStageFlags src_stage,
                vk::PipelineStageFlags dst_stage) {
  const vk::ImageMemoryBarrier barrier(src_access, dst_access, from, to, VK_QUEUE_FAMILY_IGNORED,
                                       VK_QUEUE_FAMILY_IGNORED, *img.image,
                                       {vk::ImageAspectFlagBits::eColor, 0, 1, 0, 1});
  cmd.pipelineBarrier(src_stage, dst_stage, {}, {}, {}, barrier);
}

// The framebuffer box [x0, x1) x [y0, y1) holding every pixel whose ray can meet the pattern's
// cells grown by one cell: the display bounding box of that rectangle's outline, sampled densely and grown by
// 2 px, clamped to the display. The whole display if any outline point does not map to the surface.
std::array<int, 4> PatternBoxPx(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern) {
  const PatternCells& c = pattern.cells;
  const double a0 = c.top_left_mm.x() - c.cell_mm, a1 = c.top_left_mm.x() + (c.width + 1) * c.cell_mm;
  const double b1 = c.top_left_mm.y() + c.cell_mm, b0 = c.top_left_mm.y() - (c.height + 1) * c.cell_mm;
  const std::array<int, 4> full = {0, m.width_px, 0, m.height_px};
  double x_lo = 1e300, x_hi = -1e300, y_lo = 1e300, y_hi = -1e300;
  constexpr int kSamples = 512;
  for (int i = 0; i <= kSamples; ++i) {
    const double f = static_cast<double>(i) / kSamples;
    for (const Eigen::Vector2d& ab : {Eigen::Vector2d(a0 + f * (a1 - a0), b0), Eigen::Vector2d(a0 + f * (a1 - a0), b1),
                                      Eigen::Vector2d(a0, b0 + f * (b1 - b0)), Eigen::Vector2d(a1, b0 + f * (b1 - b0))}) {
      const auto px = DisplayPxFromPattern(m, viewpoint, pattern.plane, ab);
      if (!px || !px->allFinite()) return full;
      x_lo = std::min(x_lo, px->x()), x_hi = std::max(x_hi, px->x());
      y_lo = std::min(y_lo, px->y()), y_hi = std::max(y_hi, px->y());
    }
  }
  // Display coordinate x covers framebuffer [x + 0.5 - 0.5, ...): pixel index floor(x + 0.5).
  const int x0 = std::clamp(static_cast<int>(std::floor(x_lo - 2)), 0, m.width_px);
  const int x1 = std::clamp(static_cast<int>(std::ceil(x_hi + 3)), 0, m.width_px);
  const int y0 = std::clamp(static_cast<int>(std::floor(y_lo - 2)), 0, m.height_px);
  const int y1 = std::clamp(static_cast<int>(std::ceil(y_hi + 3)), 0, m.height_px);
  if (x1 <= x0 || y1 <= y0) return full;
  return {x0, x1, y0, y1};
}

// Checks that each method can render this view correctly; throws Error naming the reason otherwise.
void CheckMethodApplies(const Monitor& m, const Eigen::Vector3d& viewpoint, const RenderOptions& o, bool tess) {
  CheckViewpoint(m, viewpoint, "viewpoint");
  if (o.method.method == Method::kWarp) MakeOffAxisFrustum(m, viewpoint);  // throws beyond 180 deg
  // Thesis 4.3.1 (after Eq 4.8): the cylindrical clip mapping of the tessellation method does not support
  // fields of view of 180 deg or more (viewpoints in front of the plane of the screen's corners).
  if (o.method.method == Method::kMesh && (viewpoint - ScreenCentreInScreen(m)).z() <= m.sagitta_mm()) {
    throw Error("viewpoint",
                fmt::format("the viewpoint is {:.1f} mm in front of the screen centre, inside the plane of its corners "
                            "({:.1f} mm): the field of view reaches 180 deg, which the mesh method's cylindrical "
                            "projection cannot render (thesis 4.3.1)",
                            (viewpoint - ScreenCentreInScreen(m)).z(), m.sagitta_mm()),
                "use the exact method");
  }
  if (o.method.method == Method::kMesh && !tess) {
    throw Error("Vulkan", "the device has no tessellation shaders, which the mesh method needs",
                "use another method or device");
  }
}

}  // namespace

std::vector<uint8_t> Renderer::Impl::Draw(const Monitor& m, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                                          const RenderOptions& o, bool coordinates, RenderTiming* timing) {
  o.Check("render options");
  CheckMethodApplies(m, viewpoint, o, has_tessellation);
  const auto t_upload = Clock::now();
  const MethodOptions& mo = o.method;
  const uint32_t width = static_cast<uint32_t>(m.width_px), height = static_cast<uint32_t>(m.height_px);
  const vk::Format target_format = coordinates ? kCoordFormat : kShadeFormat;
  // Refuse sizes the device cannot hold rather than render nothing (lavapipe: 16384 px).
  const vk::PhysicalDeviceLimits limits = physical.getProperties().limits;
  auto check_size = [&](uint64_t w, uint64_t h, const char* what) {
    const uint64_t max = std::min<uint64_t>(limits.maxImageDimension2D,
                                            std::min(limits.maxFramebufferWidth, limits.maxFramebufferHeight));
    if (w > max || h > max) {
      throw Error("render", fmt::format("{} of {}x{} px exceeds the device's limit of {} px ({})", what, w, h, max,
                                        device_name),
                  "use a smaller display or warp scale, or another device");
    }
  };
  check_size(width, height, "the display");
  check_size(static_cast<uint64_t>(pattern.cells.width) + 2, static_cast<uint64_t>(pattern.cells.height) + 2,
             "the pattern's cell grid");
  if (mo.method == Method::kWarp) {
    check_size(static_cast<uint64_t>(std::lround(mo.warp_scale * m.width_px)) + 4,
               static_cast<uint64_t>(std::lround(mo.warp_scale * m.height_px)) + 4, "the warp's first-pass image");
  }
  const Eigen::Vector3d centre = ScreenCentreInScreen(m);
  const Eigen::Vector3d eye = viewpoint - centre;  // centre frame
  const Eigen::Vector3d plane_origin = pattern.plane.origin_in_screen - centre;
  const PatternCells& cells = pattern.cells;
  const double surround_linear = std::pow(o.surround_code / 255.0, o.display_gamma);

  // Parameters.
  Params params{};
  params.monitor[0] = static_cast<float>(m.width_px);
  params.monitor[1] = static_cast<float>(m.height_px);
  params.monitor[2] = static_cast<float>(m.width_mm);
  params.monitor[3] = static_cast<float>(m.height_mm);
  params.monitor2[0] = static_cast<float>(m.curvature_per_mm);
  params.monitor2[1] = static_cast<float>(o.display_gamma);
  params.monitor2[2] = static_cast<float>(surround_linear);
  Put(params.viewpoint, eye);
  Put(params.plane_origin, plane_origin);
  Put(params.plane_x, pattern.plane.x_axis_in_screen);
  Put(params.plane_y, pattern.plane.y_axis_in_screen);
  Put(params.plane_n, pattern.plane.Normal());
  params.cells[0] = static_cast<float>(cells.cell_mm);
  params.cells[1] = static_cast<float>(cells.top_left_mm.x());
  params.cells[2] = static_cast<float>(cells.top_left_mm.y());
  params.cells_size[0] = cells.width;
  params.cells_size[1] = cells.height;
  params.mesh[0] = mo.mesh_subdivision == MeshSubdivision::kUniform ? 0.f
                   : mo.mesh_subdivision == MeshSubdivision::kPerez ? 1.f
                                                                    : 2.f;
  // mesh: the tessellator is never asked for more than kMaxTessLevel segments per edge: a higher uniform level
  // splits the patches instead, which is the same geometry (and the draws are batched, kMaxTrianglesPerDraw).
  const int mesh_split =
      mo.mesh_subdivision == MeshSubdivision::kUniform ? (mo.mesh_level + kMaxTessLevel - 1) / kMaxTessLevel : 1;
  params.mesh[1] = static_cast<float>(mo.mesh_level) / static_cast<float>(mesh_split);
  params.mesh[2] = static_cast<float>(mo.mesh_tolerance_px);

  // Warp: the off-axis frustum of the first pass, as a map from centre-frame points to Vulkan clip space.
  uint32_t inter_w = 1, inter_h = 1;
  Eigen::Matrix4d warp_clip_from_centre = Eigen::Matrix4d::Identity();
  if (mo.method == Method::kWarp) {
    // The first pass covers the frustum of thesis Eq 4.6 (extents per 4.2.2) plus a guard band of 2 texels on
    // each side, so that the cubic filter's taps at the display's edges read rendered texels, not clamped ones.
    const OffAxisFrustum fr = MakeOffAxisFrustum(m, viewpoint);
    constexpr int kGuard = 2;
    const uint32_t core_w = static_cast<uint32_t>(std::lround(mo.warp_scale * m.width_px));
    const uint32_t core_h = static_cast<uint32_t>(std::lround(mo.warp_scale * m.height_px));
    inter_w = core_w + 2 * kGuard;
    inter_h = core_h + 2 * kGuard;
    const double gx = kGuard * (fr.right_mm - fr.left_mm) / core_w, gy = kGuard * (fr.top_mm - fr.bottom_mm) / core_h;
    const double l = fr.left_mm - gx, r = fr.right_mm + gx, b = fr.bottom_mm - gy, t = fr.top_mm + gy;
    const double n = fr.near_mm, f = fr.far_mm;
    Eigen::Matrix4d proj;  // thesis Eq 4.6 with the widened extents
    proj << 2 * n / (r - l), 0, (r + l) / (r - l), 0,  //
        0, 2 * n / (t - b), (t + b) / (t - b), 0,       //
        0, 0, -f / (f - n), -(f * n) / (f - n),         //
        0, 0, -1, 0;
    // The first pass clips at the near plane (the plane of the screen's corners): a pattern plane that comes
    // nearer than that somewhere in the drawn rectangle would be cut silently, so refuse.
    {
      const PatternCells& pc = pattern.cells;
      const double ra0 = pc.top_left_mm.x() - pc.cell_mm, ra1 = pc.top_left_mm.x() + (pc.width + 1) * pc.cell_mm;
      const double rb1 = pc.top_left_mm.y() + pc.cell_mm, rb0 = pc.top_left_mm.y() - (pc.height + 1) * pc.cell_mm;
      for (const auto& [ca, cb] : {std::pair(ra0, rb0), std::pair(ra1, rb0), std::pair(ra0, rb1), std::pair(ra1, rb1)}) {
        const Eigen::Vector3d corner = pattern.plane.PointInScreen({ca, cb}) - centre;
        if (eye.z() - corner.z() < n * (1 - 1e-9)) {  // on the near plane itself is drawn (flat screens)
          throw Error("pattern plane",
                      "part of the pattern lies in front of the plane of the screen's corners, where the warp's "
                      "linear first pass clips it",
                      "use a pattern plane behind the screen, or the exact method");
        }
      }
    }
    Eigen::Matrix4d view = Eigen::Matrix4d::Identity();  // translation by -O, in the centre frame
    view.block<3, 1>(0, 3) = -eye;
    warp_clip_from_centre = FlipY() * proj * view;
    params.warp[0] = static_cast<float>(inter_w);
    params.warp[1] = static_cast<float>(inter_h);
  }
  const auto clip = ColumnMajor(warp_clip_from_centre);
  std::memcpy(params.clip_from_centre, clip.data(), sizeof(params.clip_from_centre));

  Buffer ubo = MakeBuffer(sizeof(Params), vk::BufferUsageFlagBits::eUniformBuffer);
  std::memcpy(ubo.mapped, &params, sizeof(Params));

  // Tables of the surface at pixel edges and centres, exact in double, rounded once to float.
  Buffer columns = MakeBuffer(sizeof(float) * 2 * (2 * width + 1), vk::BufferUsageFlagBits::eStorageBuffer);
  Buffer rows = MakeBuffer(sizeof(float) * (2 * height + 1), vk::BufferUsageFlagBits::eStorageBuffer);
  {
    auto* col = static_cast<float*>(columns.mapped);
    for (uint32_t k = 0; k <= 2 * width; ++k) {
      const Eigen::Vector3d s = SurfacePointFromUv(m, UvFromDisplayPx(m, {0.5 * k - 0.5, 0})) - centre;
      col[2 * k] = static_cast<float>(s.x());
      col[2 * k + 1] = static_cast<float>(s.z());
    }
    auto* row = static_cast<float*>(rows.mapped);
    for (uint32_t k = 0; k <= 2 * height; ++k) {
      row[k] = static_cast<float>((SurfacePointFromUv(m, UvFromDisplayPx(m, {0, 0.5 * k - 0.5})) - centre).y());
    }
  }

  // Pattern cells.
  // Pattern cells as labels (0 black, 1 white, 2 surround) with one cell of surround padding on each side, so
  // that the shaders need no bounds checks (shaders/common.glsl).
  const uint32_t padded_w = static_cast<uint32_t>(cells.width) + 2, padded_h = static_cast<uint32_t>(cells.height) + 2;
  Image cell_image = MakeImage(padded_w, padded_h, vk::Format::eR8Uint,
                               vk::ImageUsageFlagBits::eSampled | vk::ImageUsageFlagBits::eTransferDst);
  Buffer cell_staging = MakeBuffer(static_cast<vk::DeviceSize>(padded_w) * padded_h, vk::BufferUsageFlagBits::eTransferSrc);
  {
    auto* labels = static_cast<uint8_t*>(cell_staging.mapped);
    std::fill(labels, labels + cell_staging.size, uint8_t{2});
    for (int r = 0; r < cells.height; ++r) {
      for (int c = 0; c < cells.width; ++c) {
        labels[static_cast<size_t>(r + 1) * padded_w + static_cast<size_t>(c + 1)] = cells.Value(c, r) >= 128 ? 1 : 0;
      }
    }
  }

  // Geometry: the pattern rectangle grown by one cell (outside it the clear colour is the surround).
  const double a0 = cells.top_left_mm.x() - cells.cell_mm, a1 = cells.top_left_mm.x() + (cells.width + 1) * cells.cell_mm;
  const double b1 = cells.top_left_mm.y() + cells.cell_mm, b0 = cells.top_left_mm.y() - (cells.height + 1) * cells.cell_mm;
  const Eigen::Matrix4d centre_from_ab = CentreFromAb(pattern.plane, plane_origin);
  std::vector<float> vertices;
  if (mo.method == Method::kMesh) {
    const double patch_mm = mo.mesh_patch_px * m.pixel_pitch_mm() / mesh_split;
    const int na = std::max(1, static_cast<int>(std::ceil((a1 - a0) / patch_mm)));
    const int nb = std::max(1, static_cast<int>(std::ceil((b1 - b0) / patch_mm)));
    for (int j = 0; j < nb; ++j) {
      for (int i = 0; i < na; ++i) {
        const double x0 = a0 + (a1 - a0) * i / na, x1 = a0 + (a1 - a0) * (i + 1) / na;
        const double y0 = b0 + (b1 - b0) * j / nb, y1 = b0 + (b1 - b0) * (j + 1) / nb;
        for (const auto& [x, y] : {std::pair(x0, y0), std::pair(x1, y0), std::pair(x1, y1), std::pair(x0, y1)}) {
          vertices.push_back(static_cast<float>(x));
          vertices.push_back(static_cast<float>(y));
        }
      }
    }
  } else if (mo.method == Method::kWarp && mo.warp_grid_cols > 0) {
    // Display-space grid; each vertex: clip position, exact texel coordinates in the first-pass image.
    auto vertex = [&](int i, int j) {
      const Eigen::Vector2d px(-0.5 + m.width_px * static_cast<double>(i) / mo.warp_grid_cols,
                               -0.5 + m.height_px * static_cast<double>(j) / mo.warp_grid_rows);
      const Eigen::Vector2d uv = UvFromDisplayPx(m, px);
      const Eigen::Vector3d s = SurfacePointFromUv(m, uv) - centre;
      const Eigen::Vector4d c = warp_clip_from_centre * s.homogeneous();
      const Eigen::Vector2d texel((c.x() / c.w() * 0.5 + 0.5) * inter_w - 0.5, (c.y() / c.w() * 0.5 + 0.5) * inter_h - 0.5);
      for (double v : {uv.x(), uv.y(), texel.x(), texel.y()}) vertices.push_back(static_cast<float>(v));
    };
    for (int j = 0; j < mo.warp_grid_rows; ++j) {
      for (int i = 0; i < mo.warp_grid_cols; ++i) {
        for (const auto& [di, dj] : {std::pair(0, 0), std::pair(1, 0), std::pair(1, 1), std::pair(0, 0),
                                     std::pair(1, 1), std::pair(0, 1)}) {
          vertex(i + di, j + dj);
        }
      }
    }
  }
  const std::vector<float> quad = {static_cast<float>(a0), static_cast<float>(b0), static_cast<float>(a1),
                                   static_cast<float>(b0), static_cast<float>(a0), static_cast<float>(b1),
                                   static_cast<float>(a1), static_cast<float>(b1)};
  Buffer quad_buffer = MakeBuffer(sizeof(float) * quad.size(), vk::BufferUsageFlagBits::eVertexBuffer);
  std::memcpy(quad_buffer.mapped, quad.data(), sizeof(float) * quad.size());
  Buffer vertex_buffer = MakeBuffer(std::max<size_t>(16, sizeof(float) * vertices.size()),
                                    vk::BufferUsageFlagBits::eVertexBuffer);
  if (!vertices.empty()) std::memcpy(vertex_buffer.mapped, vertices.data(), sizeof(float) * vertices.size());

  // Projections for the quad-based methods, each from plane coordinates to clip space.
  struct QuadDraw {
    Eigen::Matrix4d clip_from_ab;
    vk::Viewport viewport;
    vk::Rect2D scissor;
  };
  std::vector<QuadDraw> quad_draws;
  const vk::Viewport full_viewport(0, 0, static_cast<float>(width), static_cast<float>(height), 0, 1);
  const vk::Rect2D full_scissor({0, 0}, {width, height});
  // exact: only the pattern's bounding box is ray cast; around it the clear colour is the surround, which is
  // what the ray cast would show there.
  const std::array<int, 4> box = PatternBoxPx(m, viewpoint, pattern);
  const vk::Rect2D exact_scissor({box[0], box[2]}, {static_cast<uint32_t>(box[1] - box[0]), static_cast<uint32_t>(box[3] - box[2])});
  if (mo.method == Method::kNone) {
    // The panel taken as flat: a W x H rectangle in the plane tangent at the screen centre.
    const double hw = 0.5 * m.width_mm, hh = 0.5 * m.height_mm;
    quad_draws.push_back({RectangleProjection({-hw, -hh, 0}, {hw, -hh, 0}, {-hw, hh, 0}, eye, "the flat screen") *
                              centre_from_ab,
                          full_viewport, full_scissor});
  } else if (mo.method == Method::kStrips) {
    for (int i = 0; i < mo.strips; ++i) {
      const double u0 = -1 + 2.0 * i / mo.strips, u1 = -1 + 2.0 * (i + 1) / mo.strips;
      const Eigen::Vector3d pa = SurfacePointFromUv(m, {u0, 1}) - centre, pb = SurfacePointFromUv(m, {u1, 1}) - centre;
      const Eigen::Vector3d pc = SurfacePointFromUv(m, {u0, -1}) - centre;
      const double e0 = 0.5 * (u0 + 1) * m.width_px, e1 = 0.5 * (u1 + 1) * m.width_px;  // framebuffer x of edges
      const int32_t s0 = static_cast<int32_t>(std::ceil(e0 - 0.5)), s1 = static_cast<int32_t>(std::ceil(e1 - 0.5));
      if (s1 <= s0) continue;  // a strip narrower than a pixel covers no pixel centre
      quad_draws.push_back(
          {RectangleProjection(pa, pb, pc, eye, fmt::format("strip {}", i)) * centre_from_ab,
           vk::Viewport(static_cast<float>(e0), 0, static_cast<float>(e1 - e0), static_cast<float>(height), 0, 1),
           vk::Rect2D({s0, 0}, {static_cast<uint32_t>(s1 - s0), height})});
    }
  } else if (mo.method == Method::kWarp) {
    quad_draws.push_back({warp_clip_from_centre * centre_from_ab,
                          vk::Viewport(0, 0, static_cast<float>(inter_w), static_cast<float>(inter_h), 0, 1),
                          vk::Rect2D({0, 0}, {inter_w, inter_h})});
  }

  // Images.
  Image target = MakeImage(width, height, target_format,
                           vk::ImageUsageFlagBits::eColorAttachment | vk::ImageUsageFlagBits::eTransferSrc);
  Image inter = MakeImage(inter_w, inter_h, coordinates ? kCoordFormat : kLinearFormat,
                          vk::ImageUsageFlagBits::eColorAttachment | vk::ImageUsageFlagBits::eSampled);
  const size_t texel_bytes = coordinates ? 8 : 1;
  Buffer readback = MakeBuffer(static_cast<vk::DeviceSize>(width) * height * texel_bytes,
                               vk::BufferUsageFlagBits::eTransferDst);

  // Descriptors.
  const vk::DescriptorPoolSize sizes[] = {{vk::DescriptorType::eUniformBuffer, 1},
                                          {vk::DescriptorType::eStorageBuffer, 2},
                                          {vk::DescriptorType::eCombinedImageSampler, 2}};
  vk::raii::DescriptorPool descriptor_pool(
      device, vk::DescriptorPoolCreateInfo(vk::DescriptorPoolCreateFlagBits::eFreeDescriptorSet, 1, sizes));
  vk::raii::DescriptorSets sets(device, vk::DescriptorSetAllocateInfo(*descriptor_pool, *set_layout));
  const vk::DescriptorSet set = *sets[0];
  const vk::DescriptorBufferInfo ubo_info(*ubo.buffer, 0, ubo.size), col_info(*columns.buffer, 0, columns.size),
      row_info(*rows.buffer, 0, rows.size);
  const vk::DescriptorImageInfo cell_info(*sampler, *cell_image.view, vk::ImageLayout::eShaderReadOnlyOptimal),
      inter_info(*sampler, *inter.view, vk::ImageLayout::eShaderReadOnlyOptimal);
  const std::array<vk::WriteDescriptorSet, 5> writes = {
      vk::WriteDescriptorSet(set, 0, 0, vk::DescriptorType::eUniformBuffer, {}, ubo_info),
      vk::WriteDescriptorSet(set, 1, 0, vk::DescriptorType::eStorageBuffer, {}, col_info),
      vk::WriteDescriptorSet(set, 2, 0, vk::DescriptorType::eStorageBuffer, {}, row_info),
      vk::WriteDescriptorSet(set, 3, 0, vk::DescriptorType::eCombinedImageSampler, cell_info),
      vk::WriteDescriptorSet(set, 4, 0, vk::DescriptorType::eCombinedImageSampler, inter_info)};
  device.updateDescriptorSets(writes, {});

  // Pipelines (created once per kind and format; counted as set-up).
  const vk::Pipeline main_pipeline = [&] {
    switch (mo.method) {
      case Method::kExact: return *Pipeline(PipelineKind::kExact, target_format, mo);
      case Method::kNone:
      case Method::kStrips: return *Pipeline(PipelineKind::kQuad, target_format, mo);
      case Method::kWarp:
        return *Pipeline(mo.warp_grid_cols > 0 ? PipelineKind::kWarpGrid : PipelineKind::kWarpPerFragment,
                         target_format, mo);
      case Method::kMesh: return *Pipeline(PipelineKind::kMesh, target_format, mo);
    }
    return vk::Pipeline{};
  }();
  const vk::Pipeline first_pass = mo.method == Method::kWarp
                                      ? *Pipeline(coordinates ? PipelineKind::kQuad : PipelineKind::kQuadLinear,
                                                  inter.format, mo)
                                      : vk::Pipeline{};

  // Upload the cells (also makes the intermediate image readable when no warp writes it).
  Submit([&](vk::raii::CommandBuffer& cmd) {
    Transition(cmd, cell_image, vk::ImageLayout::eUndefined, vk::ImageLayout::eTransferDstOptimal, {},
               vk::AccessFlagBits::eTransferWrite, vk::PipelineStageFlagBits::eTopOfPipe,
               vk::PipelineStageFlagBits::eTransfer);
    const vk::BufferImageCopy region(0, 0, 0, {vk::ImageAspectFlagBits::eColor, 0, 0, 1}, {0, 0, 0},
                                     {cell_image.width, cell_image.height, 1});
    cmd.copyBufferToImage(*cell_staging.buffer, *cell_image.image, vk::ImageLayout::eTransferDstOptimal, region);
    Transition(cmd, cell_image, vk::ImageLayout::eTransferDstOptimal, vk::ImageLayout::eShaderReadOnlyOptimal,
               vk::AccessFlagBits::eTransferWrite, vk::AccessFlagBits::eShaderRead,
               vk::PipelineStageFlagBits::eTransfer, vk::PipelineStageFlagBits::eAllGraphics);
    if (mo.method != Method::kWarp) {
      Transition(cmd, inter, vk::ImageLayout::eUndefined, vk::ImageLayout::eShaderReadOnlyOptimal, {},
                 vk::AccessFlagBits::eShaderRead, vk::PipelineStageFlagBits::eTopOfPipe,
                 vk::PipelineStageFlagBits::eAllGraphics);
    }
  });
  const double upload_ms = MsSince(t_upload);

  const float nan = std::numeric_limits<float>::quiet_NaN();
  const vk::ClearValue target_clear = coordinates ? vk::ClearColorValue(std::array<float, 4>{nan, nan, 0, 1})
                                                  : vk::ClearColorValue(std::array<float, 4>{
                                                        static_cast<float>(o.surround_code / 255.0), 0, 0, 1});
  const vk::ClearValue inter_clear =
      coordinates ? vk::ClearColorValue(std::array<float, 4>{nan, nan, 0, 1})
                  : vk::ClearColorValue(std::array<float, 4>{static_cast<float>(surround_linear), 0, 0, 1});

  auto draw_quads = [&](vk::raii::CommandBuffer& cmd, vk::Pipeline pipeline) {
    cmd.bindPipeline(vk::PipelineBindPoint::eGraphics, pipeline);
    cmd.bindDescriptorSets(vk::PipelineBindPoint::eGraphics, *pipeline_layout, 0, set, {});
    cmd.bindVertexBuffers(0, *quad_buffer.buffer, {0});
    for (const QuadDraw& q : quad_draws) {
      const auto mat = ColumnMajor(q.clip_from_ab);
      cmd.pushConstants<float>(*pipeline_layout, vk::ShaderStageFlagBits::eVertex, 0, mat);
      cmd.setViewport(0, q.viewport);
      cmd.setScissor(0, q.scissor);
      cmd.draw(4, 1, 0, 0);
    }
  };

  const double render_ms = Submit([&](vk::raii::CommandBuffer& cmd) {
    if (mo.method == Method::kWarp) {
      Transition(cmd, inter, vk::ImageLayout::eUndefined, vk::ImageLayout::eColorAttachmentOptimal, {},
                 vk::AccessFlagBits::eColorAttachmentWrite, vk::PipelineStageFlagBits::eTopOfPipe,
                 vk::PipelineStageFlagBits::eColorAttachmentOutput);
      const vk::RenderingAttachmentInfo att(*inter.view, vk::ImageLayout::eColorAttachmentOptimal, {}, {}, {},
                                            vk::AttachmentLoadOp::eClear, vk::AttachmentStoreOp::eStore, inter_clear);
      cmd.beginRendering(vk::RenderingInfo({}, vk::Rect2D({0, 0}, {inter_w, inter_h}), 1, 0, att));
      draw_quads(cmd, first_pass);
      cmd.endRendering();
      Transition(cmd, inter, vk::ImageLayout::eColorAttachmentOptimal, vk::ImageLayout::eShaderReadOnlyOptimal,
                 vk::AccessFlagBits::eColorAttachmentWrite, vk::AccessFlagBits::eShaderRead,
                 vk::PipelineStageFlagBits::eColorAttachmentOutput, vk::PipelineStageFlagBits::eFragmentShader);
    }
    Transition(cmd, target, vk::ImageLayout::eUndefined, vk::ImageLayout::eColorAttachmentOptimal, {},
               vk::AccessFlagBits::eColorAttachmentWrite, vk::PipelineStageFlagBits::eTopOfPipe,
               vk::PipelineStageFlagBits::eColorAttachmentOutput);
    const vk::RenderingAttachmentInfo att(*target.view, vk::ImageLayout::eColorAttachmentOptimal, {}, {}, {},
                                          vk::AttachmentLoadOp::eClear, vk::AttachmentStoreOp::eStore, target_clear);
    cmd.beginRendering(vk::RenderingInfo({}, vk::Rect2D({0, 0}, {width, height}), 1, 0, att));
    switch (mo.method) {
      case Method::kNone:
      case Method::kStrips: draw_quads(cmd, main_pipeline); break;
      case Method::kExact:
      case Method::kWarp:
      case Method::kMesh:
        cmd.bindPipeline(vk::PipelineBindPoint::eGraphics, main_pipeline);
        cmd.bindDescriptorSets(vk::PipelineBindPoint::eGraphics, *pipeline_layout, 0, set, {});
        cmd.setViewport(0, full_viewport);
        cmd.setScissor(0, mo.method == Method::kExact ? exact_scissor : full_scissor);
        if (mo.method == Method::kMesh) {
          cmd.bindVertexBuffers(0, *vertex_buffer.buffer, {0});
          const uint32_t patches = static_cast<uint32_t>(vertices.size() / 8);
          const double level = mo.mesh_subdivision == MeshSubdivision::kUniform ? params.mesh[1] : kMaxTessLevel;
          const uint32_t batch = std::max<uint32_t>(1, static_cast<uint32_t>(kMaxTrianglesPerDraw / (2 * level * level)));
          for (uint32_t first = 0; first < patches; first += batch) {
            cmd.draw(4 * std::min(batch, patches - first), 1, 4 * first, 0);
          }
        } else if (mo.warp_grid_cols > 0) {
          cmd.bindVertexBuffers(0, *vertex_buffer.buffer, {0});
          cmd.draw(static_cast<uint32_t>(vertices.size() / 4), 1, 0, 0);
        } else {
          cmd.draw(3, 1, 0, 0);
        }
        break;
    }
    cmd.endRendering();
  });

  const auto t_read = Clock::now();
  Submit([&](vk::raii::CommandBuffer& cmd) {
    Transition(cmd, target, vk::ImageLayout::eColorAttachmentOptimal, vk::ImageLayout::eTransferSrcOptimal,
               vk::AccessFlagBits::eColorAttachmentWrite, vk::AccessFlagBits::eTransferRead,
               vk::PipelineStageFlagBits::eColorAttachmentOutput, vk::PipelineStageFlagBits::eTransfer);
    const vk::BufferImageCopy region(0, 0, 0, {vk::ImageAspectFlagBits::eColor, 0, 0, 1}, {0, 0, 0},
                                     {width, height, 1});
    cmd.copyImageToBuffer(*target.image, vk::ImageLayout::eTransferSrcOptimal, *readback.buffer, region);
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
    timing->readback_ms = MsSince(t_read);
  }
  return bytes;
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

std::string Renderer::device_name() const { return impl_->device_name; }
double Renderer::setup_ms() const { return impl_->setup_ms; }

GrayImage Renderer::Render(const Monitor& monitor, const Eigen::Vector3d& viewpoint, const Pattern& pattern,
                           const RenderOptions& options, RenderTiming* timing) {
  GrayImage img;
  img.width = monitor.width_px;
  img.height = monitor.height_px;
  img.pixels = WithVulkanErrors([&] { return impl_->Draw(monitor, viewpoint, pattern, options, false, timing); });
  return img;
}

CoordinateImage Renderer::RenderCoordinates(const Monitor& monitor, const Eigen::Vector3d& viewpoint,
                                            const Pattern& pattern, const RenderOptions& options,
                                            RenderTiming* timing) {
  CoordinateImage img;
  img.width = monitor.width_px;
  img.height = monitor.height_px;
  const std::vector<uint8_t> bytes =
      WithVulkanErrors([&] { return impl_->Draw(monitor, viewpoint, pattern, options, true, timing); });
  img.ab.resize(bytes.size() / sizeof(float));
  std::memcpy(img.ab.data(), bytes.data(), bytes.size());
  return img;
}

}  // namespace curvecheck
