#include "core/common/json.h"

#include <cmath>

namespace wormdrag {

Json NumberOrNull(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

Json NumberOrInf(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return NumberOrNull(v);
}

std::string Dump(const Json& j) {
  return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

}  // namespace wormdrag
