#include "bench/turn_real.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "bench/real_videos.h"
#include "core/video/frame_source.h"
#include "core/video/orient.h"
#include "core/video/tracker.h"

namespace wormdrag::video {
namespace {

namespace fs = std::filesystem;

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}

std::string Reasons(const TrackSummary& s) {
  std::string out;
  for (const auto& [reason, n] : s.missing)
    if (n) out += (out.empty() ? "" : ", ") + std::to_string(n) + " " + MissingReasonName(reason);
  return out.empty() ? "none" : out;
}

// Stretches of consecutive valid frames: [first, last] pairs.
std::vector<std::pair<int, int>> ValidRuns(const std::vector<FrameTrack>& frames) {
  std::vector<std::pair<int, int>> runs;
  for (int i = 0; i < static_cast<int>(frames.size()); ++i) {
    if (!frames[i].valid()) continue;
    if (!runs.empty() && runs.back().second == i - 1)
      runs.back().second = i;
    else
      runs.emplace_back(i, i);
  }
  return runs;
}

// Per frame written valid and measured (not carried): +1 when the end of the body that is
// wider between 8 % and 16 % of its length from the tip (EndHalfWidths) is the written
// head, −1 when it is the written tail, 0 otherwise.
std::vector<int> WideEndIsHead(const std::vector<cv::Mat>& video, const TrackResult& r, const TrackOptions& opt) {
  const FrameParams p = ResolveParams(opt, {video.begin(), video.begin() + std::min<size_t>(5, video.size())});
  std::vector<int> out(r.frames.size(), 0);
  for (size_t i = 0; i < r.frames.size() && i < video.size(); ++i) {
    const FrameTrack& f = r.frames[i];
    if (!f.valid() || f.carried) continue;
    const FrameAnalysis a = AnalyseFrame(video[i], p);
    if (a.reason != MissingReason::kNone) continue;
    cv::Mat dist;
    cv::distanceTransform(a.mask, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    const std::array<double, 2> w = EndHalfWidths(dist, a.centreline);
    if (w[0] == w[1]) continue;
    const Vec2 wide = w[0] > w[1] ? a.centreline.front() : a.centreline.back();
    out[i] = (wide - f.px[0]).norm() < (wide - f.px[kNumPoints - 1]).norm() ? 1 : -1;
  }
  return out;
}

// The tracker's runs (orient.h) with their chain and the direction-of-travel evidence as
// written (net fractions over frame pairs `lag` apart: + means head first), and for each
// gap between runs the slide cost of the body after on the body before, as written and
// flipped (`crops`: centred shapes, no slide, as the tracker compares separate crops).
void PrintRuns(const std::vector<FrameTrack>& frames, int lag, bool crops, const std::vector<int>& wide_head) {
  auto centred = [](Points p) {
    Vec2 c = Vec2::Zero();
    for (const Vec2& q : p) c += q;
    for (Vec2& q : p) q -= c / kNumPoints;
    return p;
  };
  std::map<int, std::vector<int>> runs;
  for (int i = 0; i < static_cast<int>(frames.size()); ++i)
    if (frames[i].valid() && !frames[i].carried) runs[frames[i].run].push_back(i);
  std::printf(
      "- runs (frames: chain, motion, wave, swing as written, frames whose wider end is the written head; gap to the "
      "next: slide cost px as written / flipped):");
  int prev_last = -1;
  for (const auto& [r, idx] : runs) {
    if (prev_last >= 0) {
      const Points a = crops ? centred(frames[prev_last].px) : frames[prev_last].px;
      const Points b = crops ? centred(frames[idx.front()].px) : frames[idx.front()].px;
      const double slide = crops ? 0.0 : 0.75 * frames[prev_last].length_px;
      std::printf(" | gap %d: %.1f / %.1f |", idx.front() - prev_last - 1, SlideCost(a, b, slide),
                  SlideCost(a, Reversed(b), slide));
    }
    const TravelEvidence e = RunTravel(frames, idx, lag);
    int wide = 0, known = 0;
    for (int i : idx) {
      known += wide_head[i] != 0;
      wide += wide_head[i] > 0;
    }
    std::printf(" %d-%d: %d, %+.2f, %+.2f, %+.2f, wide head %d/%d", idx.front(), idx.back(), frames[idx.front()].chain,
                e.MotionNet(), e.WaveNet(), e.SwingNet(), wide, known);
    prev_last = idx.back();
  }
  std::printf("\n");
}

}  // namespace

void WormposeTurns(const fs::path& shared) {
  const fs::path dir = shared / "data/real/wormpose_data/sample_data";
  std::vector<double> skel;
  std::vector<cv::Mat> crops;
  if (!ReadWormposeSkeletons(dir / "features.h5", &skel) || !ReadWormposeCrops(dir, &crops)) return;
  const TrackOptions opt = WormposeTrackOptions();
  auto r = TrackFrames(crops, 15.0, opt);
  if (!r.ok()) {
    std::printf("%s\n", r.status().ToString().c_str());
    return;
  }
  // Per frame with a reference: distance (orientation-free) and whether our head is theirs.
  std::vector<double> dist;
  std::vector<int> agree(1000, -1);  // -1: not scored, 0: flipped against the reference, 1: same
  int with_ref = 0, within2 = 0, valid_noref = 0;
  std::map<MissingReason, int> missing_ref;
  std::vector<double> unc_ref, unc_noref;
  for (int i = 0; i < 1000; ++i) {
    const FrameTrack& f = r->frames[i];
    const bool has_ref = std::isfinite(skel[i * 104]);
    if (!has_ref) {
      valid_noref += f.valid();
      if (f.valid()) unc_noref.push_back(f.fit.uncovered);
      continue;
    }
    ++with_ref;
    if (!f.valid()) {
      ++missing_ref[f.reason];
      continue;
    }
    unc_ref.push_back(f.fit.uncovered);
    std::vector<Vec2> ref;
    for (int k = 0; k < 52; ++k) ref.emplace_back(skel[(i * 52 + k) * 2], skel[(i * 52 + k) * 2 + 1]);
    const Points theirs = *ResampleByArcLength(ref);
    const double same = MeanPointDistance(f.px, theirs), flip = MeanPointDistanceFlipped(f.px, theirs);
    dist.push_back(std::min(same, flip));
    within2 += std::min(same, flip) <= 2.0;
    agree[i] = same <= flip;
  }
  // Which end is wider near its tip, against the reference's head.
  const std::vector<int> wide_head = WideEndIsHead(crops, *r, opt);
  int wide_ref_head = 0, wide_scored = 0;
  for (int i = 0; i < 1000; ++i) {
    if (agree[i] < 0 || wide_head[i] == 0) continue;
    wide_ref_head += (wide_head[i] > 0) == (agree[i] == 1);
    ++wide_scored;
  }
  int runs_scored = 0, runs_agree = 0, runs_against = 0, runs_mixed = 0, frames_agree = 0, frames_scored = 0;
  std::string against;
  for (const auto& [a, b] : ValidRuns(r->frames)) {
    int yes = 0, no = 0;
    for (int i = a; i <= b; ++i)
      if (agree[i] >= 0) (agree[i] ? yes : no)++;
    if (yes + no == 0) continue;
    ++runs_scored;
    frames_agree += yes;
    frames_scored += yes + no;
    if (no == 0) {
      ++runs_agree;
    } else if (yes == 0) {
      ++runs_against;
      against += " " + std::to_string(a) + "-" + std::to_string(b);
    } else {
      ++runs_mixed;
      against += " " + std::to_string(a) + "-" + std::to_string(b) + "(mixed " + std::to_string(yes) + "/" +
                 std::to_string(no) + ")";
    }
  }
  double mean = 0;
  for (double d : dist) mean += d;
  mean /= std::max<size_t>(1, dist.size());
  std::string ref_missing;
  for (const auto& [reason, n] : missing_ref)
    ref_missing += (ref_missing.empty() ? "" : ", ") + std::to_string(n) + " " + MissingReasonName(reason);
  std::printf("\n## wormpose_data sample: coils (1000 crops, 15 fps, Tierpsy reference on %d frames)\n\n", with_ref);
  std::printf("- tracker: %s\n", r->summary.Report().c_str());
  std::printf("- missing: %.1f %% of all frames (%s)\n", 100.0 * (1000 - r->summary.valid) / 1000,
              Reasons(r->summary).c_str());
  std::printf(
      "- reference frames within 2 px mean distance: **%d of %d (%.1f %%)**; scored %zu, mean %.2f px, 90th pct "
      "%.2f; reference frames written missing: %s\n",
      within2, with_ref, 100.0 * within2 / std::max(1, with_ref), dist.size(), mean, Quantile(dist, 0.9),
      ref_missing.empty() ? "none" : ref_missing.c_str());
  std::printf(
      "- head/tail against the reference: %d of %d scored frames agree; runs of valid frames: %d scored, %d agree, %d "
      "against, %d mixed%s%s\n",
      frames_agree, frames_scored, runs_scored, runs_agree, runs_against, runs_mixed, against.empty() ? "" : ":",
      against.c_str());
  std::printf("- frames without a reference written valid: %d of %d\n", valid_noref, 1000 - with_ref);
  std::printf("- the end wider at 8-16 %% of the length from its tip is the reference's head on %d of %d frames\n",
              wide_ref_head, wide_scored);
  PrintRuns(r->frames, 3, true, wide_head);
  std::printf(
      "- mask left unexplained by the written skeleton (fraction of mask area): reference frames median %.3f, 99th "
      "pct %.3f, max %.3f; frames without a reference median %.3f, max %.3f\n",
      Quantile(unc_ref, 0.5), Quantile(unc_ref, 0.99), Quantile(unc_ref, 0.9999), Quantile(unc_noref, 0.5),
      Quantile(unc_noref, 0.9999));
}

void WormTracerTurns(const fs::path& shared, const fs::path& work) {
  std::vector<cv::Mat> frames, masks;
  if (!ReadWormTracer(shared, work, &frames, &masks)) return;
  auto r = TrackFrames(frames, 66, TrackOptions{});
  if (!r.ok()) return;
  const int n = static_cast<int>(std::min(frames.size(), masks.size()));
  // The written skeletons against the manual worm (largest component of the manual mask):
  // the body re-drawn from each skeleton at the manual mask's widths.
  std::vector<double> unexplained, iou, carried_iou, measured_iou;
  int poor = 0;
  for (int i = 0; i < n; ++i) {
    const FrameTrack& t = r->frames[i];
    if (!t.valid()) continue;
    int area;
    const cv::Mat worm = LargestComponent(masks[i] > 127, &area);
    cv::Mat dist;
    cv::distanceTransform(worm, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    const BodyFit fit = FitToMask(worm, dist, Polyline(t.px.begin(), t.px.end()));
    unexplained.push_back(fit.uncovered);
    iou.push_back(fit.iou);
    (t.carried ? carried_iou : measured_iou).push_back(fit.iou);
    poor += fit.uncovered > 0.1;
  }
  std::printf("\n## WormTracer: coils and sharp bends (%d frames, 66 fps, manual masks)\n\n", n);
  std::printf("- tracker: %s\n", r->summary.Report().c_str());
  std::printf("- missing: %.1f %% of all frames (%s)\n", 100.0 * (n - r->summary.valid) / n,
              Reasons(r->summary).c_str());
  std::printf(
      "- written skeletons against the manual worm mask (body re-drawn at the manual widths): unexplained mask area "
      "median %.3f, 95th pct %.3f, max %.3f; IoU median %.3f, 5th pct %.3f; frames with > 10 %% unexplained: %d of "
      "%zu\n",
      Quantile(unexplained, 0.5), Quantile(unexplained, 0.95), Quantile(unexplained, 0.9999), Quantile(iou, 0.5),
      Quantile(iou, 0.05), poor, iou.size());
  PrintRuns(r->frames, 13, false, WideEndIsHead(frames, *r, TrackOptions{}));
  std::printf(
      "- bodies carried through coils: %zu frames, IoU against the manual worm median %.3f, min %.3f (measured "
      "frames: median %.3f, min %.3f)\n",
      carried_iou.size(), Quantile(carried_iou, 0.5), Quantile(carried_iou, 0), Quantile(measured_iou, 0.5),
      Quantile(measured_iou, 0));
}

}  // namespace wormdrag::video
