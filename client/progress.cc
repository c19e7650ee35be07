#include "client/progress.h"

#include <cmath>
#include <cstdio>

namespace wormdrag::cli {

std::string FormatDuration(double s) {
  char buf[32];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.0f s", s);
  else
    std::snprintf(buf, sizeof buf, "%d:%02d", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  return buf;
}

const char* ProgressUnit(const std::string& phase) {
  return phase == "bootstrap" ? "refits" : "sets";
}

void ProgressBar::Draw(int64_t done, int64_t total, double best_e, bool final_line) {
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - phase_start_).count();
  const double rate = elapsed > 0 ? done / elapsed : 0;
  const double eta = rate > 0 ? (total - done) / rate : NAN;
  const int width = 24;
  const int fill = total > 0 ? static_cast<int>(width * static_cast<double>(done) / total) : 0;
  std::string bar(fill, '#');
  bar.resize(width, '.');
  char best[48] = "";
  if (best_e > 0 && std::isfinite(best_e)) std::snprintf(best, sizeof best, "  best E %.4g mm", best_e);
  const char* unit = ProgressUnit(phase_);
  const bool refits = unit != std::string("sets");  // a few a second: show decimals
  std::fprintf(stderr, "%s%-15s [%s] %lld/%lld  %.*f %s/s  %s %s%s%s", terminal_ ? "\r\033[K" : "", phase_.c_str(),
               bar.c_str(), static_cast<long long>(done), static_cast<long long>(total), refits ? 2 : 0, rate, unit,
               final_line ? "took" : "ETA", final_line ? FormatDuration(elapsed).c_str() : FormatDuration(eta).c_str(),
               best, terminal_ && !final_line ? "" : "\n");
  std::fflush(stderr);
  drawn_ = terminal_ && !final_line;
}

void ProgressBar::Update(const std::string& phase, int64_t done, int64_t total, double best_e) {
  const auto now = std::chrono::steady_clock::now();
  if (phase != phase_) {
    if (!phase_.empty()) Draw(last_done_, last_total_, last_best_, true);
    phase_ = phase;
    phase_start_ = now;
  }
  last_done_ = done;
  last_total_ = total;
  last_best_ = best_e;
  if (terminal_ && now - last_draw_ > std::chrono::milliseconds(100)) {
    last_draw_ = now;
    Draw(done, total, best_e, false);
  }
}

void ProgressBar::Finish() {
  if (!phase_.empty()) Draw(last_done_, last_total_, last_best_, true);
  phase_.clear();
}

}  // namespace wormdrag::cli
