// Video → kinematics (docs/video.md): per frame binarise, denoise, keep the worm's component,
// skeletonise, take the longest path, refine it to a sub-pixel centreline, split it into 13
// equal parts; across frames keep head and tail consistent and carry the body through
// coils where it crawls along its track; finally calibrate px → mm. A frame that cannot be
// measured reliably (worm touching the border, coiled, touching itself, no usable
// skeleton) is written as missing, never as a wrong skeleton.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/common/status.h"
#include "core/io/frame_quality.h"
#include "core/io/kinematics.h"
#include "core/model/body.h"
#include "core/video/body_check.h"
#include "core/video/skeleton.h"

namespace wormdrag::video {

struct TrackOptions {
  double fps = 0;                       // 0: the container's rate (an error if it has none)
  double um_per_px = 0;                 // 0: uncalibrated, lengths written in px (metadata says so)
  Polarity polarity = Polarity::kAuto;  // kAuto: decided once from the first frames
  int background_kernel_px = 0;         // 0: min(width, height)/5 clamped to [15, 101]
  double denoise_sigma_px = 1.0;        // Gaussian blur before thresholding
  // Threshold: Otsu's split of the foreground response, then (half_contrast) moved to
  // halfway between the background's and the body's median response: the edge of a
  // blurred body. threshold_scale multiplies the result.
  bool half_contrast = true;
  // With half_contrast, the worm's mask (component, holes, border, skeleton) is cut at
  // this fraction of the body's contrast instead: the dim rim of a real worm is worm.
  // Edges for the centreline's geometry stay at the half-contrast level.
  double mask_fraction = 0.35;
  double threshold_scale = 1.0;
  int min_area_px = 30;       // smaller largest component: no worm
  bool reject_border = true;  // a worm within border_margin_px of the edge is missing
  int border_margin_px = 1;
  // A skeleton shorter than this fraction of the running median length means the body
  // overlaps itself (coiled, or an omega turn) even when no hole shows: missing.
  double min_length_ratio = 0.85;
  // A centreline that leaves more than this fraction of the mask unexplained (the body
  // re-drawn from it at the mask's widths, body_check.h) short-cuts a body that touches
  // itself: missing, reason "touching". Default 0.04: right skeletons leave at most 0.033
  // (wormpose frames with a Tierpsy reference, 0.019 on rendered videos); a head hooked
  // back onto the body leaves 0.04–0.09 (rendered hairpin, docs/video.md).
  double max_unexplained = 0.04;
  bool extrapolate_tips = false;  // see RefineCentreline
  // A tapered end continues to the mask level (see ExtendEnd in skeleton.cc); false: every
  // end stops at half contrast (the behaviour before; kept for comparisons).
  bool tapered_tips = true;
  int max_link_gap = 10;  // frames across which head/tail continuity is trusted
  // Runs separated by up to this many seconds of missing frames (a coil, a turn) are
  // linked when the later body lies on the earlier one's track (orient.h). Default 3 s:
  // the coils of the rendered and real recordings in docs/video.md last 1–2.5 s.
  double max_chain_gap_s = 3.0;
  // False when every frame is a separate crop (wormpose_data): positions are not
  // comparable between frames, and the head comes from the bending wave alone.
  bool positions_comparable = true;
  // Carry the body through coiled and touching frames along its track (carry.h) where
  // the carried body explains the frame's mask; false: such frames stay missing. Needs
  // positions_comparable. Default true.
  bool carry = true;
  int first_frame = 0;  // frames before it are skipped (not written)
  int max_frames = 0;   // 0: all
};

enum class MissingReason { kNone = 0, kNoWorm, kTouchesBorder, kCoiled, kSkeletonFailed, kTouching };
const char* MissingReasonName(MissingReason r);

// One frame analysed in isolation (no head/tail decision yet).
struct FrameAnalysis {
  MissingReason reason = MissingReason::kNoWorm;
  cv::Mat mask;         // the worm's component, 0/255, full frame size
  cv::Mat foreground;   // the whole frame's binarisation (every component at the
                        // mask level, before the worm's is chosen), 0/255
  Polyline centreline;  // sub-pixel, arbitrary end first; empty if missing
  double length_px = 0;
  double half_width_px = 0;  // largest half-width (distance transform)
  double threshold = 0;
  BodyFit fit;  // how well the centreline explains the mask (body_check.h)
};

// The parameters of AnalyseFrame resolved for a video (polarity, kernel).
struct FrameParams {
  Polarity polarity = Polarity::kDarkOnLight;  // never kAuto here
  int background_kernel_px = 31;
  double denoise_sigma_px = 1.0;
  bool half_contrast = true;
  double mask_fraction = 0.35;
  double threshold_scale = 1.0;
  int min_area_px = 30;
  bool reject_border = true;
  int border_margin_px = 1;
  double max_unexplained = 0.04;
  bool extrapolate_tips = false;
  bool tapered_tips = true;
};

FrameAnalysis AnalyseFrame(const cv::Mat& gray8, const FrameParams& params);

// Resolves kAuto polarity (majority over `frames`) and the automatic kernel.
FrameParams ResolveParams(const TrackOptions& opt, const std::vector<cv::Mat>& first_frames);

struct FrameTrack {
  MissingReason reason = MissingReason::kNoWorm;
  bool valid() const { return reason == MissingReason::kNone; }
  Points px{};  // 14 points head → tail, pixels (image axes)
  double length_px = 0;
  BodyFit fit;  // of the frame's own centreline to its mask; zero when none was found
  // The sub-pixel centreline the points were taken from, either end first (valid frames;
  // carry.h builds the track through a coil from it).
  Polyline centreline;
  bool carried = false;      // the body carried through a coil along its track (carry.h)
  int run = -1, chain = -1;  // of the head/tail order (orient.h); -1 for missing frames
  // Coiled and touching frames: the worm's mask, cropped to its box at `mask_offset`, for
  // carrying the body through them; released once tracking is finished.
  cv::Mat mask;
  cv::Point mask_offset;
  // The IoU of the body re-drawn from the written skeleton against the worm's mask
  // (body_check.h); 0 for a missing frame. Written beside the kinematics (quality file).
  double quality() const { return valid() ? fit.iou : 0.0; }
};

struct TrackSummary {
  int frames = 0;
  int valid = 0;
  int carried = 0;                       // of the valid: bodies carried through coils
  std::map<MissingReason, int> missing;  // by reason
  int runs = 0;                          // stretches of frames linked by head/tail continuity
  int chains = 0;                        // runs linked across gaps (orient.h), oriented together
  int runs_flipped = 0;                  // reversed: their chain travelled tail first
  int runs_undecided = 0;                // too little evidence of travel in the chain; as found
  Polarity polarity = Polarity::kAuto;
  double seconds = 0;  // wall time of the tracking
  double frames_per_second() const { return seconds > 0 ? frames / seconds : 0; }
  // "1500 frames, 1302 valid, missing: 150 coiled, 48 touches-border; 12 runs (2 flipped); 410 frames/s"
  std::string Report() const;
};

struct TrackResult {
  Kinematics kinematics;              // mm if calibrated, else px (metadata 'calibration')
  std::vector<FrameQuality> quality;  // one row per frame of `kinematics` (frame_quality.h)
  std::vector<FrameTrack> frames;
  TrackSummary summary;
};

using ProgressFn = std::function<void(int done, int total)>;  // total −1 if unknown

// Tracks frames already in memory (tests, benchmarks).
Result<TrackResult> TrackFrames(const std::vector<cv::Mat>& frames, double fps, const TrackOptions& opt,
                                const ProgressFn& progress = nullptr);
// Tracks a video file, a multi-page TIFF or a folder of images.
Result<TrackResult> TrackFile(const std::string& input, const TrackOptions& opt, const ProgressFn& progress = nullptr);

// Draws each frame's skeleton (head red, tail blue, joints green, the body orange when
// carried through a coil; missing frames marked with their reason) on the input frames:
// a video if `out` ends in .avi/.mp4/.mkv, otherwise PNGs in folder `out` (created).
Status WriteOverlay(const std::string& input, const TrackResult& result, const TrackOptions& opt,
                    const std::string& out, const ProgressFn& progress = nullptr);

}  // namespace wormdrag::video
