// `wormdrag-server --http`: the status page and /metrics of a real coordinator, with
// real workers and a hand-driven fake worker (to expire a lease and quarantine a task),
// fetched over real HTTP and rendered by headless Chromium.
#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include <grpcpp/grpcpp.h>

#include "proto/rpc_util.h"
#include "tests/integration/process.h"
#include "wormdrag/v2/jobs.grpc.pb.h"
#include "wormdrag/v2/worker.grpc.pb.h"

namespace wormdrag {
namespace {

namespace fs = std::filesystem;
namespace v2 = wormdrag::v2;
using itest::FreePort;
using itest::Process;
using namespace std::chrono_literals;

const char* kToken = "status-test-token";

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// ------------------------------------------------------------------ Prometheus text

struct Family {
  std::string type;
  std::map<std::string, double> samples;  // "name{labels}" as written -> value
};

// Parses the text exposition format (0.0.4) strictly enough to catch what Prometheus
// rejects: metric and label names, quoted and escaped label values, numbers, one TYPE
// per family before its samples, a family's samples together, histogram buckets
// cumulative up to le="+Inf" = _count. Fails the test on the first error.
std::map<std::string, Family> ParseMetrics(const std::string& text) {
  std::map<std::string, Family> families;
  const std::regex type_re(R"(# TYPE ([a-zA-Z_:][a-zA-Z0-9_:]*) (counter|gauge|histogram|summary|untyped))");
  const std::regex help_re(R"(# HELP ([a-zA-Z_:][a-zA-Z0-9_:]*) .*)");
  const std::regex sample_re(
      R"(([a-zA-Z_:][a-zA-Z0-9_:]*)(\{(?:[a-zA-Z_][a-zA-Z0-9_]*="(?:[^"\\\n]|\\[\\"n])*",?)*\})? (\S+))");
  std::set<std::string> closed;
  std::string current;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    std::smatch m;
    if (line.empty()) continue;
    if (std::regex_match(line, m, type_re)) {
      EXPECT_EQ(families.count(m[1]), 0u) << "line " << n << ": second TYPE for " << m[1];
      families[m[1]].type = m[2];
      continue;
    }
    if (std::regex_match(line, m, help_re)) continue;
    if (!std::regex_match(line, m, sample_re)) {
      ADD_FAILURE() << "line " << n << " is not a sample: " << line;
      continue;
    }
    std::string family = m[1];
    for (const char* suffix : {"_bucket", "_sum", "_count"}) {
      const std::string base = family.substr(0, family.size() - std::min(family.size(), strlen(suffix)));
      if (family.size() > strlen(suffix) && family.compare(base.size(), std::string::npos, suffix) == 0 &&
          families.count(base) && families[base].type == "histogram")
        family = base;
    }
    EXPECT_TRUE(families.count(family)) << "line " << n << ": sample before its TYPE: " << line;
    if (family != current) {
      EXPECT_EQ(closed.count(family), 0u) << "line " << n << ": samples of " << family << " are not together";
      closed.insert(current);
      current = family;
    }
    const std::string v = m[3];
    double value = 0;
    if (v == "+Inf")
      value = INFINITY;
    else if (v == "-Inf")
      value = -INFINITY;
    else if (v == "NaN")
      value = NAN;
    else {
      size_t used = 0;
      value = std::stod(v, &used);
      EXPECT_EQ(used, v.size()) << "line " << n << ": bad value " << v;
    }
    families[family].samples[std::string(m[1]) + std::string(m[2])] = value;
  }
  for (auto& [name, f] : families) {
    if (f.type == "counter") {
      EXPECT_EQ(name.substr(name.size() - 6), "_total") << name;
      for (const auto& [s, v] : f.samples) EXPECT_GE(v, 0) << s;
    }
    if (f.type != "histogram") continue;
    double last = 0;
    for (const auto& [s, v] : f.samples)
      if (s.find("_bucket") != std::string::npos && s.find("+Inf") == std::string::npos) {
        EXPECT_GE(v, 0) << s;
        last = std::max(last, v);
      }
    const double inf = f.samples[name + "_bucket{le=\"+Inf\"}"];
    EXPECT_GE(inf, last) << name << ": buckets are cumulative";
    EXPECT_EQ(inf, f.samples[name + "_count"]) << name << ": le=+Inf is the count";
  }
  return families;
}

double Value(const std::map<std::string, Family>& m, const std::string& family, const std::string& sample = "") {
  auto f = m.find(family);
  if (f == m.end()) return -1;
  auto s = f->second.samples.find(sample.empty() ? family : sample);
  return s == f->second.samples.end() ? -1 : s->second;
}

// ------------------------------------------------------------------ fixture

class StatusPageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/wormdrag-status-XXXXXX";
    dir_ = mkdtemp(tmpl);
    address_ = "127.0.0.1:" + std::to_string(FreePort());
    http_port_ = FreePort();
  }
  void TearDown() override {
    workers_.clear();
    server_.reset();
    if (!HasFailure())
      fs::remove_all(dir_);
    else
      std::fprintf(stderr, "logs kept in %s\n", dir_.c_str());
  }

  void StartServer(std::vector<std::string> extra) {
    std::vector<std::string> argv = {WORMDRAG_SERVER_BIN,       "--listen", address_, "--db",
                                     dir_ + "/jobs.db",         "--token",  kToken,   "--http",
                                     std::to_string(http_port_)};
    argv.insert(argv.end(), extra.begin(), extra.end());
    server_ = std::make_unique<Process>(argv, dir_ + "/server.log");
    ASSERT_TRUE(WaitFor([&] { return Get("/metrics").status == 200; }, 30s)) << server_->Log();
  }
  Process& StartWorker(const std::string& id) {
    workers_.push_back(
        std::make_unique<Process>(std::vector<std::string>{WORMDRAG_WORKER_BIN, "--server", address_, "--token", kToken,
                                                           "--threads", "1", "--id", id},
                                  dir_ + "/" + id + ".log"));
    return *workers_.back();
  }

  static bool WaitFor(const std::function<bool()>& pred, std::chrono::seconds limit) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
      if (pred()) return true;
      std::this_thread::sleep_for(100ms);
    }
    return pred();
  }

  struct Reply {
    int status = 0;
    std::string body;
    httplib::Headers headers;
  };
  // GET over HTTP; auth: "bearer" (the token in a header), "query" (?token=), a wrong
  // token, or none.
  Reply Get(const std::string& path, const std::string& auth = "bearer") {
    httplib::Client cli("127.0.0.1", http_port_);
    cli.set_connection_timeout(5);
    cli.set_read_timeout(10);
    httplib::Headers h;
    std::string p = path;
    if (auth == "bearer") h.emplace("Authorization", std::string("Bearer ") + kToken);
    if (auth == "query") p += std::string(path.find('?') == std::string::npos ? "?" : "&") + "token=" + kToken;
    if (auth == "wrong") h.emplace("Authorization", "Bearer nope");
    auto r = cli.Get(p, h);
    if (!r) return {};
    return {r->status, r->body, r->headers};
  }
  std::map<std::string, Family> Metrics() {
    Reply r = Get("/metrics");
    EXPECT_EQ(r.status, 200);
    return ParseMetrics(r.body);
  }

  std::shared_ptr<grpc::Channel> Channel() { return grpc::CreateChannel(address_, grpc::InsecureChannelCredentials()); }
  // Submits the bundled example pair; `name1` replaces the first recording's name.
  int64_t Submit(int n_max, double t_max, const std::string& name1 = "L1.csv") {
    v2::SubmitJobRequest req;
    req.mutable_recording1()->set_name(name1);
    req.mutable_recording1()->set_content(ReadFile(std::string(WORMDRAG_SOURCE_DIR) + "/examples/data/L1.csv"));
    req.mutable_recording2()->set_name("L2.csv");
    req.mutable_recording2()->set_content(ReadFile(std::string(WORMDRAG_SOURCE_DIR) + "/examples/data/L2.csv"));
    req.mutable_options()->set_n_max(n_max);
    req.mutable_options()->set_t_max(t_max);
    req.mutable_options()->set_bootstrap_replicates(0);
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, kToken, 30);
    v2::SubmitJobResponse resp;
    grpc::Status st = v2::JobService::NewStub(Channel())->SubmitJob(&ctx, req, &resp);
    EXPECT_TRUE(st.ok()) << st.error_message();
    return resp.job_id();
  }
  v2::Job GetJob(int64_t id) {
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, kToken, 10);
    v2::GetJobRequest req;
    req.set_job_id(id);
    v2::Job j;
    EXPECT_TRUE(v2::JobService::NewStub(Channel())->GetJob(&ctx, req, &j).ok());
    return j;
  }
  // A worker driven by hand: leases one task (waiting for one up to 5 s).
  v2::Task Lease(const std::string& worker) {
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, kToken, 10);
    v2::LeaseTaskRequest req;
    req.set_worker_id(worker);
    req.set_threads(1);
    req.set_wait_ms(5000);
    v2::LeaseTaskResponse resp;
    EXPECT_TRUE(v2::WorkerService::NewStub(Channel())->LeaseTask(&ctx, req, &resp).ok());
    EXPECT_TRUE(resp.has_task()) << "no task to lease";
    return resp.task();
  }

  std::string dir_, address_;
  int http_port_ = 0;
  std::unique_ptr<Process> server_;
  std::vector<std::unique_ptr<Process>> workers_;
};

// ------------------------------------------------------------------ tests

// The page lists a worker as long as the scheduler's registry knows it: it leaves after
// 10 lease periods of silence (10 s with --lease-seconds 1), when the registry logs
// event=worker_forgotten, and not after a fixed time of its own.
TEST_F(StatusPageTest, SilentWorkerLeavesThePageWithTheRegistry) {
  StartServer({"--lease-seconds", "1"});
  // Taken before the call: the registry stamps the worker while serving it, so the
  // time after the call returns can be later than that stamp.
  const auto polled = std::chrono::steady_clock::now();
  {
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, kToken, 10);
    v2::LeaseTaskRequest req;
    req.set_worker_id("gone-worker");
    req.set_threads(1);
    v2::LeaseTaskResponse resp;
    ASSERT_TRUE(v2::WorkerService::NewStub(Channel())->LeaseTask(&ctx, req, &resp).ok());
  }
  EXPECT_NE(Get("/").body.find("gone-worker"), std::string::npos);
  ASSERT_TRUE(WaitFor([&] { return Get("/").body.find("gone-worker") == std::string::npos; }, 60s));
  EXPECT_GE(std::chrono::steady_clock::now() - polled, 10s);
  EXPECT_TRUE(WaitFor(
      [&] { return server_->Log().find("event=worker_forgotten worker=gone-worker") != std::string::npos; }, 10s))
      << server_->Log();
  EXPECT_NE(Get("/").body.find("No worker has called in the last 10 s"), std::string::npos);
}

TEST_F(StatusPageTest, MetricsCountersMove) {
  StartServer({"--lease-seconds", "1", "--max-attempts", "1"});
  auto m = Metrics();
  for (const char* c : {"wormdrag_tasks_leased_total", "wormdrag_tasks_expired_total",
                        "wormdrag_tasks_quarantined_total", "wormdrag_sets_simulated_total"})
    EXPECT_EQ(Value(m, c), 0) << c;
  for (const char* s : {"queued", "running", "done", "failed", "cancelled"})
    EXPECT_EQ(Value(m, "wormdrag_jobs", std::string("wormdrag_jobs{state=\"") + s + "\"}"), 0) << s;
  EXPECT_EQ(Value(m, "wormdrag_sqlite_commit_seconds", "wormdrag_sqlite_commit_seconds_count"), 0);

  // A lease that runs out, then a failure that quarantines the task (--max-attempts 1).
  const int64_t failing = Submit(3, 1);
  const v2::Task first = Lease("fake-worker");
  EXPECT_TRUE(WaitFor([&] { return Value(Metrics(), "wormdrag_tasks_expired_total") == 1; }, 30s));
  const v2::Task again = Lease("fake-worker");
  EXPECT_EQ(again.task_id(), first.task_id()) << "an expired task goes back to the front of its queue";
  {
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, kToken, 10);
    v2::ReportResultRequest req;
    req.set_worker_id("fake-worker");
    req.set_task_id(again.task_id());
    req.set_lease_id(again.lease_id());
    req.set_error("bogus <b>failure</b> & co");
    v2::ReportResultResponse resp;
    ASSERT_TRUE(v2::WorkerService::NewStub(Channel())->ReportResult(&ctx, req, &resp).ok());
  }
  EXPECT_TRUE(WaitFor([&] { return GetJob(failing).state() == v2::JOB_STATE_FAILED; }, 30s));
  m = Metrics();
  EXPECT_EQ(Value(m, "wormdrag_tasks_leased_total"), 2);
  EXPECT_EQ(Value(m, "wormdrag_tasks_expired_total"), 1);
  EXPECT_EQ(Value(m, "wormdrag_tasks_quarantined_total"), 1);
  EXPECT_EQ(Value(m, "wormdrag_task_reports_total"), 1);
  EXPECT_EQ(Value(m, "wormdrag_jobs", "wormdrag_jobs{state=\"failed\"}"), 1);
  const std::string page = Get("/").body;
  EXPECT_NE(page.find("bogus &lt;b&gt;failure&lt;/b&gt; &amp; co"), std::string::npos) << page;
  EXPECT_EQ(page.find("<b>failure"), std::string::npos);
  EXPECT_NE(page.find(again.task_id()), std::string::npos) << "quarantined task listed";

  // A real worker completes a job: sets, commits and its own series move.
  StartWorker("real-worker");
  const int64_t done = Submit(3, 1);
  EXPECT_TRUE(WaitFor([&] { return GetJob(done).state() == v2::JOB_STATE_DONE; }, 300s)) << GetJob(done).error();
  m = Metrics();
  EXPECT_GE(Value(m, "wormdrag_sets_simulated_total"), 256) << "at least the Phase 1 grid";
  EXPECT_GT(Value(m, "wormdrag_tasks_leased_total"), 2);
  EXPECT_GT(Value(m, "wormdrag_sets_per_second"), 0);
  EXPECT_GT(Value(m, "wormdrag_sqlite_commit_seconds", "wormdrag_sqlite_commit_seconds_count"), 0);
  EXPECT_GT(Value(m, "wormdrag_sqlite_commit_seconds", "wormdrag_sqlite_commit_seconds_sum"), 0);
  EXPECT_GT(Value(m, "wormdrag_sqlite_committed_results_total"), 0);
  EXPECT_EQ(Value(m, "wormdrag_jobs", "wormdrag_jobs{state=\"done\"}"), 1);
  EXPECT_GE(Value(m, "wormdrag_worker_sets_total", "wormdrag_worker_sets_total{worker=\"real-worker\"}"), 256);
  EXPECT_GE(
      Value(m, "wormdrag_worker_last_contact_seconds", "wormdrag_worker_last_contact_seconds{worker=\"real-worker\"}"),
      0);

  // Authentication: a header or the query, nothing else.
  EXPECT_EQ(Get("/metrics", "none").status, 401);
  EXPECT_EQ(Get("/metrics", "wrong").status, 401);
  EXPECT_EQ(Get("/", "none").status, 401);
  EXPECT_EQ(Get("/metrics", "query").status, 200);
  EXPECT_EQ(Get("/nothing-here").status, 404);
  Reply metrics = Get("/metrics");
  EXPECT_EQ(metrics.headers.find("Content-Type")->second, "text/plain; version=0.0.4; charset=utf-8");
}

// Chromium renders the page of a coordinator with a running job and two workers; the
// page shows the numbers `wormdrag watch` (live) and `wormdrag jobs show` (stored) show.
TEST_F(StatusPageTest, RunningJobAndTwoWorkersInChromium) {
  StartServer({});
  // Large enough to be still running while Chromium starts; cancelled at the end.
  const int64_t job = Submit(9, 2, "L1 <i>&amp;</i>.csv");
  Process& w1 = StartWorker("lab-node-1");
  Process& w2 = StartWorker("lab-node-2");
  auto worked = [&](const char* w) {
    return Value(Metrics(), "wormdrag_worker_sets_total",
                 std::string("wormdrag_worker_sets_total{worker=\"") + w + "\"}") > 0;
  };
  ASSERT_TRUE(WaitFor([&] { return worked("lab-node-1") && worked("lab-node-2"); }, 120s)) << server_->Log();

  // With both workers stopped the progress holds still: the page shows what GetJob (the
  // source of `watch`) says.
  w1.Signal(SIGSTOP);
  w2.Signal(SIGSTOP);
  bool same = false;
  std::string progress;
  for (int attempt = 0; attempt < 10 && !same; ++attempt) {
    std::this_thread::sleep_for(300ms);
    const v2::Job before = GetJob(job);
    const std::string page = Get("/").body;
    const v2::Job after = GetJob(job);
    progress = before.phase() + " " + std::to_string(before.sets_done()) + "/" + std::to_string(before.sets_total());
    same = before.sets_done() == after.sets_done() && before.phase() == after.phase() &&
           page.find(progress) != std::string::npos;
  }
  w1.Signal(SIGCONT);
  w2.Signal(SIGCONT);
  EXPECT_TRUE(same) << "the page does not show the live progress " << progress;

  Reply r = Get("/", "query");
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.headers.find("Content-Security-Policy")->second.rfind("default-src 'none';", 0), 0u);
  for (const char* banned : {"http://", "https://", "<script", "<link", "<img", "url(", "@import", "<iframe"})
    EXPECT_EQ(r.body.find(banned), std::string::npos) << banned;
  EXPECT_NE(r.body.find("L1 &lt;i&gt;&amp;amp;&lt;/i&gt;.csv"), std::string::npos) << "dataset name escaped";
  EXPECT_EQ(r.body.find("<i>"), std::string::npos);
  EXPECT_NE(r.body.find(">running<"), std::string::npos);
  EXPECT_NE(r.body.find("lab-node-1"), std::string::npos);
  EXPECT_NE(r.body.find("lab-node-2"), std::string::npos);
  EXPECT_NE(r.body.find("<b>2</b> workers active"), std::string::npos);

  // Headless Chromium, no host but this one reachable; the screenshot stays in the
  // build folder for a person to look at.
  const std::string png = std::string(WORMDRAG_BINARY_DIR) + "/status_page.png";
  fs::remove(png);
  const std::string url = "http://127.0.0.1:" + std::to_string(http_port_) + "/?token=" + kToken;
  Process chromium({"/usr/bin/chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                    "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
                    "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1",
                    "--user-data-dir=" + dir_ + "/chromium", "--screenshot=" + png, "--window-size=1200,900", url},
                   dir_ + "/chromium.log");
  int code = -1;
  ASSERT_TRUE(chromium.WaitFor(180s, &code)) << "chromium did not finish";
  EXPECT_EQ(code, 0) << chromium.Log();
  const std::string image = ReadFile(png);
  ASSERT_GT(image.size(), 24u) << "no screenshot: " << chromium.Log();
  EXPECT_EQ(image.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  auto be32 = [&](size_t at) {
    return (uint32_t(uint8_t(image[at])) << 24) | (uint32_t(uint8_t(image[at + 1])) << 16) |
           (uint32_t(uint8_t(image[at + 2])) << 8) | uint32_t(uint8_t(image[at + 3]));
  };
  EXPECT_EQ(be32(16), 1200u);
  EXPECT_EQ(be32(20), 900u);
  EXPECT_EQ(GetJob(job).state(), v2::JOB_STATE_RUNNING) << "the screenshot must show a running job";

  // Cancelled, the job moves to the past jobs with the numbers `wormdrag jobs show` prints.
  {
    grpc::ClientContext ctx;
    rpc::Prepare(&ctx, kToken, 10);
    v2::CancelJobRequest req;
    req.set_job_id(job);
    v2::CancelJobResponse resp;
    ASSERT_TRUE(v2::JobService::NewStub(Channel())->CancelJob(&ctx, req, &resp).ok());
  }
  Process show({WORMDRAG_CLI_BIN, "jobs", "show", std::to_string(job), "--server", address_, "--token", kToken},
               dir_ + "/show.log");
  ASSERT_EQ(show.Wait(), 0) << show.Log();
  std::smatch m;
  const std::string shown = show.Log();
  ASSERT_TRUE(std::regex_search(shown, m, std::regex(R"(progress: (\S+ \d+/\d+), best E (\S+) mm)"))) << shown;
  const std::string page = Get("/").body;
  const size_t past = page.find("id=\"past\"");
  ASSERT_NE(past, std::string::npos) << page;
  EXPECT_NE(page.find(m[1].str(), past), std::string::npos) << m[1] << " not on the page";
  EXPECT_NE(page.find(m[2].str(), past), std::string::npos) << m[2] << " not on the page";
  EXPECT_NE(page.find(">cancelled<", past), std::string::npos);
}

}  // namespace
}  // namespace wormdrag
