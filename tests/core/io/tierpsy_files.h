// Small files in Tierpsy Tracker's layouts for the import tests, written the way
// PyTables writes them (see pytables_writer.h).
#pragma once

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/model/body.h"
#include "tests/core/io/pytables_writer.h"

namespace wormdrag::testing {

// A fresh directory per test, removed afterwards.
class ScratchDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = ::testing::TempDir() + "/io_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name();
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  std::string dir_;
};

constexpr int kPoints = 49;

// A worm of 49 points head → tail, 1 mm long along x with a wave across it, µm.
inline std::vector<Vec2> Worm(double phase, Vec2 origin) {
  std::vector<Vec2> w;
  for (int j = 0; j < kPoints; ++j) {
    const double s = j * 1000.0 / (kPoints - 1);
    w.push_back(origin + Vec2(s, 60 * std::sin(2 * M_PI * s / 600 - phase)));
  }
  return w;
}

inline std::vector<double> Flatten(const std::vector<std::vector<Vec2>>& skeletons) {
  std::vector<double> v;
  for (const auto& s : skeletons)
    for (const Vec2& p : s) v.insert(v.end(), {p.x(), p.y()});
  return v;
}

inline std::vector<Vec2> NaNWorm() {
  return std::vector<Vec2>(kPoints, Vec2(NAN, NAN));
}

struct FeatRow {
  int ts, worm, sid, skeletonized;
};
// A *_featuresN.hdf5 as Tierpsy's smooth_skeletons_table writes it; `calibrated`
// false: the attributes Tierpsy sets when the video had no fps and no scale.
inline void WriteFeaturesN(const std::string& path, const std::vector<FeatRow>& rows,
                           const std::vector<std::vector<Vec2>>& skel, bool calibrated = true) {
  PyTablesWriter w(path);
  ASSERT_TRUE(w.ok());
  std::vector<Column> c = {
      {"timestamp_raw", ColType::kInt32, {}},     {"timestamp_time", ColType::kFloat32, {}},
      {"worm_index_joined", ColType::kInt32, {}}, {"coord_x", ColType::kFloat32, {}},
      {"coord_y", ColType::kFloat32, {}},         {"threshold", ColType::kFloat32, {}},
      {"roi_size", ColType::kFloat32, {}},        {"area", ColType::kFloat32, {}},
      {"frame_number", ColType::kInt32, {}},      {"was_skeletonized", ColType::kUInt8, {}},
      {"skeleton_id", ColType::kInt32, {}},       {"old_trajectory_data_index", ColType::kInt32, {}}};
  for (size_t i = 0; i < rows.size(); ++i) {
    const FeatRow& r = rows[i];
    const double v[] = {double(r.ts), r.ts / 25.0,  double(r.worm),         500,           400,      90, 128,
                        3000,         double(r.ts), double(r.skeletonized), double(r.sid), double(i)};
    for (size_t j = 0; j < c.size(); ++j) c[j].values.push_back(v[j]);
  }
  w.Table("/trajectories_data", c);
  const std::string t = "/trajectories_data";
  w.DoubleAttr(t, "microns_per_pixel", {calibrated ? 10.0 : 1.0});
  w.StringAttr(t, "xy_units", calibrated ? "micrometers" : "pixels");
  w.DoubleAttr(t, "fps", {calibrated ? 25.0 : 1.0});
  w.DoubleAttr(t, "expected_fps", {calibrated ? 25.0 : 1.0});
  w.StringAttr(t, "time_units", calibrated ? "seconds" : "frames");
  w.IntAttr(t, "is_light_background", 1);
  w.BoolAttr(t, "is_WT2", false);
  w.StringAttr(t, "ventral_side", "clockwise");
  w.Group("/coordinates");
  w.Array("/coordinates/skeletons", {skel.size(), kPoints, 2}, Flatten(skel), true);
}

// Worm 3 over timestamps 10…19 (15 dropped, 12 without skeleton, 17 all NaN, 18
// interpolated by Tierpsy) and worm 7 over 0…4.
inline std::vector<std::vector<Vec2>> TwoWormsFeaturesN(const std::string& path, bool calibrated = true) {
  std::vector<FeatRow> rows;
  std::vector<std::vector<Vec2>> skel;
  for (int ts = 10; ts < 20; ++ts) {
    if (ts == 15) continue;
    const bool none = ts == 12;
    rows.push_back({ts, 3, none ? -1 : static_cast<int>(skel.size()), ts == 18 || none ? 0 : 1});
    if (!none) skel.push_back(ts == 17 ? NaNWorm() : Worm(0.3 * ts, Vec2(2000 + 20 * ts, 3000)));
  }
  for (int ts = 0; ts < 5; ++ts) {
    rows.push_back({ts, 7, static_cast<int>(skel.size()), 1});
    skel.push_back(Worm(0.3 * ts, Vec2(8000, 500 + 10 * ts)));
  }
  WriteFeaturesN(path, rows, skel, calibrated);
  return skel;
}

}  // namespace wormdrag::testing
