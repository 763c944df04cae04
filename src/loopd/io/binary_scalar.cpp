#include "loopd/io/binary_scalar.hpp"

#include <cmath>
#include <cstdlib>

namespace loopd {

bool parse_float_token(const std::string& token, float* value) {
  if (token.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0') return false;
  if (std::isnan(v)) {
    *value = std::nanf("");
  } else if (v > 3.4028234e38) {
    *value = HUGE_VALF;
  } else if (v < -3.4028234e38) {
    *value = -HUGE_VALF;
  } else {
    *value = static_cast<float>(v);
  }
  return true;
}

}  // namespace loopd
