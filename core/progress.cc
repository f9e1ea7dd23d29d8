#include "core/progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace bareskin {

ProgressBar::ProgressBar(std::string label, bool enabled, bool force)
    : label_(std::move(label)), enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()), last_draw_(start_ - std::chrono::seconds(1)) {
  if (!tty_ && !force) enabled_ = false;
}

ProgressBar::~ProgressBar() { finish(); }

std::string ProgressBar::format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  char buf[32];
  if (seconds < 60) {
    std::snprintf(buf, sizeof buf, "%.1fs", seconds);
  } else if (seconds < 3600) {
    std::snprintf(buf, sizeof buf, "%dm%02ds", int(seconds) / 60, int(seconds) % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%dh%02dm", int(seconds) / 3600, (int(seconds) / 60) % 60);
  }
  return buf;
}

void ProgressBar::update(int64_t done, int64_t total, const std::string& stage) {
  if (!enabled_ || finished_ || total <= 0) return;
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  const double fraction = std::min(1.0, double(done) / double(total));
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double eta = done > 0 ? elapsed * (1.0 - fraction) / fraction : NAN;
  if (tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && done < total) return;
    last_draw_ = now;
    const int width = 30, filled = int(fraction * width);
    std::fprintf(stderr, "\r\033[K%s [%s%s] %3d%% %lld/%lld %s ETA %s", label_.c_str(), std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), int(fraction * 100), (long long)done, (long long)total,
                 stage.c_str(), format_duration(eta).c_str());
  } else {
    const int decile = int(fraction * 10);
    if (decile == last_decile_) return;
    last_decile_ = decile;
    std::fprintf(stderr, "%s %3d%% %lld/%lld %s elapsed %s ETA %s\n", label_.c_str(), decile * 10, (long long)done,
                 (long long)total, stage.c_str(), format_duration(elapsed).c_str(), format_duration(eta).c_str());
  }
  std::fflush(stderr);
}

void ProgressBar::finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!enabled_ || finished_) return;
  finished_ = true;
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (tty_) std::fprintf(stderr, "\r\033[K%s done in %s\n", label_.c_str(), format_duration(elapsed).c_str());
}

ProgressCallback ProgressBar::callback() {
  return [this](int64_t done, int64_t total, const std::string& stage) { update(done, total, stage); };
}

}  // namespace bareskin
