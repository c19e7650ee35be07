#include "core/io/kymogram.h"

#include <cmath>
#include <cstring>
#include <filesystem>

#include <gtest/gtest.h>

namespace wormdrag {
namespace {

std::string Npy(const std::string& descr, int rows, int cols, const std::vector<double>& v, bool fortran = false) {
  std::string header = "{'descr': '" + descr + "', 'fortran_order': " + (fortran ? "True" : "False") + ", 'shape': (" +
                       std::to_string(rows) + ", " + std::to_string(cols) + "), }";
  while ((10 + header.size() + 1) % 64) header += ' ';
  header += '\n';
  std::string s = "\x93NUMPY";
  s += '\x01';
  s += '\x00';
  s += static_cast<char>(header.size() & 0xff);
  s += static_cast<char>(header.size() >> 8);
  s += header;
  s.append(reinterpret_cast<const char*>(v.data()), v.size() * 8);
  return s;
}

TEST(Npy, ParsesFloat64CArrays) {
  auto a = ParseNpy(Npy("<f8", 2, 3, {1, 2, 3, 4, 5, 6}), "t.npy");
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_EQ(a->rows, 2);
  EXPECT_EQ(a->cols, 3);
  EXPECT_EQ(a->at(1, 0), 4.0);
  EXPECT_FALSE(ParseNpy(Npy("<f4", 2, 3, {1, 2, 3}), "t.npy").ok());
  EXPECT_FALSE(ParseNpy(Npy("<f8", 2, 3, {1, 2, 3, 4, 5, 6}, true), "t.npy").ok());
  auto bad = ParseNpy(Npy("<f8", 2, 3, {1, 2}), "t.npy");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("t.npy"), std::string::npos);
  EXPECT_FALSE(ParseNpy("hello", "t.npy").ok());
}

TEST(Kymogram, ConstantAnglesGiveAnArcWithTheSameTotalBend) {
  // 24 angles of 0.05 rad: the 25-rod body bends by 1.2 rad in all; its 13-link
  // resampling must bend by the same total over its 12 joints, spread evenly.
  NpyArray a;
  a.rows = 3;
  a.cols = 24;
  a.data.assign(72, 0.05);
  a.data[24 + 5] = std::nan("");
  auto k = KymogramToKinematics(a, {32.0, false}, "k.npy");
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  EXPECT_FALSE(k->frames[1].valid);
  const Shape q = ShapeOf(k->frames[0].p);
  double total = 0;
  for (double v : q) total += v;
  // Chords of the end links start half a rod in: the bend seen by the 12 joints is
  // 1.2 rad less the rod-scale end effects, within a rod angle.
  EXPECT_NEAR(total, 1.2 * 12.0 / 13.0, 0.05);
  for (double v : q) EXPECT_NEAR(v, 1.2 / 13.0, 0.01);
  EXPECT_NEAR(k->BodyLength(), 1.0, 1e-9);
  EXPECT_FALSE(KymogramToKinematics(a, {0.0, false}, "k.npy").ok());
}

TEST(Kymogram, ReadsElegansBotFiles) {
  const std::string path = std::string(WORMDRAG_SHARED_DIR) + "/data/real/elegansbot/kymogram_omega-turn.npy";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not found";
  auto a = ReadNpy(path);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_EQ(a->rows, 600);
  EXPECT_EQ(a->cols, 24);
  auto k = KymogramToKinematics(*a, {32.0, false}, path);
  ASSERT_TRUE(k.ok());
  EXPECT_EQ(k->NumValid(), 600);
  EXPECT_NEAR(k->Duration(), 599 / 32.0, 1e-9);
}

}  // namespace
}  // namespace wormdrag
