// Import of Schafer-lab Worm Tracker 2 "features" .mat files (MATLAB v5/v7.3, read with
// matio): worm.posture.skeleton.x/y (points × frames, µm, plate coordinates, NaN =
// no skeleton) and info.video.resolution.fps. Row 0 is the head (WT2 convention).
#pragma once

#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/io/kinematics.h"

namespace wormdrag {

struct Wt2Import {
  Kinematics kinematics;        // mm, missing frames kept as missing
  std::vector<int> annotation;  // info.video.annotations.frames per frame, if present
  int points_per_frame = 0;     // 49 for WT2
};

Result<Wt2Import> ReadWt2Features(const std::string& path);

}  // namespace wormdrag
