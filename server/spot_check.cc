#include "server/spot_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace wormdrag::server {

namespace {

bool NumbersAgree(double a, double b, double tol) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (std::isinf(a) || std::isinf(b)) return a == b;
  return std::fabs(a - b) <= tol * std::max(std::fabs(a), std::fabs(b));
}

// The lowest E at which a worker may have abandoned each set of the task. With the
// phase's cut (keep > 0), its running cut ends at the task's cut or at the keep-th best
// E it completed, whichever is lower; with group cuts, at the set's group cut or the
// group's best E it completed. A set is abandoned only once its E is proven above the
// cut it saw.
std::vector<double> AbandonBounds(const std::vector<double>& v, const TaskSpec& task) {
  std::vector<double> bound(v.size(), task.cut);
  if (!task.set_cuts.empty()) {
    if (task.set_cuts.size() != v.size() || task.set_groups.size() != v.size()) return bound;
    std::vector<double> best(v.size(), std::numeric_limits<double>::infinity());
    for (size_t i = 0; i < v.size(); ++i) {
      const auto g = static_cast<size_t>(task.set_groups[i]);
      if (g < v.size() && std::isfinite(v[i])) best[g] = std::min(best[g], v[i]);
    }
    for (size_t i = 0; i < v.size(); ++i) {
      const auto g = static_cast<size_t>(task.set_groups[i]);
      bound[i] = std::min(task.set_cuts[i], g < v.size() ? best[g] : task.set_cuts[i]);
    }
    return bound;
  }
  if (task.keep <= 0) return bound;
  std::vector<double> done;
  for (double x : v)
    if (std::isfinite(x)) done.push_back(x);
  if (static_cast<int64_t>(done.size()) < task.keep) return bound;
  std::nth_element(done.begin(), done.begin() + (task.keep - 1), done.end());
  std::fill(bound.begin(), bound.end(), std::min(task.cut, done[static_cast<size_t>(task.keep - 1)]));
  return bound;
}

// E values: as NumbersAgree, except that a set one worker abandoned (NaN) agrees with
// the other's value when that value lies above the first worker's abandoning bound;
// a NaN in place of a set that should have survived is a wrong result.
bool ValuesAgree(const std::vector<double>& a, const std::vector<double>& b, double tol, const TaskSpec& task) {
  if (a.size() != b.size()) return false;
  const std::vector<double> bound_a = AbandonBounds(a, task), bound_b = AbandonBounds(b, task);
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i]) != std::isnan(b[i])) {
      if (!task.may_abandon()) return false;
      const double other = std::isnan(a[i]) ? b[i] : a[i], bound = std::isnan(a[i]) ? bound_a[i] : bound_b[i];
      if (!(other >= bound * (1 - tol))) return false;
    } else if (!NumbersAgree(a[i], b[i], tol)) {
      return false;
    }
  }
  return true;
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

bool ResultsAgree(const TaskResult& a, const TaskResult& b, double tol, const TaskSpec& task) {
  return ValuesAgree(a.values, b.values, tol, task) && ListsAgree(a.residuals, b.residuals, tol) &&
         ListsAgree(a.jacobians, b.jacobians, tol);
}

}  // namespace wormdrag::server
