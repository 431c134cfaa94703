#include "paintlab/core/progress.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fmt/format.h>
#include <unistd.h>

namespace paintlab {
namespace {
std::atomic<bool> g_quiet{false};
}

void set_progress_quiet(bool quiet) { g_quiet = quiet; }

Progress::Progress(std::string label, long total, std::string unit, std::FILE* out)
    : label_(std::move(label)), total_(total), unit_(std::move(unit)), out_(out),
      terminal_(::isatty(::fileno(out)) != 0), min_interval_s_(terminal_ ? 0.1 : 5.0),
      start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
  if (!finished_) finish();
}

double Progress::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

std::string Progress::format_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "--";
  if (s < 60) return fmt::format("{:.1f}s", s);
  long t = std::lround(s);
  if (t < 3600) return fmt::format("{}:{:02d}", t / 60, t % 60);
  return fmt::format("{}:{:02d}:{:02d}", t / 3600, (t / 60) % 60, t % 60);
}

std::string Progress::render_bar(double fraction, int width) {
  fraction = std::clamp(fraction, 0.0, 1.0);
  int full = static_cast<int>(std::floor(fraction * width));
  std::string bar = "[";
  for (int i = 0; i < width; ++i) bar += i < full ? '#' : (i == full ? '>' : '.');
  if (full >= width) bar.back() = '#';
  return bar + "]";
}

std::string Progress::line(const std::string& note, bool final) const {
  double t = elapsed();
  double rate = t > 0 ? done_ / t : 0.0;
  std::string unit = unit_.empty() ? "" : " " + unit_;
  std::string s = label_ + " ";
  if (total_ > 0) {
    double frac = static_cast<double>(done_) / total_;
    if (terminal_) s += render_bar(frac, 30) + " ";
    s += fmt::format("{}/{}{} ({:.0f}%)", done_, total_, unit, 100.0 * frac);
  } else {
    s += fmt::format("{}{}", done_, unit);
  }
  s += fmt::format(", {:.2f}{}/s", rate, unit);
  if (final) {
    s += ", done in " + format_duration(t);
  } else if (total_ > 0 && done_ > 0) {
    s += ", ETA " + format_duration((total_ - done_) / rate);
  }
  if (!note.empty()) s += "  " + note;
  return s;
}

void Progress::update(long done, const std::string& note) {
  done_ = done;
  last_note_ = note;
  if (g_quiet) return;
  double t = elapsed();
  bool last = total_ > 0 && done_ >= total_;
  if (t - last_print_s_ < min_interval_s_ && !last) return;
  last_print_s_ = t;
  if (terminal_) {
    std::fprintf(out_, "\r\033[K%s", line(note, false).c_str());
  } else {
    std::fprintf(out_, "%s\n", line(note, false).c_str());
  }
  std::fflush(out_);
}

void Progress::finish(const std::string& note) {
  if (finished_) return;
  finished_ = true;
  std::string text = line(note.empty() ? last_note_ : note, true);
  if (terminal_ && !g_quiet) std::fprintf(out_, "\r\033[K");
  std::fprintf(out_, "%s\n", text.c_str());
  std::fflush(out_);
}

}  // namespace paintlab
