// --gap-check: gap_offset's mark in the residual of a base fit.
#include <cstdio>

#include "core/diagnose/gap_signature.h"

#include "bench/diagnose/bench.h"

namespace wormdrag::diagnose_bench {

int GapCheck(const Bench& b) {
  const DiagnoseOptions& o = b.o;
  // gap_offset's mark in a base fit's residual (gap_signature.h) under the given
  // coefficients (e.g. the diagnosis's base fit, from its output).
  LoadedPair p;
  if (const int rc = LoadPair(b, "--gap-check", &p)) return rc;
  auto data = PrepareForDiagnosis(p.k, o);
  if (!data.ok()) {
    std::fprintf(stderr, "%s\n", data.status().ToString().c_str());
    return 1;
  }
  const GapSignature g = MeasureGapSignature(*data, p.coef, o.epsilon);
  std::printf("%llu %s %d excess %.4f se %.4f z %.2f at_gaps %.4f elsewhere %.4f gaps %d windows %d\n",
              static_cast<unsigned long long>(p.c.seed), p.c.effect.c_str(), p.c.strength, g.excess, g.se, g.Z(),
              g.at_gaps, g.elsewhere, g.gaps, g.windows);
  return 0;
}

}  // namespace wormdrag::diagnose_bench
