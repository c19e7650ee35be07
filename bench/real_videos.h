// The real videos of ../shared/data/real that video_bench and turn_bench both read: the
// wormpose crops with their Tierpsy reference skeletons, and the WormTracer video with its
// manual masks. Each loader prints why it failed and returns false.
#pragma once

#include <filesystem>
#include <vector>

#include <opencv2/core.hpp>

#include "core/video/tracker.h"

namespace wormdrag::video {

// wormpose_data's reference skeletons: (1000, 52, 2) float64, pixels of each crop; a
// frame without a reference holds NaN.
bool ReadWormposeSkeletons(const std::filesystem::path& h5, std::vector<double>* data);
// wormpose_data's 1000 crops (00000.png …), grey.
bool ReadWormposeCrops(const std::filesystem::path& dir, std::vector<cv::Mat>* crops);
// How both benches track the crops: as one video, tight around a dark worm (touching
// the border is no reason to drop a frame), positions not comparable between crops.
TrackOptions WormposeTrackOptions();
// The WormTracer video (grey) and its manual masks, unzipped into `work` once.
bool ReadWormTracer(const std::filesystem::path& shared, const std::filesystem::path& work,
                    std::vector<cv::Mat>* frames, std::vector<cv::Mat>* masks);

}  // namespace wormdrag::video
