// The wire and storage form of task results (EncodeResult, DecodeResult), the check of
// a reported result's form (CheckResult) and the content-addressed task ids (MakeTaskId).
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "core/store/job_store.h"
#include "server/scheduler.h"

namespace wormdrag::server {

namespace {

void PutU32(std::string* s, uint32_t v) {
  s->append(reinterpret_cast<const char*>(&v), 4);
}
void PutDoubles(std::string* s, const std::vector<double>& v) {
  PutU32(s, static_cast<uint32_t>(v.size()));
  s->append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
}
bool GetU32(const std::string& s, size_t* at, uint32_t* v) {
  if (*at + 4 > s.size()) return false;
  std::memcpy(v, s.data() + *at, 4);
  *at += 4;
  return true;
}
bool GetDoubles(const std::string& s, size_t* at, std::vector<double>* v) {
  uint32_t n;
  if (!GetU32(s, at, &n) || *at + size_t{n} * sizeof(double) > s.size()) return false;
  v->resize(n);
  std::memcpy(v->data(), s.data() + *at, size_t{n} * sizeof(double));
  *at += size_t{n} * sizeof(double);
  return true;
}
}  // namespace

// A result of the right form for its task: the count and kind of numbers its kind
// carries, all finite where they must be (a worker's report is not trusted).
Status CheckResult(const TaskSpec& spec, const TaskResult& result) {
  const std::string& id = spec.id;
  const size_t n = spec.sets.size();
  if (result.worm != spec.worm)
    return Status::InvalidArgument("task " + id + ": the result answers worm " + std::to_string(result.worm) +
                                   ", the task asked for " + std::to_string(spec.worm) + " (0 = both)");
  if (spec.kind == TaskKind::kDiagnoseFit) {
    if (result.values.size() < 6 || !result.residuals.empty())
      return Status::InvalidArgument("task " + id + ": a fit result has at least 6 values, got " +
                                     std::to_string(result.values.size()));
    for (double v : result.values)
      if (!std::isfinite(v)) return Status::InvalidArgument("task " + id + ": fit result is not finite");
  } else if (spec.kind == TaskKind::kBootstrapReplicate) {
    if (result.values.size() != 6 || !result.residuals.empty())
      return Status::InvalidArgument("task " + id + ": a bootstrap refit has 6 values, got " +
                                     std::to_string(result.values.size()));
    for (double v : result.values)
      if (!std::isfinite(v) || v < 0)
        return Status::InvalidArgument("task " + id + ": refit value is not finite and >= 0");
  } else if (spec.kind == TaskKind::kResiduals || spec.kind == TaskKind::kResidualJacobians) {
    if (result.residuals.size() != n || !result.values.empty())
      return Status::InvalidArgument("task " + id + ": expected " + std::to_string(n) + " residual vectors, got " +
                                     std::to_string(result.residuals.size()));
    // Residual tasks carry no Jacobians; Jacobian tasks one of 4 columns per residual vector.
    const bool jacobians = spec.kind == TaskKind::kResidualJacobians;
    for (size_t i = 0; i < n; ++i) {
      const size_t want = jacobians ? 4 * result.residuals[i].size() : 0;
      const size_t got = i < result.jacobians.size() ? result.jacobians[i].size() : 0;
      if (got != want)
        return Status::InvalidArgument("task " + id + ": set " + std::to_string(i) + " has a Jacobian of " +
                                       std::to_string(got) + " values, expected " + std::to_string(want));
    }
    for (const auto* vectors : {&result.residuals, &result.jacobians})
      for (const auto& r : *vectors)
        for (double v : r)
          if (!std::isfinite(v)) return Status::InvalidArgument("task " + id + ": residual or Jacobian is not finite");
  } else {
    if (result.values.size() != n || !result.residuals.empty())
      return Status::InvalidArgument("task " + id + ": expected " + std::to_string(n) + " values, got " +
                                     std::to_string(result.values.size()));
    // NaN: abandoned (no E), allowed only where the task carried a cut. +inf is a
    // set the solver could not simulate (LocalEvaluator's answer), so it is kept.
    for (double v : result.values)
      if ((std::isnan(v) && !spec.may_abandon()) || v < 0)
        return Status::InvalidArgument("task " + id + ": value is NaN or negative");
  }
  return Status::Ok();
}

// Layout: u8 kind, then for 0 values; for 2 values and the two knot counts (i64); for
// 1 u32 count and that many vectors. Blobs of kind 0 (written before knot counts
// existed) still decode, with zero knots.
std::string EncodeResult(const TaskResult& r) {
  std::string s;
  if (r.residuals.empty()) {
    s.push_back(2);
    PutDoubles(&s, r.values);
    s.append(reinterpret_cast<const char*>(&r.knots), 8);
    s.append(reinterpret_cast<const char*>(&r.knots_full), 8);
  } else {
    s.push_back(1);
    PutU32(&s, static_cast<uint32_t>(r.residuals.size()));
    for (const auto& v : r.residuals) PutDoubles(&s, v);
  }
  return s;
}

bool DecodeResult(const std::string& blob, TaskResult* r) {
  if (blob.empty()) return false;
  size_t at = 1;
  *r = {};
  if (blob[0] == 0) return GetDoubles(blob, &at, &r->values) && at == blob.size();
  if (blob[0] == 2) {
    if (!GetDoubles(blob, &at, &r->values) || at + 16 != blob.size()) return false;
    std::memcpy(&r->knots, blob.data() + at, 8);
    std::memcpy(&r->knots_full, blob.data() + at + 8, 8);
    return true;
  }
  uint32_t n;
  if (!GetU32(blob, &at, &n)) return false;
  r->residuals.resize(n);
  for (auto& v : r->residuals)
    if (!GetDoubles(blob, &at, &v)) return false;
  return at == blob.size();
}

std::string MakeTaskId(int64_t job, bool screening, TaskKind kind, const Coefficients* sets, size_t count,
                       const std::string& payload) {
  std::string key = std::to_string(job) + (screening ? "|screening|" : "|accurate|") +
                    std::to_string(static_cast<int>(kind)) + "|";
  for (size_t i = 0; i < count; ++i) {
    const auto a = sets[i].AsArray();
    key.append(reinterpret_cast<const char*>(a.data()), sizeof(double) * 4);
  }
  key += payload;
  return "t" + std::to_string(job) + "-" + Sha256Hex(key).substr(0, 32);
}

}  // namespace wormdrag::server
