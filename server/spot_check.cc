#include "server/spot_check.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace wormdrag::server {

namespace {

bool NumbersAgree(double a, double b, double tol) {
  if (std::isnan(a) || std::isnan(b)) return true;
  if (std::isinf(a) || std::isinf(b)) return a == b;
  return std::fabs(a - b) <= tol * std::max(std::fabs(a), std::fabs(b));
}

bool VectorsAgree(const std::vector<double>& a, const std::vector<double>& b, double tol) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!NumbersAgree(a[i], b[i], tol)) return false;
  return true;
}

bool ListsAgree(const std::vector<std::vector<double>>& a, const std::vector<std::vector<double>>& b, double tol) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!VectorsAgree(a[i], b[i], tol)) return false;
  return true;
}

}  // namespace

bool IsSpotChecked(const std::string& task_id, double fraction) {
  if (!(fraction > 0)) return false;
  if (fraction >= 1) return true;
  // FNV-1a: the same on every platform and every start, unlike std::hash.
  uint64_t h = 14695981039346656037ull;
  for (unsigned char c : task_id) h = (h ^ c) * 1099511628211ull;
  return static_cast<double>(h >> 11) * 0x1.0p-53 < fraction;
}

bool IsSpotCheckable(TaskKind kind) {
  return kind == TaskKind::kMeanDistance || kind == TaskKind::kMeanSquaredDistance || kind == TaskKind::kResiduals ||
         kind == TaskKind::kResidualJacobians;
}

bool ResultsAgree(const TaskResult& a, const TaskResult& b, double tol) {
  return VectorsAgree(a.values, b.values, tol) && ListsAgree(a.residuals, b.residuals, tol) &&
         ListsAgree(a.jacobians, b.jacobians, tol);
}

}  // namespace wormdrag::server
