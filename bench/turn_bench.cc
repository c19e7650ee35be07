// Figures of docs/video.md, "Turns and coils": the tracker on rendered omega
// and delta turns (known truth), on the wormpose coils (Tierpsy reference skeletons) and on
// the WormTracer video (coils and sharp bends, manual masks).
//   build/bench/turn_bench [--section rendered|speed|wormpose|wormtracer] [--dump DIR] [SHARED_DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench/turn_real.h"
#include "core/common/flags.h"
#include "core/video/render.h"
#include "core/video/render_turns.h"
#include "core/video/tracker.h"

using namespace wormdrag;
using namespace wormdrag::video;
namespace fs = std::filesystem;

namespace {

// The measure: a frame is right when it is valid and its 12 joint angles are
// within 0.2 rad RMS of the truth taken head first as written (one orientation for the
// whole recording); valid frames that are not right are "valid but wrong".
constexpr double kRightRms = 0.2;

// What the tracker may do beyond measuring each frame: "full" is the default; "measured"
// carries nothing through coils; "no checks" also lets a short-cut skeleton of a touching
// body through (a tracker without the touching test, orientation aside).
enum class Mode { kFull, kMeasured, kNoChecks };
const char* ModeName(Mode m) {
  return m == Mode::kFull ? "" : m == Mode::kMeasured ? ", measured only" : ", no checks";
}

struct TurnCase {
  const char* name;
  TurnMotion motion;
  bool dark;
  double blur, noise;
  Mode mode = Mode::kFull;
};

// A delta turn whose head speeds up and slows down by half, with a 2 s period: the pace
// through the coil is not the mean of the gap's.
TurnMotion UnevenDelta() {
  TurnMotion m = DeltaTurn();
  m.pace_variation = 0.5;
  return m;
}

void RenderedTurns(const std::string& dump) {
  std::printf("\n## Rendered turns (640x480, body 300 px, 10 s at 30 fps)\n\n");
  std::printf(
      "| case | polarity | frames | right | valid but wrong | missing | flipped | carried | carried: max RMS rad | "
      "missing by reason | runs (chains) | frames/s |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  RenderOptions base;
  const TurnCase cases[] = {{"delta", DeltaTurn(), true, 1.5, 8},
                            {"delta", DeltaTurn(), false, 1.5, 8},
                            {"omega", OmegaTurn(), true, 1.5, 8},
                            {"omega", OmegaTurn(), false, 1.5, 8},
                            {"delta, very noisy", DeltaTurn(), true, 2.0, 15},
                            {"hairpin", Hairpin(), true, 1.5, 8},
                            {"delta, uneven pace", UnevenDelta(), true, 1.5, 8},
                            {"delta", DeltaTurn(), true, 1.5, 8, Mode::kMeasured},
                            {"omega", OmegaTurn(), true, 1.5, 8, Mode::kMeasured},
                            {"hairpin", Hairpin(), true, 1.5, 8, Mode::kMeasured},
                            {"hairpin", Hairpin(), true, 1.5, 8, Mode::kNoChecks}};
  for (const TurnCase& c : cases) {
    const TurnTrack track(c.motion);
    RenderOptions o = base;
    o.dark_on_light = c.dark;
    o.blur_sigma_px = c.blur;
    o.noise_sigma = c.noise;
    const double fps = 30;
    const int n = 300;
    cv::RNG rng(11);
    std::vector<cv::Mat> video;
    for (int i = 0; i < n; ++i) video.push_back(RenderOverlappingWorm(track.Centreline(i / fps), o, rng));
    TrackOptions opt;
    opt.carry = c.mode == Mode::kFull;
    if (c.mode == Mode::kNoChecks) opt.max_unexplained = 1.0;
    auto r = TrackFrames(video, fps, opt);
    if (!r.ok()) {
      std::printf("| %s | error %s |\n", c.name, r.status().ToString().c_str());
      continue;
    }
    int right = 0, wrong = 0, missing = 0, flipped = 0;
    double carried_rms = 0;
    for (int i = 0; i < n; ++i) {
      const FrameTrack& f = r->frames[i];
      if (!f.valid()) {
        ++missing;
        continue;
      }
      const Points truth = track.Skeleton(i / fps);
      const double rms = JointAngleRms(f.px, truth);
      (rms <= kRightRms ? right : wrong)++;
      if (f.carried) carried_rms = std::max(carried_rms, rms);
      flipped += MeanPointDistanceFlipped(f.px, truth) < MeanPointDistance(f.px, truth);
      if (!dump.empty())
        std::fprintf(stderr, "%s frame %d: %s, rms %.2f, unexplained %.3f\n", c.name, i,
                     f.carried ? "carried" : "valid", rms, f.fit.uncovered);
    }
    std::string reasons;
    for (const auto& [reason, k] : r->summary.missing)
      if (k) reasons += (reasons.empty() ? "" : ", ") + std::to_string(k) + " " + MissingReasonName(reason);
    std::printf("| %s%s | %s | %d | %.1f %% | %.1f %% | %.1f %% | %d | %d | %.2f | %s | %d (%d) | %.0f |\n", c.name,
                ModeName(c.mode), c.dark ? "dark on light" : "light on dark", n, 100.0 * right / n, 100.0 * wrong / n,
                100.0 * missing / n, flipped, r->summary.carried, carried_rms,
                reasons.empty() ? "none" : reasons.c_str(), r->summary.runs, r->summary.chains,
                r->summary.frames_per_second());
    if (!dump.empty() && c.dark && c.mode == Mode::kFull) {
      const fs::path dir = fs::path(dump) / c.name;
      fs::create_directories(dir);
      // One contact sheet of every 20th frame at quarter size, 5 across.
      cv::Mat sheet(3 * 120, 5 * 160, CV_8U, cv::Scalar(0));
      for (int i = 0, j = 0; i < n && j < 15; i += 20, ++j) {
        cv::Mat small;
        cv::resize(video[i], small, cv::Size(160, 120), 0, 0, cv::INTER_AREA);
        small.copyTo(sheet(cv::Rect((j % 5) * 160, (j / 5) * 120, 160, 120)));
      }
      cv::imwrite((dir / "sheet.png").string(), sheet);
    }
  }
}

// Tracking speed at 640x480 on one thread (the issue's ≥ 100 frames/s): the rendered
// crawl of video_bench ("noisy", 150 frames), best of 5 runs since other jobs share the
// machine; and the share of the per-frame time the touching test takes.
void Speed() {
  WormMotion m;
  m.speed_px_per_s = 40;
  RenderOptions o;
  o.blur_sigma_px = 1.5;
  o.noise_sigma = 8;
  cv::RNG rng(7);
  std::vector<cv::Mat> video;
  for (int i = 0; i < 150; ++i) video.push_back(RenderWorm(WormCentreline(m, i / 30.0), o, rng));
  // One core: OpenCV's own worker threads off. CPU time as well as wall time, since the
  // machine is shared: frames per CPU second is the speed of one core to itself.
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  double best = 0, best_cpu = 0;
  for (int run = 0; run < 5; ++run) {
    const std::clock_t c0 = std::clock();
    auto r = TrackFrames(video, 30, TrackOptions{});
    const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    if (r.ok()) best = std::max(best, r->summary.frames_per_second());
    if (r.ok() && cpu > 0) best_cpu = std::max(best_cpu, video.size() / cpu);
  }
  const FrameParams p = ResolveParams(TrackOptions{}, {video.begin(), video.begin() + 5});
  double fit_s = 0, all_s = 0;
  for (const cv::Mat& f : video) {
    const auto t0 = std::chrono::steady_clock::now();
    const FrameAnalysis a = AnalyseFrame(f, p);
    const auto t1 = std::chrono::steady_clock::now();
    cv::Mat dist;
    cv::distanceTransform(a.mask, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    const auto t2 = std::chrono::steady_clock::now();
    FitToMask(a.mask, dist, a.centreline);
    const auto t3 = std::chrono::steady_clock::now();
    all_s += std::chrono::duration<double>(t1 - t0).count();
    fit_s += std::chrono::duration<double>(t3 - t2).count();
  }
  std::printf("\n## Speed (640x480, rendered crawl, one thread)\n\n");
  cv::setNumThreads(threads);
  std::printf("- tracking: %.0f frames/s wall time, %.0f frames per CPU second (best of 5 runs of 150 frames)\n", best,
              best_cpu);
  std::printf("- touching test (body re-drawn against the mask): %.2f ms of %.2f ms per frame\n",
              1000 * fit_s / video.size(), 1000 * all_s / video.size());
}

}  // namespace

int main(int argc, char** argv) {
  const flags::Spec spec{
      "turn_bench",
      "[--section NAME] [--dump DIR] [SHARED_DIR]",
      "Figures of docs/video.md, \"Turns and coils\", from the data under SHARED_DIR (default " WORMDRAG_SHARED_DIR
      ").",
      {{"section", "NAME", "rendered, speed, wormpose or wormtracer", "all"},
       {"dump", "DIR", "write a contact sheet of each rendered case, list its wrong frames", ""}}};
  flags::Args args;
  if (auto rc = flags::Parse(flags::ArgList(argc, argv), spec, &args)) return *rc;
  const fs::path shared = args.positionals().empty() ? fs::path(WORMDRAG_SHARED_DIR) : fs::path(args.positionals()[0]);
  const std::string section = args.Get("section", "all");
  if (section == "all" || section == "rendered") RenderedTurns(args.Get("dump"));
  if (section == "all" || section == "speed") Speed();
  if (section == "all" || section == "wormpose") WormposeTurns(shared);
  if (section == "all" || section == "wormtracer")
    WormTracerTurns(shared, fs::path(WORMDRAG_BINARY_DIR) / "data/WormTracer");
  return 0;
}
