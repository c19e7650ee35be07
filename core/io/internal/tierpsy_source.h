// Which Tierpsy layout a file is and how it is calibrated (tierpsy_source.cc), for
// ReadTierpsy (tierpsy.h). Private to core/io.
#pragma once

#include <string>

#include "core/common/status.h"
#include "core/io/hdf5_file.h"
#include "core/io/tierpsy.h"

namespace wormdrag::tierpsy_internal {

// Tierpsy's table of worms and frames.
inline constexpr char kTable[] = "/trajectories_data";
// Stage-tracking data of single-worm videos (*_skeletons.hdf5).
inline constexpr char kStageGroup[] = "/stage_movement";

enum class Layout { kFeaturesN, kSkeletons, kWormPose };

struct Source {
  Layout layout;
  std::string skeletons;  // the skeleton dataset
  std::string name;       // for the summary
};

struct Calibration {
  double fps = 0;
  double um_per_px = 0;  // 0: the coordinates are in µm already
  std::string text;
};

// The file's layout from the datasets it has; a file with none of them is an error.
Result<Source> Detect(const h5::File& f);
// Frame rate and µm per pixel: the options' when given, else the file's attributes.
Result<Calibration> ResolveCalibration(const h5::File& f, const Source& src, const TierpsyOptions& opt);

}  // namespace wormdrag::tierpsy_internal
