#pragma once
// The one error hierarchy of paintlab. Library code throws these; only app/ catches,
// prints the one-line message (which names file, line, key, device or register) and
// maps the kind to an exit code (see exit_code()).
#include <stdexcept>
#include <string>

namespace paintlab {

enum class ErrorKind {
  Usage,        // bad command line
  Config,       // a TOML file (rig, paint) is wrong: names file, line and key
  Data,         // an input file's content is wrong (JSON, EXR, MERL, session)
  Io,           // a file could not be read or written
  Device,       // a device failed (timeout, exception reply, lost frame)
  Calibration,  // a calibration could not be computed or a check failed
  Job,          // the job itself failed (fit did not converge, run stopped)
};

class Error : public std::runtime_error {
 public:
  Error(ErrorKind kind, const std::string& message) : std::runtime_error(message), kind_(kind) {}
  ErrorKind kind() const noexcept { return kind_; }

 private:
  ErrorKind kind_;
};

class UsageError : public Error {
 public:
  explicit UsageError(const std::string& message) : Error(ErrorKind::Usage, message) {}
};

// A field of a library's options struct outside what it may be: what() reads
// "CtFitOptions::lobes = 9: allowed 1..3". The command line names the flag the user typed
// instead ("--lobes 9: allowed 1..3", app/cli.h name_flag); a field no flag sets keeps its
// struct name (a bug of the caller, not of the user). Exit 2 like every usage error.
class OptionError : public UsageError {
 public:
  OptionError(std::string field, std::string value, std::string rule);
  const std::string& field() const noexcept { return field_; }
  const std::string& value() const noexcept { return value_; }
  const std::string& rule() const noexcept { return rule_; }

 private:
  std::string field_;
  std::string value_;
  std::string rule_;
};

// A configuration error. what() reads "FILE:LINE: key 'KEY': MESSAGE".
class ConfigError : public Error {
 public:
  ConfigError(std::string file, int line, std::string key, std::string message);
  const std::string& file() const noexcept { return file_; }
  int line() const noexcept { return line_; }  // 0 when unknown
  const std::string& key() const noexcept { return key_; }
  const std::string& detail() const noexcept { return detail_; }

 private:
  std::string file_;
  int line_;
  std::string key_;
  std::string detail_;
};

class DataError : public Error {
 public:
  explicit DataError(const std::string& message) : Error(ErrorKind::Data, message) {}
};

// What a file operation was for: reading an input or writing an output.
enum class IoOp { Read, Write };

class IoError : public Error {
 public:
  // errno_value 0 when not from a system call; else the message includes strerror.
  // IoOp::Write: the file system failed an output (a full disk, a read-only folder, a file
  // size limit), so the job failed though its input was fine (exit 1); IoOp::Read: an
  // input is missing or unreadable (exit 2). A full disk or a read-only file system (ENOSPC,
  // EDQUOT, EFBIG, EROFS) counts as a failed job whichever way it was met.
  IoError(const std::string& path, const std::string& what, int errno_value = 0, IoOp op = IoOp::Read);
  const std::string& path() const noexcept { return path_; }
  int errno_value() const noexcept { return errno_; }
  IoOp op() const noexcept { return op_; }

 private:
  std::string path_;
  int errno_;
  IoOp op_;
};

// A device failure. retryable() says whether trying the same operation again may help
// (timeouts, lost frames, dropped connections) or not (exception replies, bad config).
class DeviceError : public Error {
 public:
  DeviceError(std::string device, const std::string& message, bool retryable);
  const std::string& device() const noexcept { return device_; }
  bool retryable() const noexcept { return retryable_; }

 private:
  std::string device_;
  bool retryable_;
};

class CalibrationError : public Error {
 public:
  explicit CalibrationError(const std::string& message) : Error(ErrorKind::Calibration, message) {}
};

class JobError : public Error {
 public:
  explicit JobError(const std::string& message) : Error(ErrorKind::Job, message) {}
};

// Exit codes of the command line (DESIGN.md "Contracts").
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;    // the job failed: a check, a fit, a device fault
inline constexpr int kExitBadInput = 2;  // bad usage or bad input

int exit_code(const Error& e) noexcept;
const char* to_string(ErrorKind kind) noexcept;

}  // namespace paintlab
