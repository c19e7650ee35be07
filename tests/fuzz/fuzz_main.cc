// One libFuzzer binary per target: WORMDRAG_FUZZ_TARGET names the entry of targets.h.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "tests/fuzz/targets.h"

#define WORMDRAG_STR2(x) #x
#define WORMDRAG_STR(x) WORMDRAG_STR2(x)

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const auto run = [] {
    for (const auto& t : wormdrag::fuzz::Targets())
      if (t.name == WORMDRAG_STR(WORMDRAG_FUZZ_TARGET)) return t.run;
    std::abort();
  }();
  return run(data, size);
}
