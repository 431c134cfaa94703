#include "paintlab/acquisition/runner.h"

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <fmt/format.h>
#include <memory>
#include <mutex>
#include <optional>
#include <spdlog/spdlog.h>
#include <thread>
#include <type_traits>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/hash.h"
#include "paintlab/core/progress.h"
#include "paintlab/core/version.h"

namespace fs = std::filesystem;

namespace paintlab::acq {
namespace {

struct Captured {
  int index = 0;
  double angle_deg = 0.0;
  double angle_read_deg = 0.0;
  std::vector<dev::Frame> frames;
  bool led_was_on = false;
  bool led_off_after = false;
  double clock_start_s = 0.0;
  double clock_end_s = 0.0;
};

// A bounded FIFO between the capture loop and the writer thread.
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity) : capacity_(capacity) {}
  void push(Captured item) {
    std::unique_lock lock(mutex_);
    not_full_.wait(lock, [&] { return items_.size() < capacity_ || closed_; });
    items_.push_back(std::move(item));
    not_empty_.notify_one();
  }
  std::optional<Captured> pop() {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [&] { return !items_.empty() || closed_; });
    if (items_.empty()) return std::nullopt;
    Captured c = std::move(items_.front());
    items_.pop_front();
    not_full_.notify_one();
    return c;
  }
  void close() {
    std::lock_guard lock(mutex_);
    closed_ = true;
    not_empty_.notify_all();
    not_full_.notify_all();
  }

 private:
  std::size_t capacity_;
  std::mutex mutex_;
  std::condition_variable not_full_, not_empty_;
  std::deque<Captured> items_;
  bool closed_ = false;
};

// Thrown inside the capture loop to stop safely.
struct StopRun {
  bool interrupted;
  std::string reason;
};

}  // namespace

void RunnerOptions::check() const {
  auto bad = [](const char* field, double value, const char* rule) {
    throw OptionError(std::string("RunnerOptions::") + field, fmt::format("{}", value), rule);
  };
  if (max_retries < 0 || max_retries > 100) bad("max_retries", max_retries, "0..100");
  if (!(retry_backoff_s >= 0.0) || !std::isfinite(retry_backoff_s)) bad("retry_backoff_s", retry_backoff_s, ">= 0 s");
  if (!(move_timeout_s > 0.0) || !std::isfinite(move_timeout_s)) bad("move_timeout_s", move_timeout_s, "> 0 s");
  if (!(capture_timeout_s > 0.0) || !std::isfinite(capture_timeout_s))
    bad("capture_timeout_s", capture_timeout_s, "> 0 s");
  if (!(poll_s > 0.0) || !std::isfinite(poll_s)) bad("poll_s", poll_s, "> 0 s");
  if (queue_depth < 1 || queue_depth > 64) bad("queue_depth", queue_depth, "1..64");
}

Runner::Runner(const SessionDir& session, RigHandles rig, MergeFn merge, RunnerOptions options)
    : session_(session), rig_(rig), merge_(std::move(merge)), options_(options) {
  options_.check();  // a negative max_retries would never switch the LED off
}

std::string RunSummary::describe(const fs::path& session_dir) const {
  const int finished = finished_before + measured;
  std::string s = fmt::format("positions: {} of {} finished ({} in this run, {} before)\n", finished, positions,
                              measured, finished_before);
  for (const auto& f : resume_findings) s += "resume: " + f + "\n";
  if (frames > 0) {
    const double minimum = physical_min_s();
    s += fmt::format("sweep time on the rig clock: {:.1f} s; physical minimum {:.1f} s (motion {:.1f} + settle {:.1f} + "
                     "exposure {:.1f} + readout {:.1f}{}); ratio {:.3f}\n",
                     sweep_s, minimum, motion_s, settle_s, exposure_s, readout_s,
                     wheel_moves == 0 ? std::string()
                     : wheel_min_s > 0.0
                         ? fmt::format(" + filter wheel {:.1f} in {} moves, which took {:.1f}", wheel_min_s, wheel_moves,
                                       wheel_s)
                         : fmt::format(" + filter wheel {:.1f} in {} moves, as measured: set move_ms_per_slot for "
                                       "its minimum",
                                       wheel_s, wheel_moves),
                     minimum > 0 ? sweep_s / minimum : 0.0);
    s += fmt::format("frames: {}, retries: {}, wall time {:.1f} s\n", frames, retries, wall_s);
  }
  if (skipped_frames > 0)
    s += fmt::format("adaptive bracketing skipped {} frames, saving {:.1f} s\n", skipped_frames, skipped_s);
  if (complete) return s + "session complete: " + session_dir.string() + "\n";
  s += fmt::format("stopped safely ({}): the LED is off, the table stopped, {} positions are journaled.\n",
                   interrupted ? "interrupted" : stop_reason, finished);
  return s + "resume with: paintlab measure --resume " + session_dir.string() + "\n";
}

Json RunSummary::to_json() const {
  return {{"utc_end", utc_timestamp()},
          {"positions", positions},
          {"finished_before", finished_before},
          {"measured", measured},
          {"complete", complete},
          {"interrupted", interrupted},
          {"device_fault", device_fault},
          {"stop_reason", stop_reason},
          {"resume_findings", resume_findings},
          {"sweep_s", sweep_s},
          {"physical_min_s", physical_min_s()},
          {"motion_s", motion_s},
          {"settle_s", settle_s},
          {"exposure_s", exposure_s},
          {"readout_s", readout_s},
          {"wheel_s", wheel_s},
          {"wall_s", wall_s},
          {"frames", frames},
          {"retries", retries},
          {"skipped_frames", skipped_frames},
          {"skipped_s", skipped_s}};
}

RunSummary Runner::run(const std::atomic<bool>& stop) {
  const auto wall_start = std::chrono::steady_clock::now();
  const SessionManifest& plan = session_.manifest();
  RunSummary summary;
  summary.positions = session_.position_count();

  SessionState state = session_.prepare_resume();
  summary.finished_before = state.finished_count();
  summary.resume_findings = state.problems;
  for (const auto& p : state.problems) spdlog::warn("resume: {}", p);
  if (state.todo.empty()) {
    summary.complete = true;
    return summary;
  }

  std::atomic<bool> writer_failed{false};
  std::string writer_error;
  std::mutex merged_mutex;
  std::shared_ptr<const ExrImage> last_merged;
  std::atomic<int> finished{summary.finished_before};
  std::atomic<int> measured{0};
  BoundedQueue queue(static_cast<std::size_t>(std::max(1, options_.queue_depth)));

  std::thread writer([&] {
    while (auto item = queue.pop()) {
      try {
        ExrImage img = merge_(item->frames);
        img.attributes["paintlab.sample"] = plan.sample;
        img.attributes["paintlab.index"] = std::to_string(item->index);
        img.attributes["paintlab.angle_deg"] = fmt::format("{:.6f}", item->angle_deg);
        img.attributes["paintlab.angle_read_deg"] = fmt::format("{:.6f}", item->angle_read_deg);
        img.attributes["paintlab.software_version"] = software_version();
        JournalEntry e;
        e.index = item->index;
        e.angle_deg = item->angle_deg;
        e.angle_read_deg = item->angle_read_deg;
        e.led_was_on = item->led_was_on;
        e.led_off_after = item->led_off_after;
        e.clock_start_s = item->clock_start_s;
        e.clock_end_s = item->clock_end_s;
        for (const auto& f : item->frames) {
          e.exposures_s.push_back(f.meta.exposure_s);
          e.frame_ids.push_back(f.meta.frame_id);
          e.timestamps_ns.push_back(f.meta.timestamp_ns);
          if (wheel_) {
            e.filters.push_back(std::string(1, "RGB"[std::clamp(f.meta.filter, 0, 2)]));
            e.filter_slots.push_back(wheel_slots_[static_cast<std::size_t>(std::clamp(f.meta.filter, 0, 2))]);
          }
        }
        if (options_.keep_raw) {
          fs::path raw = session_.raw_dir(item->index);
          fs::create_directories(raw);
          for (std::size_t k = 0; k < item->frames.size(); ++k) {
            const auto& f = item->frames[k];
            std::string name = fmt::format("exp_{:02d}.png", k);
            write_png(raw / name, f.pixels, dev::bit_depth(f.meta.format) <= 8 ? 8 : 16);
            e.raw_files.push_back(fs::relative(raw / name, session_.dir()).string());
          }
        }
        fs::path out = session_.hdr_path(item->index);
        write_exr(out, img);
        e.file = SessionDir::hdr_name(item->index);
        e.sha256 = sha256_file(out);
        e.utc = utc_timestamp();
        session_.journal().append(e);
        if (planner_) {
          std::lock_guard lock(merged_mutex);
          last_merged = std::make_shared<const ExrImage>(std::move(img));
        }
        ++measured;
        ++finished;
      } catch (const std::exception& ex) {
        writer_error = fmt::format("position {} could not be stored: {}", item->index, ex.what());
        writer_failed = true;
        queue.close();
        return;
      }
    }
  });

  Clock& clock = rig_.clock;
  auto check_stop = [&] {
    if (stop) throw StopRun{true, "interrupted"};
    if (writer_failed) throw StopRun{false, "storage failed"};
  };
  // Runs a device operation, retrying retryable failures with backoff.
  auto retry = [&](auto&& op, const std::string& what) {
    for (int attempt = 0;; ++attempt) {
      auto r = op();
      using V = typename decltype(r)::value_type;
      if (r) {
        if constexpr (std::is_void_v<V>) return;
        else return V(std::move(*r));
      }
      const DeviceError& err = r.error();
      if (!err.retryable() || attempt >= options_.max_retries)
        throw StopRun{false, fmt::format("{} failed{}: {}", what,
                                         attempt > 0 ? fmt::format(" after {} retries", attempt) : "", err.what())};
      ++summary.retries;
      spdlog::warn("{} failed ({}); retry {} of {}", what, err.what(), attempt + 1, options_.max_retries);
      clock.sleep_s(options_.retry_backoff_s * std::pow(2.0, attempt));
      check_stop();
    }
  };
  auto light_off_safely = [&]() -> bool {
    for (int attempt = 0; attempt <= options_.max_retries; ++attempt) {
      auto r = rig_.light.off();
      if (r) {
        auto on = rig_.light.is_on();
        if (on && !*on) return true;
      }
    }
    return false;
  };

  // Puts the filter of `channel` in front of the lens: moved (retried like every device
  // operation), then read back; a wheel elsewhere after the retries stops the run.
  int position_count = 0;
  int wheel_at = 0;  // the slot last read back (0: not yet read)
  auto move_wheel = [&](int channel) {
    const int slot = wheel_slots_[static_cast<std::size_t>(channel)];
    // Already there (the serpentine order starts each position with the last filter): read
    // back, no move.
    if (wheel_at == 0 || wheel_at == slot)
      wheel_at = retry([&] { return wheel_->position(); }, wheel_->id() + ": read position");
    if (wheel_at == slot) return;
    const std::string what = fmt::format("{}: move to slot {} ({} filter)", wheel_->id(), slot, "RGB"[channel]);
    for (int attempt = 0;; ++attempt) {
      const double t0 = clock.now_s();
      retry([&] { return wheel_->move_to(slot); }, what);
      const int at = retry([&] { return wheel_->position(); }, wheel_->id() + ": read position");
      summary.wheel_s += clock.now_s() - t0;
      ++summary.wheel_moves;
      const int from = wheel_at;
      wheel_at = at;
      if (at == slot) {
        summary.wheel_min_s += wheel_->min_move_s(from, slot);  // a retried move's minimum is the last one's
        return;
      }
      if (attempt >= options_.max_retries)
        throw StopRun{false, fmt::format("{}: the wheel is at slot {} after {} attempts to reach slot {} ({} filter)",
                                         wheel_->id(), at, attempt + 1, slot, "RGB"[channel])};
      ++summary.retries;
      spdlog::warn("{}: at slot {} instead of {}; retry {} of {}", wheel_->id(), at, slot, attempt + 1,
                   options_.max_retries);
      check_stop();
    }
  };

  const std::vector<double>& bracket = plan.exposures_s;
  double sweep_start = 0.0;
  bool swept = false;
  try {
    check_stop();
    if (options_.home_first) {
      retry([&] { return rig_.table.home(); }, rig_.table.id() + ": home");
      const double deadline = clock.now_s() + options_.move_timeout_s;
      for (;;) {
        auto st = retry([&] { return rig_.table.status(); }, rig_.table.id() + ": status");
        if (st.in_position && !st.moving) break;
        if (stop) {
          (void)rig_.table.stop();
          check_stop();
        }
        if (clock.now_s() > deadline)
          throw StopRun{false, fmt::format("{}: homing did not finish within {:.0f} s", rig_.table.id(),
                                           options_.move_timeout_s)};
        clock.sleep_s(options_.poll_s);
      }
    }
    sweep_start = clock.now_s();
    swept = true;
    double prev_angle = retry([&] { return rig_.table.angle_deg(); }, rig_.table.id() + ": read angle");
    for (int index : state.todo) {
      check_stop();
      Captured cap;
      cap.index = index;
      cap.angle_deg = plan.angles_deg[index];
      cap.clock_start_s = clock.now_s();
      retry([&] { return rig_.table.move_to(cap.angle_deg); }, fmt::format("{}: move to {:g} deg", rig_.table.id(), cap.angle_deg));
      const double deadline = clock.now_s() + options_.move_timeout_s;
      for (;;) {
        auto st = retry([&] { return rig_.table.status(); }, rig_.table.id() + ": status");
        if (st.alarm_code != 0)
          throw StopRun{false, fmt::format("{}: alarm {} during the move to {:g} deg", rig_.table.id(), st.alarm_code,
                                           cap.angle_deg)};
        if (st.in_position && !st.moving) break;
        if (stop) {
          (void)rig_.table.stop();
          check_stop();
        }
        if (clock.now_s() > deadline)
          throw StopRun{false, fmt::format("{}: the move to {:g} deg did not settle within {:.0f} s", rig_.table.id(),
                                           cap.angle_deg, options_.move_timeout_s)};
        clock.sleep_s(options_.poll_s);
      }
      cap.angle_read_deg = retry([&] { return rig_.table.angle_deg(); }, rig_.table.id() + ": read angle");
      summary.motion_s += rig_.table.move_time_s(prev_angle, cap.angle_deg);
      prev_angle = cap.angle_deg;
      // Settle: wait in short steps so a stop request is honoured at once.
      for (double left = plan.settle_s; left > 0; left -= 0.05) {
        check_stop();
        clock.sleep_s(std::min(0.05, left));
      }
      summary.settle_s += plan.settle_s;

      // The bracket of this position (of one filter's, with a wheel): the planner's choice.
      auto exposures_for = [&](int filter) {
        if (!planner_) return bracket;
        std::shared_ptr<const ExrImage> prev;
        {
          std::lock_guard lock(merged_mutex);
          prev = last_merged;
        }
        std::vector<double> chosen =
            filter < 0 ? planner_->choose(bracket, prev.get()) : planner_->choose_for_filter(filter, bracket, prev.get());
        const double readout = rig_.camera.readout_s();
        for (double e : bracket)
          if (std::find(chosen.begin(), chosen.end(), e) == chosen.end()) {
            ++summary.skipped_frames;
            summary.skipped_s += e + readout;
          }
        return chosen;
      };

      retry([&] { return rig_.light.on(); }, rig_.light.id() + ": switch on");
      bool on = retry([&] { return rig_.light.is_on(); }, rig_.light.id() + ": read state");
      if (!on) {
        light_off_safely();
        throw StopRun{false, rig_.light.id() + ": the LED did not switch on (read back off)"};
      }
      cap.led_was_on = true;
      try {
        // One bracket, or one per filter (R, G, B, or B, G, R at every other position).
        const bool reverse = wheel_ && (position_count++ % 2 == 1);
        for (int k = 0; k < (wheel_ ? 3 : 1); ++k) {
          const int filter = wheel_ ? (reverse ? 2 - k : k) : -1;
          if (wheel_) move_wheel(filter);
          for (double e : exposures_for(filter)) {
            check_stop();
            double applied = retry([&] { return rig_.camera.set_exposure(e); },
                                   fmt::format("{}: set exposure {:.6g} s", rig_.camera.id(), e));
            dev::Frame frame = retry([&] { return rig_.camera.capture(options_.capture_timeout_s); },
                                     fmt::format("{}: capture at {:.6g} s", rig_.camera.id(), applied));
            frame.meta.filter = filter;
            summary.exposure_s += frame.meta.exposure_s;
            summary.readout_s += rig_.camera.readout_s();
            ++summary.frames;
            cap.frames.push_back(std::move(frame));
          }
        }
      } catch (...) {
        light_off_safely();
        throw;
      }
      if (!light_off_safely()) throw StopRun{false, rig_.light.id() + ": the LED did not switch off (stuck on)"};
      cap.led_off_after = true;
      cap.clock_end_s = clock.now_s();
      queue.push(std::move(cap));
      if (progress_) progress_->update(finished.load(), fmt::format("angle {:g} deg", plan.angles_deg[index]));
    }
  } catch (const StopRun& s) {
    summary.interrupted = s.interrupted;
    summary.device_fault = !s.interrupted && !writer_failed;
    summary.stop_reason = s.reason;
    light_off_safely();
    (void)rig_.table.stop();
  }
  if (swept) summary.sweep_s = clock.now_s() - sweep_start;
  queue.close();
  writer.join();
  if (writer_failed) {
    summary.device_fault = false;
    summary.stop_reason = writer_error;
  }
  summary.measured = measured.load();
  summary.complete = finished.load() == summary.positions;
  if (progress_) progress_->update(finished.load());
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  // The run's record. Its loss (a full disk now) loses no measurement: the journal and the
  // images are written; so it is a warning, not an error that would hide the run's outcome.
  try {
    append_jsonl_line(session_.dir() / kRunsFile, summary.to_json());
  } catch (const Error& e) {
    spdlog::warn("{}: the run's record was not written: {}", kRunsFile, e.what());
  }
  return summary;
}

}  // namespace paintlab::acq
