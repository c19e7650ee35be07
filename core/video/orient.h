// Head/tail order over a whole recording (docs/video.md, "Head and tail"): frames are
// linked into runs by continuity, runs across gaps (coils, turns) into chains by the
// later body lying on the earlier body's track, and each chain takes the orientation
// that two cues of the direction of travel agree on over all of its runs (the body moves
// toward its head, and the bending wave travels from head to tail) or, where they cannot
// be trusted, the head's larger swing.
#pragma once

#include <vector>

#include "core/model/body.h"
#include "core/video/tracker.h"

namespace wormdrag::video {

struct OrientOptions {
  // Frames across which frame-to-frame continuity is trusted. Default 10.
  int max_link_gap = 10;
  // Runs separated by up to this many missing frames are linked into one chain when the
  // later run's first body lies on the earlier run's last body, slid along itself, in one
  // orientation only (a crawling body follows its own track). Default 90 (3 s at 30 fps:
  // the coils and turns of the rendered and real recordings in docs/video.md last
  // 1–2.5 s); the tracker passes 3 s at the recording's rate.
  int max_chain_gap = 90;
  // Frames between the two bodies compared for the direction of travel. Default 6
  // (0.2 s at 30 fps; the tracker passes 0.2 s at the recording's rate): between
  // consecutive frames of a fast camera the body moves less than the skeleton's jitter.
  int travel_lag = 6;
  // False for recordings whose frames are separate crops (wormpose_data): positions are
  // not comparable between frames, so continuity compares centred shapes and the
  // orientation comes from the head's swing, or the bending wave where the swing does
  // not decide. Default true.
  bool positions_comparable = true;
};

// Orders every valid frame head → tail and fills the summary's run counts.
void OrderHeadTail(std::vector<FrameTrack>& frames, const OrientOptions& opt, TrackSummary* summary);

// Mean distance of `b`'s points to `a`'s body slid along itself (by the advance, within
// ± max_slide px, that fits best), over the points that stay on `a`'s body; infinity when
// fewer than 5 do. The same body one moment later, crawled along its track, scores ~0;
// the same body with head and tail swapped does not.
// `advance` (optional) receives the best advance: `b`'s head lies that far beyond `a`'s
// head along `a`'s track (negative: behind it).
double SlideCost(const Points& a, const Points& b, double max_slide, double* advance = nullptr);

// Evidence that `b` (the next frame of the same run) continues `a` head first: the
// along-body displacement toward the head summed over points (motion), the bending
// wave's travel toward the tail, and the head end's swing (squared change of the three
// joint angles nearest the head, less that of the three nearest the tail: a foraging
// head moves more than the tail whichever way the worm travels). Wave and swing use the
// shape only, so they hold for crops too. Each is returned as a signed amount and its
// absolute total, for summing over a run.
struct TravelEvidence {
  double motion = 0, motion_total = 0;
  double wave = 0, wave_total = 0;
  double swing = 0, swing_total = 0;
  TravelEvidence& operator+=(const TravelEvidence& o);
  // Each cue's net fraction in [−1, 1] (+: head first); 0 without evidence.
  double MotionNet() const { return motion_total > 0 ? motion / motion_total : 0.0; }
  double WaveNet() const { return wave_total > 0 ? wave / wave_total : 0.0; }
  double SwingNet() const { return swing_total > 0 ? swing / swing_total : 0.0; }
};
TravelEvidence Travel(const Points& a, const Points& b);

// The evidence of one run (frame indices in order), summed over frame pairs `lag` frames
// apart, or over the run's ends if it is shorter.
TravelEvidence RunTravel(const std::vector<FrameTrack>& frames, const std::vector<int>& run, int lag);

}  // namespace wormdrag::video
