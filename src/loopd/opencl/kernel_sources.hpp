#pragma once
#include <string>

namespace loopd {
/// @brief Text of an OpenCL source file from kernels/ (embedded at build time), by file name
///        (e.g. "m2dp.cl"). Empty when no such file was embedded.
std::string kernel_source(const std::string& name);
}  // namespace loopd
