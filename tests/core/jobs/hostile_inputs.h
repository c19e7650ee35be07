// Inputs shared by the in-process and real-process tests of hostile recordings.
#pragma once

#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"

namespace wormdrag::hostile {

// A legal recording whose '# fps' says 0.001 while its frames are 1/100 s apart: at the
// default 600 knots/s every frame interval asks for 600 000 solver knots.
inline std::string SlowFpsRecording(int loco) {
  RecordingSpec spec;
  spec.fps = 100;
  spec.duration = 1;
  auto k = GenerateRecording(Locomotion(loco), {0.45, 0.15, 0.004, 0.002}, SimOptions(), spec);
  EXPECT_TRUE(k.ok());
  k->fps = 0.001;
  return FormatKinematics(*k);
}

// A legal recording of at least `bytes` whose rows are times only ("0.01"): every frame
// is missing. At ~8 bytes a row, each would be a ~250-byte Frame if it were built.
inline std::string TimeOnlyRecording(size_t bytes) {
  std::string csv = "# fps: 100\nt,x0,y0,x1,y1,x2,y2\n";
  csv.reserve(bytes + 32);
  char row[32];
  for (int i = 0; csv.size() < bytes; ++i) {
    std::snprintf(row, sizeof row, "%.10g\n", i / 100.0);
    csv += row;
  }
  return csv;
}

// Small, fast options for jobs that must fail before they run.
inline JobOptions SmallOptions() {
  JobOptions o;
  o.estimate.eval.t_max = 1;
  o.estimate.search.n_max = 3;
  o.smoothing = SmoothingMethod::kNone;
  o.bootstrap.replicates = 0;
  return o;
}

}  // namespace wormdrag::hostile
