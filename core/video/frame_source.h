// Grayscale frames from a video file, a multi-page TIFF or a folder of images.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/common/status.h"

namespace wormdrag::video {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Frame count if known in advance (-1 otherwise: some containers do not say).
  virtual int NumFrames() const = 0;
  // Frame rate declared by the container; 0 when the input has none (TIFF, folder).
  virtual double Fps() const = 0;
  // The next frame as 8-bit grayscale; false at the end. Errors name the input and frame.
  virtual Result<bool> Next(cv::Mat* gray8) = 0;
  virtual const std::string& Name() const = 0;

  // Chooses by what `path` is: a directory (images sorted by name), .tif/.tiff, or
  // anything OpenCV's video reader opens.
  static Result<std::unique_ptr<FrameSource>> Open(const std::string& path);
};

// Any image (8- or 16-bit, gray or colour) to 8-bit grayscale; 16-bit is scaled by its
// own min–max so that faint 12-bit camera data keeps its contrast.
cv::Mat ToGray8(const cv::Mat& img);

}  // namespace wormdrag::video
