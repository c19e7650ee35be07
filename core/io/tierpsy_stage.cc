#include "core/io/tierpsy_stage.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace wormdrag {

Result<std::map<long, Vec2>> ReadStageAlignment(const h5::File& f) {
  const std::string group = "/stage_movement", where = f.path() + ": " + group;
  auto finished = f.NumericAttribute(group, "has_finished");
  if (!finished.ok()) return finished.status();
  if (finished->front() != 1 && finished->front() != 2)
    return Status::InvalidArgument(where + ": has_finished = " + std::to_string(std::lround(finished->front())) +
                                   ": Tierpsy's stage alignment did not succeed; give --no-stage to import in "
                                   "image coordinates");
  auto rot = f.NumericAttribute(group, "rotation_matrix");
  auto scale = f.NumericAttribute(group, "microns_per_pixel_scale");
  auto shape = f.Shape(group + "/stage_vec");
  auto vec = f.ReadDoubles(group + "/stage_vec");
  auto raw = f.ReadDoubles("/timestamp/raw");
  for (const Status& st : {rot.status(), scale.status(), shape.status(), vec.status(), raw.status()})
    if (!st.ok()) return st;
  if (rot->size() != 4) return Status::InvalidArgument(where + ": attribute 'rotation_matrix': expected 2 × 2 values");
  if (scale->size() != 2)
    return Status::InvalidArgument(where + ": attribute 'microns_per_pixel_scale': expected 2 values");
  if (shape->size() != 2 || (*shape)[1] != 2 || (*shape)[0] == 0)
    return Status::InvalidArgument(where + "/stage_vec: expected a shape (entries, 2)");
  const std::vector<double>& R = *rot;
  const double d0 = (*scale)[0] > 0 ? 1 : -1, d1 = (*scale)[1] > 0 ? 1 : -1;
  const size_t n_vec = (*shape)[0];
  std::map<long, Vec2> by_time;
  for (size_t i = 0; i < raw->size(); ++i) {
    if (!std::isfinite((*raw)[i])) continue;
    const size_t j = std::min(i, n_vec - 1);  // Tierpsy pads a short stage_vec with its last entry
    const double vx = (*vec)[2 * j], vy = (*vec)[2 * j + 1];
    by_time.emplace(std::lround((*raw)[i]), -Vec2(R[0] * d0 * vx - R[1] * d1 * vy, -R[2] * d0 * vx + R[3] * d1 * vy));
  }
  return by_time;
}

Result<std::vector<Vec2>> ReadStagePositionPix(const h5::File& f) {
  const std::string ds = "/stage_position_pix";
  auto shape = f.Shape(ds);
  if (!shape.ok()) return shape.status();
  if (shape->size() != 2 || (*shape)[1] != 2)
    return Status::InvalidArgument(f.path() + ": " + ds + ": expected a shape (frames, 2)");
  auto pos = f.ReadDoubles(ds);
  if (!pos.ok()) return pos.status();
  std::vector<Vec2> out((*shape)[0]);
  for (size_t i = 0; i < out.size(); ++i) out[i] = Vec2((*pos)[2 * i], (*pos)[2 * i + 1]);
  return out;
}

}  // namespace wormdrag
