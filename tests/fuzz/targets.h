// The fuzz targets' entry functions, one per untrusted input format. Each parses `data`
// as a file of its format would be parsed and returns 0; a crash, sanitizer report or
// exception is the finding. Shared by the libFuzzer binaries (fuzz_main.cc) and the
// regression test that replays the corpus and the kept findings in every build.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace wormdrag::fuzz {

int KinematicsCsv(const uint8_t* data, size_t size);
int Wcon(const uint8_t* data, size_t size);
int Npy(const uint8_t* data, size_t size);
int Wt2Mat(const uint8_t* data, size_t size);
int Celest(const uint8_t* data, size_t size);
int JobOptions(const uint8_t* data, size_t size);

struct Target {
  std::string name;  // the corpus folder: corpus/<name>/, regressions/<name>/
  int (*run)(const uint8_t*, size_t);
};
const std::vector<Target>& Targets();

}  // namespace wormdrag::fuzz
