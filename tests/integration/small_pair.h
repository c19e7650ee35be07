// The pair the service tests estimate: the paper's pattern at amplitudes 0.4 and 0.6
// rad, 100 fps, driven with known friction, as CSV text. Small enough for a job of a
// few seconds on one worker.
#pragma once

#include <array>
#include <string>

#include <gtest/gtest.h>

#include "core/io/kinematics.h"
#include "core/jobs/estimate_job.h"
#include "core/sim/pattern.h"

namespace wormdrag::itest {

inline std::array<JobInput, 2> SmallPair(double duration = 1) {
  std::array<JobInput, 2> in;
  const double amp[2] = {0.4, 0.6};
  for (int j = 0; j < 2; ++j) {
    JointPattern p;
    p.amplitude = amp[j];
    RecordingSpec rs;
    rs.fps = 100;
    rs.duration = duration;
    auto k = GenerateRecording(p, {0.5, 0.2, 0.005, 0.002}, SimOptions(), rs);
    EXPECT_TRUE(k.ok()) << k.status().ToString();
    in[j] = {"worm" + std::to_string(j + 1) + ".csv", FormatKinematics(*k)};
  }
  return in;
}

}  // namespace wormdrag::itest
