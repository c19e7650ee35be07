// Joint-angle kymograms as NumPy .npy files (e.g. ElegansBot's, Broekmans et al. 2016):
// one row per time step, N angles between adjacent rods of an (N+1)-rod body, head first.
// They hold shapes only, no positions: every frame's body is built by integrating the
// angles along a body of unit length (1 mm) with the head at the origin and the first rod
// along +x. Only the joint angles of the result are meaningful; the path is not.
#pragma once

#include <string>
#include <vector>

#include "core/common/status.h"
#include "core/io/kinematics.h"

namespace wormdrag {

// A 2-D float64 array in C order.
struct NpyArray {
  int rows = 0, cols = 0;
  std::vector<double> data;  // row-major
  double at(int r, int c) const { return data[static_cast<size_t>(r) * cols + c]; }
};

// Reads .npy format 1.0/2.0/3.0 holding a little- or big-endian float64 ('<f8', '>f8')
// 2-D C-order array; anything else is an error naming the field.
Result<NpyArray> ParseNpy(const std::string& bytes, const std::string& name);
Result<NpyArray> ReadNpy(const std::string& path);

struct KymogramOptions {
  double fps = 0;          // required: .npy files carry no time base
  bool flip_sign = false;  // mirror the body (for the other polarity convention)
};

// The N rod-to-rod angles of each row become an (N+1)-rod polyline of unit length,
// resampled by arc length to the 14 model points, so the 12 joint angles are the
// arc-position resampling of the recorded ones. Rows with a non-finite angle are missing.
Result<Kinematics> KymogramToKinematics(const NpyArray& kymo, const KymogramOptions& opt, const std::string& name);

}  // namespace wormdrag
