#include "core/io/pose_csv.h"

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

PoseCsvOptions Opt(double min_likelihood = 0.6) {
  PoseCsvOptions o;
  o.fps = 10;
  o.um_per_px = 4;
  o.min_likelihood = min_likelihood;
  return o;
}

// DeepLabCut's analyze_videos output written by pandas' to_csv: level names in the
// first column, the frame number as index, x, y, likelihood per body part.
const char kDlc[] =
    "scorer,DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_"
    "50000,"
    "DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_50000,"
    "DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_50000,"
    "DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_50000,DLC_resnet50_wormJun1shuffle1_50000\n"
    "bodyparts,head,head,head,neck,neck,neck,hips,hips,hips,tail,tail,tail\n"
    "coords,x,y,likelihood,x,y,likelihood,x,y,likelihood,x,y,likelihood\n"
    "0,100.0,200.0,0.99,150.0,210.0,0.98,200.0,200.0,0.97,250.0,190.0,0.95\n"
    "1,102.0,201.0,0.99,152.0,211.0,0.98,202.0,201.0,0.97,252.0,191.0,0.95\n"
    "2,104.0,202.0,0.30,154.0,212.0,0.98,204.0,202.0,0.97,254.0,192.0,0.95\n"
    "3,106.0,203.0,0.99,156.0,213.0,0.98,206.0,203.0,0.97,,,\n"
    "4,108.0,204.0,0.99,158.0,214.0,0.98,208.0,204.0,0.97,258.0,194.0,0.95\r\n"
    "5,110.0,205.0,0.99,160.0,215.0,0.98,210.0,205.0,0.97,260.0,195.0,0.95\n";

TEST(PoseCsv, DeepLabCutPredictionsInMillimetresWithUnsureFramesMissing) {
  auto r = ParsePoseCsv(kDlc, Opt(), "worm.csv");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Kinematics& k = r->kinematics;
  ASSERT_EQ(k.frames.size(), 6u);
  EXPECT_DOUBLE_EQ(k.fps, 10);
  EXPECT_NEAR(k.frames[5].t, 0.5, 1e-12);
  EXPECT_FALSE(k.frames[2].valid);  // head likelihood 0.30
  EXPECT_FALSE(k.frames[3].valid);  // tail not detected
  EXPECT_TRUE(k.frames[4].valid);   // CRLF line end
  EXPECT_NEAR(k.frames[0].p[0].x(), 0.400, 1e-12);
  EXPECT_NEAR(k.frames[0].p[0].y(), 0.800, 1e-12);
  EXPECT_NEAR(k.frames[5].p[13].x(), 1.040, 1e-12);
  EXPECT_NEAR(k.frames[5].p[13].y(), 0.780, 1e-12);
  const double len_px = 2 * std::hypot(50, 10) + std::hypot(50, 10);
  EXPECT_NEAR(k.frames[0].arc_length, len_px * 4 / 1000, 1e-9);
  EXPECT_EQ(r->summary.Report(0.6),
            "DeepLabCut: 4 body parts (head … tail); 6 frames, 4 valid, missing: 1 undetected, 1 likelihood < 0.6");
  EXPECT_EQ(k.metadata.at("bodyparts"), "head neck hips tail");
  EXPECT_EQ(k.metadata.at("calibration"), "4 µm/px, 10 fps");

  auto lenient = ParsePoseCsv(kDlc, Opt(0.2), "worm.csv");
  ASSERT_TRUE(lenient.ok());
  EXPECT_TRUE(lenient->kinematics.frames[2].valid);
  EXPECT_EQ(lenient->kinematics.NumValid(), 5);
}

TEST(PoseCsv, LabelledImagesAreNumberedByRow) {
  // DeepLabCut ≥ 2.3 labelled data: three index columns, x and y only.
  const char csv[] =
      "scorer,,,Me,Me,Me,Me,Me,Me\n"
      "bodyparts,,,A,A,B,B,C,C\n"
      "coords,,,x,y,x,y,x,y\n"
      "labeled-data,video,img005.png,0,1,2,3,4,5\n"
      "labeled-data,video,img020.png,12,13,,,15,16\n"
      "labeled-data,video,img031.png,1,1,5,1,9,1\n";
  auto r = ParsePoseCsv(csv, Opt(), "CollectedData_Me.csv");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_EQ(r->kinematics.frames.size(), 3u);
  EXPECT_TRUE(r->kinematics.frames[0].valid);
  EXPECT_FALSE(r->kinematics.frames[1].valid);
  EXPECT_NEAR(r->kinematics.frames[2].p[13].x(), 9 * 4 / 1000.0, 1e-12);
}

TEST(PoseCsv, MultiAnimalDeepLabCutImportsTheChosenIndividual) {
  const char csv[] =
      "scorer,S,S,S,S,S,S,S,S,S,S,S,S,S,S\n"
      "individuals,worm1,worm1,worm1,worm1,worm1,worm1,worm2,worm2,worm2,worm2,worm2,worm2,single,single\n"
      "bodyparts,h,h,m,m,t,t,h,h,m,m,t,t,food,food\n"
      "coords,x,y,x,y,x,y,x,y,x,y,x,y,x,y\n"
      "0,0,0,10,0,20,0,100,50,110,50,120,50,7,7\n"
      "1,1,0,11,0,21,0,100,51,110,51,120,51,7,7\n";
  PoseCsvOptions o = Opt();
  auto both = ParsePoseCsv(csv, o, "ma.csv");
  ASSERT_FALSE(both.ok());
  EXPECT_NE(both.status().message().find("ma.csv:2: 2 individuals ('worm1', 'worm2'); choose one with --id"),
            std::string::npos)
      << both.status().message();
  o.individual = "worm9";
  auto absent = ParsePoseCsv(csv, o, "ma.csv");
  ASSERT_FALSE(absent.ok());
  EXPECT_NE(absent.status().message().find("no individual 'worm9'; the file has 'worm1', 'worm2'"), std::string::npos);
  o.individual = "worm2";
  auto r = ParsePoseCsv(csv, o, "ma.csv");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->summary.bodyparts.size(), 3u);
  EXPECT_NEAR(r->kinematics.frames[1].p[0].y(), 51 * 4 / 1000.0, 1e-12);
  EXPECT_EQ(r->kinematics.metadata.at("source"), "multi-animal DeepLabCut CSV ma.csv 'worm2'");
}

TEST(PoseCsv, SleapAnalysisCsvKeepsTheTracksFramesOnTheTimeBase) {
  // SLEAP's export: one row per instance; track_0 is not found in frame 2.
  const char csv[] =
      "track,frame_idx,instance.score,head.x,head.y,head.score,mid.x,mid.y,mid.score,tail.x,tail.y,tail.score\n"
      "track_0,0,0.95,10,10,0.9,20,10,0.9,30,10,0.9\n"
      "track_1,0,0.91,70,70,0.9,80,70,0.9,90,70,0.9\n"
      "track_0,1,0.95,11,10,0.9,21,10,0.9,31,10,0.1\n"
      "track_0,3,nan,13,10,,23,10,,33,10,\n"
      "track_1,3,0.91,70,73,0.9,80,73,0.9,90,73,0.9\n";
  PoseCsvOptions o = Opt();
  o.individual = "track_0";
  auto r = ParsePoseCsv(csv, o, "labels.analysis.csv");
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Kinematics& k = r->kinematics;
  ASSERT_EQ(k.frames.size(), 4u);
  EXPECT_TRUE(k.frames[0].valid);
  EXPECT_FALSE(k.frames[1].valid);  // tail score 0.1
  EXPECT_FALSE(k.frames[2].valid);  // no row
  EXPECT_TRUE(k.frames[3].valid);   // a user-labelled instance has no scores
  EXPECT_NEAR(k.frames[3].p[0].x(), 13 * 4 / 1000.0, 1e-12);
  EXPECT_EQ(r->summary.Report(0.6),
            "SLEAP 'track_0': 3 body parts (head … tail); 4 frames, 2 valid, missing: 1 absent, 1 likelihood < 0.6");
  o.individual.clear();
  auto ambiguous = ParsePoseCsv(csv, o, "labels.analysis.csv");
  ASSERT_FALSE(ambiguous.ok());
  EXPECT_NE(ambiguous.status().message().find("2 tracks ('track_0', 'track_1'); choose one with --id"),
            std::string::npos)
      << ambiguous.status().message();
}

TEST(PoseCsv, PlainTablesWithAndWithoutHeader) {
  auto headed = ParsePoseCsv("x0,y0,x1,y1,x2,y2\n0,0,5,0,10,0\n0,1,5,1,nan,1\n", Opt(), "p.csv");
  ASSERT_TRUE(headed.ok()) << headed.status().ToString();
  EXPECT_EQ(headed->kinematics.frames.size(), 2u);
  EXPECT_FALSE(headed->kinematics.frames[1].valid);
  EXPECT_NEAR(headed->kinematics.BodyLength(), 10 * 4 / 1000.0, 1e-12);

  auto framed = ParsePoseCsv("frame,x0,y0,x1,y1,x2,y2\n4,0,0,5,0,10,0\n6,0,1,5,1,10,1\n", Opt(), "p.csv");
  ASSERT_TRUE(framed.ok()) << framed.status().ToString();
  ASSERT_EQ(framed->kinematics.frames.size(), 3u);
  EXPECT_NEAR(framed->kinematics.frames[0].t, 0.4, 1e-12);
  EXPECT_FALSE(framed->kinematics.frames[1].valid);

  auto bare = ParsePoseCsv("0,0,5,0,10,0\n0,1,5,1,10,1\n", Opt(), "p.csv");
  ASSERT_TRUE(bare.ok()) << bare.status().ToString();
  EXPECT_EQ(bare->kinematics.NumValid(), 2);
  EXPECT_EQ(bare->summary.layout, "plain");
}

TEST(PoseCsv, NamesTheLineColumnAndFieldOfEachError) {
  auto error = [](const std::string& text, const PoseCsvOptions& o = Opt()) {
    auto r = ParsePoseCsv(text, o, "in.csv");
    return r.ok() ? std::string("ok") : r.status().message();
  };
  EXPECT_EQ(error(kDlc, PoseCsvOptions{}),
            "in.csv: a pose CSV holds pixels and frame numbers only: give --fps and "
            "--um-per-px");
  std::string bad = kDlc;
  bad.replace(bad.find("152.0,211.0"), 11, "152.0,abc");
  EXPECT_EQ(error(bad), "in.csv:5: column 6 (neck y): not a number 'abc'");
  std::string short_row = kDlc;
  short_row.replace(short_row.find(",258.0,194.0,0.95"), 17, "");
  EXPECT_EQ(error(short_row), "in.csv:8: 10 cells, expected 13");
  EXPECT_EQ(error("x0,y0,x1,y1\n0,0,1,1\n"), "in.csv: 2 body parts; a skeleton needs at least 3, head → tail");
  EXPECT_EQ(error("x0,y0,x1,y2,x2,y2\n0,0,1,1,2,2\n"), "in.csv:1: column 4 'y2', expected 'y1'");
  EXPECT_EQ(error("frame,x0,y0,x1,y1,x2,y2\n1,0,0,1,1,2,2\n1,0,0,1,1,2,2\n"),
            "in.csv:3: frame 1 appears twice (also on line 2)");
  EXPECT_EQ(error("frame,x0,y0,x1,y1,x2,y2\n-1,0,0,1,1,2,2\n"), "in.csv:2: column 1: not a frame number '-1'");
  EXPECT_NE(error("t,x0,y0,x1,y1,x2,y2\n0,0,0,1,1,2,2\n").find("in.csv:1: not a pose CSV"), std::string::npos);
  EXPECT_EQ(error("scorer,a,a,a,a,a,a\nbodyparts,h,h,m,m,t,t\ncoords,x,y,x,likelihood,x,y\n0,1,2,3,1,5,6\n"),
            "in.csv:3: body part 'm' has no y column");
  EXPECT_EQ(error("scorer,a,a\ncoords,x,y\n0,1,2\n"),
            "in.csv:1: a DeepLabCut header needs the rows scorer, bodyparts and coords");
}

TEST(PoseCsv, TellsPoseFilesFromKinematicsFiles) {
  EXPECT_TRUE(LooksLikePoseCsv("scorer,DLC_resnet50,DLC_resnet50"));
  EXPECT_TRUE(LooksLikePoseCsv("track,frame_idx,instance.score,head.x,head.y,head.score"));
  EXPECT_TRUE(LooksLikePoseCsv("x0,y0,x1,y1,x2,y2\r"));
  EXPECT_TRUE(LooksLikePoseCsv("frame,x0,y0,x1,y1,x2,y2"));
  EXPECT_TRUE(LooksLikePoseCsv("1.5,2,3,4,5,6"));
  EXPECT_FALSE(LooksLikePoseCsv("# fps: 30"));
  EXPECT_FALSE(LooksLikePoseCsv("t,x0,y0,x1,y1"));
}

}  // namespace
}  // namespace wormdrag
