// Hostile and unlucky inputs to the importers and the job options: each is an
// InvalidArgument naming the file and field, never an exception or an abort.
#include <string>

#include <gtest/gtest.h>

#include "core/io/kinematics.h"
#include "core/io/kymogram.h"
#include "core/io/wcon.h"
#include "core/jobs/estimate_job.h"

namespace wormdrag {
namespace {

std::string NpyWithShape(const std::string& shape, size_t data_bytes) {
  std::string h = "{'descr': '<f8', 'fortran_order': False, 'shape': " + shape + ", }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string out = "\x93NUMPY\x01";
  out += '\0';
  out += static_cast<char>(h.size() & 0xff);
  out += static_cast<char>(h.size() >> 8);
  return out + h + std::string(data_bytes, '\0');
}

// Format 2.0: a 4-byte header length, so the header may be long.
std::string NpyWithShapeV2(const std::string& shape, size_t data_bytes) {
  std::string h = "{'descr': '<f8', 'fortran_order': False, 'shape': " + shape + ", }\n";
  std::string out = "\x93NUMPY\x02";
  out += '\0';
  for (int i = 0; i < 4; ++i) out += static_cast<char>((h.size() >> (8 * i)) & 0xff);
  return out + h + std::string(data_bytes, '\0');
}

void ExpectInvalid(const Status& st, const std::string& part) {
  EXPECT_EQ(st.code(), Status::Code::kInvalidArgument) << st.ToString();
  EXPECT_NE(st.message().find(part), std::string::npos) << st.message();
}

TEST(HostileInput, NpyShapeBeyondIntIsRefused) {
  ExpectInvalid(ParseNpy(NpyWithShape("(99999999999999999999, 3)", 48), "k.npy").status(), "k.npy: 'shape'");
}

TEST(HostileInput, NpyShapeLargerThanItsDataIsRefusedBeforeAllocating) {
  ExpectInvalid(ParseNpy(NpyWithShape("(2000000000, 2000000000)", 48), "k.npy").status(), "k.npy: 'shape'");
  auto ok = ParseNpy(NpyWithShape("(2, 3)", 48), "k.npy");
  ASSERT_TRUE(ok.ok()) << ok.status().ToString();
  EXPECT_EQ(ok->rows, 2);
}

TEST(HostileInput, NpyHeaderLongerThanNumpyAllowsIsRefused) {
  std::string shape = "(2,";
  shape += std::string(200000, ' ');
  shape += "3)";
  ExpectInvalid(ParseNpy(NpyWithShapeV2(shape, 48), "k.npy").status(), "k.npy: .npy header of");
}

TEST(HostileInput, WconWhoseXIsANumberIsRefused) {
  const std::string w = R"({"units":{"t":"s","x":"mm","y":"mm"},
    "data":[{"id":"1","t":[0,1],"x":5,"y":[[1,2,3],[1,2,3]]}]})";
  ExpectInvalid(ParseWcon(w, {}, "w.wcon").status(), "w.wcon: data[0].x");
}

TEST(HostileInput, WconWithFewerXEntriesThanTimesIsRefused) {
  const std::string w = R"({"units":{"t":"s","x":"mm","y":"mm"},
    "data":[{"id":"1","t":[0,1,2],"x":[[0,1,2]],"y":[[0,0,0]]}]})";
  ExpectInvalid(ParseWcon(w, {}, "w.wcon").status(), "w.wcon: data[0].x");
}

TEST(HostileInput, WconTimeSpanOfBillionsOfFramesIsRefused) {
  const std::string w = R"({"units":{"t":"s","x":"mm","y":"mm"},
    "data":[{"id":"1","t":[0,1e9],"x":[[0,1,2],[0,1,2]],"y":[[0,0,0],[0,0,0]]}]})";
  WconReadOptions o;
  o.fps = 30;
  ExpectInvalid(ParseWcon(w, o, "w.wcon").status(), "w.wcon: data t spans");
}

TEST(HostileInput, CsvWithMoreFramesThanAllowedIsRefused) {
  std::string csv = "# fps: 30\nt,x0,y0,x1,y1,x2,y2\n0,0,0,1,0,2,0\n";
  csv.reserve(csv.size() + 9 * (kMaxFrames + 1));
  for (int i = 1; i <= kMaxFrames; ++i) csv += std::to_string(i) + "\n";
  ExpectInvalid(ParseKinematics(csv, "k.csv").status(), "k.csv:");
}

// Rows that are a time and nothing else (every frame missing): held as times while no
// frame has points, so the file is refused without building a frame. A reader that
// knows the job's t_max refuses at the first row past it, naming line and column.
TEST(HostileInput, CsvOfTimeOnlyRowsIsRefusedWithoutBuildingFrames) {
  std::string csv = "# fps: 100\nt,x0,y0,x1,y1,x2,y2\n";
  for (int i = 0; i < 1000; ++i) csv += std::to_string(i / 100.0) + "\n";
  ExpectInvalid(ParseKinematics(csv, "k.csv").status(),
                "k.csv: every frame is missing: none of the 1000 rows after the header (line 2) has a number in "
                "every column x0 … y2");
  // t = 1.01 (line 104) is the first row past t_max = 1 s and its half-frame slack.
  ExpectInvalid(ParseKinematics(csv, "k.csv", {1.0}).status(), "k.csv:104: column 2 (x0): no row within 1 s");
  // A frame with points within t_max is enough; the missing frames keep their places.
  csv.insert(csv.find("1.000000\n"), "0.995,0,0,1,0,2,0\n");
  auto k = ParseKinematics(csv, "k.csv", {1.0});
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  ASSERT_EQ(k->frames.size(), 1001u);
  EXPECT_EQ(k->NumValid(), 1);
  EXPECT_TRUE(k->frames[100].valid);
  EXPECT_DOUBLE_EQ(k->frames[100].t, 0.995);
  EXPECT_DOUBLE_EQ(k->frames[99].t, 0.99);
  EXPECT_DOUBLE_EQ(k->frames[101].t, 1.0);
  EXPECT_DOUBLE_EQ(k->frames.back().t, 9.99);
}

TEST(HostileInput, JobOptionsWithOutOfRangeIntegersAreRefused) {
  JobOptions o;
  std::string json = o.ToJson();
  const std::string key = "\"substeps\":0";
  ASSERT_NE(json.find(key), std::string::npos) << json;
  for (const char* v : {"1e300", "99999999999", "-1e300", "2.5"}) {
    std::string bad = json;
    bad.replace(bad.find(key), key.size(), std::string("\"substeps\":") + v);
    ExpectInvalid(JobOptionsFromJson(bad).status(), "substeps");
  }
}

}  // namespace
}  // namespace wormdrag
