// Carrying the body through coils and touching frames (docs/video.md, "Turns and coils").
// A crawling worm's body follows its own track, and the body after a coil lies on the
// track its head made during the coil (its tail, when it backs up). So when the first body after a gap lies on the
// last body before it (slid along itself, orient.h), the two together are the track
// through the gap, and each missing frame's body is the stretch of that track, one body
// length long, that fits the frame's mask best. It is written only when it explains the
// mask as well as a measured skeleton must (body_check.h); otherwise the frame stays
// missing with its reason.
#pragma once

#include <vector>

#include "core/video/tracker.h"

namespace wormdrag::video {

struct CarryOptions {
  // Longest gap (frames) carried through. Default 90 (3 s at 30 fps, as the chain gap of
  // orient.h); the tracker passes TrackOptions::max_chain_gap_s at the recording's rate.
  int max_gap = 90;
  // A carried body must leave no more of the mask unexplained than a measured skeleton
  // may (TrackOptions::max_unexplained). Default 0.04.
  double max_unexplained = 0.04;
  // Fraction of the carried centreline that must lie on the mask. Default 0.95: the
  // centreline of a right body lies on it everywhere; a body carried past where the
  // worm went leaves it at the head or tail.
  double min_inside = 0.95;
};

// Fills missing frames that hold a mask (coiled, touching) between two valid frames
// with carried bodies (FrameTrack::carried); returns how many. Frames must be oriented
// (OrderHeadTail) first.
int CarryThroughCoils(std::vector<FrameTrack>& frames, const CarryOptions& opt);

}  // namespace wormdrag::video
