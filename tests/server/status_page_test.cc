// The status page, /metrics and their HTTP plumbing, without a coordinator: rendering
// of a hand-made snapshot (escaping of everything that comes from the store or a
// worker), the Prometheus text, address parsing, token checks and worker activity.
#include <gtest/gtest.h>

#include <regex>

#include "core/common/format.h"
#include "server/metrics_text.h"
#include "server/scheduler.h"
#include "server/status_http.h"
#include "server/status_page.h"
#include "server/worker_activity.h"
#include "tests/server/manual_clock.h"

namespace wormdrag::server {
namespace {

const char* kEvil = "<script>alert('x')</script> & \"more\"";

StatusSnapshot EvilSnapshot() {
  StatusSnapshot s;
  s.now = std::chrono::system_clock::now();
  s.started_at = s.now - std::chrono::seconds(3725);
  s.lease_seconds = 30;
  JobProgressView running;
  running.job.id = 7;
  running.job.state = JobState::kRunning;
  running.job.dataset_names = {kEvil, "worm2.csv"};
  running.job.phase = "phase1";
  running.job.sets_done = 120;
  running.job.sets_total = 625;
  running.job.best_e = 0.0123456;
  running.tasks = {3, 2, 10};
  running.sets_per_second = 88.26;
  running.eta_seconds = 95;
  s.active.push_back(running);
  JobRecord failed;
  failed.id = 6;
  failed.kind = "estimate";
  failed.state = JobState::kFailed;
  failed.dataset_names = {"a.csv", "b.csv"};
  failed.error = kEvil;
  failed.created_at = "2026-01-02T03:04:05.678Z";
  s.past.push_back(failed);
  s.jobs_by_state = {{JobState::kQueued, 0},
                     {JobState::kRunning, 1},
                     {JobState::kDone, 4},
                     {JobState::kFailed, 1},
                     {JobState::kCancelled, 0}};
  WorkerView w;
  w.id = kEvil;
  w.threads = 8;
  w.seconds_since_contact = 1.5;
  w.task = "t7-abc";
  w.sets_done = 1024;
  w.sets_per_second = 51.2;
  s.workers.push_back(w);
  s.active_workers = 1;
  s.quarantined.push_back({"t6-<b>", "w\"1", kEvil, 6, 3, s.now});
  s.quarantined_workers = {{"rogue<i>", kEvil}};
  s.tasks = {40, 38, 1, 1, 3, 2};
  s.commits.count = 4;
  s.commits.results = 38;
  s.commits.seconds_sum = 0.02;
  s.commits.le = {0, 1, 2, 3, 4, 4, 4, 4, 4, 4, 4};
  return s;
}

TEST(StatusPageTest, EscapesEveryStringFromTheStoreAndWorkers) {
  const std::string page = RenderStatusPage(EvilSnapshot(), "");
  EXPECT_EQ(page.find("<script"), std::string::npos) << page;
  EXPECT_EQ(page.find("t6-<b>"), std::string::npos);
  const std::string escaped = HtmlEscape(kEvil);
  EXPECT_EQ(escaped, "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;more&quot;");
  // Dataset name, worker id, job error, quarantine error and a quarantined worker's reason.
  size_t n = 0;
  for (size_t at = page.find(escaped); at != std::string::npos; at = page.find(escaped, at + 1)) ++n;
  EXPECT_EQ(n, 5u) << page;
  EXPECT_NE(page.find("rogue&lt;i&gt;"), std::string::npos);
  EXPECT_NE(page.find("t6-&lt;b&gt;"), std::string::npos);
  EXPECT_NE(page.find("w&quot;1"), std::string::npos);
}

TEST(StatusPageTest, ShowsTheNumbersTheCliShows) {
  const std::string page = RenderStatusPage(EvilSnapshot(), "");
  EXPECT_NE(page.find("phase1 120/625"), std::string::npos);  // as `wormdrag jobs` prints progress
  EXPECT_NE(page.find("0.012346"), std::string::npos);        // best E, 5 significant digits
  EXPECT_NE(page.find("88.3"), std::string::npos);            // sets/s
  EXPECT_NE(page.find("1 min 35 s"), std::string::npos);      // ETA
  EXPECT_NE(page.find("3 / 2 / 10"), std::string::npos);      // tasks queued / leased / done
  EXPECT_NE(page.find("up 1 h 02 min"), std::string::npos);
  EXPECT_NE(page.find("1 failed"), std::string::npos);
  EXPECT_NE(page.find("2026-01-02T03:04:05"), std::string::npos);  // as `wormdrag jobs list`
  EXPECT_NE(page.find("width:19.2%"), std::string::npos);          // 120 of 625
}

TEST(StatusPageTest, LoadsNothingFromTheNetwork) {
  const std::string page = RenderStatusPage(EvilSnapshot(), "t&k");
  for (const char* banned : {"http://", "https://", "<script", "<link", "<img", "url(", "@import", "<iframe"})
    EXPECT_EQ(page.find(banned), std::string::npos) << banned;
  // The token the page was opened with follows its link to /metrics, encoded.
  EXPECT_NE(page.find("href=\"/metrics?token=t%26k\""), std::string::npos) << page;
}

TEST(StatusPageTest, EmptyCoordinatorSaysSo) {
  StatusSnapshot s;
  s.now = s.started_at = std::chrono::system_clock::now();
  s.worker_forget_seconds = 300;
  const std::string page = RenderStatusPage(s, "");
  EXPECT_NE(page.find("No running or queued jobs"), std::string::npos);
  EXPECT_NE(page.find("No worker has called in the last 5 min 00 s"), std::string::npos) << page;
  EXPECT_NE(page.find("No task has been quarantined"), std::string::npos);
  EXPECT_NE(page.find("No worker has been quarantined"), std::string::npos);
}

TEST(MetricsTextTest, FamiliesSamplesAndEscapedLabels) {
  const std::string m = RenderMetrics(EvilSnapshot());
  EXPECT_NE(m.find("# TYPE wormdrag_tasks_expired_total counter\nwormdrag_tasks_expired_total 1\n"), std::string::npos);
  EXPECT_NE(m.find("wormdrag_jobs{state=\"done\"} 4\n"), std::string::npos);
  EXPECT_NE(m.find("wormdrag_sqlite_commit_seconds_bucket{le=\"0.001\"} 1\n"), std::string::npos);
  EXPECT_NE(m.find("wormdrag_sqlite_commit_seconds_bucket{le=\"+Inf\"} 4\n"), std::string::npos);
  EXPECT_NE(m.find("wormdrag_sqlite_commit_seconds_sum 0.02\n"), std::string::npos);
  EXPECT_NE(m.find("wormdrag_worker_sets_total{worker=\"<script>alert('x')</script> & \\\"more\\\"\"} 1024\n"),
            std::string::npos)
      << m;
  // Every line is a comment or `name{labels} value`.
  const std::regex sample(R"(^[a-zA-Z_:][a-zA-Z0-9_:]*(\{([a-zA-Z_][a-zA-Z0-9_]*="([^"\\]|\\.)*",?)*\})? \S+$)");
  std::istringstream in(m);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("# ", 0) != 0) { EXPECT_TRUE(std::regex_match(line, sample)) << line; }
  EXPECT_EQ(EscapeLabelValue("a\\b\"c\nd"), "a\\\\b\\\"c\\nd");
}

TEST(StatusHttpTest, ParsesPortOrHostAndPort) {
  StatusHttpOptions o;
  std::string error;
  ASSERT_TRUE(ParseHttpAddress("8080", &o, &error));
  EXPECT_EQ(o.host, "127.0.0.1");
  EXPECT_EQ(o.port, 8080);
  ASSERT_TRUE(ParseHttpAddress("0.0.0.0:9100", &o, &error));
  EXPECT_EQ(o.host, "0.0.0.0");
  EXPECT_EQ(o.port, 9100);
  ASSERT_TRUE(ParseHttpAddress("[::1]:80", &o, &error));
  EXPECT_EQ(o.host, "::1");
  for (const char* bad : {"", "http", "70000", ":80", "host:", "1.2.3.4:-1"}) {
    EXPECT_FALSE(ParseHttpAddress(bad, &o, &error)) << bad;
    EXPECT_NE(error.find("--http"), std::string::npos);
  }
}

TEST(StatusHttpTest, TokenInHeaderOrQuery) {
  EXPECT_TRUE(HttpAuthorized("", "", ""));
  EXPECT_TRUE(HttpAuthorized("Bearer s3cret", "", "s3cret"));
  EXPECT_TRUE(HttpAuthorized("", "s3cret", "s3cret"));
  EXPECT_FALSE(HttpAuthorized("", "", "s3cret"));
  EXPECT_FALSE(HttpAuthorized("Bearer s3cre", "s3cret2", "s3cret"));
  EXPECT_FALSE(HttpAuthorized("s3cret", "", "s3cret"));
}

TEST(WorkerActivityTest, CountsReportedSetsPerWorker) {
  WorkerActivity a(SchedulerOptions().WorkerForgetAfter());
  a.Polled("w1", 4);
  a.Polled("w2", 2);
  a.Leased("w1", "t1", 128);
  a.Leased("w2", "t2", 64);
  auto ws = a.Workers();
  ASSERT_EQ(ws.size(), 2u);
  for (const auto& w : ws) EXPECT_FALSE(w.task.empty());
  a.Reported("w1", "t1", false, 999);  // the leased task's size counts, not the fallback
  a.Reported("w2", "t2", true, 64);    // a failure simulates nothing
  a.Reported("w2", "t9", false, 8);    // a task it was not known to hold
  EXPECT_EQ(a.sets_total(), 136);
  ws = a.Workers();
  ASSERT_EQ(ws.size(), 2u);
  for (const auto& w : ws) {
    EXPECT_TRUE(w.task.empty()) << w.id;
    if (w.id == "w1") {
      EXPECT_EQ(w.threads, 4);
      EXPECT_EQ(w.sets_done, 128);
      EXPECT_EQ(w.tasks_done, 1);
    } else {
      EXPECT_EQ(w.sets_done, 8);
      EXPECT_EQ(w.tasks_failed, 1);
    }
  }
}

// The list forgets a worker when the scheduler's registry does, after
// worker_forget_leases (10) lease periods of silence: 20 s with 2 s leases.
TEST(WorkerActivityTest, ForgetsWorkersAfterTheRegistrysLeasePeriods) {
  SchedulerOptions so;
  so.lease_seconds = 2;
  ASSERT_EQ(so.WorkerForgetAfter(), std::chrono::seconds(20));
  ManualClock clock;
  WorkerActivity a(so.WorkerForgetAfter(), &clock);
  EXPECT_EQ(a.forget_after(), std::chrono::seconds(20));
  a.Polled("w1", 1);
  clock.Advance(std::chrono::seconds(15));
  a.Heartbeat("w2");
  clock.Advance(std::chrono::seconds(5));
  EXPECT_EQ(a.Workers().size(), 2u) << "w1, silent for exactly 20 s, is still listed";
  clock.Advance(std::chrono::milliseconds(1));
  auto ws = a.Workers();
  ASSERT_EQ(ws.size(), 1u);
  EXPECT_EQ(ws[0].id, "w2");
  a.Polled("w1", 1);  // a forgotten worker that calls again is listed afresh
  clock.Advance(std::chrono::seconds(16));
  ws = a.Workers();
  ASSERT_EQ(ws.size(), 1u);
  EXPECT_EQ(ws[0].id, "w1");
  EXPECT_EQ(ws[0].tasks_done, 0);
}

}  // namespace
}  // namespace wormdrag::server
