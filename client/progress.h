// A progress line on stderr: phase, bar, sets done, rate, ETA and best E. Redrawn in
// place at most ten times a second when stderr is a terminal; otherwise one line per
// finished phase, so logs stay readable.
#pragma once

#include <chrono>
#include <string>

namespace wormdrag::cli {

class ProgressBar {
 public:
  explicit ProgressBar(bool terminal) : terminal_(terminal) {}
  void Update(const std::string& phase, int64_t done, int64_t total, double best_e);
  void Finish();  // ends the current line

 private:
  bool terminal_;
  std::string phase_;
  std::chrono::steady_clock::time_point phase_start_, last_draw_;
  int64_t last_done_ = 0, last_total_ = 0;
  double last_best_ = 0;
  bool drawn_ = false;
  void Draw(int64_t done, int64_t total, double best_e, bool final_line);
};

// "1:05" / "12 s"
std::string FormatDuration(double seconds);

// What an estimate's stage counts: "refits" in the bootstrap, else "sets".
const char* ProgressUnit(const std::string& phase);

}  // namespace wormdrag::cli
