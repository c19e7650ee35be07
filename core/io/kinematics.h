// Kinematics files (docs/conventions.md §6, binding): CSV, '# key: value' metadata (fps required),
// header t,x0,y0,…,xM,yM, one row per frame, empty or nan cells = missing frame.
// Every frame is resampled to the 14 model points equally spaced along its arc; all
// lengths are converted to mm on reading.
#pragma once

#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/status.h"
#include "core/model/body.h"

namespace wormdrag {

// Most frames a recording may have (about 7.7 h at 300 fps; a Frame is ~250 bytes,
// so 500 MB). Importers refuse more before sizing anything from a file's claim.
inline constexpr int kMaxFrames = 2'000'000;

struct Frame {
  Frame() { p.fill(Vec2::Zero()); }
  double t = 0;           // s
  bool valid = false;     // false: missing frame (points undefined)
  Points p;               // 14 points head → tail, mm, lab frame
  double arc_length = 0;  // of the frame as recorded (before resampling), mm
};

struct Kinematics {
  double fps = 0;
  std::map<std::string, std::string> metadata;  // everything from '# key: value' lines
  std::vector<Frame> frames;

  // The model's body length: the mean recorded arc length over valid frames (mm).
  double BodyLength() const;
  int NumValid() const;
  // Duration from the first to the last frame, s.
  double Duration() const { return frames.empty() ? 0 : frames.back().t - frames.front().t; }
  // The frames with t − t0 ≤ t_max (the analysed span).
  Kinematics Truncated(double t_max) const;
};

// Resamples a polyline of ≥ 3 points (head → tail) to 14 points equally spaced
// along its arc length. A polyline already so spaced is returned unchanged.
Result<Points> ResampleByArcLength(const std::vector<Vec2>& polyline);
double ArcLength(const std::vector<Vec2>& polyline);

// What a reader that knows the job refuses while it reads, before the rest of the file
// is held in memory.
struct KinematicsLimits {
  // A row with points must come within this span (s, plus half a frame) of the first
  // row's time. An estimate analyses the frames within t_max of the first row
  // (Kinematics::Truncated) and fails without one with points there, so it passes its
  // t_max: a file of time-only rows is refused at the first row past that span.
  double points_within = std::numeric_limits<double>::infinity();
};

// `name` is used in error messages ("k.csv:12: column 5 (y1): …"). Missing frames are
// held as times only until a frame with points follows them, so a file without one is
// refused at a cost of 8 bytes per row.
Result<Kinematics> ParseKinematics(std::string_view text, const std::string& name, const KinematicsLimits& limits = {});
Result<Kinematics> ReadKinematics(const std::string& path);

// Writes in mm with fps and the metadata; atomically (a temporary file renamed into
// place), so a failed write never leaves a half-written file.
Status WriteKinematics(const Kinematics& k, const std::string& path);
std::string FormatKinematics(const Kinematics& k);

// Writes `contents` to `path` through a temporary file and rename.
Status WriteFileAtomically(const std::string& path, const std::string& contents);
Result<std::string> ReadFile(const std::string& path);

}  // namespace wormdrag
