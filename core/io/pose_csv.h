// Import of body-part tracks from pose-estimation tools, as CSV in pixels:
//
// - DeepLabCut (pandas' to_csv of its MultiIndex table): header rows whose first cell
//   names the level, "scorer", "individuals" (multi-animal projects only), "bodyparts",
//   "coords"; one index column (the video frame number) or three (labelled images:
//   folder, video, image), then per body part the columns x, y and, for predictions,
//   likelihood. An empty cell means not detected. Multi-animal files add the
//   individual "single" for unique body parts, which are not part of a worm.
// - SLEAP's analysis CSV: header track, frame_idx, instance.score, then <node>.x,
//   <node>.y, <node>.score per node; one row per tracked instance and frame.
// - plain: a header x0,y0,…,xM,yM, optionally led by a frame column, or no header at
//   all (2(M+1) numbers per row, one row per frame).
//
// The body parts (nodes, columns) must be listed head → tail, at least 3. A frame is
// missing when a coordinate is empty or NaN, when a point's likelihood (score) is below
// the threshold, or when no row has its frame number (frames between the first and
// last row). The time base is the file's: t = frame / fps. Coordinates stay in image
// axes (y down), scaled to mm.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/common/status.h"
#include "core/io/kinematics.h"

namespace wormdrag {

struct PoseCsvOptions {
  double fps = 0;        // frames per second; required (the files hold none)
  double um_per_px = 0;  // image scale; required
  // A multi-animal DeepLabCut individual or a SLEAP track; "" = the file's only one.
  std::string individual;
  // Default: 0.6, why: DeepLabCut's default pcutoff, the likelihood below which its own
  // plots and filters treat a point as not detected.
  double min_likelihood = 0.6;
};

struct PoseCsvSummary {
  std::string layout;  // "DeepLabCut", "multi-animal DeepLabCut", "SLEAP" or "plain"
  std::string individual;
  std::vector<std::string> bodyparts;  // head → tail
  int frames = 0, valid = 0;
  // Missing frames by reason, each counted once, in this order.
  int absent = 0;          // no row for the frame number
  int undetected = 0;      // an empty or NaN coordinate
  int low_likelihood = 0;  // a point below min_likelihood
  // "DeepLabCut: 14 body parts (head … tail); 300 frames, 290 valid, missing: 6 undetected,
  //  4 likelihood < 0.6"
  std::string Report(double min_likelihood) const;
};

struct PoseCsvImport {
  Kinematics kinematics;  // mm; metadata fps, units, source, calibration, bodyparts, import
  PoseCsvSummary summary;
};

// True for a first line that starts one of the layouts above (and not a kinematics file).
bool LooksLikePoseCsv(std::string_view first_line);

// `name` is used in error messages ("dlc.csv:7: column 5 (mid y): not a number 'abc'").
Result<PoseCsvImport> ParsePoseCsv(std::string_view text, const PoseCsvOptions& opt, const std::string& name);
Result<PoseCsvImport> ReadPoseCsv(const std::string& path, const PoseCsvOptions& opt);

}  // namespace wormdrag
