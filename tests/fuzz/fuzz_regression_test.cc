// Replays the seed corpus and every finding the fuzzers made (regressions/<target>/)
// through the fuzz targets' entry functions, in every build: a finding stays fixed.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "tests/fuzz/targets.h"

namespace wormdrag::fuzz {
namespace {

namespace fs = std::filesystem;

int Replay(const Target& t, const char* kind) {
  const fs::path dir = fs::path(WORMDRAG_FUZZ_DIR) / kind / t.name;
  if (!fs::is_directory(dir)) return 0;
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    SCOPED_TRACE(e.path().string());
    EXPECT_EQ(t.run(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), 0);
    ++n;
  }
  return n;
}

TEST(FuzzRegression, EveryTargetHasASeedCorpus) {
  for (const auto& t : Targets()) EXPECT_GT(Replay(t, "corpus"), 0) << t.name;
}

TEST(FuzzRegression, KeptFindingsStayFixed) {
  for (const auto& t : Targets()) Replay(t, "regressions");
}

}  // namespace
}  // namespace wormdrag::fuzz
