// Figures of docs/video.md: tracker accuracy on rendered videos, WormTracer IoU, wormpose
// skeleton distance, modes2movement import, tracking speed. Full data, not a test:
//   build/bench/video_bench [SHARED_DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "bench/real_videos.h"
#include "core/common/flags.h"
#include "core/io/gaps.h"
#include "core/io/wt2_mat.h"
#include "core/video/frame_source.h"
#include "core/video/render.h"
#include "core/video/tracker.h"

using namespace wormdrag;
using namespace wormdrag::video;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

void Rendered() {
  std::printf("\n## Rendered videos (640x480, body 300 px, 150 frames at 30 fps, A=0.6, w=5 rad/s, k=0.6)\n\n");
  std::printf(
      "| case | polarity | blur px | noise | light gradient | valid | mean error %% BL | 95th pct %% BL | max %% BL | "
      "head/tail flips | tail short by px | head across px | body across px | frames/s "
      "|\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  struct Case {
    const char* name;
    bool dark;
    double blur, noise, grad, bias;
  };
  const Case cases[] = {{"clean", true, 1.0, 0, 0, 0},
                        {"clean", false, 1.0, 0, 0, 0},
                        {"noisy", true, 1.5, 8, 0.3, 0},
                        {"noisy", false, 1.5, 8, 0.3, 0},
                        {"very noisy", true, 2.0, 15, 0.5, 0},
                        {"very noisy", false, 2.0, 15, 0.5, 0},
                        {"turning B=0.1", true, 1.5, 8, 0.3, 0.1}};
  for (const Case& c : cases) {
    WormMotion m;
    m.bias = c.bias;
    m.speed_px_per_s = 40;
    RenderOptions o;
    o.dark_on_light = c.dark;
    o.blur_sigma_px = c.blur;
    o.noise_sigma = c.noise;
    o.illumination_gradient = c.grad;
    cv::RNG rng(7);
    const int n = 150;
    const double fps = 30;
    std::vector<cv::Mat> video;
    for (int i = 0; i < n; ++i) video.push_back(RenderWorm(WormCentreline(m, i / fps), o, rng));
    auto r = TrackFrames(video, fps, TrackOptions{});
    if (!r.ok()) {
      std::printf("| %s | error %s |\n", c.name, r.status().ToString().c_str());
      continue;
    }
    std::vector<double> err;
    int flips = 0;
    // Where the error lies: the tail point's along-body offset (+: short of the true tip),
    // the head point's and the interior points' distance across the true body.
    double tail_short = 0, head_across = 0, body_across = 0;
    for (int i = 0; i < n; ++i) {
      const FrameTrack& f = r->frames[i];
      if (!f.valid()) continue;
      const Points truth = TrueSkeleton(m, i / fps);
      for (int k = 0; k < kNumPoints; ++k) err.push_back((f.px[k] - truth[k]).norm() / m.body_length_px * 100);
      if (MeanPointDistanceFlipped(f.px, truth) < MeanPointDistance(f.px, truth)) ++flips;
      for (int k = 0; k < kNumPoints; ++k) {
        const Vec2 t = (truth[std::min(k + 1, kNumPoints - 1)] - truth[std::max(k - 1, 0)]).normalized();
        const Vec2 d = f.px[k] - truth[k];
        const double across = std::abs(d.x() * t.y() - d.y() * t.x());
        if (k == 0)
          head_across += across;
        else if (k == kNumPoints - 1)
          tail_short -= d.dot(t);
        else
          body_across += across / (kNumPoints - 2);
      }
    }
    const int nv = std::max(1, r->summary.valid);
    std::sort(err.begin(), err.end());
    double mean = 0;
    for (double e : err) mean += e;
    mean /= std::max<size_t>(1, err.size());
    std::printf("| %s | %s | %.1f | %.0f | %.1f | %d/%d | %.3f | %.3f | %.3f | %d | %.2f | %.2f | %.2f | %.0f |\n",
                c.name, c.dark ? "dark on light" : "light on dark", c.blur, c.noise, c.grad, r->summary.valid, n, mean,
                err.empty() ? 0 : err[err.size() * 95 / 100], err.empty() ? 0 : err.back(), flips, tail_short / nv,
                head_across / nv, body_across / nv, r->summary.frames_per_second());
  }
}

void WormTracer(const fs::path& shared, const fs::path& work) {
  std::vector<cv::Mat> frames, masks;
  if (!ReadWormTracer(shared, work, &frames, &masks)) return;
  const FrameParams p = ResolveParams(TrackOptions{}, {frames.begin(), frames.begin() + 5});
  const size_t n = std::min(frames.size(), masks.size());
  auto iou = [](const cv::Mat& a, const cv::Mat& b) {
    const int u = cv::countNonZero(a | b);
    return u > 0 ? static_cast<double>(cv::countNonZero(a & b)) / u : 1.0;
  };
  double sum_worm = 0, sum_whole = 0, sum_fg = 0, min_worm = 1, min_fg = 1;
  double worm_area = 0, other_area = 0, other_border = 0, other_marked = 0;
  int above = 0, fg_above = 0;
  // Reference only: mean IoU of `grey >= t` against the whole masks for every t, to find
  // how far one global brightness threshold (chosen on the test masks themselves)
  // reproduces them.
  std::vector<double> global_whole(256, 0.0);
  double secs = 0;
  for (size_t i = 0; i < n; ++i) {
    const auto t0 = Clock::now();
    const FrameAnalysis a = AnalyseFrame(frames[i], p);
    secs += std::chrono::duration<double>(Clock::now() - t0).count();
    const cv::Mat whole = masks[i] > 127;
    int area;
    const cv::Mat worm = LargestComponent(whole, &area);
    const double iw = iou(a.mask, worm);
    sum_worm += iw;
    min_worm = std::min(min_worm, iw);
    above += iw >= 0.9;
    sum_whole += iou(a.mask, whole);
    const double ifg = iou(a.foreground, whole);
    sum_fg += ifg;
    min_fg = std::min(min_fg, ifg);
    fg_above += ifg >= 0.9;
    // What the masks mark besides the worm, and how much of it touches the image border.
    const cv::Mat other = whole & ~worm;
    worm_area += area;
    other_area += cv::countNonZero(other);
    other_marked += cv::countNonZero(other & a.foreground);
    cv::Mat labels, stats, centroids;
    const int nc = cv::connectedComponentsWithStats(other, labels, stats, centroids, 8, CV_32S);
    for (int c = 1; c < nc; ++c) {
      const int x = stats.at<int>(c, cv::CC_STAT_LEFT), y = stats.at<int>(c, cv::CC_STAT_TOP);
      const int w = stats.at<int>(c, cv::CC_STAT_WIDTH), h = stats.at<int>(c, cv::CC_STAT_HEIGHT);
      if (x == 0 || y == 0 || x + w == whole.cols || y + h == whole.rows)
        other_border += stats.at<int>(c, cv::CC_STAT_AREA);
    }
    std::vector<int> h_in(256, 0), h_out(256, 0);
    for (int r = 0; r < whole.rows; ++r)
      for (int c = 0; c < whole.cols; ++c) (whole.at<uchar>(r, c) ? h_in : h_out)[frames[i].at<uchar>(r, c)]++;
    int in_above = cv::countNonZero(whole), out_above = static_cast<int>(whole.total()) - in_above;
    for (int t = 0; t < 256; ++t) {
      global_whole[t] += static_cast<double>(in_above) / (cv::countNonZero(whole) + out_above);
      in_above -= h_in[t];
      out_above -= h_out[t];
    }
  }
  const int best_t = static_cast<int>(std::max_element(global_whole.begin(), global_whole.end()) -
                                      global_whole.begin());
  double global_worm = 0;
  for (size_t i = 0; i < n; ++i) {
    int area;
    global_worm += iou(LargestComponent(frames[i] >= best_t, &area), LargestComponent(masks[i] > 127, &area));
  }
  std::printf("\n## WormTracer (%zu frames, 255x221, light worm on dark)\n\n", n);
  std::printf(
      "- the worm: our worm component against the manual mask's worm (its largest component): **%.4f** (min %.3f, "
      "%d/%zu frames >= 0.9)\n",
      sum_worm / n, min_worm, above, n);
  std::printf(
      "- the whole frame: our binarisation of the whole frame (every component at the mask level, before the worm's is "
      "chosen) against the whole manual mask: **%.4f** (min %.3f, %d/%zu frames >= 0.9)\n",
      sum_fg / n, min_fg, fg_above, n);
  std::printf("- our worm component against the whole manual mask: %.4f\n", sum_whole / n);
  std::printf(
      "- the manual masks mark %.0f px/frame besides the worm (worm %.0f px/frame): %.0f px/frame in components "
      "touching the image border (bright corners), the rest faint tracks in the agar; our whole-frame binarisation "
      "marks %.1f %% of those pixels\n",
      other_area / n, worm_area / n, other_border / n, 100 * other_marked / std::max(1.0, other_area));
  std::printf(
      "- reference, tuned on the test masks: the one global grey threshold that best reproduces them (grey >= %d) "
      "gives %.4f against the whole masks and %.4f for its largest component against the worm\n",
      best_t, global_whole[best_t] / n, global_worm / n);
  std::printf("- per-frame analysis speed: %.0f frames/s\n", n / secs);
  TrackOptions opt;
  opt.fps = 66;
  auto r = TrackFrames(frames, 66, opt);
  if (r.ok()) std::printf("- `wormdrag track` summary: %s\n", r->summary.Report().c_str());
  // What the tapered-tail rule does here: skeleton lengths, and how far the ends lie
  // outside the manual mask's worm, with and without it.
  TrackOptions half = opt;
  half.tapered_tips = false;
  auto h = TrackFrames(frames, 66, half);
  if (r.ok() && h.ok()) {
    auto ends = [&](const TrackResult& t, double* length, int* outside, double* max_out) {
      int valid = 0;
      *length = 0;
      *outside = 0;
      *max_out = 0;
      for (size_t i = 0; i < n; ++i) {
        const FrameTrack& f = t.frames[i];
        if (!f.valid()) continue;
        ++valid;
        *length += f.length_px;
        int area;
        cv::Mat dist;
        cv::distanceTransform(255 - LargestComponent(masks[i] > 127, &area), dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
        for (const Vec2& e : {f.px[0], f.px[kNumPoints - 1]}) {
          const int x = std::clamp(static_cast<int>(std::lround(e.x())), 0, dist.cols - 1);
          const int y = std::clamp(static_cast<int>(std::lround(e.y())), 0, dist.rows - 1);
          const double d = dist.at<float>(y, x);
          *outside += d > 0;
          *max_out = std::max(*max_out, d);
        }
      }
      *length /= std::max(1, valid);
      return valid;
    };
    double l1, l0, m1, m0;
    int o1, o0;
    const int v1 = ends(*r, &l1, &o1, &m1);
    ends(*h, &l0, &o0, &m0);
    std::printf(
        "- tapered-tail rule: mean skeleton length %.1f px (%.1f with every end at half contrast); ends outside the "
        "manual worm mask %d of %d (%d without the rule), at most %.1f px outside (%.1f)\n",
        l1, l0, o1, 2 * v1, o0, m1, m0);
  }
}

void Wormpose(const fs::path& shared) {
  const fs::path dir = shared / "data/real/wormpose_data/sample_data";
  std::vector<double> skel;
  std::vector<cv::Mat> crops;
  if (!ReadWormposeSkeletons(dir / "features.h5", &skel) || !ReadWormposeCrops(dir, &crops)) return;
  int with_ref = 0, scored = 0, coiled = 0, other_missing = 0, valid_without_ref = 0;
  std::vector<double> dist;
  std::map<MissingReason, int> reasons;
  // Tracked as one video (the crop sizes vary, which the per-frame analysis allows) so
  // that the self-overlap test against the running median length applies.
  const TrackOptions opt = WormposeTrackOptions();
  auto r = TrackFrames(crops, 15.0, opt);
  if (!r.ok()) {
    std::printf("%s\n", r.status().ToString().c_str());
    return;
  }
  const double secs = r->summary.seconds;
  for (int i = 0; i < 1000; ++i) {
    std::vector<Vec2> ref;
    for (int k = 0; k < 52; ++k) {
      const double x = skel[(i * 52 + k) * 2], y = skel[(i * 52 + k) * 2 + 1];
      if (std::isfinite(x) && std::isfinite(y)) ref.emplace_back(x, y);
    }
    const FrameTrack& f = r->frames[i];
    const bool has_ref = ref.size() == 52;
    with_ref += has_ref;
    if (!has_ref) {
      valid_without_ref += f.valid();
      continue;
    }
    if (!f.valid()) {
      ++reasons[f.reason];
      (f.reason == MissingReason::kCoiled ? coiled : other_missing)++;
      continue;
    }
    const Points theirs = *ResampleByArcLength(ref);
    // Head/tail of the reference is unverified (PROVENANCE) and crops are independent:
    // orientation-free distance.
    dist.push_back(std::min(MeanPointDistance(f.px, theirs), MeanPointDistanceFlipped(f.px, theirs)));
    ++scored;
  }
  std::sort(dist.begin(), dist.end());
  double mean = 0;
  for (double d : dist) mean += d;
  mean /= std::max<size_t>(1, dist.size());
  // The same score with every end stopped at half contrast (no tapered-tail rule).
  double mean_half = 0;
  int scored_half = 0;
  {
    TrackOptions half = opt;
    half.tapered_tips = false;
    auto h = TrackFrames(crops, 15.0, half);
    for (int i = 0; h.ok() && i < 1000; ++i) {
      if (!std::isfinite(skel[i * 52 * 2]) || !h->frames[i].valid()) continue;
      std::vector<Vec2> ref;
      for (int k = 0; k < 52; ++k) ref.emplace_back(skel[(i * 52 + k) * 2], skel[(i * 52 + k) * 2 + 1]);
      const Points theirs = *ResampleByArcLength(ref);
      mean_half += std::min(MeanPointDistance(h->frames[i].px, theirs),
                            MeanPointDistanceFlipped(h->frames[i].px, theirs));
      ++scored_half;
    }
    mean_half /= std::max(1, scored_half);
  }
  std::printf("\n## wormpose_data sample (1000 crops, dark worm, reference Tierpsy skeletons)\n\n");
  std::printf("- frames with a reference skeleton: %d\n", with_ref);
  std::printf("- scored (tracker valid): %d; mean point distance **%.2f px** (median %.2f, 90th pct %.2f)\n", scored,
              mean, dist.empty() ? 0 : dist[dist.size() / 2], dist.empty() ? 0 : dist[dist.size() * 9 / 10]);
  std::printf("- without the tapered-tail rule (every end at half contrast): %.2f px on %d frames\n", mean_half,
              scored_half);
  std::printf("- reference exists but tracker reports coiled (not scored): %d; other missing: %d\n", coiled,
              other_missing);
  for (const auto& [r, c] : reasons) std::printf("  - %s: %d\n", MissingReasonName(r), c);
  std::printf("- tracker valid on frames without reference: %d of %d\n", valid_without_ref, 1000 - with_ref);
  // Frames without a reference (Tierpsy gave up: mostly coils). Report what the tracker
  // made of them, and whether the skeletons it accepted there are plausible: length against
  // the median tracked length, and shape continuity with the nearest accepted frame (crops
  // move, so shapes are compared with their centroids subtracted, orientation-free). The
  // same continuity on frames with a reference is the yardstick.
  {
    std::map<MissingReason, int> noref;
    std::vector<double> lengths;
    for (int i = 0; i < 1000; ++i)
      if (r->frames[i].valid()) lengths.push_back(r->frames[i].length_px);
    std::sort(lengths.begin(), lengths.end());
    const double median_len = lengths.empty() ? 0 : lengths[lengths.size() / 2];
    auto has_ref = [&](int i) { return std::isfinite(skel[i * 52 * 2]); };
    auto centred = [](Points p) {
      Vec2 c = Vec2::Zero();
      for (const Vec2& q : p) c += q;
      c /= kNumPoints;
      for (Vec2& q : p) q -= c;
      return p;
    };
    // Shape change to the nearest other valid frame within 2 frames (-1: none).
    auto continuity = [&](int i) {
      double best = -1;
      for (int d = 1; d <= 2; ++d)
        for (int j : {i - d, i + d}) {
          if (j < 0 || j >= 1000 || !r->frames[j].valid()) continue;
          const Points a = centred(r->frames[i].px), b = centred(r->frames[j].px);
          const double m = std::min(MeanPointDistance(a, b), MeanPointDistanceFlipped(a, b));
          if (best < 0 || m < best) best = m;
        }
      return best;
    };
    std::vector<double> len_noref, cont_noref, cont_ref;
    for (int i = 0; i < 1000; ++i) {
      const FrameTrack& f = r->frames[i];
      if (!has_ref(i)) ++noref[f.reason];
      if (!f.valid()) continue;
      const double c = continuity(i);
      if (has_ref(i)) {
        if (c >= 0) cont_ref.push_back(c);
        continue;
      }
      len_noref.push_back(f.length_px / median_len);
      if (c >= 0) cont_noref.push_back(c);
    }
    auto pct = [](std::vector<double> v, double q) {
      if (v.empty()) return 0.0;
      std::sort(v.begin(), v.end());
      return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
    };
    std::string marks;
    for (const auto& [reason, c] : noref)
      marks += (marks.empty() ? "" : ", ") + std::to_string(c) + " " + MissingReasonName(reason);
    std::printf("- coiled frames, reported separately: of the %d frames without a reference the tracker marks %s\n",
                1000 - with_ref, marks.c_str());
    std::printf("  - accepted ones: length / median tracked length (%.0f px): min %.2f, median %.2f, max %.2f\n",
                median_len, pct(len_noref, 0), pct(len_noref, 0.5), pct(len_noref, 0.9999));
    std::printf(
        "  - shape change to the nearest accepted frame within 2 frames (centred, px): median %.2f, 90th pct %.2f, max "
        "%.2f over %zu frames (frames with a reference: median %.2f, 90th pct %.2f, max %.2f)\n",
        pct(cont_noref, 0.5), pct(cont_noref, 0.9), pct(cont_noref, 0.9999), cont_noref.size(), pct(cont_ref, 0.5),
        pct(cont_ref, 0.9), pct(cont_ref, 0.9999));
    const double ref_max = pct(cont_ref, 0.9999);
    std::printf("  - accepted frames without a reference whose shape change exceeds the largest on frames with one:");
    for (int i = 0; i < 1000; ++i)
      if (!has_ref(i) && r->frames[i].valid() && continuity(i) > ref_max)
        std::printf(" %d (%.2f px)", i, continuity(i));
    std::printf("\n");
    std::printf("  - accepted frames without a reference:");
    for (int i = 0; i < 1000; ++i)
      if (!has_ref(i) && r->frames[i].valid()) std::printf(" %d", i);
    std::printf("\n");
  }
  std::printf("- tracking speed: %.0f frames/s; %s\n", 1000 / secs, r->summary.Report().c_str());
}

void Modes2Movement(const fs::path& shared) {
  auto r = ReadWt2Features((shared / "data/real/modes2movement/short_worm_features.mat").string());
  if (!r.ok()) {
    std::printf("%s\n", r.status().ToString().c_str());
    return;
  }
  const Kinematics& k = r->kinematics;
  std::printf("\n## modes2movement (Worm Tracker 2 features .mat)\n\n");
  std::printf("- %zu frames at %.5f fps, %d valid, body length %.4f mm\n", k.frames.size(), k.fps, k.NumValid(),
              k.BodyLength());
  std::printf("- valid runs:");
  for (size_t i = 0; i < k.frames.size();) {
    if (!k.frames[i].valid) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j < k.frames.size() && k.frames[j].valid) ++j;
    std::printf(" %zu-%zu", i, j - 1);
    i = j;
  }
  std::printf("\n");
  Kinematics filled = k;
  const int n = InterpolateShortGaps(filled, 8);
  std::printf("- `--interpolate-gaps 8`: %d frames filled, %d valid (0-498 continuous)\n", n, filled.NumValid());
}

}  // namespace

int main(int argc, char** argv) {
  const flags::Spec spec{"video_bench",
                         "[SHARED_DIR]",
                         "Figures of docs/video.md from the data under SHARED_DIR (default " WORMDRAG_SHARED_DIR ").",
                         {}};
  flags::Args args;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec, &args)) return *rc;
  const fs::path shared = args.positionals().empty() ? fs::path(WORMDRAG_SHARED_DIR) : fs::path(args.positionals()[0]);
  const fs::path work = fs::path(WORMDRAG_BINARY_DIR) / "data/WormTracer";
  Rendered();
  WormTracer(shared, work);
  Wormpose(shared);
  Modes2Movement(shared);
  return 0;
}
