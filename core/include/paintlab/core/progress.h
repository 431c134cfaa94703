#pragma once
// Progress of long work. On a terminal it redraws one line: a bar, count, rate and ETA.
// Not on a terminal (logs, CI) it prints a plain line at most every few seconds and at
// the end, so logs stay readable. Quiet mode (-q) prints only the final line.
#include <chrono>
#include <cstdio>
#include <string>

namespace paintlab {

class Progress {
 public:
  // total = number of steps; unit names a step ("pos", "img"). Output goes to `out`.
  Progress(std::string label, long total, std::string unit = "", std::FILE* out = stderr);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Sets the number of finished steps and an optional note ("angle 42.0 deg").
  void update(long done, const std::string& note = {});
  void step(const std::string& note = {}) { update(done_ + 1, note); }
  // Prints the final line (elapsed time and mean rate). Called by the destructor too.
  void finish(const std::string& note = {});

  // Formats used by the reporter; public for tests.
  static std::string format_duration(double seconds);   // "1:02:03", "4:05", "7.3s"
  static std::string render_bar(double fraction, int width);
  // Forces terminal or plain mode (tests); by default isatty() decides.
  void set_terminal(bool on) { terminal_ = on; }
  void set_min_interval(double seconds) { min_interval_s_ = seconds; }

 private:
  std::string line(const std::string& note, bool final) const;
  double elapsed() const;

  std::string label_;
  long total_;
  std::string unit_;
  std::FILE* out_;
  bool terminal_;
  bool finished_ = false;
  long done_ = 0;
  std::string last_note_;
  double min_interval_s_;
  double last_print_s_ = -1e9;
  std::chrono::steady_clock::time_point start_;
};

// Global quiet switch set by the command line (-q).
void set_progress_quiet(bool quiet);

}  // namespace paintlab
