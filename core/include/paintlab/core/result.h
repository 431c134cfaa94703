#pragma once
// Expected device failures are values: Result<T> holds a T or the DeviceError that says
// whether a retry may help (STYLE.md "Errors").
#include <tl/expected.hpp>

#include "paintlab/core/error.h"

namespace paintlab {

template <class T>
using Result = tl::expected<T, DeviceError>;

inline tl::unexpected<DeviceError> device_failure(std::string device, const std::string& message,
                                                  bool retryable) {
  return tl::unexpected<DeviceError>(DeviceError(std::move(device), message, retryable));
}

// Returns the value or throws the DeviceError.
template <class T>
T value_or_throw(Result<T> r) {
  if (!r) throw r.error();
  return std::move(*r);
}
inline void value_or_throw(Result<void> r) {
  if (!r) throw r.error();
}

}  // namespace paintlab
