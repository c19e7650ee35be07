#include "core/video/orient.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/video/render.h"
#include "core/video/render_turns.h"

namespace wormdrag::video {
namespace {

TEST(Orient, SlideCostFindsTheBodyOnItsOwnTrack) {
  const TurnTrack track(DeltaTurn());
  const Points a = track.Skeleton(0.0), b = track.Skeleton(1.0);  // 60 px further along
  EXPECT_LT(SlideCost(a, b, 150), 2.0);                           // chords between 14 points of a sinuous body
  EXPECT_GT(SlideCost(a, Reversed(b), 150), 10.0);
  // Without sliding the same comparison sees the 60 px the body crawled.
  EXPECT_GT(SlideCost(a, b, 0), 10.0);
}

TEST(Orient, BendingWaveTravelsTowardTheTail) {
  WormMotion m;  // q_i(t) = A sin(ωt − k i): the wave runs from head to tail
  const Points a = TrueSkeleton(m, 0.0), b = TrueSkeleton(m, 0.1);
  EXPECT_GT(Travel(a, b).wave, 0.5 * Travel(a, b).wave_total);
  EXPECT_LT(Travel(Reversed(a), Reversed(b)).wave, -0.5 * Travel(a, b).wave_total);
  EXPECT_GT(Travel(a, b).motion, 0);
}

std::vector<FrameTrack> FramesOf(const TurnTrack& track, int n, double fps) {
  std::vector<FrameTrack> frames(n);
  for (int i = 0; i < n; ++i) {
    frames[i].reason = MissingReason::kNone;
    frames[i].px = track.Skeleton(i / fps);
    frames[i].length_px = 300;
  }
  return frames;
}

// After a 1.3 s coil the worm pauses (no motion of its own to orient the run by) and
// was found tail first: the link to the run before the coil must turn it round.
TEST(Orient, RunAfterACoilTakesItsOrientationFromTheRunBefore) {
  const double fps = 30;
  const TurnTrack track(OmegaTurn());
  std::vector<FrameTrack> frames = FramesOf(track, 150, fps);
  for (int i = 100; i < 140; ++i) frames[i].reason = MissingReason::kCoiled;
  for (int i = 140; i < 150; ++i) frames[i].px = Reversed(track.Skeleton(140 / fps));
  TrackSummary s;
  OrientOptions opt;
  OrderHeadTail(frames, opt, &s);
  for (int i : {0, 99, 140, 149})
    EXPECT_LT(MeanPointDistance(frames[i].px, track.Skeleton(std::min(i, 140) / fps)), 1e-9) << i;
  EXPECT_EQ(s.runs, 2);
  EXPECT_EQ(s.chains, 1);
  // Beyond the longest gap linked, the paused run is on its own and left as found.
  opt.max_chain_gap = 30;
  frames = FramesOf(track, 150, fps);
  for (int i = 100; i < 140; ++i) frames[i].reason = MissingReason::kCoiled;
  for (int i = 140; i < 150; ++i) frames[i].px = Reversed(track.Skeleton(140 / fps));
  TrackSummary t;
  OrderHeadTail(frames, opt, &t);
  EXPECT_EQ(t.chains, 2);
  EXPECT_EQ(t.runs_undecided, 1);
}

Points Centred(Points p) {
  Vec2 c = Vec2::Zero();
  for (const Vec2& q : p) c += q;
  for (Vec2& q : p) q -= c / kNumPoints;
  return p;
}

// Orders crops taken at 15 fps, as the tracker does with --crops.
TrackSummary OrderCrops(std::vector<FrameTrack>& frames) {
  OrientOptions opt;
  opt.positions_comparable = false;
  opt.travel_lag = 3;
  TrackSummary s;
  OrderHeadTail(frames, opt, &s);
  return s;
}

// Separate crops (wormpose_data): every frame shifted by its own crop offset, some found
// tail first. Centred shapes link the frames; with the same swing at both ends the
// bending wave gives the head.
TEST(Orient, CropsWithoutASwingingHeadAreOrientedByTheWave) {
  WormMotion m;
  cv::RNG rng(5);
  std::vector<FrameTrack> frames(40);
  for (int i = 0; i < 40; ++i) {
    Points p = TrueSkeleton(m, i / 15.0);
    const Vec2 crop(rng.uniform(-60.0, 60.0), rng.uniform(-60.0, 60.0));
    for (Vec2& q : p) q += crop;
    frames[i].reason = MissingReason::kNone;
    frames[i].px = i % 3 == 1 ? Reversed(p) : p;
    frames[i].length_px = m.body_length_px;
  }
  EXPECT_EQ(OrderCrops(frames).runs, 1);
  for (int i = 0; i < 40; ++i) {
    const Points a = Centred(frames[i].px), truth = Centred(TrueSkeleton(m, i / 15.0));
    EXPECT_LT(MeanPointDistance(a, truth), 1e-6) << i;  // head first
  }
}

// A worm backing up in separate crops: its wave travels toward the head, so the wave
// alone would name the tail as the head. The head end swings more than the tail end
// (0.8 against 0.3 rad), which orients the run whichever way it travels.
TEST(Orient, CropsOfABackingWormAreOrientedByTheHeadsSwing) {
  auto body = [](double t, double head_amplitude) {
    Shape q;
    for (int k = 0; k < kNumJoints; ++k) {
      const double amplitude = 0.3 + (head_amplitude - 0.3) * std::max(0.0, 1 - k / 4.0);
      q[k] = amplitude * std::sin(-5.0 * t - 0.6 * k);  // the wave runs toward the head
    }
    return LabPoints(Pose{40.0 * std::sin(t), 0.0, 0.2}, q, 20.0);
  };
  for (const double head_amplitude : {0.8, 0.3}) {
    std::vector<FrameTrack> frames(40);
    for (int i = 0; i < 40; ++i) {
      frames[i].reason = MissingReason::kNone;
      frames[i].px = i % 3 == 1 ? Reversed(body(i / 15.0, head_amplitude)) : body(i / 15.0, head_amplitude);
      frames[i].length_px = 260;
    }
    ASSERT_EQ(OrderCrops(frames).runs, 1);
    // Head first with the swinging head; tail first (the wave's answer) without it.
    const Points truth = Centred(body(0, head_amplitude));
    const Points a = Centred(frames[0].px);
    if (head_amplitude > 0.3)
      EXPECT_LT(MeanPointDistance(a, truth), 1e-6);
    else
      EXPECT_LT(MeanPointDistanceFlipped(a, truth), 1e-6);
  }
}

}  // namespace
}  // namespace wormdrag::video
