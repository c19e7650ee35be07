// The tracker's per-frame quality file, written beside a kinematics file (K.csv →
// K.quality.csv; docs/conventions.md §6 leaves the kinematics format itself unchanged):
// '#' comment lines, a header `frame,t,status,quality`, one row per frame of the
// kinematics file in the same order. `status` is `valid` or the reason a frame is missing
// (coiled, touching, touches-border, no-worm, no-skeleton, …); `quality` ∈ [0, 1] says how
// well the written skeleton explains the worm in the image (the IoU of the body re-drawn
// from it against the worm's mask; 0 for a missing frame), so an estimator can skip or
// down-weight frames.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/common/status.h"

namespace wormdrag {

struct FrameQuality {
  int frame = 0;
  double t = 0;        // s, as in the kinematics file
  std::string status;  // "valid" or the missing reason
  double quality = 0;  // [0, 1]
};

// "dir/K.csv" → "dir/K.quality.csv" (any other name: NAME + ".quality.csv").
std::string QualityPathFor(const std::string& kinematics_path);

std::string FormatFrameQuality(const std::vector<FrameQuality>& rows);
Status WriteFrameQuality(const std::vector<FrameQuality>& rows, const std::string& path);
// `name` is used in error messages ("k.quality.csv:4: column 4 (quality): …").
Result<std::vector<FrameQuality>> ParseFrameQuality(std::string_view text, const std::string& name);
Result<std::vector<FrameQuality>> ReadFrameQuality(const std::string& path);

// The kinematics text with every frame whose quality is below `min_quality` marked
// missing (its point cells `nan`, its time kept); everything else is left as written.
// The quality rows must be the kinematics file's frames in order (same count, times
// within 1e-5 s); `kinematics_name` and `quality_name` name the files in errors.
// `masked` (optional): the frames newly marked missing.
Result<std::string> MaskLowQualityFrames(std::string_view kinematics_text, const std::string& kinematics_name,
                                         const std::vector<FrameQuality>& quality, const std::string& quality_name,
                                         double min_quality, int* masked = nullptr);

}  // namespace wormdrag
