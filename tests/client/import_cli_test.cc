// wormdrag import of tracker output as a user runs it: a Tierpsy featuresN file written
// the way PyTables writes it, and a DeepLabCut CSV, through the real binary.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "core/io/kinematics.h"
#include "run_wormdrag.h"
#include "tests/core/io/tierpsy_files.h"

namespace wormdrag {
namespace {

using ::wormdrag::testing::Outcome;
using ::wormdrag::testing::RunWormdrag;

class ImportCli : public ::wormdrag::testing::ScratchDir {};

TEST_F(ImportCli, ImportsOneWormOfATierpsyFeaturesFile) {
  const std::string h5 = Path("plate_featuresN.hdf5"), out = Path("k.csv");
  ::wormdrag::testing::TwoWormsFeaturesN(h5);
  const Outcome both = RunWormdrag("import " + h5 + " --out " + out);
  EXPECT_EQ(both.code, 2) << both.out;
  EXPECT_NE(both.out.find("/trajectories_data: 2 worms (worm_index_joined 3, 7); choose one with --worm"),
            std::string::npos)
      << both.out;
  const Outcome absent = RunWormdrag("import " + h5 + " --worm 9 --out " + out);
  EXPECT_EQ(absent.code, 2);
  EXPECT_NE(absent.out.find("no worm with worm_index_joined 9; the file has 3, 7"), std::string::npos) << absent.out;

  const Outcome ok = RunWormdrag("import " + h5 + " --worm 3 --out " + out);
  ASSERT_EQ(ok.code, 0) << ok.out;
  EXPECT_NE(ok.out.find("featuresN worm 3: 10 frames, 7 valid, missing: 2 no skeleton, 1 dropped"), std::string::npos)
      << ok.out;
  auto k = ReadKinematics(out);
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  EXPECT_EQ(k->frames.size(), 10u);
  EXPECT_EQ(k->NumValid(), 7);
  EXPECT_EQ(k->metadata.at("source"), "Tierpsy featuresN plate_featuresN.hdf5 worm 3");
  EXPECT_NEAR(k->BodyLength(), 1.0, 0.25);  // the 1 mm test worm, bent

  const Outcome stage = RunWormdrag("import " + h5 + " --worm 3 --no-stage --out " + out);
  EXPECT_EQ(stage.code, 2);
  EXPECT_NE(stage.out.find("--stage and --no-stage apply to *_skeletons.hdf5 files"), std::string::npos) << stage.out;
}

TEST_F(ImportCli, ImportsADeepLabCutCsvRecognisedByItsHeader) {
  const std::string csv = Path("worm_DLC.csv"), out = Path("k.csv");
  std::ofstream(csv) << "scorer,S,S,S,S,S,S,S,S,S\n"
                        "bodyparts,head,head,head,mid,mid,mid,tail,tail,tail\n"
                        "coords,x,y,likelihood,x,y,likelihood,x,y,likelihood\n"
                        "0,100,200,0.99,150,200,0.99,200,200,0.99\n"
                        "1,101,200,0.99,151,200,0.40,201,200,0.99\n"
                        "2,102,200,0.99,152,200,0.99,202,200,0.99\n";
  const Outcome uncalibrated = RunWormdrag("import " + csv + " --out " + out);
  EXPECT_EQ(uncalibrated.code, 2);
  EXPECT_NE(uncalibrated.out.find("worm_DLC.csv: a pose CSV holds pixels and frame numbers only: give --fps and "
                                  "--um-per-px"),
            std::string::npos)
      << uncalibrated.out;
  const Outcome twice = RunWormdrag("import " + csv + " --fps 10 --um-per-px 4 --mm-per-px 0.004 --out " + out);
  EXPECT_EQ(twice.code, 2);
  EXPECT_NE(twice.out.find("give the scale once"), std::string::npos) << twice.out;
  const Outcome bad_p = RunWormdrag("import " + csv + " --fps 10 --um-per-px 4 --min-likelihood 2 --out " + out);
  EXPECT_EQ(bad_p.code, 2);
  EXPECT_NE(bad_p.out.find("--min-likelihood must be within 0 … 1"), std::string::npos) << bad_p.out;

  const Outcome ok = RunWormdrag("import " + csv + " --fps 10 --um-per-px 4 --out " + out);
  ASSERT_EQ(ok.code, 0) << ok.out;
  EXPECT_NE(ok.out.find("DeepLabCut: 3 body parts (head … tail); 3 frames, 2 valid, missing: 1 likelihood < 0.6"),
            std::string::npos)
      << ok.out;
  auto k = ReadKinematics(out);
  ASSERT_TRUE(k.ok()) << k.status().ToString();
  ASSERT_EQ(k->frames.size(), 3u);
  EXPECT_FALSE(k->frames[1].valid);
  EXPECT_NEAR(k->frames[2].p[0].x(), 102 * 4 / 1000.0, 1e-9);
  EXPECT_NEAR(k->BodyLength(), 100 * 4 / 1000.0, 1e-9);

  const Outcome lenient = RunWormdrag("import " + csv + " --fps 10 --um-per-px 4 --min-likelihood 0.3 --out " + out);
  ASSERT_EQ(lenient.code, 0) << lenient.out;
  EXPECT_NE(lenient.out.find("3 frames, 3 valid"), std::string::npos) << lenient.out;
}

TEST_F(ImportCli, HelpNamesTheTrackerFormats) {
  const Outcome help = RunWormdrag("import --help");
  ASSERT_EQ(help.code, 0);
  for (const char* s :
       {"tierpsy (*_featuresN.hdf5, *_skeletons.hdf5)", "--um-per-px", "--min-likelihood", "--no-stage"})
    EXPECT_NE(help.out.find(s), std::string::npos) << s;
}

}  // namespace
}  // namespace wormdrag
