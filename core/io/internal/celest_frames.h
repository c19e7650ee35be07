// The frames of a CeleST file between reading and output (celest_frames.cc): what the
// parser keeps of each record, and the checks and head/tail ordering that follow.
// Private to core/io: ParseCelest (celest.h) runs them.
#pragma once

#include <vector>

#include "core/io/celest.h"
#include "core/model/body.h"

namespace wormdrag::celest_internal {

// One record of the chosen worm, as read.
struct RawFrame {
  bool present = false;
  std::vector<Vec2> px;  // centreline, pixels, the file's order
  bool lost = false, missed = false, overlapped = false;
};

enum class Reason { kValid, kLost, kMissed, kOverlapped, kNoCentreline, kLength, kGlitch };

// A frame on its way to the output: points resampled in pixels, in the file's order until
// `reversed` says otherwise.
struct Candidate {
  Reason reason = Reason::kNoCentreline;
  Points p{};
  double length_px = 0;
  bool reversed = false;
};

// CeleST's flags, then the centreline itself; resamples what is kept.
std::vector<Candidate> Classify(const std::vector<RawFrame>& raw, const CelestOptions& opt);
// Isolated glitches: far from both neighbours (in time, within the link gap) while the
// neighbours agree; at either end of the sequence, far from the only neighbour while that
// one agrees with its own next. Tested on the distances before any frame is dropped.
void DropGlitches(std::vector<Candidate>& c, const CelestOptions& opt);
// Continuity links each valid frame to the previous one when the gap is short and one order
// is clearly closer (under half the other, and under a third of the body); linked frames form
// a run. Each run is then turned so that its centroid moves toward the head.
void OrderHeadTail(std::vector<Candidate>& c, const CelestOptions& opt, CelestSummary* s);

}  // namespace wormdrag::celest_internal
