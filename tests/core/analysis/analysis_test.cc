// Tests of core/analysis: friction forces against the simulator's own wrench, E
// slices from the store, and the HTML report (self-contained; a headless-browser
// screenshot that is not blank).
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/analysis/forces.h"
#include "core/analysis/job_analysis.h"
#include "core/analysis/report.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"

namespace wormdrag {
namespace {

// ---- forces ----

Result<ShapeDrive> PatternDrive(double fps, double duration) {
  std::vector<double> times;
  for (int i = 0; i <= static_cast<int>(std::lround(duration * fps)); ++i) times.push_back(i / fps);
  const JointPattern pat = Locomotion(2);
  BodyModel body;
  body.length = 1.0;
  ShapeDriveOptions o;
  o.substeps = 2;
  return ShapeDrive::FromFunction(
      times, [&](double t, Shape* q, Shape* qd) { pat.Evaluate(t, q, qd); }, body, Pose{}, o);
}

TEST(Forces, HeadFrameForcesSumToTheSimulatorsWrench) {
  auto drive = PatternDrive(50, 0.5);
  ASSERT_TRUE(drive.ok()) << drive.status().ToString();
  const Coefficients c{0.6, 0.2, 0.005, 0.002};
  const JointPattern pat = Locomotion(2);
  for (int knot : {0, 7, 30}) {
    const auto& g = drive->knots()[knot];
    Shape q, qd;
    pat.Evaluate(g.t, &q, &qd);
    const std::array<double, 3> xi = {0.03, -0.01, 0.2};
    std::array<Vec2, kNumLinks> f, v;
    std::array<double, kNumLinks> ft, fn;
    HeadFrameLinkForces(g, q, c, 1e-4, xi, &f, &v, &ft, &fn);
    Vec2 sum = Vec2::Zero();
    double moment = 0;
    const Points p = HeadFramePoints(q, drive->body().link_length());
    for (int k = 0; k < kNumLinks; ++k) {
      sum += f[k];
      const Vec2 ck = 0.5 * (p[k] + p[k + 1]);
      moment += ck.x() * f[k].y() - ck.y() * f[k].x();
      EXPECT_NEAR(f[k].norm(), std::hypot(ft[k], fn[k]), 1e-12);
    }
    const auto w = FrictionWrench(g, c, 1e-4, xi);
    EXPECT_NEAR(sum.x(), w[0], 1e-12);
    EXPECT_NEAR(sum.y(), w[1], 1e-12);
    EXPECT_NEAR(moment, w[2], 1e-12);
  }
}

TEST(Forces, QuasiStaticBalanceAndScaleProportionality) {
  auto drive = PatternDrive(50, 1.0);
  ASSERT_TRUE(drive.ok());
  SimOptions o;
  o.solver = Solver::kQuasiStatic;
  const Coefficients c{0.6, 0.2, 0.005, 0.002};
  auto f1 = ComputeLinkForces(*drive, c, o);
  auto f2 = ComputeLinkForces(*drive, c.Scaled(2), o);
  ASSERT_TRUE(f1.ok()) << f1.status().ToString();
  ASSERT_TRUE(f2.ok());
  ASSERT_EQ(f1->t.size(), 51u);
  EXPECT_GT(f1->rms_link, 1e-3);
  // No inertia: the friction on the body balances at every frame.
  for (size_t i = 0; i < f1->t.size(); ++i) {
    EXPECT_LT(f1->net[i].norm(), 1e-6 * f1->magnitude_sum[i]) << i;
    EXPECT_LT(std::fabs(f1->net_moment[i]), 1e-6 * f1->magnitude_sum[i]) << i;
  }
  // Same path, forces × 2 (docs/conventions.md §2).
  EXPECT_NEAR(f2->rms_link, 2 * f1->rms_link, 1e-6 * f1->rms_link);
  EXPECT_NEAR(f2->mean_thrust, 2 * f1->mean_thrust, 1e-6 * f1->mean_thrust);
  EXPECT_NEAR(f2->mean_power, 2 * f1->mean_power, 1e-6 * f1->mean_power);
  // Friction dissipates: power ≥ 0; propulsion needs thrust.
  for (double p : f1->power) EXPECT_GE(p, -1e-12);
  EXPECT_GT(f1->mean_thrust, 0);
  EXPECT_NE(LinkForcesCsv(*f1).find("fx13,fy13,ft13,fn13,net_x"), std::string::npos);
}

TEST(Forces, InertialNetForceIsTheMomentumChangeAndTiny) {
  auto drive = PatternDrive(50, 1.0);
  ASSERT_TRUE(drive.ok());
  SimOptions o;  // inertial, the paper's masses
  auto f = ComputeLinkForces(*drive, {0.6, 0.2, 0.005, 0.002}, o);
  ASSERT_TRUE(f.ok());
  EXPECT_LT(f->rms_net, 1e-3 * f->rms_link);
}

// ---- jobs, slices, report ----

std::string Recording(int loco, const Coefficients& c) {
  RecordingSpec spec;
  spec.fps = 30;
  spec.duration = 1;
  auto k = GenerateRecording(Locomotion(loco), c, SimOptions{}, spec);
  EXPECT_TRUE(k.ok());
  return FormatKinematics(*k);
}

class ReportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = ::testing::TempDir() + "/analysis_test_" + std::to_string(::getpid());
    std::filesystem::create_directories(dir_);
    auto s = JobStore::Open(dir_ + "/jobs.db");
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    store_ = s->release();
    const Coefficients truth{0.4, 0.2, 0.004, 0.002};
    JobOptions o;
    o.estimate.eval.t_max = 1;
    o.estimate.search.n_max = 3;
    o.estimate.search.d_mu = 0.25;
    o.estimate.search.d_eta = 0.0025;
    o.estimate.search.d1 = 5;
    o.estimate.search.d2 = 2;
    o.estimate.phase3.scale_rounds = 1;
    o.estimate.search.abandon = false;  // the E slices read every grid point's E
    o.smoothing = SmoothingMethod::kNone;
    o.bootstrap.replicates = 0;
    bool reused = false;
    auto id = SubmitEstimateJob(
        *store_, {JobInput{"L1.csv", Recording(1, truth)}, JobInput{"L2.csv", Recording(2, truth)}}, o, false, &reused);
    ASSERT_TRUE(id.ok()) << id.status().ToString();
    ASSERT_TRUE(RunEstimateJob(*store_, *id, LocalEvaluatorFactory(2)).ok());
    done_ = *id;
    o.estimate.eval.t_max = 0.5;  // a second job, left queued
    auto q = SubmitEstimateJob(
        *store_, {JobInput{"L1.csv", Recording(1, truth)}, JobInput{"L2.csv", Recording(2, truth)}}, o, false, &reused);
    ASSERT_TRUE(q.ok());
    queued_ = *q;
  }
  static void TearDownTestSuite() {
    delete store_;
    std::filesystem::remove_all(dir_);
  }
  static inline std::string dir_;
  static inline JobStore* store_ = nullptr;
  static inline int64_t done_ = 0, queued_ = 0;
};

TEST_F(ReportTest, LoadDoneJobErrors) {
  auto missing = LoadDoneJob(*store_, 999);
  EXPECT_EQ(missing.status().code(), Status::Code::kNotFound);
  auto queued = LoadDoneJob(*store_, queued_);
  EXPECT_EQ(queued.status().code(), Status::Code::kFailedPrecondition);
  EXPECT_NE(queued.status().message().find("queued"), std::string::npos);
  auto ok = LoadDoneJob(*store_, done_);
  ASSERT_TRUE(ok.ok()) << ok.status().ToString();
  EXPECT_GT(ok->e_mm, 0);
  EXPECT_LT(ok->e_percent, 1.0);  // a consistent synthetic pair is fitted closely
}

TEST_F(ReportTest, PhaseOneSlicesThroughTheOptimum) {
  auto job = store_->GetJob(done_);
  ASSERT_TRUE(job.ok());
  auto opt = JobOptionsFromJson(job->options_json);
  ASSERT_TRUE(opt.ok());
  auto s = PhaseOneSlices(*store_, *job, opt->estimate.search);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->total, 256);
  EXPECT_GT(s->evaluated, 200);  // sets with zero friction in one direction cannot be simulated
  ASSERT_EQ(s->slices.size(), 6u);
  // The best stored phase-1 value is the optimum and appears in every slice at its cell.
  auto best = store_->Evaluations(done_, 1, 1);
  ASSERT_TRUE(best.ok());
  ASSERT_EQ(best->size(), 1u);
  EXPECT_DOUBLE_EQ(s->e_opt, (*best)[0].e);
  const auto oa = s->optimum.AsArray();
  for (const auto& sl : s->slices) {
    const int ia = static_cast<int>(std::lround(oa[sl.a] / (sl.a < 2 ? 0.25 : 0.0025)));
    const int ib = static_cast<int>(std::lround(oa[sl.b] / (sl.b < 2 ? 0.25 : 0.0025)));
    EXPECT_DOUBLE_EQ(sl.e[ia * sl.vb.size() + ib], s->e_opt);
    for (double v : sl.e) {
      if (std::isfinite(v)) { EXPECT_GE(v, s->e_opt); }
    }
  }
}

TEST_F(ReportTest, TrajectoriesOfScaledSetsCoincide) {
  auto job = LoadDoneJob(*store_, done_);
  ASSERT_TRUE(job.ok());
  const Coefficients c = job->estimate;
  auto tr = CompareCoefficientSets(*job->pair, {c, c.Scaled(3), {c.mu_n * 4, c.mu_t, c.eta_n, c.eta_t}});
  ASSERT_TRUE(tr.ok()) << tr.status().ToString();
  EXPECT_NEAR(tr->e_mm[0], job->e_mm, 1e-9);
  EXPECT_EQ(tr->distance_to_first_mm[0], 0);
  // Same ratios: the same path up to inertia (~1e-5 BL); other ratios: another path.
  EXPECT_LT(tr->distance_to_first_mm[1], 1e-4 * tr->body_length);
  EXPECT_GT(tr->distance_to_first_mm[2], 1e-3 * tr->body_length);
}

std::string WriteReport(const std::string& dir, int64_t id, JobStore& store, const std::string& diagnosis) {
  auto d = CollectReport(store, id);
  EXPECT_TRUE(d.ok()) << d.status().ToString();
  if (!d.ok()) return "";
  d->diagnosis_json = diagnosis;
  const std::string html = RenderReportHtml(*d);
  const std::string path = dir + "/report.html";
  EXPECT_TRUE(WriteFileAtomically(path, html).ok());
  return path;
}

TEST_F(ReportTest, ReportIsSelfContained) {
  const std::string diag =
      R"({"verdict":"gap_offset","confidence":"tentative","explanation":"the dropped frames","base_e_mm":0.01,)"
      R"("where":[{"name":"by point","units":"mm","cells":[{"label":"joint 3","value":0.01,"noise_hi":0.004}]}],)"
      R"("which":{"effects":[{"name":"lag","improvement":0.25,"threshold":0.1,"significant":true}]}})";
  const std::string path = WriteReport(dir_, done_, *store_, diag);
  auto html = ReadFile(path);
  ASSERT_TRUE(html.ok());
  for (const char* must :
       {"<!DOCTYPE html>", "Measured and simulated paths", "what the data determine", "scale ray", "Phase 1 grid",
        "Friction forces", "gap_offset (tentative)", "the dropped frames", "K<sub>μ</sub>",
        // The noise tick of the "where" bars and the effects' table.
        "noise bound</title>", "<td class=\"l\">lag</td>"})
    EXPECT_NE(html->find(must), std::string::npos) << must;
  // Offline: no scripts, no external resources.
  for (const char* banned : {"<script", "<link", "src=", "href=", "@import", "url(http", "https:"})
    EXPECT_EQ(html->find(banned), std::string::npos) << banned;
  // Every xmlns is the SVG namespace identifier, not a fetched resource.
  size_t n_svg = 0;
  for (size_t pos = 0; (pos = html->find("<svg", pos)) != std::string::npos; ++pos) ++n_svg;
  EXPECT_GE(n_svg, 2u + 1 + 6 + 1);  // paths, distance, scale profile, 6 slices, forces
}

TEST_F(ReportTest, HeadlessBrowserScreenshotIsNotBlank) {
  if (std::system("command -v chromium > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "chromium is not installed (apt-get install -y chromium): the report is not rendered";
  const std::string path = WriteReport(dir_, done_, *store_, "");
  ASSERT_FALSE(path.empty());
  const std::string png = dir_ + "/report.png", profile = dir_ + "/chromium-profile";
  std::filesystem::create_directories(profile);
  const std::string cmd =
      "chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking "
      "--disable-component-update --disable-sync --hide-scrollbars --user-data-dir=" +
      profile + " --screenshot=" + png + " --window-size=1280,2000 file://" + std::filesystem::absolute(path).string() +
      " > " + dir_ + "/chromium.log 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_EQ(rc, 0) << "chromium failed; see " << dir_ << "/chromium.log";
  ASSERT_TRUE(std::filesystem::exists(png));
  cv::Mat img = cv::imread(png, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img.empty()) << "not a readable PNG: " << png;
  EXPECT_EQ(img.cols, 1280);
  cv::Scalar mean, sd;
  cv::meanStdDev(img, mean, sd);
  EXPECT_GT(sd[0], 15) << "the screenshot is (nearly) uniform: mean " << mean[0];
  // Not all white: a real share of the page is drawn (text, lines, heat maps).
  const double dark = cv::countNonZero(img < 200) / static_cast<double>(img.total());
  EXPECT_GT(dark, 0.02);
  if (const char* keep = std::getenv("WORMDRAG_KEEP_SCREENSHOT"))
    std::filesystem::copy_file(png, keep, std::filesystem::copy_options::overwrite_existing);
}

}  // namespace
}  // namespace wormdrag
