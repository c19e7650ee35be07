// Tierpsy *_skeletons.hdf5 (pixels of the video frame) with the stage positions of a
// stage-tracking video, and WormPose's conversion of Tierpsy skeletons.
#include <filesystem>

#include <gtest/gtest.h>

#include "core/io/tierpsy.h"
#include "tests/core/io/tierpsy_files.h"

namespace wormdrag {
namespace {

using testing::ColType;
using testing::Column;
using testing::Flatten;
using testing::kPoints;
using testing::PyTablesWriter;
using testing::Worm;

class TierpsySkeletons : public testing::ScratchDir {};

struct SkelRow {
  int frame;
  double timestamp;  // NaN: the video had no timestamps
  int has_skeleton, is_good_skel;
};

// One worm (worm_index_joined 2) as Tierpsy's skeletons step writes it: /skeleton in
// pixels (NaN where there is none), /trajectories_data with the filter's is_good_skel,
// the unit attributes copied from the masked video.
void WriteSkeletons(PyTablesWriter& w, const std::vector<SkelRow>& rows, const std::vector<std::vector<Vec2>>& px,
                    double microns_per_pixel) {
  std::vector<Column> c = {{"frame_number", ColType::kInt32, {}},    {"worm_index_joined", ColType::kInt32, {}},
                           {"plate_worm_id", ColType::kInt32, {}},   {"skeleton_id", ColType::kInt32, {}},
                           {"coord_x", ColType::kFloat32, {}},       {"coord_y", ColType::kFloat32, {}},
                           {"threshold", ColType::kFloat32, {}},     {"has_skeleton", ColType::kUInt8, {}},
                           {"roi_size", ColType::kFloat32, {}},      {"area", ColType::kFloat32, {}},
                           {"timestamp_raw", ColType::kFloat32, {}}, {"timestamp_time", ColType::kFloat32, {}},
                           {"is_good_skel", ColType::kUInt8, {}},    {"skel_outliers_flag", ColType::kUInt8, {}},
                           {"int_map_id", ColType::kInt32, {}}};
  for (size_t i = 0; i < rows.size(); ++i) {
    const SkelRow& r = rows[i];
    const double v[] = {double(r.frame),
                        2,
                        double(i),
                        double(i),
                        320,
                        240,
                        80,
                        double(r.has_skeleton),
                        160,
                        2500,
                        r.timestamp,
                        r.timestamp / 30,
                        double(r.is_good_skel),
                        r.is_good_skel ? 0.0 : 4.0,
                        double(i)};
    for (size_t j = 0; j < c.size(); ++j) c[j].values.push_back(v[j]);
  }
  w.Table("/trajectories_data", c);
  const std::string t = "/trajectories_data";
  w.StringAttr(t, "bgnd_param", "{}");
  w.DoubleAttr(t, "microns_per_pixel", {microns_per_pixel});
  w.StringAttr(t, "xy_units", "micrometers");
  w.DoubleAttr(t, "fps", {30.0});
  w.DoubleAttr(t, "expected_fps", {30.0});
  w.StringAttr(t, "time_units", "seconds");
  w.IntAttr(t, "is_light_background", 1);
  w.Array("/skeleton", {px.size(), kPoints, 2}, Flatten(px));
}

Vec2 Sign(Vec2 v) {
  return Vec2(v.x() > 0 ? 1 : -1, v.y() > 0 ? 1 : -1);
}

// Tierpsy's _h_get_stage_inv, line for line: rotation_matrix_inv = (R * [(1, −1), (−1, 1)])
// · diag(sign(scale)); stage_vec_inv = −rotation_matrix_inv · stage_vec.
Vec2 StageInv(const Eigen::Matrix2d& R, Vec2 scale, Vec2 stage_vec) {
  Eigen::Matrix2d flip;
  flip << 1, -1, -1, 1;
  const Eigen::Matrix2d rinv = R.cwiseProduct(flip) * Sign(scale).asDiagonal();
  return -(rinv * stage_vec);
}

TEST_F(TierpsySkeletons, StageAlignmentPutsAStillWormAtOnePlacePosition) {
  // Video frames 0…7 carry timestamps 0, 1, 2, 4, …, 8 (timestamp 3 was dropped). The
  // stage moves every frame and is in motion at frame 5 (stage_vec NaN); the worm lies
  // still on the plate at P, so its image moves against the stage.
  const std::vector<double> raw = {0, 1, 2, 4, 5, 6, 7, 8};
  const double a = 0.1;
  Eigen::Matrix2d R;
  R << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
  const Vec2 scale(-4, 4);
  const std::vector<Vec2> P = Worm(0, Vec2(5000, 6000));
  std::vector<std::vector<Vec2>> px;
  std::vector<double> stage_vec;
  std::vector<SkelRow> rows;
  for (int f = 0; f < 8; ++f) {
    const Vec2 v = f == 5 ? Vec2(NAN, NAN) : Vec2(100.0 * f, -50.0 * f);
    stage_vec.insert(stage_vec.end(), {v.x(), v.y()});
    const Vec2 inv = f == 5 ? Vec2::Zero() : StageInv(R, scale, v);
    std::vector<Vec2> image;
    for (const Vec2& p : P) image.push_back((p - inv) / 4.0);
    px.push_back(f == 1 ? testing::NaNWorm() : image);
    rows.push_back({f, raw[f], f == 1 ? 0 : 1, f == 1 || f == 6 ? 0 : 1});
  }
  auto write = [&](const std::string& path, long has_finished) {
    PyTablesWriter w(path);
    WriteSkeletons(w, rows, px, /*microns_per_pixel=*/3.9);
    w.Group("/timestamp");
    w.Array("/timestamp/raw", {raw.size()}, raw, false, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE);
    w.Group("/stage_movement");
    w.Array("/stage_movement/stage_vec", {8, 2}, stage_vec, false, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE);
    w.IntAttr("/stage_movement", "has_finished", has_finished);
    w.DoubleAttr("/stage_movement", "fps", {30.0});
    w.DoubleAttr("/stage_movement", "microns_per_pixel_scale", {scale.x(), scale.y()}, {2});
    w.DoubleAttr("/stage_movement", "rotation_matrix", {R(0, 0), R(0, 1), R(1, 0), R(1, 1)}, {2, 2});
  };
  const std::string path = Path("wt2_skeletons.hdf5");
  write(path, 1);
  auto r = ReadTierpsy(path, {});
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Kinematics& k = r->kinematics;
  ASSERT_EQ(k.frames.size(), 9u);
  EXPECT_EQ(r->summary.Report(),
            "skeletons worm 2: 9 frames, 5 valid, missing: 1 no skeleton, 1 rejected by Tierpsy's filter, 1 stage "
            "moving, 1 dropped; 49 points; calibration 4 µm/px (attribute microns_per_pixel_scale of "
            "/stage_movement), 30 fps (attribute fps); stage from /stage_movement");
  for (int ts : {0, 2, 4, 5, 8}) {
    ASSERT_TRUE(k.frames[ts].valid) << ts;
    EXPECT_NEAR(k.frames[ts].t, ts / 30.0, 1e-12);
    EXPECT_NEAR(k.frames[ts].p[0].x(), P.front().x() / 1000, 1e-6) << ts;
    EXPECT_NEAR(k.frames[ts].p[0].y(), P.front().y() / 1000, 1e-6) << ts;
    EXPECT_NEAR(k.frames[ts].p[13].x(), P.back().x() / 1000, 1e-6) << ts;
  }

  TierpsyOptions image;
  image.use_stage = false;
  auto im = ReadTierpsy(path, image);
  ASSERT_TRUE(im.ok()) << im.status().ToString();
  EXPECT_EQ(im->kinematics.NumValid(), 6);  // the stage-moving frame is kept
  EXPECT_NEAR(im->kinematics.frames[8].p[0].x(), px[7].front().x() * 4 / 1000, 1e-6);

  write(Path("failed_skeletons.hdf5"), 0);
  auto failed = ReadTierpsy(Path("failed_skeletons.hdf5"), {});
  ASSERT_FALSE(failed.ok());
  EXPECT_NE(failed.status().message().find("failed_skeletons.hdf5: /stage_movement: has_finished = 0: Tierpsy's stage "
                                           "alignment did not succeed; give --no-stage"),
            std::string::npos)
      << failed.status().message();
}

TEST_F(TierpsySkeletons, StagePositionsComeFromTheMaskedVideo) {
  // No video timestamps (NaN): frame_number is the time index, as in Tierpsy.
  std::vector<SkelRow> rows;
  std::vector<std::vector<Vec2>> px;
  std::vector<double> spp;
  for (int f = 0; f < 5; ++f) {
    rows.push_back({f, NAN, 1, 1});
    px.push_back(Worm(0.2 * f, Vec2(300 + 3 * f, 200)));
    spp.insert(spp.end(), {f == 2 ? NAN : 10.0 * f, f == 2 ? NAN : -5.0 * f});
  }
  const std::string skel = Path("single_skeletons.hdf5"), masked = Path("single.hdf5"),
                    short_masked = Path("short.hdf5");
  {
    PyTablesWriter w(skel);
    WriteSkeletons(w, rows, px, 2.5);
  }
  {
    PyTablesWriter w(masked);
    w.Array("/stage_position_pix", {5, 2}, spp, false, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE);
  }
  {
    PyTablesWriter w(short_masked);
    w.Array("/stage_position_pix", {3, 2}, spp, false, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE);
  }
  TierpsyOptions opt;
  opt.stage_file = masked;
  auto r = ReadTierpsy(skel, opt);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const Kinematics& k = r->kinematics;
  ASSERT_EQ(k.frames.size(), 5u);
  EXPECT_EQ(k.NumValid(), 4);
  EXPECT_FALSE(k.frames[2].valid);
  EXPECT_NEAR(k.frames[3].p[0].x(), (px[3].front().x() + 30) * 2.5 / 1000, 1e-6);
  EXPECT_NEAR(k.frames[3].p[0].y(), (px[3].front().y() - 15) * 2.5 / 1000, 1e-6);
  EXPECT_EQ(k.metadata.at("stage"), "from /stage_position_pix of single.hdf5");

  auto plain = ReadTierpsy(skel, {});
  ASSERT_TRUE(plain.ok()) << plain.status().ToString();
  EXPECT_EQ(plain->kinematics.NumValid(), 5);
  EXPECT_NEAR(plain->kinematics.frames[3].p[0].x(), px[3].front().x() * 2.5 / 1000, 1e-6);
  EXPECT_EQ(plain->summary.stage, "none (no /stage_movement): image coordinates");

  opt.stage_file = short_masked;
  auto too_short = ReadTierpsy(skel, opt);
  ASSERT_FALSE(too_short.ok());
  EXPECT_NE(too_short.status().message().find("short.hdf5: /stage_position_pix: 3 frames, but worm 2 has "
                                              "frame_number 3"),
            std::string::npos)
      << too_short.status().message();
}

TEST(TierpsyWormPose, ImportsTheSampleDataWithTheUsersScale) {
  const std::string h5 = std::string(WORMDRAG_SHARED_DIR) + "/data/real/wormpose_data/sample_data/features.h5";
  if (!std::filesystem::exists(h5)) GTEST_SKIP() << h5 << " not found";
  auto no_scale = ReadTierpsy(h5, {});
  ASSERT_FALSE(no_scale.ok());
  EXPECT_NE(no_scale.status().message().find("features.h5: WormPose skeletons are in pixels of each frame's crop"),
            std::string::npos)
      << no_scale.status().message();
  TierpsyOptions opt;
  opt.um_per_px = 5;
  auto r = ReadTierpsy(h5, opt);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  // PROVENANCE.md: 1000 frames at 15 fps, 280 of them all-NaN, 52 points.
  EXPECT_EQ(r->kinematics.frames.size(), 1000u);
  EXPECT_EQ(r->kinematics.NumValid(), 720);
  EXPECT_DOUBLE_EQ(r->kinematics.fps, 15);
  EXPECT_EQ(r->summary.points, 52);
  EXPECT_EQ(r->summary.calibration, "5 µm/px (--um-per-px), 15 fps (attribute framerate)");
}

}  // namespace
}  // namespace wormdrag
