#include "core/video/rect_filter.h"

#include <algorithm>
#include <limits>
#include <vector>

namespace wormdrag::video {
namespace {

// dst(y, c) = max (or min) of src over rows y − k/2 … y + k/2 of column c, the window cut
// at the image's edges: a max or min filter with BORDER_REPLICATE sees the edge pixel,
// which the cut window holds anyway. Van Herk / Gil-Werman: with rows in blocks of k,
// any window of k rows joins a block's suffix and the next block's prefix, so each pixel
// takes three comparisons whatever k. Whole rows at a time, which the compiler
// vectorises. `buffer` is the caller's, grown as needed and reused: the image and its
// transpose need differently shaped prefix and suffix tables, and a table allocated per
// call would cost its page faults on every frame.
template <bool kMax>
void ColumnExtreme(const cv::Mat& src, cv::Mat& dst, int k, std::vector<float>& buffer) {
  const int rows = src.rows, cols = src.cols, r = k / 2;
  const int padded = (rows + 2 * r + k - 1) / k * k;
  const size_t table = static_cast<size_t>(padded) * cols;
  if (buffer.size() < 2 * table) buffer.resize(2 * table);
  cv::Mat g(padded, cols, CV_32F, buffer.data()), h(padded, cols, CV_32F, buffer.data() + table);
  constexpr float kPad = kMax ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
  auto op = [](float a, float b) { return kMax ? std::max(a, b) : std::min(a, b); };
  // Row i of the padded column (i − r of the image, or padding).
  auto in = [&](int i) { return i >= r && i < rows + r ? src.ptr<float>(i - r) : nullptr; };
  for (int i = 0; i < padded; ++i) {
    float* gi = g.ptr<float>(i);
    const float* x = in(i);
    if (i % k == 0) {
      if (x)
        std::copy(x, x + cols, gi);
      else
        std::fill(gi, gi + cols, kPad);
    } else if (x) {
      const float* prev = g.ptr<float>(i - 1);
      for (int c = 0; c < cols; ++c) gi[c] = op(prev[c], x[c]);
    } else {
      std::copy(g.ptr<float>(i - 1), g.ptr<float>(i - 1) + cols, gi);
    }
  }
  for (int i = padded - 1; i >= 0; --i) {
    float* hi = h.ptr<float>(i);
    const float* x = in(i);
    if (i % k == k - 1) {
      if (x)
        std::copy(x, x + cols, hi);
      else
        std::fill(hi, hi + cols, kPad);
    } else if (x) {
      const float* next = h.ptr<float>(i + 1);
      for (int c = 0; c < cols; ++c) hi[c] = op(next[c], x[c]);
    } else {
      std::copy(h.ptr<float>(i + 1), h.ptr<float>(i + 1) + cols, hi);
    }
  }
  dst.create(rows, cols, CV_32F);
  for (int y = 0; y < rows; ++y) {
    // Output row y is padded row y + r; its window runs over padded rows y … y + 2r.
    const float* start = h.ptr<float>(y);
    const float* end = g.ptr<float>(y + 2 * r);
    float* d = dst.ptr<float>(y);
    for (int c = 0; c < cols; ++c) d[c] = op(start[c], end[c]);
  }
}

}  // namespace

cv::Mat RectMorphology(const cv::Mat& src, int k, RectMorph op) {
  CV_Assert(src.type() == CV_32F && k >= 1 && k % 2 == 1);
  // One set of buffers per thread: frames are analysed on several threads at once.
  thread_local std::vector<float> buffer;
  thread_local cv::Mat a, b;
  // A square's max (min) filter is the column filter of the row filter, in either order;
  // the row filter is the column filter of the transpose. Closing = erosion of the
  // dilation = Vmin ∘ Hmin ∘ Hmax ∘ Vmax, so the two row passes share one transpose.
  using Pass = void (*)(const cv::Mat&, cv::Mat&, int, std::vector<float>&);
  const bool close = op == RectMorph::kClose;
  const Pass first = close ? &ColumnExtreme<true> : &ColumnExtreme<false>;
  const Pass second = close ? &ColumnExtreme<false> : &ColumnExtreme<true>;
  first(src, a, k, buffer);
  cv::transpose(a, b);
  first(b, a, k, buffer);
  second(a, b, k, buffer);
  cv::transpose(b, a);
  cv::Mat out;
  second(a, out, k, buffer);
  return out;
}

}  // namespace wormdrag::video
