// `wormdrag track` runs the separate wormdrag-track executable (client/cmd_track.cc), so that
// the other commands start without OpenCV. Real processes; the dynamic loader's own log
// (LD_DEBUG=libs) tells which libraries a command loaded.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "run_wormdrag.h"

namespace {

namespace fs = std::filesystem;
using wormdrag::testing::Outcome;
using wormdrag::testing::RunCommand;
using wormdrag::testing::RunWormdrag;

// `wormdrag ARGS` with the loader logging every library it loads (to stderr).
Outcome WithLoaderLog(const std::string& args) {
  return RunCommand("LD_DEBUG=libs " + std::string(WORMDRAG_CLI) + " " + args);
}

class TrackCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("track_cli_" + std::to_string(::getpid()) + "_" +
                                             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
};

size_t DataRows(const std::string& csv) {
  std::ifstream in(csv);
  size_t rows = 0;
  for (std::string line; std::getline(in, line);) rows += !line.empty() && line[0] != '#' && line[0] != 't';
  return rows;
}

TEST_F(TrackCli, OnlyTrackLoadsOpenCV) {
  const Outcome help = WithLoaderLog("--help");
  ASSERT_EQ(help.code, 0) << help.out;
  // The log is there (so the absence below means something) ...
  ASSERT_NE(help.out.find("libstdc++"), std::string::npos) << help.out;
  // ... and names no OpenCV library.
  EXPECT_EQ(help.out.find("libopencv"), std::string::npos) << help.out;

  ASSERT_EQ(
      RunWormdrag("generate --pattern 0.6,0 --coef 0.5,0.2,0.005,0.002 --fps 60 --duration 1 --out " + Path("k.csv"))
          .code,
      0);
  const Outcome sim = WithLoaderLog("simulate --kinematics " + Path("k.csv") + " --coef 0.5,0.2,0.005,0.002 --out " +
                                    Path("sim.csv"));
  ASSERT_EQ(sim.code, 0) << sim.out;
  EXPECT_EQ(sim.out.find("libopencv"), std::string::npos) << sim.out;

  // The tracker does load it, through the helper: the check above can see OpenCV.
  const Outcome track = WithLoaderLog("track --help");
  ASSERT_EQ(track.code, 0) << track.out;
  EXPECT_NE(track.out.find("libopencv_videoio"), std::string::npos) << track.out;
  EXPECT_NE(track.out.find("usage: wormdrag track"), std::string::npos) << track.out;
}

TEST_F(TrackCli, TracksTheFirstFramesOfARealVideo) {
  const fs::path avi = fs::path(WORMDRAG_SHARED_DIR) / "data/real/WormTracer/WT_grayscale.avi";
  if (!fs::exists(avi)) GTEST_SKIP() << avi << " not found";
  const Outcome r = RunWormdrag("track " + avi.string() + " --max-frames 8 --um-per-px 10 --out " + Path("k.csv"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("8 frames"), std::string::npos) << r.out;
  EXPECT_EQ(DataRows(Path("k.csv")), 8u);
  // Each frame's status and quality beside it (header 'frame,…' plus a row per frame).
  EXPECT_EQ(DataRows(Path("k.quality.csv")), 9u);
  const Outcome named = RunWormdrag("track " + avi.string() + " --max-frames 3 --out " + Path("k2.csv") +
                                    " --quality " + Path("q.csv"));
  ASSERT_EQ(named.code, 0) << named.out;
  EXPECT_EQ(DataRows(Path("q.csv")), 4u);
  EXPECT_FALSE(fs::exists(Path("k2.quality.csv")));
}

TEST_F(TrackCli, ErrorsComeBackThroughTheHelper) {
  const Outcome missing = RunWormdrag("track " + Path("nope.avi") + " --out " + Path("k.csv"));
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.out.find("nope.avi: no such file or folder"), std::string::npos) << missing.out;
  EXPECT_FALSE(fs::exists(Path("k.csv")));
  const Outcome option = RunWormdrag("track x.avi --out k.csv --mask-fraction 2");
  EXPECT_EQ(option.code, 2);
  EXPECT_NE(option.out.find("wormdrag track: --mask-fraction must be in (0, 1)"), std::string::npos) << option.out;
}

TEST_F(TrackCli, AMissingHelperIsNamed) {
  // A copy of wormdrag alone in a folder: its helper would be beside it and is not.
  const fs::path lone = dir_ / "wormdrag";
  fs::copy_file(WORMDRAG_CLI, lone);
  const Outcome r = RunCommand(lone.string() + " track in.avi --out " + Path("k.csv"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("wormdrag track: cannot run " + (dir_ / "wormdrag-track").string()), std::string::npos) << r.out;
  // The other commands do not need it.
  EXPECT_EQ(RunCommand(lone.string() + " --help").code, 0);
}

}  // namespace
