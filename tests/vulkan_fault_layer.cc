// VK_LAYER_CURVECHECK_fault: a Vulkan layer for tests only, which makes the driver fail the way real hardware
// does and lavapipe never does, so that curvecheck's handling of it can be tested (issue 8 item 1, "a Vulkan
// device that is ... lost"). It sits between curvecheck and the driver and passes every call through, except what
// CURVECHECK_VULKAN_FAULT asks it to break:
//   device-lost          the first vkQueueSubmit returns VK_ERROR_DEVICE_LOST (the work is not submitted), and from
//                        then on every submit and wait (vkQueueSubmit/2, vkQueueWaitIdle, vkDeviceWaitIdle,
//                        vkWaitForFences, vkGetFenceStatus) does too, as on a device that has hung and been reset;
//   device-lost-after=N  the same after N submits have gone through;
//   out-of-device-memory vkAllocateMemory returns VK_ERROR_OUT_OF_DEVICE_MEMORY.
// Destroy calls always go through, so that a program that cleans up after a lost device leaks nothing.
//
// Enabled with VK_LAYER_PATH=<the folder of VkLayer_curvecheck_fault.json> VK_INSTANCE_LAYERS=VK_LAYER_CURVECHECK_fault
// (tests/CMakeLists.txt writes the manifest). The chain is built as the loader's layer interface describes
// (vk_layer.h: VkLayerInstanceCreateInfo / VkLayerDeviceCreateInfo link info, interface version 2).
#include <vulkan/vk_layer.h>
#include <vulkan/vulkan.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <unordered_map>

namespace {

enum class Fault { kNone, kDeviceLost, kOutOfDeviceMemory };

struct Config {
  Fault fault = Fault::kNone;
  long submits_before_loss = 0;
};

Config ReadConfig() {
  Config c;
  const char* v = std::getenv("CURVECHECK_VULKAN_FAULT");
  const std::string s = v ? v : "";
  const std::string after = "device-lost-after=";
  if (s == "device-lost") {
    c.fault = Fault::kDeviceLost;
  } else if (s.rfind(after, 0) == 0) {
    c.fault = Fault::kDeviceLost;
    c.submits_before_loss = std::strtol(s.c_str() + after.size(), nullptr, 10);
  } else if (s == "out-of-device-memory") {
    c.fault = Fault::kOutOfDeviceMemory;
  }
  return c;
}

const Config& Cfg() {
  static const Config c = ReadConfig();
  return c;
}

// The next layer's entry points, per instance and per device, keyed by the loader's dispatch pointer (the first
// word of every dispatchable handle; a VkQueue shares its VkDevice's).
void* Key(const void* handle) { return *static_cast<void* const*>(handle); }

struct InstanceNext {
  PFN_vkGetInstanceProcAddr gipa = nullptr;
  PFN_vkDestroyInstance destroy = nullptr;
};

struct DeviceNext {
  PFN_vkGetDeviceProcAddr gdpa = nullptr;
  PFN_vkDestroyDevice destroy = nullptr;
  PFN_vkQueueSubmit submit = nullptr;
  PFN_vkQueueSubmit2 submit2 = nullptr;
  PFN_vkQueueWaitIdle queue_wait_idle = nullptr;
  PFN_vkDeviceWaitIdle device_wait_idle = nullptr;
  PFN_vkWaitForFences wait_for_fences = nullptr;
  PFN_vkGetFenceStatus get_fence_status = nullptr;
  PFN_vkAllocateMemory allocate_memory = nullptr;
  long submits = 0;
  bool lost = false;
};

std::mutex mutex;
std::unordered_map<void*, InstanceNext> instances;
std::unordered_map<void*, DeviceNext> devices;

// Removes `handle`'s entry from `table` and returns it (for its destroy call, made after the lock is released).
template <typename Next>
Next Forget(std::unordered_map<void*, Next>& table, const void* handle) {
  std::lock_guard<std::mutex> lock(mutex);
  auto it = table.find(Key(handle));
  const Next next = it->second;
  table.erase(it);
  return next;
}

DeviceNext& Device(const void* handle) {
  std::lock_guard<std::mutex> lock(mutex);
  return devices.at(Key(handle));
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetInstanceProcAddr(VkInstance instance, const char* name);
VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char* name);

// The loader's link info for this layer in a create-info chain (VkLayerInstanceCreateInfo or
// VkLayerDeviceCreateInfo of `type` with function VK_LAYER_LINK_INFO); nullptr when absent.
template <typename LinkInfo>
LinkInfo* FindLink(const void* chain, VkStructureType type) {
  auto* link = static_cast<LinkInfo*>(const_cast<void*>(chain));
  while (link && !(link->sType == type && link->function == VK_LAYER_LINK_INFO)) {
    link = static_cast<LinkInfo*>(const_cast<void*>(link->pNext));
  }
  return link;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateInstance(const VkInstanceCreateInfo* info, const VkAllocationCallbacks* alloc,
                                              VkInstance* instance) {
  auto* link = FindLink<VkLayerInstanceCreateInfo>(info->pNext, VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO);
  if (!link) return VK_ERROR_INITIALIZATION_FAILED;
  const PFN_vkGetInstanceProcAddr next_gipa = link->u.pLayerInfo->pfnNextGetInstanceProcAddr;
  link->u.pLayerInfo = link->u.pLayerInfo->pNext;  // the next layer finds its own link
  auto create = reinterpret_cast<PFN_vkCreateInstance>(next_gipa(VK_NULL_HANDLE, "vkCreateInstance"));
  const VkResult r = create(info, alloc, instance);
  if (r != VK_SUCCESS) return r;
  InstanceNext next;
  next.gipa = next_gipa;
  next.destroy = reinterpret_cast<PFN_vkDestroyInstance>(next_gipa(*instance, "vkDestroyInstance"));
  std::lock_guard<std::mutex> lock(mutex);
  instances[Key(*instance)] = next;
  return VK_SUCCESS;
}

VKAPI_ATTR void VKAPI_CALL DestroyInstance(VkInstance instance, const VkAllocationCallbacks* alloc) {
  Forget(instances, instance).destroy(instance, alloc);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateDevice(VkPhysicalDevice physical, const VkDeviceCreateInfo* info,
                                            const VkAllocationCallbacks* alloc, VkDevice* device) {
  auto* link = FindLink<VkLayerDeviceCreateInfo>(info->pNext, VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO);
  if (!link) return VK_ERROR_INITIALIZATION_FAILED;
  const PFN_vkGetInstanceProcAddr next_gipa = link->u.pLayerInfo->pfnNextGetInstanceProcAddr;
  const PFN_vkGetDeviceProcAddr next_gdpa = link->u.pLayerInfo->pfnNextGetDeviceProcAddr;
  link->u.pLayerInfo = link->u.pLayerInfo->pNext;
  auto create = reinterpret_cast<PFN_vkCreateDevice>(next_gipa(VK_NULL_HANDLE, "vkCreateDevice"));
  const VkResult r = create(physical, info, alloc, device);
  if (r != VK_SUCCESS) return r;
  DeviceNext next;
  next.gdpa = next_gdpa;
  auto get = [&](const char* name) { return next_gdpa(*device, name); };
  next.destroy = reinterpret_cast<PFN_vkDestroyDevice>(get("vkDestroyDevice"));
  next.submit = reinterpret_cast<PFN_vkQueueSubmit>(get("vkQueueSubmit"));
  next.submit2 = reinterpret_cast<PFN_vkQueueSubmit2>(get("vkQueueSubmit2"));
  next.queue_wait_idle = reinterpret_cast<PFN_vkQueueWaitIdle>(get("vkQueueWaitIdle"));
  next.device_wait_idle = reinterpret_cast<PFN_vkDeviceWaitIdle>(get("vkDeviceWaitIdle"));
  next.wait_for_fences = reinterpret_cast<PFN_vkWaitForFences>(get("vkWaitForFences"));
  next.get_fence_status = reinterpret_cast<PFN_vkGetFenceStatus>(get("vkGetFenceStatus"));
  next.allocate_memory = reinterpret_cast<PFN_vkAllocateMemory>(get("vkAllocateMemory"));
  std::lock_guard<std::mutex> lock(mutex);
  devices[Key(*device)] = next;
  return VK_SUCCESS;
}

VKAPI_ATTR void VKAPI_CALL DestroyDevice(VkDevice device, const VkAllocationCallbacks* alloc) {
  Forget(devices, device).destroy(device, alloc);
}

// True when this submit is the one that loses the device, or it is lost already.
bool LoseOnSubmit(DeviceNext& d) {
  if (Cfg().fault != Fault::kDeviceLost) return false;
  std::lock_guard<std::mutex> lock(mutex);
  if (!d.lost && d.submits >= Cfg().submits_before_loss) d.lost = true;
  if (!d.lost) ++d.submits;
  return d.lost;
}

bool Lost(DeviceNext& d) {
  std::lock_guard<std::mutex> lock(mutex);
  return d.lost;
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit(VkQueue queue, uint32_t count, const VkSubmitInfo* submits, VkFence fence) {
  DeviceNext& d = Device(queue);
  return LoseOnSubmit(d) ? VK_ERROR_DEVICE_LOST : d.submit(queue, count, submits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueSubmit2(VkQueue queue, uint32_t count, const VkSubmitInfo2* submits,
                                            VkFence fence) {
  DeviceNext& d = Device(queue);
  return LoseOnSubmit(d) ? VK_ERROR_DEVICE_LOST : d.submit2(queue, count, submits, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL QueueWaitIdle(VkQueue queue) {
  DeviceNext& d = Device(queue);
  return Lost(d) ? VK_ERROR_DEVICE_LOST : d.queue_wait_idle(queue);
}

VKAPI_ATTR VkResult VKAPI_CALL DeviceWaitIdle(VkDevice device) {
  DeviceNext& d = Device(device);
  return Lost(d) ? VK_ERROR_DEVICE_LOST : d.device_wait_idle(device);
}

VKAPI_ATTR VkResult VKAPI_CALL WaitForFences(VkDevice device, uint32_t count, const VkFence* fences, VkBool32 all,
                                             uint64_t timeout) {
  DeviceNext& d = Device(device);
  return Lost(d) ? VK_ERROR_DEVICE_LOST : d.wait_for_fences(device, count, fences, all, timeout);
}

VKAPI_ATTR VkResult VKAPI_CALL GetFenceStatus(VkDevice device, VkFence fence) {
  DeviceNext& d = Device(device);
  return Lost(d) ? VK_ERROR_DEVICE_LOST : d.get_fence_status(device, fence);
}

VKAPI_ATTR VkResult VKAPI_CALL AllocateMemory(VkDevice device, const VkMemoryAllocateInfo* info,
                                              const VkAllocationCallbacks* alloc, VkDeviceMemory* memory) {
  DeviceNext& d = Device(device);
  if (Cfg().fault == Fault::kOutOfDeviceMemory) return VK_ERROR_OUT_OF_DEVICE_MEMORY;
  return d.allocate_memory(device, info, alloc, memory);
}

// The device-level functions this layer wraps; nullptr for any other name.
PFN_vkVoidFunction Wrapped(const char* name) {
  struct Entry {
    const char* name;
    PFN_vkVoidFunction fn;
  };
  static const Entry kEntries[] = {
      {"vkGetDeviceProcAddr", reinterpret_cast<PFN_vkVoidFunction>(&GetDeviceProcAddr)},
      {"vkDestroyDevice", reinterpret_cast<PFN_vkVoidFunction>(&DestroyDevice)},
      {"vkQueueSubmit", reinterpret_cast<PFN_vkVoidFunction>(&QueueSubmit)},
      {"vkQueueSubmit2", reinterpret_cast<PFN_vkVoidFunction>(&QueueSubmit2)},
      {"vkQueueSubmit2KHR", reinterpret_cast<PFN_vkVoidFunction>(&QueueSubmit2)},
      {"vkQueueWaitIdle", reinterpret_cast<PFN_vkVoidFunction>(&QueueWaitIdle)},
      {"vkDeviceWaitIdle", reinterpret_cast<PFN_vkVoidFunction>(&DeviceWaitIdle)},
      {"vkWaitForFences", reinterpret_cast<PFN_vkVoidFunction>(&WaitForFences)},
      {"vkGetFenceStatus", reinterpret_cast<PFN_vkVoidFunction>(&GetFenceStatus)},
      {"vkAllocateMemory", reinterpret_cast<PFN_vkVoidFunction>(&AllocateMemory)},
  };
  for (const Entry& e : kEntries) {
    if (std::strcmp(e.name, name) == 0) return e.fn;
  }
  return nullptr;
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetDeviceProcAddr(VkDevice device, const char* name) {
  if (PFN_vkVoidFunction f = Wrapped(name)) return f;
  return Device(device).gdpa(device, name);
}

VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL GetInstanceProcAddr(VkInstance instance, const char* name) {
  if (std::strcmp(name, "vkGetInstanceProcAddr") == 0) return reinterpret_cast<PFN_vkVoidFunction>(&GetInstanceProcAddr);
  if (std::strcmp(name, "vkCreateInstance") == 0) return reinterpret_cast<PFN_vkVoidFunction>(&CreateInstance);
  if (std::strcmp(name, "vkDestroyInstance") == 0) return reinterpret_cast<PFN_vkVoidFunction>(&DestroyInstance);
  if (std::strcmp(name, "vkCreateDevice") == 0) return reinterpret_cast<PFN_vkVoidFunction>(&CreateDevice);
  if (PFN_vkVoidFunction f = Wrapped(name)) return f;
  if (instance == VK_NULL_HANDLE) return nullptr;
  PFN_vkGetInstanceProcAddr next;
  {
    std::lock_guard<std::mutex> lock(mutex);
    next = instances.at(Key(instance)).gipa;
  }
  return next(instance, name);
}

}  // namespace

extern "C" VKAPI_ATTR __attribute__((visibility("default"))) VkResult VKAPI_CALL
vkNegotiateLoaderLayerInterfaceVersion(VkNegotiateLayerInterface* version) {
  if (version == nullptr || version->sType != LAYER_NEGOTIATE_INTERFACE_STRUCT) return VK_ERROR_INITIALIZATION_FAILED;
  if (version->loaderLayerInterfaceVersion > 2) version->loaderLayerInterfaceVersion = 2;
  version->pfnGetInstanceProcAddr = &GetInstanceProcAddr;
  version->pfnGetDeviceProcAddr = &GetDeviceProcAddr;
  version->pfnGetPhysicalDeviceProcAddr = nullptr;
  return VK_SUCCESS;
}
