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

// Median of `img` where `mask` is set, or (`outside`) where it is not, over every
// `step`-th row and column.
double MedianOf(const cv::Mat& img, const cv::Mat& mask, bool outside, int step) {
  std::vector<float> v;
  for (int r = 0; r < img.rows; r += step) {
    const float* row = img.ptr<float>(r);
    const uchar* m = mask.ptr<uchar>(r);
    for (int c = 0; c < img.cols; c += step)
      if ((m[c] != 0) != outside) v.push_back(row[c]);
  }
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

FrameAnalysis AnalyseFrame(const cv::Mat& gray8, const FrameParams& params) {
  FrameAnalysis out;
  const cv::Mat response = ForegroundResponse(gray8, params.polarity, params.background_kernel_px,
                                              params.denoise_sigma_px);
  out.threshold = OtsuThreshold(response);
  int area = 0;
  out.foreground = Binarise(response, out.threshold);
  out.mask = LargestComponent(out.foreground, &area);
  if (area < params.min_area_px) {
    out.reason = MissingReason::kNoWorm;
    return out;
  }
  double tip_threshold = 0;
  if (params.half_contrast) {
    // The edge of a blurred body lies where the response is halfway between background
    // and body; Otsu's split sits higher when the body's brightness varies (textured
    // real worms), which thins the mask.
    // The background is most of the frame: every 3rd row and column gives its median
    // as well, at a ninth of the cost.
    const double body = MedianOf(response, out.mask, false, 1);
    const double background = MedianOf(response, out.mask, true, 3);
    out.threshold = background + 0.5 * (body - background);
    tip_threshold = background + params.mask_fraction * (body - background);
    // The mask (what is worm at all) takes in the dim rim too: a lower fraction.
    out.foreground = Binarise(response, background + params.mask_fraction * (body - background));
    out.mask = LargestComponent(out.foreground, &area);
  }
  out.threshold *= params.threshold_scale;
  // The worm's box with a ring of background: distances and holes within it are those of
  // the whole frame, at a fraction of the cost.
  const cv::Rect worm_box = (cv::boundingRect(out.mask) + cv::Size(2, 2) - cv::Point(1, 1)) &
                            cv::Rect(0, 0, gray8.cols, gray8.rows);
  cv::Mat dist = cv::Mat::zeros(gray8.size(), CV_32F);
  cv::Mat dist_box = dist(worm_box);
  cv::distanceTransform(out.mask(worm_box), dist_box, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  double max_dist;
  cv::minMaxLoc(dist_box, nullptr, &max_dist);
  out.half_width_px = max_dist;
  // Holes up to a body width across are noise; a larger one is the space inside a coil.
  const int max_hole = std::max(4, static_cast<int>(std::ceil(max_dist * max_dist)));
  cv::Mat mask_box = out.mask(worm_box);
  const int holes = FillSmallHoles(mask_box, max_hole);
  if (params.reject_border && TouchesBorder(out.mask, params.border_margin_px)) {
    out.reason = MissingReason::kTouchesBorder;
    return out;
  }
  if (holes > 0) {
    out.reason = MissingReason::kCoiled;
    return out;
  }
  // Thin a slightly smoothed copy of the component's neighbourhood: a jagged outline
  // grows spurs on the skeleton.
  const cv::Rect box = cv::boundingRect(out.mask);
  const cv::Rect roi = (box + cv::Size(4, 4) - cv::Point(2, 2)) & cv::Rect(0, 0, gray8.cols, gray8.rows);
  cv::Mat smooth;
  cv::GaussianBlur(out.mask(roi), smooth, cv::Size(0, 0), 1.0);
  cv::threshold(smooth, smooth, 127, 255, cv::THRESH_BINARY);
  const cv::Mat skeleton = ThinZhangSuen(smooth);
  std::vector<cv::Point> path = LongestSkeletonPath(skeleton);
  for (cv::Point& p : path) p += roi.tl();
  if (path.size() < 3) {
    out.reason = MissingReason::kSkeletonFailed;
    return out;
  }
  CentrelineOptions copt;
  copt.extrapolate_tips = params.extrapolate_tips;
  // A tapered tail ends where the mask ends (see ExtendEnd).
  if (params.tapered_tips) copt.tip_threshold = tip_threshold * params.threshold_scale;
  out.centreline = RefineCentreline(path, response, out.threshold, out.half_width_px, copt);
  out.length_px = PolylineLength(out.centreline);
  // A body at least 3 widths long is the least a worm can be; shorter is a blob.
  if (out.centreline.size() < 3 || out.length_px < 6 * out.half_width_px) {
    out.reason = MissingReason::kSkeletonFailed;
    out.centreline.clear();
    return out;
  }
  out.fit = FitToMask(out.mask, dist, out.centreline);
  if (out.fit.uncovered > params.max_unexplained) {
    out.reason = MissingReason::kTouching;
    out.centreline.clear();
    return out;
  }
  out.reason = MissingReason::kNone;
  return out;
}

FrameParams ResolveParams(const TrackOptions& opt, const std::vector<cv::Mat>& first_frames) {
  FrameParams p;
  p.denoise_sigma_px = opt.denoise_sigma_px;
  p.threshold_scale = opt.threshold_scale;
  p.half_contrast = opt.half_contrast;
  p.mask_fraction = opt.mask_fraction;
  p.min_area_px = opt.min_area_px;
  p.reject_border = opt.reject_border;
  p.border_margin_px = opt.border_margin_px;
  p.max_unexplained = opt.max_unexplained;
  p.extrapolate_tips = opt.extrapolate_tips;
  p.tapered_tips = opt.tapered_tips;
  const cv::Mat& f0 = first_frames.empty() ? cv::Mat() : first_frames.front();
  p.background_kernel_px = opt.background_kernel_px > 0 ? opt.background_kernel_px
                                                        : std::clamp(std::min(f0.rows, f0.cols) / 5, 15, 101);
  p.polarity = opt.polarity;
  if (p.polarity == Polarity::kAuto) {
    int dark = 0, light = 0;
    for (const cv::Mat& f : first_frames) (DetectPolarity(f) == Polarity::kDarkOnLight ? dark : light)++;
    p.polarity = dark >= light ? Polarity::kDarkOnLight : Polarity::kLightOnDark;
  }
  return p;
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
