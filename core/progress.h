// Progress reporting. Libraries take a ProgressCallback (may be empty) and call it as work advances; only apps draw
// a bar (ProgressBar), so tests and other callers stay silent.
#pragma once
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace bareskin {

// done/total in units the caller chooses (scans, rows, iterations); stage names the current step.
using ProgressCallback = std::function<void(int64_t done, int64_t total, const std::string& stage)>;

inline void report(const ProgressCallback& progress, int64_t done, int64_t total, const std::string& stage) {
  if (progress) progress(done, total, stage);
}

// A one-line bar on stderr with percentage, rate and ETA, redrawn at most 10 times a second. Draws nothing when
// stderr is not a terminal unless `force` is set; then it prints a line at every 10%.
class ProgressBar {
 public:
  explicit ProgressBar(std::string label, bool enabled = true, bool force = false);
  ~ProgressBar();
  void update(int64_t done, int64_t total, const std::string& stage);
  void finish();
  ProgressCallback callback();

  // "1m05s", "3.2s": used for the ETA and elapsed time.
  static std::string format_duration(double seconds);

 private:
  std::string label_;
  bool enabled_;
  bool tty_;
  bool finished_ = false;
  int last_decile_ = -1;
  std::chrono::steady_clock::time_point start_, last_draw_;
  std::mutex mutex_;
};

}  // namespace bareskin
