#include "core/video/frame_source.h"

#include <algorithm>
#include <cctype>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

namespace wormdrag::video {

namespace fs = std::filesystem;

cv::Mat ToGray8(const cv::Mat& img) {
  cv::Mat g = img;
  if (img.channels() == 3)
    cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
  else if (img.channels() == 4)
    cv::cvtColor(img, g, cv::COLOR_BGRA2GRAY);
  if (g.depth() == CV_8U) return g;
  cv::Mat out;
  double lo, hi;
  cv::minMaxLoc(g, &lo, &hi);
  g.convertTo(out, CV_8U, hi > lo ? 255.0 / (hi - lo) : 1.0, hi > lo ? -lo * 255.0 / (hi - lo) : 0);
  return out;
}

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

class VideoSource : public FrameSource {
 public:
  VideoSource(std::string name, cv::VideoCapture cap) : name_(std::move(name)), cap_(std::move(cap)) {}
  int NumFrames() const override {
    const double n = cap_.get(cv::CAP_PROP_FRAME_COUNT);
    return n > 0 ? static_cast<int>(n) : -1;
  }
  double Fps() const override {
    const double f = cap_.get(cv::CAP_PROP_FPS);
    return f > 0 && f < 1e4 ? f : 0;
  }
  Result<bool> Next(cv::Mat* gray8) override {
    cv::Mat frame;
    if (!cap_.read(frame) || frame.empty()) return false;
    *gray8 = ToGray8(frame);
    ++index_;
    return true;
  }
  const std::string& Name() const override { return name_; }

 private:
  std::string name_;
  mutable cv::VideoCapture cap_;
  int index_ = 0;
};

// Multi-page TIFF, read in chunks so a long stack never has to fit in memory at once.
class TiffSource : public FrameSource {
 public:
  TiffSource(std::string name, int count) : name_(std::move(name)), count_(count) {}
  int NumFrames() const override { return count_; }
  double Fps() const override { return 0; }
  Result<bool> Next(cv::Mat* gray8) override {
    if (next_ >= count_) return false;
    if (chunk_pos_ >= chunk_.size()) {
      chunk_.clear();
      chunk_pos_ = 0;
      const int n = std::min(kChunk, count_ - next_);
      if (!cv::imreadmulti(name_, chunk_, next_, n, cv::IMREAD_UNCHANGED) || chunk_.empty())
        return Status::InvalidArgument(name_ + ": cannot read TIFF page " + std::to_string(next_));
    }
    *gray8 = ToGray8(chunk_[chunk_pos_++]);
    ++next_;
    return true;
  }
  const std::string& Name() const override { return name_; }

 private:
  static constexpr int kChunk = 64;
  std::string name_;
  int count_;
  int next_ = 0;
  std::vector<cv::Mat> chunk_;
  size_t chunk_pos_ = 0;
};

class FolderSource : public FrameSource {
 public:
  FolderSource(std::string name, std::vector<std::string> files) : name_(std::move(name)), files_(std::move(files)) {}
  int NumFrames() const override { return static_cast<int>(files_.size()); }
  double Fps() const override { return 0; }
  Result<bool> Next(cv::Mat* gray8) override {
    if (next_ >= files_.size()) return false;
    const cv::Mat img = cv::imread(files_[next_], cv::IMREAD_UNCHANGED);
    if (img.empty()) return Status::InvalidArgument(files_[next_] + ": cannot read image");
    *gray8 = ToGray8(img);
    ++next_;
    return true;
  }
  const std::string& Name() const override { return name_; }

 private:
  std::string name_;
  std::vector<std::string> files_;
  size_t next_ = 0;
};

}  // namespace

Result<std::unique_ptr<FrameSource>> FrameSource::Open(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return Status::NotFound(path + ": no such file or folder");
  try {
    if (fs::is_directory(path, ec)) {
      static const char* kExt[] = {".png", ".tif", ".tiff", ".jpg", ".jpeg", ".bmp", ".pgm"};
      std::vector<std::string> files;
      for (const auto& e : fs::directory_iterator(path)) {
        if (!e.is_regular_file()) continue;
        const std::string ext = Lower(e.path().extension().string());
        if (std::find(std::begin(kExt), std::end(kExt), ext) != std::end(kExt)) files.push_back(e.path().string());
      }
      if (files.empty()) return Status::InvalidArgument(path + ": folder holds no images (png, tif, jpg, bmp, pgm)");
      std::sort(files.begin(), files.end());
      return std::unique_ptr<FrameSource>(new FolderSource(path, std::move(files)));
    }
    const std::string ext = Lower(fs::path(path).extension().string());
    if (ext == ".tif" || ext == ".tiff") {
      const size_t n = cv::imcount(path, cv::IMREAD_UNCHANGED);
      if (n == 0) return Status::InvalidArgument(path + ": not a readable TIFF");
      return std::unique_ptr<FrameSource>(new TiffSource(path, static_cast<int>(n)));
    }
    cv::VideoCapture cap(path);
    if (!cap.isOpened()) return Status::InvalidArgument(path + ": cannot open as a video");
    return std::unique_ptr<FrameSource>(new VideoSource(path, std::move(cap)));
  } catch (const cv::Exception& e) {
    return Status::InvalidArgument(path + ": " + e.what());
  } catch (const fs::filesystem_error& e) { return Status::InvalidArgument(path + ": " + e.what()); }
}

}  // namespace wormdrag::video
