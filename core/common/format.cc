#include "core/common/format.h"

#include <fmt/format.h>

namespace wormdrag {

std::string FormatNumber(double v, int significant) {
  return fmt::format("{:.{}g}", v, significant);
}

std::string FormatFixed(double v, int decimals) {
  return fmt::format("{:.{}f}", v, decimals);
}

}  // namespace wormdrag
