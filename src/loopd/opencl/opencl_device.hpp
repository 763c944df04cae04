#pragma once
// Light OpenCL helpers (no CL headers here, see the style guide): device listing and error strings.
#include <string>
#include <vector>

namespace loopd {

/// @brief One OpenCL device of one platform.
struct OpenClDeviceInfo {
  int index = 0;         ///< position in list_opencl_devices() (the `opencl_device` config value)
  std::string platform;  ///< platform name (e.g. "Portable Computing Language")
  std::string name;      ///< device name
  bool gpu = false;      ///< CL_DEVICE_TYPE_GPU
  int compute_units = 0;
  void* id = nullptr;  ///< cl_device_id
};

/// @brief All devices of all platforms, in platform order. Empty when no ICD / platform exists.
std::vector<OpenClDeviceInfo> list_opencl_devices();

/// @brief The device picked for a configured index, or why there is none.
struct OpenClDevicePick {
  bool ok = false;
  std::string error;
  OpenClDeviceInfo device;
};

/// @brief The device for a configured index: `index` >= 0 picks that entry; -1 the first GPU, else the first device.
OpenClDevicePick pick_opencl_device(int index);

/// @brief "CL_OUT_OF_RESOURCES (-5)" style text for an OpenCL error code.
std::string opencl_error_string(int code);

}  // namespace loopd
