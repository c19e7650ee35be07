#include "core/model/friction_law.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/common/format.h"

namespace wormdrag {

std::string Coefficients::ToString() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%.10g,%.10g,%.10g,%.10g", mu_n, mu_t, eta_n, eta_t);
  return buf;
}

Result<Coefficients> ParseCoefficients(const std::string& text) {
  std::array<double, 4> a{};
  static const char* kNames[4] = {"mu_n", "mu_t", "eta_n", "eta_t"};
  int n = 0;
  for (const std::string& cell : SplitList(text)) {
    if (n == 4)
      return Status::InvalidArgument("coefficients '" + text + "': expected 4 values MUN,MUT,ETAN,ETAT, got more");
    char* end = nullptr;
    const double v = std::strtod(cell.c_str(), &end);
    if (cell.empty() || end == cell.c_str() || *end != '\0' || !std::isfinite(v))
      return Status::InvalidArgument("coefficients '" + text + "': value " + std::to_string(n + 1) + " (" + kNames[n] +
                                     ") is not a number: '" + cell + "'");
    if (v < 0)
      return Status::InvalidArgument("coefficients '" + text + "': " + kNames[n] + " must be >= 0, got " + cell);
    a[n++] = v;
  }
  if (n != 4)
    return Status::InvalidArgument("coefficients '" + text + "': expected 4 values MUN,MUT,ETAN,ETAT, got " +
                                   std::to_string(n));
  return Coefficients::FromArray(a);
}

std::string QuasiStaticSingularity(const Coefficients& c) {
  if (c.mu_n == 0 && c.mu_t == 0 && c.eta_n == 0 && c.eta_t == 0) return "no friction at all";
  if (c.mu_t == 0 && c.eta_t == 0) return "no tangential friction (mu_t = eta_t = 0)";
  if (c.mu_n == 0 && c.eta_n == 0) return "no normal friction (mu_n = eta_n = 0)";
  return "";
}

}  // namespace wormdrag
