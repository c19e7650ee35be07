// The wormdrag command as a user runs it: real process, real files, real SQLite store.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "core/io/frame_quality.h"
#include "core/io/kinematics.h"
#include "core/store/job_store.h"
#include "run_wormdrag.h"

namespace {

using wormdrag::testing::Outcome;

Outcome Wormdrag(const std::string& args) {
  return wormdrag::testing::RunWormdrag(args);
}

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/cli_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::system(("rm -rf " + dir_ + " && mkdir -p " + dir_).c_str());
  }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  void Generate() {
    for (auto [name, pattern] : {std::pair{"L1.csv", "0.4,0"}, std::pair{"L2.csv", "0.6,0"}}) {
      const Outcome r = Wormdrag(std::string("generate --pattern ") + pattern +
                                 " --coef 0.5,0.2,0.005,0.002 --fps 60 --duration 1 --out " + Path(name));
      ASSERT_EQ(r.code, 0) << r.out;
    }
  }
  std::string dir_;
};

TEST_F(Cli, HelpAndUnknownCommands) {
  EXPECT_EQ(Wormdrag("--help").code, 0);
  for (const char* c : {"simulate", "generate", "estimate", "jobs", "results", "verify", "track", "import"}) {
    const Outcome r = Wormdrag(std::string(c) + " --help");
    EXPECT_EQ(r.code, 0) << c;
    EXPECT_NE(r.out.find("usage: wormdrag " + std::string(c)), std::string::npos) << c;
  }
  const Outcome bad = Wormdrag("frobnicate");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.out.find("unknown command 'frobnicate'"), std::string::npos);
  const Outcome opt = Wormdrag("simulate --nope 1");
  EXPECT_EQ(opt.code, 2);
  EXPECT_NE(opt.out.find("unknown option --nope"), std::string::npos);
}

TEST_F(Cli, DiagnoseRejectsAnUnknownChoice) {
  const Outcome r = Wormdrag("diagnose a.csv b.csv --unestimated both");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--unestimated must be skip or name, not 'both'"), std::string::npos) << r.out;
  const Outcome help = Wormdrag("diagnose --help");
  EXPECT_NE(help.out.find("--unestimated skip|name"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("--smoothing METHOD"), std::string::npos) << help.out;
  const Outcome smoothing = Wormdrag("diagnose a.csv b.csv --smoothing spline");
  EXPECT_EQ(smoothing.code, 2);
  EXPECT_NE(smoothing.out.find("--smoothing: "), std::string::npos) << smoothing.out;
  EXPECT_NE(smoothing.out.find("spline"), std::string::npos) << smoothing.out;
  const Outcome both = Wormdrag("diagnose a.csv b.csv --smoothing auto --lowpass 3");
  EXPECT_EQ(both.code, 2);
  EXPECT_NE(both.out.find("--lowpass goes with --smoothing lowpass, not auto"), std::string::npos) << both.out;
  EXPECT_NE(help.out.find("--false-alarm-rate A"), std::string::npos) << help.out;
  const Outcome rate = Wormdrag("diagnose a.csv b.csv --false-alarm-rate 1.5");
  EXPECT_EQ(rate.code, 2);
  EXPECT_NE(rate.out.find("false_alarm_rate must lie between 0 and 1"), std::string::npos) << rate.out;
}

TEST_F(Cli, SimulateWritesEveryFrameAndRejectsBadInput) {
  Generate();
  const Outcome ok = Wormdrag("simulate --kinematics " + Path("L1.csv") + " --coef 0.5,0.2,0.005,0.002 --out " +
                              Path("sim.csv"));
  ASSERT_EQ(ok.code, 0) << ok.out;
  std::ifstream in(Path("sim.csv"));
  int rows = 0;
  for (std::string line; std::getline(in, line);) rows += !line.empty() && line[0] != '#' && line[0] != 't';
  EXPECT_EQ(rows, 61);
  const Outcome coef = Wormdrag("simulate --kinematics " + Path("L1.csv") + " --coef 0.5,x,0,0 --out " + Path("s.csv"));
  EXPECT_EQ(coef.code, 2);
  EXPECT_NE(coef.out.find("value 2 (mu_t) is not a number"), std::string::npos) << coef.out;
  std::ofstream(Path("bad.csv")) << "# fps: 10\nt,x0,y0,x1,y1,x2,y2\n0,0,0,1,0,2,0\n0.1,0,0,1,zero,2,0\n";
  const Outcome file = Wormdrag("simulate --kinematics " + Path("bad.csv") + " --coef 1,1,0,0 --out " + Path("s.csv"));
  EXPECT_EQ(file.code, 2);
  EXPECT_NE(file.out.find("bad.csv:4: column 5 (y1): not a number 'zero'"), std::string::npos) << file.out;
  const Outcome singular = Wormdrag("simulate --solver quasi-static --kinematics " + Path("L1.csv") +
                                    " --coef 0.5,0,0.01,0 --out " + Path("s.csv"));
  EXPECT_NE(singular.code, 0);
  EXPECT_NE(singular.out.find("singular"), std::string::npos) << singular.out;
  EXPECT_FALSE(std::ifstream(Path("s.csv")).good());  // nothing written
}

TEST_F(Cli, EstimateStoresJobsAndReusesThem) {
  Generate();
  const std::string common = Path("L1.csv") + " " + Path("L2.csv") + " --db " + Path("jobs.db") +
                             " --n-max 3 --d-mu 0.2 --d-eta 0.002 --d1 5 --d2 2 --t-max 1 --lowpass 0 --bootstrap 0";
  const Outcome first = Wormdrag("estimate " + common + " --json");
  ASSERT_EQ(first.code, 0) << first.out;
  EXPECT_NE(first.out.find("\"identifiability\""), std::string::npos);
  const Outcome again = Wormdrag("estimate " + common);
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_NE(again.out.find("same inputs and options as job 1"), std::string::npos) << again.out;
  EXPECT_NE(again.out.find("K_mu = mu_n/mu_t"), std::string::npos);
  // Phases 1-2 report the sets abandoned early and the knots simulated of the full count.
  EXPECT_NE(again.out.find(" abandoned, knots "), std::string::npos) << again.out;
  const Outcome list = Wormdrag("jobs list --db " + Path("jobs.db"));
  EXPECT_NE(list.out.find("done"), std::string::npos) << list.out;
  const Outcome csv = Wormdrag("results 1 --db " + Path("jobs.db") + " --phase 1 --top 5 --format csv");
  ASSERT_EQ(csv.code, 0) << csv.out;
  EXPECT_EQ(csv.out.rfind("phase,mu_n,mu_t,eta_n,eta_t,E_mm\n", 0), 0u);
  // Best first.
  double prev = 0;
  int rows = 0;
  size_t pos = csv.out.find('\n') + 1;
  while (pos < csv.out.size()) {
    const size_t end = csv.out.find('\n', pos);
    const std::string line = csv.out.substr(pos, end - pos);
    const double e = std::stod(line.substr(line.rfind(',') + 1));
    EXPECT_GE(e, prev);
    prev = e;
    ++rows;
    pos = end + 1;
  }
  EXPECT_EQ(rows, 5);
  const Outcome missing = Wormdrag("results 42 --db " + Path("jobs.db"));
  EXPECT_NE(missing.code, 0);
  EXPECT_NE(missing.out.find("42"), std::string::npos) << missing.out;
}

// --min-quality drops the frames the tracker's quality file marks as poor before the job
// is stored; without the quality file the command names the file it looked for.
TEST_F(Cli, MinQualityMarksPoorFramesMissing) {
  using wormdrag::FrameQuality, wormdrag::JobStore;
  Generate();
  for (const char* name : {"L1", "L2"}) {
    auto k = wormdrag::ReadKinematics(Path(std::string(name) + ".csv"));
    ASSERT_TRUE(k.ok()) << k.status().ToString();
    std::vector<FrameQuality> q;
    for (size_t f = 0; f < k->frames.size(); ++f)
      q.push_back({static_cast<int>(f), k->frames[f].t, "valid", f % 10 == 5 ? 0.4 : 0.9});
    ASSERT_TRUE(wormdrag::WriteFrameQuality(q, Path(std::string(name) + ".quality.csv")).ok());
  }
  const std::string common = Path("L1.csv") + " " + Path("L2.csv") + " --db " + Path("jobs.db") +
                             " --n-max 2 --d-mu 0.2 --d-eta 0.002 --d1 5 --d2 5 --t-max 1 --bootstrap 0";
  const Outcome r = Wormdrag("estimate " + common + " --min-quality 0.5");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("L1.csv: 6 frame(s) with quality below 0.5 marked missing"), std::string::npos) << r.out;
  auto store = JobStore::Open(Path("jobs.db"));
  ASSERT_TRUE(store.ok());
  auto job = (*store)->GetJob(1);
  ASSERT_TRUE(job.ok());
  auto stored = (*store)->GetDataset(job->dataset_hashes[0]);
  ASSERT_TRUE(stored.ok()) << stored.status().ToString();
  auto k = wormdrag::ParseKinematics(stored->content, "stored");
  ASSERT_TRUE(k.ok());
  EXPECT_FALSE(k->frames[5].valid);
  EXPECT_TRUE(k->frames[6].valid);
  std::filesystem::remove(Path("L2.quality.csv"));
  const Outcome missing = Wormdrag("estimate " + common + " --min-quality 0.5");
  EXPECT_EQ(missing.code, 2) << missing.out;
  EXPECT_NE(missing.out.find("L2.quality.csv"), std::string::npos) << missing.out;
}

TEST_F(Cli, RejectedEstimateStoresNothing) {
  Generate();
  std::ofstream(Path("short.csv")) << "# fps: 10\nt,x0,y0,x1,y1,x2,y2\n0,0,0,1,0,2,0\n0.1,0,0,1,0.1,2,0\n";
  const Outcome r = Wormdrag("estimate " + Path("L1.csv") + " " + Path("short.csv") + " --db " + Path("jobs.db") +
                             " --t-max 1 --n-max 3 --lowpass 0");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("short.csv: the recording is 0.1 s long, shorter than t_max = 1 s"), std::string::npos) << r.out;
  const Outcome opts = Wormdrag("estimate " + Path("L1.csv") + " " + Path("L2.csv") + " --db " + Path("jobs.db") +
                                " --d-mu -0.1");
  EXPECT_EQ(opts.code, 2);
  EXPECT_NE(opts.out.find("d_mu"), std::string::npos) << opts.out;
  const Outcome list = Wormdrag("jobs list --db " + Path("jobs.db"));
  EXPECT_EQ(list.out.find("estimate "), std::string::npos) << list.out;  // no job rows
}

TEST_F(Cli, VerifyRecoversAPresetSet) {
  const Outcome r = Wormdrag("verify --sets 6 --n-max 4 --t-max 1 --fps 60 --out " + dir_);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("F6   L3+L4"), std::string::npos) << r.out;
  std::ifstream csv(Path("verify.csv"));
  std::string header, row;
  std::getline(csv, header);
  std::getline(csv, row);
  EXPECT_EQ(row.rfind("F6,L3+L4,", 0), 0u) << row;
}

// Noisy recordings are smoothed as `estimate` smooths them; a ratio whose estimate is
// 0/0 is "undefined" in the table and an empty cell in verify.csv, never nan.
TEST_F(Cli, VerifyWithNoiseSmoothsAsEstimateAndPrintsNoNan) {
  // F1 at this noise fits η_n = η_t = 0.
  const Outcome r = Wormdrag("verify --sets 1 --n-max 3 --t-max 1 --fps 60 --noise 0.005 --out " + dir_);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("F1   L1+L2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(",undefined,"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
  std::ifstream csv(Path("verify.csv"));
  const std::string written((std::istreambuf_iterator<char>(csv)), std::istreambuf_iterator<char>());
  EXPECT_NE(written.find("F1,L1+L2,"), std::string::npos) << written;
  EXPECT_EQ(written.find("nan"), std::string::npos) << written;
  for (const char* bad : {"--sets 1,x", "--sets 11", "--smoothing median", "--seed -1"}) {
    const Outcome e = Wormdrag(std::string("verify ") + bad);
    EXPECT_EQ(e.code, 2) << bad << "\n" << e.out;
  }
}

// A CeleST segmentation (two worms, 20 frames, bodies of 12 points 5 px apart, zigzagging by
// 1 px, moving head-first along x by 1.5 px a frame; every other frame written tail first) with its fileDB.xml beside
// it.
void WriteCelestSample(const std::string& dir) {
  std::ofstream segm(dir + "/wormSegm_SampleT.txt");
  segm << "format %s_%02d_%s_%04d\nblock 9\nworms 2\nframes 20\nprecision 2\n";
  for (int w = 1; w <= 2; ++w)
    for (int f = 1; f <= 20; ++f) {
      char head[32];
      std::snprintf(head, sizeof head, "worm %02d frame %04d\n", w, f);
      std::string x = "x ", y = "y ", wd = "w ";
      for (int i = 0; i < 12; ++i) {
        const int j = f % 2 ? i : 11 - i;
        x += std::to_string(10000 + 150 * f - 500 * j) + ",";
        y += std::to_string(20000 * w + 100 * (j % 2)) + ",";
        wd += "300,";
      }
      segm << head << x << "\n" << y << "\n" << wd << "\nt 6000,\ng 5500,\nm 0,\nl 0,\no 0,\n";
    }
  std::ofstream(dir + "/fileDB.xml")
      << "<?xml version=\"1.0\"?>\n<sequences_database>\n  <sequence number=\"1\">\n"
         "    <feature class=\"char\" name=\"name\">SampleT</feature>\n"
         "    <feature class=\"double\" name=\"frames_per_second\" precision=\"4\">200000</feature>\n"
         "    <feature class=\"double\" name=\"mm_per_pixel\" precision=\"4\">200</feature>\n"
         "  </sequence>\n</sequences_database>\n";
}

TEST_F(Cli, ImportsOneWormOfACelestFile) {
  WriteCelestSample(dir_);
  const std::string segm = Path("wormSegm_SampleT.txt");
  const Outcome ok = Wormdrag("import " + segm + " --worm 2 --out " + Path("k.csv"));
  ASSERT_EQ(ok.code, 0) << ok.out;
  // Travel: 19 frames × 1.5 px over a body of 11 × √(5² + 1²) = 56.1 px.
  EXPECT_NE(ok.out.find("worm 2: calibration 0.02 mm/px, 20 fps (fileDB.xml entry SampleT); 20 frames, 20 valid; "
                        "19 head/tail swaps fixed; head from motion: 0.51 body lengths head-first"),
            std::string::npos)
      << ok.out;
  std::ifstream in(Path("k.csv"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("# environment: swimming (CeleST)\n"), std::string::npos) << text;
  EXPECT_NE(text.find("# source: CeleST segmentation wormSegm_SampleT.txt worm 2\n"), std::string::npos) << text;
  const Outcome worm = Wormdrag("import " + segm + " --worm 9 --out " + Path("k9.csv"));
  EXPECT_EQ(worm.code, 2);
  EXPECT_NE(worm.out.find("wormSegm_SampleT.txt:3: worms 2: there is no worm 9 (the file has worms 1-2)"),
            std::string::npos)
      << worm.out;
  std::remove(Path("fileDB.xml").c_str());
  const Outcome cal = Wormdrag("import " + segm + " --worm 1 --out " + Path("k1.csv"));
  EXPECT_EQ(cal.code, 2);
  EXPECT_NE(cal.out.find("no calibration for SampleT: no fileDB.xml beside it"), std::string::npos) << cal.out;
  EXPECT_EQ(Wormdrag("import " + segm + " --worm 1 --fps 20 --mm-per-px 0.02 --out " + Path("k1.csv")).code, 0);
}

}  // namespace
