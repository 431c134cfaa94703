#pragma once
// The software version recorded in every output file: "0.1.0+g<commit>[-dirty]".
#include <string>

namespace paintlab {

const std::string& software_version();
// Current UTC time as ISO 8601 ("2026-11-23T11:52:07Z").
std::string utc_timestamp();
// Parses utc_timestamp()'s format to seconds since the epoch; -1 when malformed.
long long parse_utc_timestamp(const std::string& text);

}  // namespace paintlab
