// Stage positions of Tierpsy's stage-tracking (single-worm) videos, for the Tierpsy
// import (core/io/tierpsy.h): the camera follows the worm, so image coordinates reach
// the plate only with the stage's position.
#pragma once

#include <map>
#include <vector>

#include "core/common/status.h"
#include "core/io/hdf5_file.h"
#include "core/model/body.h"

namespace wormdrag {

// Tierpsy's stage alignment in a *_skeletons.hdf5 (/stage_movement, /timestamp/raw): per
// timestamp T, the offset in µm that puts a skeleton in µm on the plate, NaN while the
// stage moves: −R⁻¹·stage_vec[i] for /timestamp/raw[i] = T, with
// R⁻¹ = (R ∘ [[1, −1], [−1, 1]])·diag(sign(microns_per_pixel_scale)) and R the
// attribute rotation_matrix (Tierpsy's alignStageMotion._h_get_stage_inv). An alignment
// whose has_finished is not 1 or 2 (failed or unfinished) is an error.
Result<std::map<long, Vec2>> ReadStageAlignment(const h5::File& f);

// /stage_position_pix of Tierpsy's masked video: per video frame, the stage offset in
// pixels to add to image coordinates; NaN while the stage moves.
Result<std::vector<Vec2>> ReadStagePositionPix(const h5::File& f);

}  // namespace wormdrag
