// The ElegansBot kymograms as the benchmarks' driving shapes: one loader for the noise
// benchmark's real drive (bench/noise_pairs.h) and the diagnosis benchmark's kymogram
// pairs (bench/diagnose/cases.cc).
#pragma once

#include <string>

#include "core/filter/butterworth.h"
#include "core/io/kymogram.h"

namespace wormdrag::bench {

// The kymogram at `path` (32 frames/s, as ElegansBot's examples load it), named `name`
// in its metadata and errors, with its joint angles low-passed at `cutoff_hz` when that
// is positive.
inline Result<Kinematics> KymogramShapes(const std::string& path, const std::string& name, double cutoff_hz) {
  auto kymo = ReadNpy(path);
  if (!kymo.ok()) return kymo.status();
  KymogramOptions ko;
  ko.fps = 32;
  auto k = KymogramToKinematics(*kymo, ko, name);
  if (!k.ok() || !(cutoff_hz > 0)) return k;
  AngleFilterOptions fo;
  fo.cutoff_hz = cutoff_hz;
  auto f = FilterJointAngles(*k, fo);
  if (!f.ok()) return f.status().Annotate(name);
  return f;
}

}  // namespace wormdrag::bench
