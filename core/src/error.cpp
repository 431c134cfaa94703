#include "paintlab/core/error.h"

#include "paintlab/core/enum_names.h"

#include <cerrno>
#include <cstring>

namespace paintlab {
namespace {
std::string config_message(const std::string& file, int line, const std::string& key, const std::string& message) {
  std::string where = file;
  if (line > 0) where += ":" + std::to_string(line);
  if (!key.empty()) return where + ": key '" + key + "': " + message;
  return where + ": " + message;
}
std::string io_message(const std::string& path, const std::string& what, int errno_value) {
  std::string m = path + ": " + what;
  if (errno_value != 0) m += " (" + std::string(std::strerror(errno_value)) + ")";
  return m;
}
}  // namespace

ConfigError::ConfigError(std::string file, int line, std::string key, std::string message)
    : Error(ErrorKind::Config, config_message(file, line, key, message)),
      file_(std::move(file)), line_(line), key_(std::move(key)), detail_(std::move(message)) {}

OptionError::OptionError(std::string field, std::string value, std::string rule)
    : UsageError(field + " = " + value + ": allowed " + rule),
      field_(std::move(field)), value_(std::move(value)), rule_(std::move(rule)) {}

IoError::IoError(const std::string& path, const std::string& what, int errno_value, IoOp op)
    : Error(ErrorKind::Io, io_message(path, what, errno_value)), path_(path), errno_(errno_value), op_(op) {}

DeviceError::DeviceError(std::string device, const std::string& message, bool retryable)
    : Error(ErrorKind::Device, device + ": " + message), device_(std::move(device)), retryable_(retryable) {}

int exit_code(const Error& e) noexcept {
  switch (e.kind()) {
    case ErrorKind::Io: {
      const auto* io = dynamic_cast<const IoError*>(&e);
      if (!io) return kExitBadInput;
      const int err = io->errno_value();
      const bool environment = err == ENOSPC || err == EDQUOT || err == EFBIG || err == EROFS;
      return io->op() == IoOp::Write || environment ? kExitFailed : kExitBadInput;
    }
    case ErrorKind::Usage:
    case ErrorKind::Config:
    case ErrorKind::Data:
      return kExitBadInput;
    case ErrorKind::Device:
    case ErrorKind::Calibration:
    case ErrorKind::Job:
      return kExitFailed;
  }
  return kExitFailed;
}

const char* to_string(ErrorKind kind) noexcept {
  static constexpr EnumNames<ErrorKind, 7> kNames{{{ErrorKind::Usage, "usage"},
                                                   {ErrorKind::Config, "config"},
                                                   {ErrorKind::Data, "data"},
                                                   {ErrorKind::Io, "io"},
                                                   {ErrorKind::Device, "device"},
                                                   {ErrorKind::Calibration, "calibration"},
                                                   {ErrorKind::Job, "job"}}};
  return enum_name(kNames, kind, "error");
}

}  // namespace paintlab
