#include "server/metrics_text.h"

#include <cmath>
#include <cstdio>

namespace wormdrag::server {

namespace {

class Writer {
 public:
  // Starts a metric family: its help text and type.
  void Family(const char* name, const char* type, const std::string& help) {
    out_ += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n";
  }
  void Sample(const std::string& name_and_labels, double v) {
    char buf[64];
    if (std::isnan(v))
      std::snprintf(buf, sizeof buf, "NaN");
    else if (std::isinf(v))
      std::snprintf(buf, sizeof buf, v > 0 ? "+Inf" : "-Inf");
    else if (v == std::floor(v) && std::fabs(v) < 1e15)
      std::snprintf(buf, sizeof buf, "%.0f", v);
    else
      std::snprintf(buf, sizeof buf, "%.9g", v);
    out_ += name_and_labels + " " + buf + "\n";
  }
  void Metric(const char* name, const char* type, const std::string& help, double v) {
    Family(name, type, help);
    Sample(name, v);
  }
  std::string Take() { return std::move(out_); }

 private:
  std::string out_;
};

std::string Label(const char* key, const std::string& value) {
  return std::string("{") + key + "=\"" + EscapeLabelValue(value) + "\"}";
}

std::string Bound(double b) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", b);
  return buf;
}

}  // namespace

std::string EscapeLabelValue(const std::string& v) {
  std::string out;
  for (char ch : v) {
    if (ch == '\\')
      out += "\\\\";
    else if (ch == '"')
      out += "\\\"";
    else if (ch == '\n')
      out += "\\n";
    else
      out += ch;
  }
  return out;
}

std::string RenderMetrics(const StatusSnapshot& s) {
  const std::string window = " over the last " + std::to_string(WorkerActivity::kRateWindow.count()) + " s.";
  Writer w;
  w.Metric("wormdrag_uptime_seconds", "gauge", "Seconds since the coordinator started.",
           std::chrono::duration<double>(s.now - s.started_at).count());
  w.Family("wormdrag_jobs", "gauge", "Jobs in the job store, by state.");
  for (const auto& [state, n] : s.jobs_by_state) w.Sample("wormdrag_jobs" + Label("state", JobStateName(state)), n);
  w.Metric("wormdrag_workers_active", "gauge", "Workers heard from within the lease period.", s.active_workers);
  w.Metric("wormdrag_tasks_queued", "gauge", "Tasks waiting for a worker.", s.tasks.queued);
  w.Metric("wormdrag_tasks_leased", "gauge", "Tasks a worker holds now.", s.tasks.leased);
  w.Metric("wormdrag_tasks_leased_total", "counter", "Leases handed out (a task leased again counts again).",
           s.tasks.leased_total);
  w.Metric("wormdrag_tasks_expired_total", "counter",
           "Leases lost: run out without a heartbeat or report, or past the task's deadline.", s.tasks.expired_total);
  w.Metric("wormdrag_tasks_quarantined_total", "counter",
           "Tasks taken out of service after --max-attempts failures or --max-lost-leases lost leases (their jobs "
           "fail).",
           s.tasks.quarantined_total);
  w.Metric("wormdrag_task_reports_total", "counter", "Reports received from workers (results, failures, duplicates).",
           s.tasks.reports_total);
  w.Metric("wormdrag_task_reports_rejected_total", "counter",
           "Reports refused for not holding the task's current lease (not counted as failures).",
           s.tasks.rejected_total);
  w.Metric("wormdrag_spot_checks_total", "counter", "Results held back for a second worker's opinion.",
           s.tasks.spot_checks_total);
  w.Metric("wormdrag_spot_check_mismatches_total", "counter",
           "Spot-checks whose two results differed (a third worker decided).", s.tasks.spot_mismatches_total);
  w.Metric("wormdrag_workers_quarantined", "gauge", "Workers a spot-check caught returning wrong results.",
           s.tasks.workers_quarantined_total);
  w.Metric("wormdrag_sets_simulated_total", "counter",
           "Coefficient sets whose results workers reported (a diagnosis fit counts one).", s.sets_total);
  w.Metric("wormdrag_sets_per_second", "gauge", "Sets reported per second" + window, s.sets_per_second);

  const CommitStats& c = s.commits;
  w.Family("wormdrag_sqlite_commit_seconds", "histogram",
           "Group commits of task results to SQLite, from BEGIN to the durable COMMIT (synchronous=FULL).");
  for (size_t i = 0; i < CommitStats::kBounds.size(); ++i)
    w.Sample("wormdrag_sqlite_commit_seconds_bucket" + Label("le", Bound(CommitStats::kBounds[i])), c.le[i]);
  w.Sample("wormdrag_sqlite_commit_seconds_bucket" + Label("le", "+Inf"), c.count);
  w.Sample("wormdrag_sqlite_commit_seconds_sum", c.seconds_sum);
  w.Sample("wormdrag_sqlite_commit_seconds_count", c.count);
  w.Metric("wormdrag_sqlite_committed_results_total", "counter", "Task results made durable by those commits.",
           c.results);

  w.Family("wormdrag_worker_last_contact_seconds", "gauge",
           "Seconds since each worker's last call (lease poll, heartbeat or report).");
  for (const auto& wk : s.workers)
    w.Sample("wormdrag_worker_last_contact_seconds" + Label("worker", wk.id), wk.seconds_since_contact);
  w.Family("wormdrag_worker_sets_total", "counter", "Sets each worker reported since the coordinator first saw it.");
  for (const auto& wk : s.workers) w.Sample("wormdrag_worker_sets_total" + Label("worker", wk.id), wk.sets_done);
  w.Family("wormdrag_worker_sets_per_second", "gauge", "Sets each worker reported per second" + window);
  for (const auto& wk : s.workers)
    w.Sample("wormdrag_worker_sets_per_second" + Label("worker", wk.id), wk.sets_per_second);
  return w.Take();
}

}  // namespace wormdrag::server
