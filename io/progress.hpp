// One progress line for long commands (`wake run`, `wake surface`, `wake export`): on a
// terminal a single line updated in place, otherwise plain log lines, at most one per
// second (and always the last); nothing without a stream.
#pragma once

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <string>

namespace wake {

/// "0:12", "12:34" or "1:02:03"; "--:--" when unknown.
inline std::string formatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long s = std::lround(seconds);
  char buf[32];
  if (s >= 3600)
    std::snprintf(buf, sizeof(buf), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  else
    std::snprintf(buf, sizeof(buf), "%ld:%02ld", s / 60, s % 60);
  return buf;
}

class ProgressLine {
 public:
  /// `out` nullptr: silent.
  ProgressLine(std::ostream* out, bool interactive) : out_(out), interactive_(interactive) {}

  /// Seconds since construction.
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

  /// Shows `line` ("[wake] ..."); `last` ends the updating line. A log shows the first,
  /// the last, and at most one per second between them.
  void update(const std::string& line, bool last) {
    if (!out_) return;
    const double now = elapsed();
    if (!interactive_ && !last && shown_ && now - last_print_ < 1.0) return;
    shown_ = true;
    last_print_ = now;
    if (interactive_) {
      // Pad over a longer previous line; the final newline comes with the last update.
      const std::size_t pad = line_width_ > line.size() ? line_width_ - line.size() : 0;
      *out_ << "\r" << line << std::string(pad, ' ') << (last ? "\n" : "") << std::flush;
      line_width_ = last ? 0 : line.size();
    } else {
      *out_ << line << std::endl;
    }
  }

  /// A line of its own ("[wake] " + line), clearing an updating line first.
  void message(const std::string& line) {
    if (!out_) return;
    if (interactive_ && line_width_ > 0) *out_ << "\r" << std::string(line_width_, ' ') << "\r";
    line_width_ = 0;
    *out_ << "[wake] " << line << std::endl;
  }

  /// Ends an unfinished updating line (before an error message is printed).
  void abandon() {
    if (out_ && interactive_ && line_width_ > 0) *out_ << std::endl;
    line_width_ = 0;
  }

  bool silent() const { return out_ == nullptr; }

 private:
  std::ostream* out_;
  bool interactive_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  double last_print_ = -1.0;
  bool shown_ = false;
  std::size_t line_width_ = 0;
};

}  // namespace wake
