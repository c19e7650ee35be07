// Import of one worm from Tierpsy Tracker's HDF5 files (Javer et al. 2018), written by
// PyTables:
//
// - *_featuresN.hdf5: /coordinates/skeletons (skeletons × points × 2, float32) in µm on
//   the plate, smoothed, and for single-worm (stage-tracking) videos already corrected
//   for the stage motion; /trajectories_data, a table with one row per worm and video
//   frame: worm_index_joined, timestamp_raw (frame index from the video timestamp, with
//   dropped frames filled in), frame_number, skeleton_id (row in /coordinates/skeletons,
//   −1 = none), was_skeletonized (0: Tierpsy interpolated the skeleton over a short gap).
//   Its attributes hold fps, microns_per_pixel, time_units ("frames" when no frame rate
//   was known), xy_units ("pixels" when no scale was known) and is_WT2.
// - *_skeletons.hdf5: /skeleton (rows × 49 × 2, float32, NaN where none) in pixels of
//   the video frame; /trajectories_data with skeleton_id, has_skeleton and, after
//   Tierpsy's filter, is_good_skel; timestamp_raw may be NaN (then frame_number is the
//   time index, as in Tierpsy). A stage-tracking video has /stage_movement: stage_vec
//   (µm per entry of /timestamp/raw, NaN while the stage moves), attributes
//   has_finished (1 or 2 when the alignment succeeded), rotation_matrix and
//   microns_per_pixel_scale (whose magnitude then is the image scale). Tierpsy's masked
//   video (<name>.hdf5) holds the same offsets per frame as /stage_position_pix (pixels).
// - WormPose's conversion (features.h5): root dataset skeletons (frames × points × 2,
//   pixels of each frame's crop) and root attribute framerate; no scale, no positions.
//
// Points are taken in the file's order (Tierpsy: head first). The time base is the
// file's: t = timestamp / fps; timestamps between the worm's first and last without a
// row (dropped frames) become missing frames, as do rows without a skeleton, rejected
// skeletons, skeletons with NaN and frames while the stage moved. Coordinates stay in
// image axes (y down), scaled to mm.
#pragma once

#include <string>

#include "core/common/status.h"
#include "core/io/kinematics.h"

namespace wormdrag {

struct TierpsyOptions {
  // The worm's worm_index_joined; −1: the file's only worm (with several, an error lists them).
  long worm = -1;
  double fps = 0;        // > 0: replaces the file's frame rate
  double um_per_px = 0;  // > 0: the scale of a file in pixels (skeletons, WormPose, uncalibrated featuresN)
  // skeletons: a file with /stage_position_pix (Tierpsy's masked video), used when the
  // skeletons file has no /stage_movement; "" = only the file's own stage data.
  std::string stage_file;
  // false: skeletons in image coordinates, stage data ignored (e.g. a failed alignment).
  bool use_stage = true;
};

struct TierpsySummary {
  std::string layout;  // "featuresN", "skeletons" or "WormPose"
  long worm = -1;
  int points = 0;  // per skeleton in the file
  int frames = 0, valid = 0;
  // Missing frames by reason, each counted once.
  int dropped = 0;          // no row for the timestamp (a dropped video frame)
  int no_skeleton = 0;      // skeleton_id −1, has_skeleton 0, or NaN coordinates
  int rejected = 0;         // is_good_skel 0 (Tierpsy's skeleton filter)
  int stage_moving = 0;     // no stage position (the stage was moving)
  int interpolated = 0;     // valid frames Tierpsy interpolated (was_skeletonized 0)
  std::string calibration;  // scale and frame rate and where they came from
  std::string stage;        // how positions reach the plate frame
  // "featuresN worm 3: 250 frames, 240 valid, missing: 6 no skeleton, 4 dropped; 12
  //  interpolated by Tierpsy; 49 points; calibration …; stage …"
  std::string Report() const;
};

struct TierpsyImport {
  Kinematics kinematics;  // mm; metadata fps, units, source, calibration, stage, import
  TierpsySummary summary;
};

Result<TierpsyImport> ReadTierpsy(const std::string& path, const TierpsyOptions& opt);

}  // namespace wormdrag
