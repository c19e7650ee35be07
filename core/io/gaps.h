// Short gaps of missing frames (dropped frames, tracker failures): kept as missing by
// default; optionally filled by interpolating the body's shape and pose across the gap.
#pragma once

#include "core/io/kinematics.h"

namespace wormdrag {

// Fills every run of at most `max_gap_frames` missing frames that has a valid frame on
// both sides: joint angles q_k, the rigid pose (x, y, q0, with q0 unwrapped) and the link
// length are interpolated linearly in time between the two valid frames, and the points
// rebuilt from them (so the body keeps its length and bends smoothly, unlike averaging
// points). The pose is each valid frame's best fit to all its points (docs/conventions.md §3).
// Returns the number of frames filled; adds metadata 'interpolated_frames'.
int InterpolateShortGaps(Kinematics& k, int max_gap_frames);

}  // namespace wormdrag
