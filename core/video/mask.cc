// The image steps of tracking (skeleton.h): polarity, foreground response, Otsu
// threshold, the worm's component, hole filling and Zhang–Suen thinning.
#include "core/video/skeleton.h"

#include <algorithm>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "core/video/rect_filter.h"

namespace wormdrag::video {

const char* PolarityName(Polarity p) {
  switch (p) {
    case Polarity::kAuto:
      return "auto";
    case Polarity::kDarkOnLight:
      return "dark-on-light";
    case Polarity::kLightOnDark:
      return "light-on-dark";
  }
  return "?";
}

namespace {

int OddAtLeast(int v, int lo) {
  v = std::max(v, lo);
  return v % 2 ? v : v + 1;
}

// Value below which a fraction `q` of the pixels of a CV_32F image lie.
double Quantile(const cv::Mat& img, double q) {
  std::vector<float> v;
  v.reserve(img.total());
  for (int r = 0; r < img.rows; ++r) {
    const float* row = img.ptr<float>(r);
    v.insert(v.end(), row, row + img.cols);
  }
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

}  // namespace

Polarity DetectPolarity(const cv::Mat& gray8) {
  // Background from a median over a window several worm widths wide: the worm occupies a
  // minority of each window, so the median is the local background even when the light
  // is uneven. The worm is then the long tail of the residual on one side.
  const int k = OddAtLeast(std::min(gray8.rows, gray8.cols) / 4, 5);
  cv::Mat bg, smooth;
  cv::GaussianBlur(gray8, smooth, cv::Size(0, 0), 1.0);
  cv::medianBlur(smooth, bg, std::min(k, 255));
  cv::Mat residual;
  cv::subtract(smooth, bg, residual, cv::noArray(), CV_32F);
  const double lo = Quantile(residual, 0.005), hi = Quantile(residual, 0.995);
  return -lo > hi ? Polarity::kDarkOnLight : Polarity::kLightOnDark;
}

cv::Mat ForegroundResponse(const cv::Mat& gray8, Polarity polarity, int background_kernel_px, double denoise_sigma_px) {
  cv::Mat f;
  gray8.convertTo(f, CV_32F);
  if (denoise_sigma_px > 0) cv::GaussianBlur(f, f, cv::Size(0, 0), denoise_sigma_px);
  const int k = OddAtLeast(background_kernel_px, 3);
  // Closing removes dark structures narrower than the kernel: what is left is the light.
  if (polarity == Polarity::kDarkOnLight) return RectMorphology(f, k, RectMorph::kClose) - f;
  return f - RectMorphology(f, k, RectMorph::kOpen);
}

double OtsuThreshold(const cv::Mat& response) {
  double lo, hi;
  cv::minMaxLoc(response, &lo, &hi);
  if (!(hi > lo)) return hi;
  constexpr int kBins = 256;
  std::vector<double> hist(kBins, 0.0);
  const double scale = (kBins - 1) / (hi - lo);
  for (int r = 0; r < response.rows; ++r) {
    const float* row = response.ptr<float>(r);
    for (int c = 0; c < response.cols; ++c) hist[static_cast<int>((row[c] - lo) * scale)] += 1;
  }
  const double total = static_cast<double>(response.total());
  double sum_all = 0;
  for (int i = 0; i < kBins; ++i) sum_all += i * hist[i];
  double w0 = 0, sum0 = 0, best = -1;
  int best_i = 0;
  for (int i = 0; i < kBins - 1; ++i) {
    w0 += hist[i];
    sum0 += i * hist[i];
    const double w1 = total - w0;
    if (w0 <= 0 || w1 <= 0) continue;
    const double m0 = sum0 / w0, m1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (between > best) {
      best = between;
      best_i = i;
    }
  }
  return lo + (best_i + 0.5) / scale;
}

cv::Mat Binarise(const cv::Mat& response, double threshold) {
  cv::Mat mask;
  cv::compare(response, threshold, mask, cv::CMP_GT);
  return mask;
}

cv::Mat LargestComponent(const cv::Mat& mask, int* area) {
  cv::Mat labels, stats, centroids;
  // Block-based labelling (Grana's BBDT) takes a third of the default's time on a frame
  // that is mostly background; the components are the same.
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S, cv::CCL_GRANA);
  int best = 0, best_area = 0;
  for (int i = 1; i < n; ++i) {
    const int a = stats.at<int>(i, cv::CC_STAT_AREA);
    if (a > best_area) {
      best_area = a;
      best = i;
    }
  }
  if (area) *area = best_area;
  cv::Mat out = cv::Mat::zeros(mask.size(), CV_8U);
  if (best > 0) {
    const cv::Rect box(stats.at<int>(best, cv::CC_STAT_LEFT), stats.at<int>(best, cv::CC_STAT_TOP),
                       stats.at<int>(best, cv::CC_STAT_WIDTH), stats.at<int>(best, cv::CC_STAT_HEIGHT));
    out(box).setTo(255, labels(box) == best);
  }
  return out;
}

int FillSmallHoles(cv::Mat& mask, int max_hole_area) {
  cv::Mat inv = 255 - mask;
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(inv, labels, stats, centroids, 4, CV_32S);
  int large = 0;
  for (int i = 1; i < n; ++i) {
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const bool border = x == 0 || y == 0 || x + w == mask.cols || y + h == mask.rows;
    if (border) continue;
    if (stats.at<int>(i, cv::CC_STAT_AREA) <= max_hole_area) {
      mask.setTo(255, labels == i);
    } else {
      ++large;
    }
  }
  return large;
}

bool TouchesBorder(const cv::Mat& mask, int margin) {
  const int m = std::max(1, margin);
  if (mask.rows <= 2 * m || mask.cols <= 2 * m) return cv::countNonZero(mask) > 0;
  const cv::Rect inner(m, m, mask.cols - 2 * m, mask.rows - 2 * m);
  return cv::countNonZero(mask) != cv::countNonZero(mask(inner));
}

cv::Mat ThinZhangSuen(const cv::Mat& mask) {
  // Work on a 0/1 copy with a one-pixel frame so that every pixel has 8 neighbours.
  cv::Mat img;
  cv::copyMakeBorder(mask, img, 1, 1, 1, 1, cv::BORDER_CONSTANT, 0);
  img = img / 255;
  std::vector<cv::Point> candidates, removed;
  for (int r = 1; r < img.rows - 1; ++r)
    for (int c = 1; c < img.cols - 1; ++c)
      if (img.at<uchar>(r, c)) candidates.emplace_back(c, r);
  bool changed = true;
  while (changed) {
    changed = false;
    for (int pass = 0; pass < 2; ++pass) {
      removed.clear();
      for (const cv::Point& p : candidates) {
        const int r = p.y, c = p.x;
        if (!img.at<uchar>(r, c)) continue;
        // Neighbours P2..P9 clockwise from north.
        const int n[8] = {img.at<uchar>(r - 1, c),     img.at<uchar>(r - 1, c + 1), img.at<uchar>(r, c + 1),
                          img.at<uchar>(r + 1, c + 1), img.at<uchar>(r + 1, c),     img.at<uchar>(r + 1, c - 1),
                          img.at<uchar>(r, c - 1),     img.at<uchar>(r - 1, c - 1)};
        int b = 0, a = 0;
        for (int i = 0; i < 8; ++i) {
          b += n[i];
          a += (n[i] == 0 && n[(i + 1) % 8] == 1);
        }
        if (b < 2 || b > 6 || a != 1) continue;
        const bool ok = pass == 0 ? (n[0] * n[2] * n[4] == 0 && n[2] * n[4] * n[6] == 0)
                                  : (n[0] * n[2] * n[6] == 0 && n[0] * n[4] * n[6] == 0);
        if (ok) removed.push_back(p);
      }
      for (const cv::Point& p : removed) img.at<uchar>(p.y, p.x) = 0;
      if (!removed.empty()) changed = true;
    }
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                    [&](const cv::Point& p) { return !img.at<uchar>(p.y, p.x); }),
                     candidates.end());
  }
  cv::Mat out = img(cv::Rect(1, 1, mask.cols, mask.rows)) * 255;
  return out.clone();
}

}  // namespace wormdrag::video
