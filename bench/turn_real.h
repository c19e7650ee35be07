// The real-data sections of turn_bench (docs/video.md, "Turns and coils").
#pragma once

#include <filesystem>

namespace wormdrag::video {

// wormpose_data sample: skeleton distance to Tierpsy's references, head/tail order of
// every run against theirs, missing fraction.
void WormposeTurns(const std::filesystem::path& shared);

// WormTracer video: missing fraction by reason, how well the written skeletons explain
// the manual masks, head/tail decisions over the recording. `work` holds the unzipped masks.
void WormTracerTurns(const std::filesystem::path& shared, const std::filesystem::path& work);

}  // namespace wormdrag::video
