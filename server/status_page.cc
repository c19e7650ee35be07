#include "server/status_page.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "core/common/format.h"

namespace wormdrag::server {

namespace {

using Clock = std::chrono::system_clock;

// As the CLI prints E (`wormdrag jobs`, `watch`): 5 significant digits, "-" for none.
std::string FormatE(double e) {
  if (!(e > 0) || !std::isfinite(e)) return "-";
  return FormatNumber(e, 5);
}

std::string Duration(double s) {
  if (!(s >= 0) || !std::isfinite(s)) return "-";
  const long t = std::lround(s);
  char buf[48];
  if (t < 60)
    std::snprintf(buf, sizeof buf, "%ld s", t);
  else if (t < 3600)
    std::snprintf(buf, sizeof buf, "%ld min %02ld s", t / 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%ld h %02ld min", t / 3600, (t % 3600) / 60);
  return buf;
}

std::string Utc(Clock::time_point t) {
  const std::time_t tt = Clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&tt, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%d %H:%M:%S", &tm);
  return buf;
}

// "phase done/total" as `wormdrag jobs` prints a job's progress ("" when done or none).
std::string ProgressText(const JobRecord& j) {
  if (j.state == JobState::kDone || j.sets_total == 0) return "";
  return j.phase + " " + std::to_string(j.sets_done) + "/" + std::to_string(j.sets_total);
}

std::string Inputs(const JobRecord& j) {
  return HtmlEscape(j.dataset_names[0]) + "<br>" + HtmlEscape(j.dataset_names[1]);
}

std::string Cell(const std::string& html, const char* cls = nullptr) {
  return cls ? std::string("<td class=\"") + cls + "\">" + html + "</td>" : "<td>" + html + "</td>";
}

std::string Header(std::initializer_list<const char*> names) {
  std::string h = "<tr>";
  for (const char* n : names) h += std::string("<th>") + n + "</th>";
  return h + "</tr>\n";
}

const char* kStyle =
    "body{font-family:system-ui,sans-serif;margin:1.5em;color:#222;background:#fff}"
    "h1{font-size:1.4em;margin:0 0 .3em}h2{font-size:1.1em;margin:1.4em 0 .4em}"
    "p.summary{margin:.2em 0;color:#444}"
    "table{border-collapse:collapse;font-size:.9em}th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left;"
    "vertical-align:top}th{background:#f0f0f0}td.n{text-align:right;font-variant-numeric:tabular-nums}"
    "td.err{max-width:40em;word-break:break-word;color:#a00}"
    ".bar{width:12em;height:.7em;background:#e4e4e4;border-radius:.35em;overflow:hidden;margin:.25em 0}"
    ".bar div{height:100%;background:#3a7bd5}"
    ".state-running{color:#1a6}.state-failed{color:#a00}.state-cancelled{color:#888}.silent{color:#a60}"
    "p.none{color:#777;margin:.2em 0}footer{margin-top:2em;font-size:.85em;color:#666}";

std::string ActiveJobs(const StatusSnapshot& s) {
  if (s.active.empty()) return "<p class=\"none\">No running or queued jobs.</p>\n";
  std::string h = "<table id=\"active\">\n" + Header({"job", "kind", "state", "inputs", "progress", "sets/s",
                                                      "phase ETA", "best E (mm)", "tasks queued / leased / done"});
  for (const auto& p : s.active) {
    const JobRecord& j = p.job;
    const double frac = j.sets_total > 0 ? std::min(1.0, static_cast<double>(j.sets_done) / j.sets_total) : 0;
    h += "<tr>" + Cell(std::to_string(j.id), "n") + Cell(HtmlEscape(j.kind)) +
         Cell(std::string("<span class=\"state-") + JobStateName(j.state) + "\">" + JobStateName(j.state) + "</span>") +
         Cell(Inputs(j)) +
         Cell("<div class=\"bar\"><div style=\"width:" + FormatFixed(100 * frac, 1) + "%\"></div></div>" +
              HtmlEscape(ProgressText(j))) +
         Cell(p.sets_per_second > 0 ? FormatFixed(p.sets_per_second, 1) : "-", "n") +
         Cell(p.eta_seconds >= 0 ? Duration(p.eta_seconds) : "-", "n") + Cell(FormatE(j.best_e), "n") +
         Cell(std::to_string(p.tasks.queued) + " / " + std::to_string(p.tasks.leased) + " / " +
                  std::to_string(p.tasks.done),
              "n") +
         "</tr>\n";
  }
  return h + "</table>\n";
}

std::string Workers(const StatusSnapshot& s) {
  if (s.workers.empty())
    return "<p class=\"none\">No worker has called in the last " + Duration(s.worker_forget_seconds) + ".</p>\n";
  std::string h = "<table id=\"workers\">\n" + Header({"worker", "threads", "last heartbeat", "task in hand",
                                                       "tasks done", "failed", "sets done", "sets/s"});
  for (const auto& w : s.workers) {
    const bool silent = w.seconds_since_contact > s.lease_seconds;
    h += "<tr>" + Cell(HtmlEscape(w.id)) + Cell(std::to_string(w.threads), "n") +
         Cell(std::string(silent ? "<span class=\"silent\">" : "<span>") + Duration(w.seconds_since_contact) +
                  " ago</span>",
              "n") +
         Cell(w.task.empty() ? "-" : HtmlEscape(w.task)) + Cell(std::to_string(w.tasks_done), "n") +
         Cell(std::to_string(w.tasks_failed), "n") + Cell(std::to_string(w.sets_done), "n") +
         Cell(FormatFixed(w.sets_per_second, 1), "n") + "</tr>\n";
  }
  return h + "</table>\n";
}

std::string Quarantined(const StatusSnapshot& s) {
  if (s.quarantined.empty()) return "<p class=\"none\">No task has been quarantined.</p>\n";
  // "workers": the one whose error quarantined the task, or every worker that lost a
  // lease of it (the workers a poison task killed).
  std::string h = "<table id=\"quarantined\">\n" +
                  Header({"when (UTC)", "job", "task", "workers", "attempts", "last error"});
  for (auto it = s.quarantined.rbegin(); it != s.quarantined.rend(); ++it)
    h += "<tr>" + Cell(Utc(it->at)) + Cell(std::to_string(it->job), "n") + Cell(HtmlEscape(it->task_id)) +
         Cell(HtmlEscape(it->worker)) + Cell(std::to_string(it->attempts), "n") + Cell(HtmlEscape(it->error), "err") +
         "</tr>\n";
  return h + "</table>\n";
}

std::string QuarantinedWorkers(const StatusSnapshot& s) {
  if (s.quarantined_workers.empty()) return "<p class=\"none\">No worker has been quarantined.</p>\n";
  // Caught by a spot-check: their lease requests are refused until the coordinator restarts.
  std::string h = "<table id=\"quarantined-workers\">\n" + Header({"worker", "why"});
  for (const auto& [worker, why] : s.quarantined_workers)
    h += "<tr>" + Cell(HtmlEscape(worker)) + Cell(HtmlEscape(why), "err") + "</tr>\n";
  return h + "</table>\n";
}

std::string PastJobs(const StatusSnapshot& s) {
  if (s.past.empty()) return "<p class=\"none\">No job has ended yet.</p>\n";
  std::string h = "<table id=\"past\">\n" + Header({"job", "kind", "state", "inputs", "created (UTC)", "updated (UTC)",
                                                    "progress", "best E (mm)", "error"});
  for (const auto& j : s.past) {
    const std::string state = JobStateName(j.state);
    h += "<tr>" + Cell(std::to_string(j.id), "n") + Cell(HtmlEscape(j.kind)) +
         Cell("<span class=\"state-" + state + "\">" + state + "</span>") + Cell(Inputs(j)) +
         Cell(HtmlEscape(j.created_at.substr(0, 19))) + Cell(HtmlEscape(j.updated_at.substr(0, 19))) +
         Cell(HtmlEscape(ProgressText(j))) + Cell(FormatE(j.best_e), "n") + Cell(HtmlEscape(j.error), "err") +
         "</tr>\n";
  }
  return h + "</table>\n";
}

}  // namespace

std::string UrlEncode(std::string_view s) {
  static const char* kHex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char ch : s) {
    if (std::isalnum(ch) || ch == '-' || ch == '_' || ch == '.' || ch == '~') {
      out += static_cast<char>(ch);
    } else {
      out += '%';
      out += kHex[ch >> 4];
      out += kHex[ch & 15];
    }
  }
  return out;
}

std::string RenderStatusPage(const StatusSnapshot& s, const std::string& token) {
  auto count = [&](JobState st) {
    auto it = s.jobs_by_state.find(st);
    return std::to_string(it == s.jobs_by_state.end() ? 0 : it->second);
  };
  const std::string query = token.empty() ? "" : "?token=" + UrlEncode(token);
  std::string h =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
      "<meta http-equiv=\"refresh\" content=\"" +
      std::to_string(kStatusRefreshSeconds) +
      "\">\n"
      "<title>wormdrag coordinator</title>\n<style>" +
      std::string(kStyle) +
      "</style></head>\n<body>\n"
      "<h1>wormdrag coordinator</h1>\n";
  h += "<p class=\"summary\" id=\"summary\">up " +
       Duration(std::chrono::duration<double>(s.now - s.started_at).count()) + " &middot; <b>" +
       std::to_string(s.active_workers) + "</b> workers active &middot; " + FormatFixed(s.sets_per_second, 1) +
       " sets/s &middot; " + std::to_string(s.tasks.queued) + " tasks queued, " + std::to_string(s.tasks.leased) +
       " leased</p>\n<p class=\"summary\">jobs: " + count(JobState::kRunning) + " running, " +
       count(JobState::kQueued) + " queued, " + count(JobState::kDone) + " done, " + count(JobState::kFailed) +
       " failed, " + count(JobState::kCancelled) +
       " cancelled &middot; tasks since start: " + std::to_string(s.tasks.leased_total) + " leased, " +
       std::to_string(s.tasks.expired_total) + " expired, " + std::to_string(s.tasks.quarantined_total) +
       " quarantined</p>\n";
  h += "<h2>Running and queued jobs</h2>\n" + ActiveJobs(s);
  h += "<h2>Workers</h2>\n" + Workers(s);
  h += "<h2>Quarantined tasks</h2>\n" + Quarantined(s);
  h += "<h2>Quarantined workers</h2>\n" + QuarantinedWorkers(s);
  h += "<h2>Past jobs</h2>\n" + PastJobs(s);
  h += "<footer>" + Utc(s.now) + " UTC &middot; reloads every " + std::to_string(kStatusRefreshSeconds) +
       " s &middot; <a href=\"/metrics" + HtmlEscape(query) + "\">metrics</a> (Prometheus)</footer>\n</body></html>\n";
  return h;
}

}  // namespace wormdrag::server
