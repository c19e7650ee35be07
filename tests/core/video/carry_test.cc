#include "core/video/carry.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "core/video/render_turns.h"

namespace wormdrag::video {
namespace {

// The mask of a body of half-width `r` along `c`, cropped to its box.
void DrawMask(const Polyline& c, double r, FrameTrack* f) {
  cv::Mat full = cv::Mat::zeros(600, 800, CV_8U);
  for (const Vec2& q : ResamplePolyline(c, 300))
    cv::circle(full, cv::Point(static_cast<int>(std::lround(q.x())), static_cast<int>(std::lround(q.y()))),
               static_cast<int>(r), cv::Scalar(255), -1);
  const cv::Rect box = cv::boundingRect(full);
  f->mask = full(box).clone();
  f->mask_offset = box.tl();
}

// Frame i shows the body at TimeOf(i): `backing` plays the crawl backwards, so the worm
// backs along its track tail first.
double TimeOf(int i, double fps, bool backing) {
  return (backing ? 59 - i : i) / fps;
}

std::vector<FrameTrack> CoilGap(const TurnTrack& track, double fps, const Vec2& mask_shift, bool backing = false) {
  std::vector<FrameTrack> frames(60);
  for (int i = 0; i < 60; ++i) {
    FrameTrack& f = frames[i];
    const double t = TimeOf(i, fps, backing);
    f.px = track.Skeleton(t);
    f.length_px = 300;
    if (i < 20 || i >= 40) {
      f.reason = MissingReason::kNone;
      f.centreline = track.Centreline(t);
    } else {
      f.reason = MissingReason::kCoiled;
      Polyline c = track.Centreline(t);
      for (Vec2& q : c) q += mask_shift;
      DrawMask(c, 12, &f);
    }
  }
  return frames;
}

TEST(Carry, BodyCarriedAlongItsTrackThroughTheGap) {
  const double fps = 30;
  const TurnTrack track(DeltaTurn());
  for (const bool backing : {false, true}) {
    std::vector<FrameTrack> frames = CoilGap(track, fps, Vec2::Zero(), backing);
    EXPECT_EQ(CarryThroughCoils(frames, CarryOptions{}), 20) << backing;
    for (int i = 20; i < 40; ++i) {
      ASSERT_TRUE(frames[i].valid()) << i;
      EXPECT_TRUE(frames[i].carried);
      // The drawn mask ends in discs as wide as the body, so the body's place along its
      // track is settled only to a few px (1 % of its length). Head first either way.
      EXPECT_LT(MeanPointDistance(frames[i].px, track.Skeleton(TimeOf(i, fps, backing))), 3.0) << i << backing;
      EXPECT_TRUE(frames[i].mask.empty());  // released
    }
  }
}

// Masks that the track does not explain (the worm is elsewhere): the frames stay missing.
TEST(Carry, RefusedWhereTheMaskDisagrees) {
  const TurnTrack track(DeltaTurn());
  std::vector<FrameTrack> frames = CoilGap(track, 30, Vec2(0, 40));
  EXPECT_EQ(CarryThroughCoils(frames, CarryOptions{}), 0);
  for (int i = 20; i < 40; ++i) EXPECT_EQ(frames[i].reason, MissingReason::kCoiled);
  // A gap longer than allowed is not carried either.
  frames = CoilGap(track, 30, Vec2::Zero());
  CarryOptions short_gaps;
  short_gaps.max_gap = 10;
  EXPECT_EQ(CarryThroughCoils(frames, short_gaps), 0);
}

}  // namespace
}  // namespace wormdrag::video
