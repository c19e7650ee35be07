#include "core/common/format.h"

#include <fmt/format.h>

namespace wormdrag {

std::string FormatNumber(double v, int significant) {
  return fmt::format("{:.{}g}", v, significant);
}

std::string FormatFixed(double v, int decimals) {
  return fmt::format("{:.{}f}", v, decimals);
}

std::string HtmlEscape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char ch : s) {
    switch (ch) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += ch;
    }
  }
  return out;
}

}  // namespace wormdrag
