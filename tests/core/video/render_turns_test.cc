#include "core/video/render_turns.h"

#include <gtest/gtest.h>

#include "core/video/tracker.h"

namespace wormdrag::video {
namespace {

// A frame is right when its 12 joint angles are within 0.2 rad RMS of the truth, head first.
constexpr double kRightRms = 0.2;

struct TurnScore {
  int right = 0, wrong = 0, missing = 0, flipped = 0;
  std::vector<FrameTrack> frames;
};

TurnScore TrackTurn(const TurnMotion& m, int first, int count, double fps = 30, const TrackOptions& opt = {}) {
  const TurnTrack track(m);
  RenderOptions o;
  o.blur_sigma_px = 1.5;
  o.noise_sigma = 8;
  cv::RNG rng(3);
  std::vector<cv::Mat> video;
  for (int i = first; i < first + count; ++i) video.push_back(RenderOverlappingWorm(track.Centreline(i / fps), o, rng));
  auto r = TrackFrames(video, fps, opt);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  TurnScore s;
  if (!r.ok()) return s;
  for (int j = 0; j < count; ++j) {
    const FrameTrack& f = r->frames[j];
    if (!f.valid()) {
      ++s.missing;
      continue;
    }
    const Points truth = track.Skeleton((first + j) / fps);
    (JointAngleRms(f.px, truth) <= kRightRms ? s.right : s.wrong)++;
    s.flipped += MeanPointDistanceFlipped(f.px, truth) < MeanPointDistance(f.px, truth);
  }
  s.frames = r->frames;
  return s;
}

TEST(TurnTrack, BodyFollowsTheHeadAlongTheTrack) {
  const TurnMotion m = DeltaTurn();
  const TurnTrack track(m);
  // Length is the body's, head first, and the head leads: after dt the tail point lies
  // on the earlier body (crawling along the track), within sampling error.
  const Points a = track.Skeleton(0.0), b = track.Skeleton(0.5);
  EXPECT_NEAR(ArcLength(std::vector<Vec2>(a.begin(), a.end())), m.body_length_px, 2.0);  // chords of 14 points
  EXPECT_LT((a[0] - m.start).norm(), 1e-6);
  const Polyline before = track.Centreline(0.0);
  double nearest = 1e9;
  for (const Vec2& q : before) nearest = std::min(nearest, (q - b[kNumPoints - 1]).norm());
  EXPECT_LT(nearest, 1.0);
  // A reversal backs the head along the same track.
  const TurnMotion o = OmegaTurn();
  const TurnTrack t2(o);
  EXPECT_NEAR(t2.HeadArc(o.reversal_at_s + o.reversal_s), o.speed_px_per_s * (o.reversal_at_s - o.reversal_s), 1e-9);
}

// The hairpin's head hooks back onto the body for ~20 frames (from frame ~90 at 30 fps):
// the thinned mask short-cuts the hook. Without the touching test about 20 of these 40
// frames are written valid with the short-cut skeleton; with it the hook is missing
// (touching) but for the few frames where the hook is just closing (unexplained mask
// just under the 0.04 limit).
TEST(RenderedTurn, HookedHeadIsNotWrittenValidWithAShortCut) {
  TrackOptions measured_only;  // the test of each frame on its own, nothing carried
  measured_only.carry = false;
  const TurnScore s = TrackTurn(Hairpin(), 80, 40, 30, measured_only);
  int touching = 0;
  for (const FrameTrack& f : s.frames) touching += f.reason == MissingReason::kTouching;
  std::printf("hairpin frames 80-119: %d right, %d valid but wrong, %d missing (%d touching)\n", s.right, s.wrong,
              s.missing, touching);
  EXPECT_GE(touching, 10);
  EXPECT_LE(s.wrong, 5);
  EXPECT_GE(s.right, 10);  // the frames before the hook stay valid
}

// Through a delta turn the head is kept, and the body is carried through the ~2 s while
// it crosses itself: the targets (≥ 85 % of all frames right, ≤ 3 % valid but
// wrong, one orientation) hold. Without carrying, those frames are missing.
TEST(RenderedTurn, DeltaTurnKeepsOneOrientationAndIsCarriedThrough) {
  const int n = 240;
  const TurnScore s = TrackTurn(DeltaTurn(), 0, n, 20);
  int carried = 0;
  for (const FrameTrack& f : s.frames) carried += f.carried;
  std::printf("delta turn: %d right, %d valid but wrong, %d missing, %d flipped, %d carried\n", s.right, s.wrong,
              s.missing, s.flipped, carried);
  EXPECT_EQ(s.flipped, 0);
  EXPECT_GE(s.right, 0.85 * n);
  EXPECT_LE(s.wrong, 0.03 * n);
  EXPECT_GE(carried, 30);
  TrackOptions measured_only;
  measured_only.carry = false;
  const TurnScore m = TrackTurn(DeltaTurn(), 0, n, 20, measured_only);
  EXPECT_GE(m.missing, 30);
  EXPECT_EQ(m.wrong, 0);
}

}  // namespace
}  // namespace wormdrag::video
