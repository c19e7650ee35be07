#include "core/io/celest.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include <unistd.h>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

namespace fs = std::filesystem;

// One record of a synthetic CeleST file.
struct Record {
  std::vector<Vec2> px;
  bool lost = false;
};

// A segmentation file in CeleST's format (precision 2: coordinates are pixels × 100).
std::string CelestText(const std::vector<std::vector<Record>>& worms) {
  std::string out = "format %s_%02d_%s_%04d\nblock 9\nworms " + std::to_string(worms.size()) + "\nframes " +
                    std::to_string(worms[0].size()) + "\nprecision 2\n";
  char buf[64];
  for (size_t w = 0; w < worms.size(); ++w) {
    for (size_t f = 0; f < worms[w].size(); ++f) {
      const Record& r = worms[w][f];
      std::snprintf(buf, sizeof buf, "worm %02zu frame %04zu\n", w + 1, f + 1);
      out += buf;
      std::string x = "x ", y = "y ", width = "w ";
      for (const Vec2& p : r.px) {
        x += std::to_string(std::lround(p.x() * 100)) + ",";
        y += std::to_string(std::lround(p.y() * 100)) + ",";
        width += "300,";
      }
      out += x + "\n" + y + "\n" + width + "\nt 6408,\ng 6000,\nm 0,\nl " + (r.lost ? "1" : "0") + ",\no 0,\n";
    }
  }
  return out;
}

// A worm 60 px long swimming along x with a bending wave running head → tail. Its head is at
// x = 100 + speed·f, the body trails toward −x. The ends are trimmed by 0–3 px (as CeleST's
// are) and the number of points varies, like the real files.
std::vector<Vec2> Swimmer(int f, double speed, std::mt19937& rng) {
  std::uniform_real_distribution<double> trim(0.0, 3.0);
  std::uniform_int_distribution<int> count(10, 24);
  const double s0 = trim(rng), s1 = 60.0 - trim(rng);
  const int n = count(rng);
  std::vector<Vec2> px(n);
  for (int i = 0; i < n; ++i) {
    const double s = s0 + (s1 - s0) * i / (n - 1);
    px[i] = Vec2(100 + speed * f - s, 200 + 4 * std::sin(2 * M_PI * (s / 40.0 - f / 20.0)));
  }
  return px;
}

// The s = 0 end of Swimmer (before trimming), pixels.
Vec2 TrueHead(int f, double speed) {
  return Vec2(100 + speed * f, 200 + 4 * std::sin(-2 * M_PI * f / 20.0));
}

// `frames` records of one swimmer, each reversed at random (probability 0.3); returns the
// number of places where the file's order changes between consecutive frames.
int SwimmerRecords(std::vector<Record>* recs, int frames, double speed, unsigned seed) {
  std::mt19937 rng(seed);
  std::bernoulli_distribution flip(0.3);
  int changes = 0;
  bool last = false;
  for (int f = 0; f < frames; ++f) {
    Record r{Swimmer(f, speed, rng)};
    const bool rev = flip(rng);
    if (rev) std::reverse(r.px.begin(), r.px.end());
    if (f > 0) changes += rev != last;
    last = rev;
    recs->push_back(r);
  }
  return changes;
}

CelestOptions Options(int worm) {
  CelestOptions opt;
  opt.worm = worm;
  opt.calibration = {20.0, 0.01, "test"};
  return opt;
}

TEST(Celest, RestoresOneOrientationAndTheHeadOfASwimmer) {
  for (double speed : {0.5, -0.5}) {  // head-first toward +x, then toward −x
    std::vector<Record> recs;
    const int changes = SwimmerRecords(&recs, 100, speed, 7);
    auto r = ParseCelest(CelestText({recs}), Options(1), "wormSegm_Synth.txt");
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    const Kinematics& k = r->kinematics;
    const CelestSummary& s = r->summary;
    EXPECT_EQ(s.frames, 100);
    EXPECT_EQ(s.valid, 100);
    EXPECT_EQ(s.swaps_fixed, changes);
    EXPECT_GT(changes, 20);
    EXPECT_EQ(s.runs, 1);
    EXPECT_EQ(s.runs_undecided, 0);
    // 99 frames × 0.5 px = 0.495 mm, in body lengths.
    EXPECT_NEAR(s.travel, 0.495 / s.body_length_mm, 0.06);
    EXPECT_DOUBLE_EQ(k.fps, 20.0);
    EXPECT_DOUBLE_EQ(k.frames[10].t, 0.5);
    // The head is the end the body moves toward: the synthetic body's s = 0 end when it
    // moves toward +x, the other end when it moves toward −x.
    for (int f = 0; f < 100; ++f) {
      const Frame& fr = k.frames[f];
      ASSERT_TRUE(fr.valid);
      const Vec2 front = (speed > 0 ? fr.p[0] : fr.p[kNumPoints - 1]) / 0.01;  // pixels
      EXPECT_LT((front - TrueHead(f, speed)).norm(), 3.5) << "frame " << f;
      EXPECT_EQ(speed > 0, fr.p[0].x() > fr.p[kNumPoints - 1].x()) << "frame " << f;
    }
    EXPECT_NEAR(s.body_length_mm, 0.63, 0.03);  // 57-60 px of a wave 4 px high, 40 px long
    EXPECT_EQ(k.metadata.at("environment"), "swimming (CeleST)");
    EXPECT_NE(k.metadata.at("source").find("wormSegm_Synth.txt worm 1"), std::string::npos);
  }
}

TEST(Celest, MarksFlaggedShortOffLengthAndGlitchFramesMissing) {
  std::vector<Record> recs;
  SwimmerRecords(&recs, 100, 0.5, 11);
  recs[30].lost = true;
  recs[50].px = {Vec2(120, 230), Vec2(130, 240), Vec2(140, 230), Vec2(150, 240), Vec2(160, 230), Vec2(170, 240)};
  recs[70].px.resize(4);                                         // too few points
  for (Vec2& p : recs[80].px) p = Vec2(2 * p.x() - 140, p.y());  // twice as long
  auto r = ParseCelest(CelestText({recs}), Options(1), "s.txt");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const CelestSummary& s = r->summary;
  EXPECT_EQ(s.valid, 96);
  EXPECT_EQ(s.lost, 1);
  EXPECT_EQ(s.glitches, 1);
  EXPECT_EQ(s.no_centreline, 1);
  EXPECT_EQ(s.length_outliers, 1);
  for (int f : {30, 50, 70, 80}) EXPECT_FALSE(r->kinematics.frames[f].valid) << f;
  EXPECT_NE(s.Report().find("missing: 1 lost, 1 no centreline, 1 length, 1 glitch"), std::string::npos) << s.Report();
}

TEST(Celest, OrientsEachRunSeparatelyAcrossALongGap) {
  std::vector<Record> recs;
  SwimmerRecords(&recs, 100, 0.5, 3);
  for (int f = 40; f < 60; ++f) recs[f].lost = true;  // 20 frames: beyond the link gap
  // The second run starts reversed in the file, so continuity alone would keep it tail-first.
  std::reverse(recs[60].px.begin(), recs[60].px.end());
  auto r = ParseCelest(CelestText({recs}), Options(1), "s.txt");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->summary.runs, 2);
  EXPECT_EQ(r->summary.runs_undecided, 0);
  for (const Frame& f : r->kinematics.frames) {
    if (!f.valid) continue;
    EXPECT_GT(f.p[0].x(), f.p[kNumPoints - 1].x()) << f.t;
  }
}

TEST(Celest, LeavesAWormThatDoesNotTravelUndecidedButConsistent) {
  std::vector<Record> recs;
  SwimmerRecords(&recs, 100, 0.0, 5);
  auto r = ParseCelest(CelestText({recs}), Options(1), "s.txt");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->summary.runs_undecided, 1);
  const bool first = r->kinematics.frames[0].p[0].x() > r->kinematics.frames[0].p[kNumPoints - 1].x();
  for (const Frame& f : r->kinematics.frames) EXPECT_EQ(f.p[0].x() > f.p[kNumPoints - 1].x(), first) << f.t;
  EXPECT_NE(r->summary.Report().find("undecided"), std::string::npos);
}

TEST(Celest, ImportsTheChosenWormOnly) {
  std::vector<Record> a, b;
  SwimmerRecords(&a, 30, 0.5, 1);
  SwimmerRecords(&b, 30, 0.5, 2);
  for (Record& rec : b)
    for (Vec2& p : rec.px) p += Vec2(0, 100);
  auto r = ParseCelest(CelestText({a, b}), Options(2), "s.txt");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_NEAR(r->kinematics.frames[0].p[0].y(), 3.0, 0.1);  // (200 + 100) px × 0.01 mm/px
}

TEST(Celest, ErrorsNameTheFileLineAndField) {
  std::vector<Record> recs;
  SwimmerRecords(&recs, 5, 0.5, 1);
  const std::string good = CelestText({recs});
  auto error = [](const std::string& text, int worm = 1) {
    auto r = ParseCelest(text, Options(worm), "wormSegm_S.txt");
    return r.ok() ? std::string("ok") : r.status().message();
  };
  // Line 16 is the x line of worm 1 frame 2 (5 header lines, 9 lines per record).
  std::string bad = good;
  const size_t x2 = bad.find("x ", bad.find("worm 01 frame 0002"));
  bad.replace(x2 + 2, 3, "1a2");
  EXPECT_NE(error(bad).find("wormSegm_S.txt:16: worm 01 frame 0002: field 'x': not a list of integers"),
            std::string::npos)
      << error(bad);
  EXPECT_NE(error(good, 3).find("wormSegm_S.txt:3: worms 1: there is no worm 3 (the file has worms 1-1)"),
            std::string::npos)
      << error(good, 3);
  bad = good;
  bad.replace(bad.find("\nl 0,", bad.find("worm 01 frame 0003")), 5, "\nl 2,");
  EXPECT_NE(error(bad).find("wormSegm_S.txt:31: worm 01 frame 0003: field 'l': a flag is 0 or 1, got 2"),
            std::string::npos)
      << error(bad);
  bad = good;
  bad.erase(bad.find("\ng 6000,", bad.find("worm 01 frame 0004")), 8);
  EXPECT_NE(error(bad).find("wormSegm_S.txt:33: worm 01 frame 0004: field 'g' missing"), std::string::npos)
      << error(bad);
  bad = good;
  bad.replace(bad.find("worm 01 frame 0005"), 18, "worm 01 frame 0009");
  EXPECT_NE(error(bad).find(":42: frame 0009 is outside 1-5 (header 'frames')"), std::string::npos) << error(bad);
  EXPECT_NE(error("format x\nblock 9\nworms 1\nprecision 2\nworm 01 frame 0001\n").find("'frames N' missing"),
            std::string::npos);
  for (Record& rec : recs) rec.lost = true;
  EXPECT_NE(
      error(CelestText({recs})).find("wormSegm_S.txt: worm 1 has no valid frame (5 frames, 0 valid, missing: 5 lost)"),
      std::string::npos)
      << error(CelestText({recs}));
}

const char* kFileDb = R"(<?xml version="1.0" encoding="UTF-8"?>
<sequences_database>
    <sequence number="1">
        <feature class="char" name="name">Sample01</feature>
        <feature class="double" name="frames_per_second" precision="4">181333</feature>
        <feature class="double" name="mm_per_pixel" precision="4">201</feature>
    </sequence>
    <sequence number="2">
        <feature class="char" name="name">Sample04</feature>
        <feature class="double" name="trial" precision="4">NaN</feature>
        <feature class="double" name="frames_per_second" precision="4">300000</feature>
        <feature class="double" name="mm_per_pixel" precision="3">25</feature>
    </sequence>
</sequences_database>
)";

TEST(CelestFileDb, ReadsTheSamplesScaledValues) {
  auto a = ParseCelestFileDb(kFileDb, "Sample01", "fileDB.xml");
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_DOUBLE_EQ(a->fps, 18.1333);
  EXPECT_DOUBLE_EQ(a->mm_per_px, 0.0201);
  auto b = ParseCelestFileDb(kFileDb, "Sample04", "fileDB.xml");
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  EXPECT_DOUBLE_EQ(b->fps, 30.0);
  EXPECT_DOUBLE_EQ(b->mm_per_px, 0.025);  // its own precision, 3
  auto none = ParseCelestFileDb(kFileDb, "Sample02", "fileDB.xml");
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.status().message(), "fileDB.xml: no entry for Sample02 (it lists Sample01, Sample04)");
}

TEST(CelestFileDb, RejectsBrokenXmlAndValuesWithTheirLine) {
  std::string unclosed = kFileDb;
  unclosed.erase(unclosed.find("</feature>", unclosed.find("mm_per_pixel\" precision=\"4\"")), 10);
  auto r = ParseCelestFileDb(unclosed, "Sample01", "fileDB.xml");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("fileDB.xml:6: <feature name=\"mm_per_pixel\"> is not closed by </feature>"),
            std::string::npos)
      << r.status().message();
  std::string nan = kFileDb;
  nan.replace(nan.find("300000"), 6, "NaN");
  r = ParseCelestFileDb(nan, "Sample04", "fileDB.xml");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("fileDB.xml:11: Sample04 frames_per_second: not a positive number 'NaN'"),
            std::string::npos)
      << r.status().message();
  EXPECT_FALSE(ParseCelestFileDb("<html></html>", "Sample01", "x.xml").ok());
}

TEST(CelestFileDb, ResolvesBesideTheFileWithFlagsOverriding) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("celest_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string segm = (dir / "wormSegm_Sample01.txt").string();
  EXPECT_EQ(CelestSampleName(segm), "Sample01");
  auto missing = ResolveCelestCalibration(segm, "", 0, 0);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("no fileDB.xml beside it"), std::string::npos);
  auto given = ResolveCelestCalibration(segm, "", 18, 0.02);  // no fileDB needed
  ASSERT_TRUE(given.ok());
  EXPECT_EQ(given->origin, "given");
  std::ofstream(dir / "fileDB.xml") << kFileDb;
  auto db = ResolveCelestCalibration(segm, "", 0, 0.03);
  ASSERT_TRUE(db.ok()) << db.status().ToString();
  EXPECT_DOUBLE_EQ(db->fps, 18.1333);
  EXPECT_DOUBLE_EQ(db->mm_per_px, 0.03);
  EXPECT_EQ(db->origin, "fileDB.xml entry Sample01, mm/px given");
  auto other = ResolveCelestCalibration((dir / "wormSegm_Sample02.txt").string(), "", 0, 0);
  ASSERT_FALSE(other.ok());
  EXPECT_NE(other.status().message().find("no entry for Sample02 (it lists Sample01, Sample04); give --fps and "
                                          "--mm-per-px"),
            std::string::npos)
      << other.status().message();
  fs::remove_all(dir);
}

// Real data (PROVENANCE.md §5): CeleST's segmentation of a swim-test video, 6 worms.
const std::string kDir = std::string(WORMDRAG_SHARED_DIR) + "/data/real/celest/";

Result<CelestImport> ImportReal(const std::string& file, int worm) {
  auto cal = ResolveCelestCalibration(kDir + file, "", file == "wormSegm_Sample02.txt" ? 18.1333 : 0,
                                      file == "wormSegm_Sample02.txt" ? 0.0201 : 0);
  if (!cal.ok()) return cal.status();
  CelestOptions opt;
  opt.worm = worm;
  opt.calibration = *cal;
  return ReadCelest(kDir + file, opt);
}

TEST(CelestReal, Sample04WormsHaveSensibleLengthsAndNoHeadTailFlips) {
  if (!fs::exists(kDir + "wormSegm_Sample04.txt")) GTEST_SKIP() << kDir << "wormSegm_Sample04.txt not found";
  for (int worm = 1; worm <= 5; ++worm) {
    auto r = ImportReal("wormSegm_Sample04.txt", worm);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    const Kinematics& k = r->kinematics;
    EXPECT_DOUBLE_EQ(k.fps, 18.1333) << worm;
    EXPECT_EQ(k.frames.size(), 544u);
    EXPECT_GT(k.NumValid(), 500) << worm;
    EXPECT_GE(k.BodyLength(), 0.9) << worm;
    EXPECT_LE(k.BodyLength(), 1.3) << worm;
    EXPECT_GT(r->summary.swaps_fixed, 0) << worm;  // the file's order does change
    for (size_t i = 1; i < k.frames.size(); ++i) {
      const Frame &a = k.frames[i - 1], &b = k.frames[i];
      if (!a.valid || !b.valid) continue;
      const double head_step = (b.p[0] - a.p[0]).norm();
      EXPECT_LT(head_step, (b.p[0] - b.p[kNumPoints - 1]).norm()) << "worm " << worm << " frame " << i;
      EXPECT_LT(head_step, (b.p[0] - a.p[kNumPoints - 1]).norm()) << "worm " << worm << " frame " << i;
    }
  }
}

TEST(CelestReal, Sample04Worm6IsLostOnEveryFrame) {
  if (!fs::exists(kDir + "wormSegm_Sample04.txt")) GTEST_SKIP() << kDir << "wormSegm_Sample04.txt not found";
  auto r = ImportReal("wormSegm_Sample04.txt", 6);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("worm 6 has no valid frame (544 frames, 0 valid, missing: 544 lost)"),
            std::string::npos)
      << r.status().message();
}

TEST(CelestReal, Sample02LastFrameIsAGlitchForWorms124) {
  if (!fs::exists(kDir + "wormSegm_Sample02.txt")) GTEST_SKIP() << kDir << "wormSegm_Sample02.txt not found";
  for (int worm = 1; worm <= 5; ++worm) {
    auto r = ImportReal("wormSegm_Sample02.txt", worm);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_EQ(r->kinematics.frames.size(), 545u);
    EXPECT_EQ(r->kinematics.frames.back().valid, worm == 3 || worm == 5) << worm;
  }
}

}  // namespace
}  // namespace wormdrag
