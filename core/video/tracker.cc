#include "core/video/tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "core/video/carry.h"
#include "core/video/frame_source.h"
#include "core/video/orient.h"

namespace wormdrag::video {

const char* MissingReasonName(MissingReason r) {
  switch (r) {
    case MissingReason::kNone:
      return "valid";
    case MissingReason::kNoWorm:
      return "no-worm";
    case MissingReason::kTouchesBorder:
      return "touches-border";
    case MissingReason::kCoiled:
      return "coiled";
    case MissingReason::kSkeletonFailed:
      return "no-skeleton";
    case MissingReason::kTouching:
      return "touching";
  }
  return "?";
}

std::string TrackSummary::Report() const {
  std::ostringstream o;
  o << frames << " frames, " << valid << " valid";
  if (carried) o << " (" << carried << " carried through coils)";
  bool first = true;
  for (const auto& [reason, n] : missing) {
    if (!n) continue;
    o << (first ? ", missing: " : ", ") << n << " " << MissingReasonName(reason);
    first = false;
  }
  o << "; " << runs << " runs in " << chains << " chains (" << runs_flipped << " flipped, " << runs_undecided
    << " undecided); " << PolarityName(polarity);
  if (seconds > 0) o << "; " << static_cast<int>(std::lround(frames_per_second())) << " frames/s";
  return o.str();
}

namespace {

// Streaming state of a tracking run.
class Tracker {
 public:
  Tracker(const TrackOptions& opt, const FrameParams& params, double fps)
      : opt_(opt), params_(params), max_gap_(static_cast<int>(std::lround(opt.max_chain_gap_s * fps))) {}

  Status Add(const cv::Mat& gray8) {
    FrameTrack t;
    FrameAnalysis a;
    try {
      a = AnalyseFrame(gray8, params_);
    } catch (const cv::Exception& e) {
      return Status::Internal("frame " + std::to_string(frames_.size()) + ": OpenCV: " + e.what());
    }
    t.reason = a.reason;
    t.fit = a.fit;
    if (a.reason == MissingReason::kNone) {
      Result<Points> pts = ResampleByArcLength(a.centreline);
      if (!pts.ok()) {
        t.reason = MissingReason::kSkeletonFailed;
      } else {
        t.px = *pts;
        t.length_px = a.length_px;
        t.centreline = std::move(a.centreline);
        // A self-overlapping body looks shorter than the worm: compare with the median
        // of the recent valid lengths.
        if (recent_lengths_.size() >= 5) {
          std::vector<double> v(recent_lengths_.end() - std::min<size_t>(recent_lengths_.size(), 51),
                                recent_lengths_.end());
          std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
          if (t.length_px < opt_.min_length_ratio * v[v.size() / 2]) t.reason = MissingReason::kCoiled;
        }
        if (t.reason == MissingReason::kNone) recent_lengths_.push_back(t.length_px);
      }
    }
    if (Carrying() && (t.reason == MissingReason::kCoiled || t.reason == MissingReason::kTouching) && !a.mask.empty()) {
      const cv::Rect box = cv::boundingRect(a.mask);
      t.mask = a.mask(box).clone();
      t.mask_offset = box.tl();
    }
    frames_.push_back(std::move(t));
    KeepOnlyWhatCarryingNeeds();
    return Status::Ok();
  }

  TrackResult Finish(double fps, double seconds) {
    TrackResult r;
    r.summary.frames = static_cast<int>(frames_.size());
    r.summary.polarity = params_.polarity;
    OrientOptions orient;
    orient.max_link_gap = opt_.max_link_gap;
    orient.max_chain_gap = static_cast<int>(std::lround(opt_.max_chain_gap_s * fps));
    orient.positions_comparable = opt_.positions_comparable;
    orient.travel_lag = std::max(1, static_cast<int>(std::lround(0.2 * fps)));
    OrderHeadTail(frames_, orient, &r.summary);
    // Carrying compares positions between frames, which separate crops do not allow.
    if (opt_.carry && opt_.positions_comparable) {
      CarryOptions carry;
      carry.max_gap = orient.max_chain_gap;
      carry.max_unexplained = opt_.max_unexplained;
      r.summary.carried = CarryThroughCoils(frames_, carry);
    }
    const bool calibrated = opt_.um_per_px > 0;
    const double scale = calibrated ? opt_.um_per_px / 1000.0 : 1.0;
    Kinematics& k = r.kinematics;
    k.fps = fps;
    k.metadata["fps"] = std::to_string(fps);
    k.metadata["source"] = "wormdrag track";
    k.metadata["axes"] = "image (x = column to the right, y = row downward)";
    k.metadata["calibration"] = calibrated ? std::to_string(opt_.um_per_px) + " um/px" : "none: lengths are pixels";
    if (!calibrated) k.metadata["units"] = "px";
    for (size_t i = 0; i < frames_.size(); ++i) {
      const FrameTrack& f = frames_[i];
      Frame fr;
      fr.t = i / fps;
      fr.valid = f.valid();
      if (f.valid()) {
        ++r.summary.valid;
        for (int j = 0; j < kNumPoints; ++j) fr.p[j] = f.px[j] * scale;
        fr.arc_length = f.length_px * scale;
      } else {
        ++r.summary.missing[f.reason];
      }
      k.frames.push_back(fr);
      r.quality.push_back({static_cast<int>(i) + opt_.first_frame, fr.t,
                           f.carried ? "carried" : MissingReasonName(f.reason), f.quality()});
    }
    r.summary.seconds = seconds;
    r.frames = std::move(frames_);
    return r;
  }

 private:
  bool Carrying() const { return opt_.carry && opt_.positions_comparable; }

  // Carrying needs the masks of a gap no longer than max_gap_ and the centrelines of the
  // valid frames on either side of one: what else the last frames hold is released as
  // soon as it is known not to be needed, so that memory stays bounded on long videos.
  void KeepOnlyWhatCarryingNeeds() {
    const int n = static_cast<int>(frames_.size());
    auto gap_frame = [&](int i) { return i >= 0 && !frames_[i].valid() && !frames_[i].mask.empty(); };
    // A valid frame between two frames that are not gap frames borders no gap.
    if (n >= 2 && frames_[n - 2].valid() && !gap_frame(n - 3) && !gap_frame(n - 1))
      frames_[n - 2].centreline = Polyline();
    if (!Carrying()) {
      if (n >= 1) frames_[n - 1].centreline = Polyline();
      return;
    }
    // A gap longer than can be carried: its masks go.
    int start = n;
    while (start > 0 && gap_frame(start - 1)) --start;
    if (n - start > max_gap_)
      for (int i = start; i < n; ++i) frames_[i].mask.release();
  }

  TrackOptions opt_;
  FrameParams params_;
  int max_gap_ = 0;  // frames
  std::vector<FrameTrack> frames_;
  std::vector<double> recent_lengths_;
};

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

constexpr int kPolarityFrames = 5;

}  // namespace

Result<TrackResult> TrackFrames(const std::vector<cv::Mat>& frames, double fps, const TrackOptions& opt,
                                const ProgressFn& progress) {
  if (!(fps > 0)) return Status::InvalidArgument("frame rate must be > 0");
  const auto t0 = Clock::now();
  const int begin = std::clamp(opt.first_frame, 0, static_cast<int>(frames.size()));
  int end = static_cast<int>(frames.size());
  if (opt.max_frames > 0) end = std::min(end, begin + opt.max_frames);
  std::vector<cv::Mat> first(frames.begin() + begin, frames.begin() + std::min(end, begin + kPolarityFrames));
  if (first.empty()) return Status::InvalidArgument("no frames to track");
  Tracker tracker(opt, ResolveParams(opt, first), fps);
  for (int i = begin; i < end; ++i) {
    WORMDRAG_RETURN_IF_ERROR(tracker.Add(frames[i]));
    if (progress) progress(i - begin + 1, end - begin);
  }
  return tracker.Finish(fps, SecondsSince(t0));
}

Result<TrackResult> TrackFile(const std::string& input, const TrackOptions& opt, const ProgressFn& progress) {
  const auto t0 = Clock::now();
  auto source = FrameSource::Open(input);
  if (!source.ok()) return source.status();
  FrameSource& src = **source;
  const double fps = opt.fps > 0 ? opt.fps : src.Fps();
  if (!(fps > 0)) return Status::InvalidArgument(input + ": the input declares no frame rate; give --fps");
  int total = src.NumFrames();
  if (total > 0) {
    total = std::max(0, total - opt.first_frame);
    if (opt.max_frames > 0) total = std::min(total, opt.max_frames);
  }
  try {
    cv::Mat frame;
    for (int i = 0; i < opt.first_frame; ++i) {
      auto more = src.Next(&frame);
      if (!more.ok()) return more.status();
      if (!*more) return Status::InvalidArgument(input + ": fewer frames than --first-frame");
    }
    // Buffer the first frames to decide polarity before the first one is analysed.
    std::vector<cv::Mat> head;
    while (static_cast<int>(head.size()) < kPolarityFrames &&
           (opt.max_frames <= 0 || static_cast<int>(head.size()) < opt.max_frames)) {
      auto more = src.Next(&frame);
      if (!more.ok()) return more.status();
      if (!*more) break;
      head.push_back(frame.clone());
    }
    if (head.empty()) return Status::InvalidArgument(input + ": no frames");
    Tracker tracker(opt, ResolveParams(opt, head), fps);
    int done = 0;
    for (const cv::Mat& f : head) {
      WORMDRAG_RETURN_IF_ERROR(tracker.Add(f).Annotate(input));
      ++done;
      if (progress) progress(done, total);
    }
    while (opt.max_frames <= 0 || done < opt.max_frames) {
      auto more = src.Next(&frame);
      if (!more.ok()) return more.status();
      if (!*more) break;
      WORMDRAG_RETURN_IF_ERROR(tracker.Add(frame).Annotate(input));
      ++done;
      if (progress) progress(done, total);
    }
    TrackResult r = tracker.Finish(fps, SecondsSince(t0));
    r.kinematics.metadata["source"] = "wormdrag track " + input;
    return r;
  } catch (const cv::Exception& e) { return Status::Internal(input + ": OpenCV: " + e.what()); }
}

Status WriteOverlay(const std::string& input, const TrackResult& result, const TrackOptions& opt,
                    const std::string& out, const ProgressFn& progress) {
  namespace fs = std::filesystem;
  auto source = FrameSource::Open(input);
  if (!source.ok()) return source.status();
  FrameSource& src = **source;
  std::string ext = fs::path(out).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  const bool as_video = ext == ".avi" || ext == ".mp4" || ext == ".mkv";
  try {
    cv::VideoWriter writer;
    if (!as_video) {
      std::error_code ec;
      fs::create_directories(out, ec);
      if (ec) return Status::InvalidArgument(out + ": cannot create folder: " + ec.message());
    }
    cv::Mat gray, bgr;
    for (int i = 0; i < opt.first_frame; ++i) {
      auto more = src.Next(&gray);
      if (!more.ok()) return more.status();
    }
    const int n = static_cast<int>(result.frames.size());
    for (int i = 0; i < n; ++i) {
      auto more = src.Next(&gray);
      if (!more.ok()) return more.status();
      if (!*more) break;
      // Draw at 2x (at least 400 px wide) so small crops stay legible.
      const double s = std::max(2.0, 400.0 / gray.cols);
      cv::resize(gray, gray, cv::Size(), s, s, cv::INTER_NEAREST);
      cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
      const FrameTrack& f = result.frames[i];
      constexpr int kShift = 4;  // sub-pixel drawing
      auto P = [&](const Vec2& v) {
        return cv::Point(static_cast<int>(std::lround((v.x() + 0.5) * s * (1 << kShift) - (1 << (kShift - 1)))),
                         static_cast<int>(std::lround((v.y() + 0.5) * s * (1 << kShift) - (1 << (kShift - 1)))));
      };
      if (f.valid()) {
        for (int k = 0; k + 1 < kNumPoints; ++k)
          cv::line(bgr, P(f.px[k]), P(f.px[k + 1]), f.carried ? cv::Scalar(0, 160, 255) : cv::Scalar(0, 255, 255), 1,
                   cv::LINE_AA, kShift);
        for (int k = 1; k + 1 < kNumPoints; ++k)
          cv::circle(bgr, P(f.px[k]), 2 << kShift, cv::Scalar(0, 200, 0), 1, cv::LINE_AA, kShift);
        cv::circle(bgr, P(f.px[0]), 4 << kShift, cv::Scalar(0, 0, 255), -1, cv::LINE_AA, kShift);
        cv::circle(bgr, P(f.px[kNumPoints - 1]), 3 << kShift, cv::Scalar(255, 0, 0), -1, cv::LINE_AA, kShift);
      }
      const std::string label = std::to_string(i + opt.first_frame) + " " +
                                (f.carried ? "carried" : MissingReasonName(f.reason));
      cv::putText(bgr, label, cv::Point(5, 18), cv::FONT_HERSHEY_SIMPLEX, 0.5,
                  f.valid() ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
      if (as_video) {
        if (!writer.isOpened()) {
          const int fourcc = ext == ".mp4" ? cv::VideoWriter::fourcc('m', 'p', '4', 'v')
                                           : cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
          writer.open(out, fourcc, std::max(1.0, result.kinematics.fps), bgr.size(), true);
          if (!writer.isOpened()) return Status::InvalidArgument(out + ": cannot open video for writing");
        }
        writer.write(bgr);
      } else {
        char name[32];
        std::snprintf(name, sizeof name, "%06d.png", i + opt.first_frame);
        if (!cv::imwrite((fs::path(out) / name).string(), bgr))
          return Status::InvalidArgument(out + "/" + name + ": cannot write");
      }
      if (progress) progress(i + 1, n);
    }
  } catch (const cv::Exception& e) { return Status::Internal(out + ": OpenCV: " + e.what()); }
  return Status::Ok();
}

}  // namespace wormdrag::video
