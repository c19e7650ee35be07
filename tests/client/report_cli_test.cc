// wormdrag report / analyze / import --frames as a user runs them: a real process
// (the shim around client/cmd_report.cc), real files, a real SQLite store.
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "run_wormdrag.h"

namespace {

using wormdrag::testing::Outcome;

Outcome Cli(const std::string& args) {
  return wormdrag::testing::RunWormdrag(args);
}

std::string Slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

const std::string kData = std::string(WORMDRAG_SOURCE_DIR) + "/examples/data/";
const std::string kSmall = " --n-max 3 --d-mu 0.3 --d-eta 0.003 --t-max 0.4 --lowpass 0 --threads 2 ";

class ReportCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = ::testing::TempDir() + "/report_cli_" + std::to_string(::getpid());
    std::filesystem::create_directories(dir_);
    db_ = " --db " + dir_ + "/jobs.db ";
    // Three small jobs (different spans), enough for a 2 + 1… no: 2 + 2 with a repeat.
    for (const char* t : {"0.4", "0.3", "0.35"}) {
      std::string opts = kSmall;
      opts.replace(opts.find("--t-max 0.4"), 11, std::string("--t-max ") + t);
      const Outcome r = Cli("estimate " + kData + "L1.csv " + kData + "L2.csv" + opts + db_);
      ASSERT_EQ(r.code, 0) << r.out;
    }
    // Job 4: the paper's swimming protocol, four stretches per worm (analyze progress).
    const Outcome r = Cli("estimate " + kData + "L1.csv " + kData + "L2.csv" + kSmall + "--restart-every 0.1" + db_);
    ASSERT_EQ(r.code, 0) << r.out;
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }
  static inline std::string dir_, db_;
};

TEST_F(ReportCli, HelpAndErrors) {
  for (const char* c : {"report --help", "analyze --help"}) {
    const Outcome r = Cli(c);
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("usage: wormdrag"), std::string::npos) << r.out;
  }
  Outcome r = Cli("report 99 --out " + dir_ + "/x.html" + db_);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("not found"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/x.html"));
  r = Cli("report 1" + db_);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--out"), std::string::npos) << r.out;
  r = Cli("report abc --out " + dir_ + "/x.html" + db_);
  EXPECT_EQ(r.code, 2);
  r = Cli("analyze forces 42" + db_);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("not found"), std::string::npos) << r.out;
  r = Cli("analyze trajectories 1" + db_);
  EXPECT_EQ(r.code, 2) << r.out;
  r = Cli("analyze wobble 1" + db_);
  EXPECT_EQ(r.code, 2) << r.out;
  r = Cli("analyze progress" + db_);
  EXPECT_EQ(r.code, 2) << r.out;
  r = Cli("analyze progress 4 --coef 1,2" + db_);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--coef 1,2"), std::string::npos) << r.out;
  std::ofstream(dir_ + "/bad.json") << "[1,2";
  r = Cli("report 1 --out " + dir_ + "/x.html --diagnosis " + dir_ + "/bad.json" + db_);
  EXPECT_EQ(r.code, 2) << r.out;
}

TEST_F(ReportCli, ReportWritesOneHtmlFile) {
  const Outcome r = Cli("report 1 --out " + dir_ + "/r.html" + db_);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string html = Slurp(dir_ + "/r.html");
  EXPECT_NE(html.find("Friction estimate, job 1"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_NE(html.find("</html>"), std::string::npos);
}

TEST_F(ReportCli, AnalyzeForcesTrajectoriesCompare) {
  Outcome r = Cli("analyze forces 1 --csv " + dir_ + "/f.csv" + db_);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("RMS|f_k|"), std::string::npos);
  EXPECT_NE(r.out.find("overall coefficient scale"), std::string::npos);
  const std::string csv = Slurp(dir_ + "/f.csv");
  EXPECT_EQ(csv.rfind("worm,t,fx1,", 0), 0u) << csv.substr(0, 80);
  r = Cli("analyze trajectories 1 --coef 0.5,0.2,0.005,0.002 --coef 1,0.4,0.01,0.004 --csv " + dir_ + "/t.csv" + db_);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("3 coefficient sets"), std::string::npos) << r.out;
  // A set without viscous drag has no K_eta: said in words, never "nan".
  r = Cli("analyze trajectories 1 --coef 0.5,0.2,0,0" + db_);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("2.5 undefined inf"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
  // Sets 1 and 2 have the same ratios: their paths agree to well below a micrometre.
  r = Cli("analyze compare --group-a 1,2 --group-b 2,3" + db_);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("Welch t-test: t = "), std::string::npos) << r.out;
  // Job 4's stretches: the estimate follows the travel, the still body does not propel.
  r = Cli("analyze progress 4 --coef 0.5,0.2,0.005,0.002 --csv " + dir_ + "/p.csv" + db_);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("1 (the still body)         1     4 "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("MISSED SIDE"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("nan"), std::string::npos) << r.out;
  EXPECT_EQ(Slurp(dir_ + "/p.csv").rfind("set,worm,t0,t1,measured_along", 0), 0u);
  r = Cli("analyze compare --group-a 1,2 --group-b 3 --metric E-percent" + db_);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.out.find("at least 2"), std::string::npos) << r.out;
  r = Cli("analyze compare --group-a 1,2 --group-b 2,3 --metric nope" + db_);
  EXPECT_EQ(r.code, 2) << r.out;
}

TEST_F(ReportCli, ImportFramesCutsAndRezeroes) {
  Outcome r = Cli("import " + kData + "L1.csv --frames 30:89 --out " + dir_ + "/cut.csv");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("60 frames"), std::string::npos) << r.out;
  const std::string cut = Slurp(dir_ + "/cut.csv");
  EXPECT_NE(cut.find("# frames: 30:89 of L1.csv"), std::string::npos);
  EXPECT_NE(cut.find("\n0,"), std::string::npos);  // time re-zeroed
  r = Cli("import " + kData + "L1.csv --frames 30:99999 --out " + dir_ + "/cut2.csv");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("has only"), std::string::npos) << r.out;
  r = Cli("import " + kData + "L1.csv --frames 9:3 --out " + dir_ + "/cut2.csv");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/cut2.csv"));
}

}  // namespace
