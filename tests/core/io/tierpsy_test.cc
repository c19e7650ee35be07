#include "core/io/tierpsy.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "tests/core/io/tierpsy_files.h"

namespace wormdrag {
namespace {

using testing::ColType;
using testing::Column;
using testing::Flatten;
using testing::kPoints;
using testing::PyTablesWriter;
using testing::TwoWormsFeaturesN;
using testing::Worm;

class Tierpsy : public testing::ScratchDir {};

TEST_F(Tierpsy, FeaturesNImportsTheChosenWormInMillimetres) {
  const std::string path = Path("video_featuresN.hdf5");
  const auto skel = TwoWormsFeaturesN(path);
  TierpsyOptions opt;
  opt.worm = 3;
  auto r = ReadTierpsy(path, opt);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Kinematics& k = r->kinematics;
  ASSERT_EQ(k.frames.size(), 10u);
  EXPECT_DOUBLE_EQ(k.fps, 25);
  EXPECT_NEAR(k.frames.front().t, 10 / 25.0, 1e-12);  // the file's time base
  EXPECT_NEAR(k.frames.back().t, 19 / 25.0, 1e-12);
  for (int ts : {12, 15, 17}) EXPECT_FALSE(k.frames[ts - 10].valid) << ts;
  EXPECT_EQ(k.NumValid(), 7);
  // Skeleton row 0 is timestamp 10, row 4 timestamp 16 (after the −1 at 12 and the gap at 15).
  for (auto [ts, row] : {std::pair{10, 0}, std::pair{16, 4}}) {
    const Frame& f = k.frames[ts - 10];
    EXPECT_NEAR(f.p[0].x(), skel[row].front().x() / 1000, 1e-6);
    EXPECT_NEAR(f.p[0].y(), skel[row].front().y() / 1000, 1e-6);
    EXPECT_NEAR(f.p[13].x(), skel[row].back().x() / 1000, 1e-6);
    double len = 0;
    for (int j = 1; j < kPoints; ++j) len += (skel[row][j] - skel[row][j - 1]).norm();
    EXPECT_NEAR(f.arc_length, len / 1000, 1e-6);
  }
  EXPECT_EQ(r->summary.Report(),
            "featuresN worm 3: 10 frames, 7 valid, missing: 2 no skeleton, 1 dropped; 1 interpolated by Tierpsy; "
            "49 points; calibration coordinates in µm, 25 fps (attribute fps); stage fixed camera (plate coordinates)");
  EXPECT_EQ(k.metadata.at("source"), "Tierpsy featuresN video_featuresN.hdf5 worm 3");

  opt.worm = 7;
  auto w7 = ReadTierpsy(path, opt);
  ASSERT_TRUE(w7.ok()) << w7.status().ToString();
  EXPECT_EQ(w7->kinematics.frames.size(), 5u);
  EXPECT_EQ(w7->kinematics.NumValid(), 5);
  EXPECT_NEAR(w7->kinematics.frames[2].p[0].y(), (500 + 20 + 60 * std::sin(-0.6)) / 1000, 1e-6);

  opt.worm = -1;
  auto none = ReadTierpsy(path, opt);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find(
                "video_featuresN.hdf5: /trajectories_data: 2 worms (worm_index_joined 3, 7); choose one with --worm"),
            std::string::npos)
      << none.status().message();
  opt.worm = 5;
  auto absent = ReadTierpsy(path, opt);
  ASSERT_FALSE(absent.ok());
  EXPECT_NE(absent.status().message().find("/trajectories_data: no worm with worm_index_joined 5; the file has 3, 7"),
            std::string::npos)
      << absent.status().message();
}

TEST_F(Tierpsy, UncalibratedFeaturesNNeedsTheUsersFpsAndScale) {
  const std::string path = Path("raw_featuresN.hdf5");
  const auto skel = TwoWormsFeaturesN(path, /*calibrated=*/false);
  TierpsyOptions opt;
  opt.worm = 7;
  auto no_fps = ReadTierpsy(path, opt);
  ASSERT_FALSE(no_fps.ok());
  EXPECT_NE(no_fps.status().message().find("raw_featuresN.hdf5: /trajectories_data: time_units 'frames': Tierpsy "
                                           "had no frame rate for this video; give --fps"),
            std::string::npos)
      << no_fps.status().message();
  opt.fps = 20;
  auto no_scale = ReadTierpsy(path, opt);
  ASSERT_FALSE(no_scale.ok());
  EXPECT_NE(no_scale.status().message().find("xy_units 'pixels': Tierpsy had no scale for this video, so "
                                             "/coordinates/skeletons is in pixels; give --um-per-px"),
            std::string::npos)
      << no_scale.status().message();
  opt.um_per_px = 5;
  auto ok = ReadTierpsy(path, opt);
  ASSERT_TRUE(ok.ok()) << ok.status().ToString();
  EXPECT_DOUBLE_EQ(ok->kinematics.fps, 20);
  EXPECT_NEAR(ok->kinematics.frames[1].t, 1 / 20.0, 1e-12);
  EXPECT_NEAR(ok->kinematics.frames[1].p[13].x(), skel[9].back().x() * 5 / 1000, 1e-6);
  EXPECT_EQ(ok->kinematics.metadata.at("calibration"), "5 µm/px (--um-per-px), 20 fps (--fps)");

  const std::string um = Path("um_featuresN.hdf5");
  TwoWormsFeaturesN(um);
  auto twice = ReadTierpsy(um, opt);
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.status().message().find("/coordinates/skeletons is in µm already"), std::string::npos)
      << twice.status().message();
}

Status ErrorOf(const std::string& path, long worm = -1) {
  TierpsyOptions opt;
  opt.worm = worm;
  auto r = ReadTierpsy(path, opt);
  return r.ok() ? Status::Ok() : r.status();
}

TEST_F(Tierpsy, NamesTheFileDatasetAndFieldOfEachError) {
  auto expect = [](const Status& s, const std::string& part) {
    EXPECT_FALSE(s.ok());
    EXPECT_NE(s.message().find(part), std::string::npos) << s.message();
  };
  expect(ErrorOf(Path("absent.hdf5")), "absent.hdf5: no such file");
  std::ofstream(Path("text.hdf5")) << "not hdf5\n";
  expect(ErrorOf(Path("text.hdf5")), "text.hdf5: not an HDF5 file");
  {
    PyTablesWriter w(Path("empty.hdf5"));
    w.Group("/coordinates");
  }
  expect(ErrorOf(Path("empty.hdf5")), "empty.hdf5: not a Tierpsy file: it has none of /coordinates/skeletons");
  {
    PyTablesWriter w(Path("notable_featuresN.hdf5"));
    w.Group("/coordinates");
    w.Array("/coordinates/skeletons", {1, kPoints, 2}, Flatten({Worm(0, Vec2::Zero())}), true);
  }
  expect(ErrorOf(Path("notable_featuresN.hdf5")), "notable_featuresN.hdf5: /trajectories_data: missing");
  {
    PyTablesWriter w(Path("shape_featuresN.hdf5"));
    w.Table("/trajectories_data", {{"worm_index_joined", ColType::kInt32, {1}}, {"skeleton_id", ColType::kInt32, {0}}});
    w.Group("/coordinates");
    w.Array("/coordinates/skeletons", {2, kPoints, 3}, std::vector<double>(2 * kPoints * 3, 1.0), true);
  }
  expect(ErrorOf(Path("shape_featuresN.hdf5")),
         "shape_featuresN.hdf5: /coordinates/skeletons: shape (2, 49, 3), expected (skeletons, points ≥ 3, 2)");
  {
    PyTablesWriter w(Path("columns_featuresN.hdf5"));
    w.Table("/trajectories_data", {{"worm_index", ColType::kInt32, {1}}, {"skeleton_id", ColType::kInt32, {0}}});
    w.Group("/coordinates");
    w.Array("/coordinates/skeletons", {1, kPoints, 2}, Flatten({Worm(0, Vec2::Zero())}), true);
  }
  expect(
      ErrorOf(Path("columns_featuresN.hdf5")),
      "columns_featuresN.hdf5: /trajectories_data: no column 'worm_index_joined' (columns: worm_index, skeleton_id)");
  {
    PyTablesWriter w(Path("sid_featuresN.hdf5"));
    w.Table("/trajectories_data", {{"worm_index_joined", ColType::kInt32, {1, 1, 1}},
                                   {"timestamp_raw", ColType::kInt32, {0, 1, 2}},
                                   {"skeleton_id", ColType::kInt32, {0, 1, 40}}});
    w.Group("/coordinates");
    w.Array("/coordinates/skeletons", {2, kPoints, 2}, Flatten({Worm(0, Vec2::Zero()), Worm(1, Vec2::Zero())}), true);
  }
  expect(ErrorOf(Path("sid_featuresN.hdf5")),
         "sid_featuresN.hdf5: /trajectories_data: row 2: skeleton_id 40 beyond /coordinates/skeletons (2 rows)");
  {
    PyTablesWriter w(Path("nofps_featuresN.hdf5"));
    w.Table("/trajectories_data", {{"worm_index_joined", ColType::kInt32, {1}},
                                   {"timestamp_raw", ColType::kInt32, {0}},
                                   {"skeleton_id", ColType::kInt32, {0}}});
    w.StringAttr("/trajectories_data", "xy_units", "micrometers");
    w.Group("/coordinates");
    w.Array("/coordinates/skeletons", {1, kPoints, 2}, Flatten({Worm(0, Vec2::Zero())}), true);
  }
  expect(ErrorOf(Path("nofps_featuresN.hdf5")),
         "nofps_featuresN.hdf5: /trajectories_data: no frame rate (attribute 'fps', 'expected_fps' or 'framerate'); "
         "give --fps");
}

}  // namespace
}  // namespace wormdrag
