// Rendered turns with known truth (docs/video.md, "Turns"): a worm that crawls along its
// own track, so that every point of the body follows the head, as on agar. The track is a
// sinuous line with one sharp turn in it; when the turn is tighter than a body length the
// head meets the body it is still dragging behind: an omega turn (the head sweeps round
// and touches the tail end) or a delta turn (the head crosses the posterior body). An
// optional reversal before the turn backs the body along its track, as worms do before
// most omega turns. The body is drawn as a union of discs and segments, so a body that
// crosses itself is drawn as the overlap a camera sees.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "core/model/body.h"
#include "core/video/render.h"
#include "core/video/skeleton.h"

namespace wormdrag::video {

struct TurnMotion {
  double body_length_px = 300;
  double speed_px_per_s = 60;  // head speed along its track (0.2 body lengths/s crawling)
  // Sinuous crawl: the track's heading swings by ± wave_amplitude rad with this wavelength.
  double wave_amplitude = 0.5;
  double wavelength_bl = 0.6;  // body lengths
  // The turn: the track's heading changes by turn_angle (rad, positive = left in image
  // axes) over turn_arc_bl body lengths of track, starting turn_start_bl body lengths
  // ahead of the head's starting point. Default: a delta turn, 1.4 π over half a body
  // length, whose outgoing track crosses the posterior body.
  double turn_angle = 1.4 * M_PI;
  double turn_arc_bl = 0.5;
  double turn_start_bl = 0.5;
  // Seconds of backing along the track at the same speed, starting reversal_at_s after
  // the start; 0: no reversal.
  double reversal_s = 0;
  double reversal_at_s = 1.0;
  // Uneven pace: the head's speed along its track is speed × (1 + pace_variation ·
  // sin(2π t / pace_period_s)); 0: steady.
  double pace_variation = 0;
  double pace_period_s = 2.0;
  double heading = 0.3;  // rad, direction of the track at the head's starting point
  Vec2 start{380, 300};  // the head at t = 0, px
};

// A delta turn and an omega turn (the head sweeps round by 1.15 π and meets the tail end;
// before it the worm backs for 1 s), both with the defaults otherwise.
TurnMotion DeltaTurn();
TurnMotion OmegaTurn();
// A U-turn of π over a fifth of a body length: the head hooks back and lies on the body
// before the track straightens out, then the tail end passes through the same tight bend.
TurnMotion Hairpin();

// The track of a TurnMotion, sampled once, and the body on it at any time.
class TurnTrack {
 public:
  explicit TurnTrack(const TurnMotion& m);
  // Arc position of the head on the track at time t (px from its starting point).
  double HeadArc(double t) const;
  // Smooth centreline, head first, `samples` points equally spaced in arc.
  Polyline Centreline(double t, int samples = 400) const;
  // The true 14 model points (head → tail) at time t.
  Points Skeleton(double t) const;

 private:
  Vec2 At(double arc) const;  // the track point at arc position `arc` (px)
  TurnMotion m_;
  double arc0_ = 0;          // arc of the first sample (negative: behind the start)
  double step_ = 0.5;        // px between samples
  std::vector<Vec2> track_;  // samples from arc0_ on
};

// One 8-bit frame of a body that may cross or touch itself: the coverage is a union of
// the body's discs and segments drawn at 4× and averaged down (edges anti-aliased without
// seams where the body overlaps itself); body radius as in RenderWorm.
cv::Mat RenderOverlappingWorm(const Polyline& centreline, const RenderOptions& opt, cv::RNG& rng);

// RMS over the 12 joint angles of the difference between two skeletons taken head →
// tail as they are (no re-ordering), rad: the measure of a frame being right.
double JointAngleRms(const Points& a, const Points& b);

}  // namespace wormdrag::video
