#pragma once
// The measurement runner: for each light position still to measure, move the table,
// wait until settled, LED on, capture the exposure bracket (applied exposures as read
// back), LED off; a writer thread merges each bracket into an HDR image, writes
// hdr/pos_XXX.exr atomically and then journals the position. Capture of the next
// position overlaps merging of the previous one through a bounded queue.
// The runner sees only the device interfaces (devices/*.h) and a Clock.
#include <array>
#include <atomic>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "paintlab/acquisition/session.h"
#include "paintlab/core/clock.h"
#include "paintlab/core/image_io.h"
#include "paintlab/core/json.h"
#include "paintlab/devices/camera.h"
#include "paintlab/devices/filter_wheel.h"
#include "paintlab/devices/light.h"
#include "paintlab/devices/turntable.h"

namespace paintlab {
class Progress;
}

namespace paintlab::acq {

struct RigHandles {
  dev::Turntable& table;
  dev::Light& light;
  dev::Camera& camera;
  Clock& clock;
};

// Turns one position's bracket (frames in capture order) into the HDR image to store.
using MergeFn = std::function<ExrImage(const std::vector<dev::Frame>& frames)>;

// Chooses the exposures for the next position (adaptive bracketing). `previous` is the
// merged image of the position measured before (nullptr at the start).
class ExposurePlanner {
 public:
  virtual ~ExposurePlanner() = default;
  virtual std::vector<double> choose(const std::vector<double>& bracket_s, const ExrImage* previous) = 0;
  // With a filter wheel: the exposures for the bracket through one filter (0 R, 1 G, 2 B); by
  // default the same as choose().
  virtual std::vector<double> choose_for_filter(int filter, const std::vector<double>& bracket_s,
                                                const ExrImage* previous) {
    (void)filter;
    return choose(bracket_s, previous);
  }
};

struct RunnerOptions {
  int max_retries = 3;            // per device operation, for retryable errors
  double retry_backoff_s = 0.2;   // doubled after each retry
  double move_timeout_s = 120.0;  // a move must settle within this (rig clock)
  double capture_timeout_s = 10.0;
  double poll_s = 0.01;           // status polling interval while moving (rig clock)
  int queue_depth = 2;            // captured brackets waiting for the writer (memory bound)
  bool keep_raw = false;          // also store raw frames as 16-bit PNG under raw/
  bool home_first = true;
  // UsageError naming the field, its value and the rule (max_retries 0..100, backoff >= 0,
  // timeouts and polling > 0, queue_depth 1..64).
  void check() const;
};

struct RunSummary {
  int positions = 0;          // in the plan
  int finished_before = 0;    // already finished when this run started
  int measured = 0;           // finished by this run
  bool complete = false;      // every position finished
  bool interrupted = false;   // stopped by a signal
  bool device_fault = false;  // stopped by a device failure
  std::string stop_reason;
  std::vector<std::string> resume_findings;  // what resume found (missing, bad checksums)
  // Rig-clock figures of this run's sweep (after homing).
  double sweep_s = 0.0;         // elapsed on the rig clock
  double motion_s = 0.0;        // physical minimum parts: motion profile times
  double settle_s = 0.0;        //   settle waits
  double exposure_s = 0.0;      //   sum of applied exposures
  double readout_s = 0.0;       //   frame readouts
  double wheel_s = 0.0;         // filter-wheel moves as long as they took (read on the rig clock)
  double wheel_min_s = 0.0;     //   their physical minimum (FilterWheel::min_move_s; 0 when unknown)
  int wheel_moves = 0;
  // The wheel's part of the minimum: its modelled moves, or what they took when its speed is
  // not known (rig.toml move_ms_per_slot).
  double wheel_part_s() const { return wheel_min_s > 0.0 ? wheel_min_s : wheel_s; }
  double physical_min_s() const { return motion_s + settle_s + exposure_s + readout_s + wheel_part_s(); }
  double wall_s = 0.0;          // wall-clock time of the run
  int frames = 0;
  int retries = 0;
  int skipped_frames = 0;       // adaptive bracketing
  double skipped_s = 0.0;       // exposure + readout time saved by adaptive bracketing

  // What `paintlab measure` prints at the end: positions finished, what resume found, the
  // sweep time against its physical minimum, frames and retries, adaptive savings, then
  // "session complete: DIR" or how it stopped and the command that resumes it.
  std::string describe(const std::filesystem::path& session_dir) const;
  // One line of the session's runs.jsonl: the figures above, the physical minimum, and when
  // the run ended (UTC). `paintlab report` draws the runs from it.
  Json to_json() const;
};
// The session's record of its runs: one JSON line a run, appended when the run ends (complete,
// stopped or faulted). The journal stays the record of what was measured.
inline constexpr const char* kRunsFile = "runs.jsonl";

class Runner {
 public:
  Runner(const SessionDir& session, RigHandles rig, MergeFn merge, RunnerOptions options = {});
  void set_planner(ExposurePlanner* planner) { planner_ = planner; }
  void set_progress(Progress* progress) { progress_ = progress; }
  // A monochrome camera behind a filter wheel: each position takes one bracket per filter, in
  // the slots given for R, G and B (the order reversed at every other position, so the wheel
  // starts where it stopped); every frame carries its filter (FrameMeta::filter) and the
  // journal records it. A wheel that does not reach its slot (read back) after the retries is
  // a device fault: a safe stop that `--resume` continues.
  void set_filter_wheel(dev::FilterWheel* wheel, std::array<int, 3> slots) {
    wheel_ = wheel;
    wheel_slots_ = slots;
  }
  // Measures every position not yet finished. Returns when all are finished, when `stop`
  // becomes true (SIGINT/SIGTERM), or after a device fault that retries did not cure;
  // in every case the LED is off, the table stopped and the journal consistent.
  RunSummary run(const std::atomic<bool>& stop);

 private:
  const SessionDir& session_;
  RigHandles rig_;
  MergeFn merge_;
  RunnerOptions options_;
  ExposurePlanner* planner_ = nullptr;
  Progress* progress_ = nullptr;
  dev::FilterWheel* wheel_ = nullptr;
  std::array<int, 3> wheel_slots_{1, 2, 3};
};

}  // namespace paintlab::acq
