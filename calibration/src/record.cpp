#include "paintlab/calibration/record.h"

#include <cmath>
#include <ctime>
#include <limits>

#include "paintlab/core/hash.h"
#include "paintlab/core/version.h"

namespace paintlab::calib {

Provenance Provenance::make(const std::string& kind, const std::vector<std::filesystem::path>& files, Json devices) {
  Provenance p;
  p.kind = kind;
  p.date = utc_timestamp();
  p.software_version = paintlab::software_version();
  for (const auto& f : files) p.inputs.push_back({f.string(), sha256_file(f)});
  p.devices = std::move(devices);
  return p;
}

Json Provenance::to_json() const {
  Json in = Json::array();
  for (const auto& f : inputs) in.push_back({{"path", f.path}, {"sha256", f.sha256}});
  return {{"kind", kind}, {"date", date}, {"software_version", software_version}, {"inputs", in}, {"devices", devices}};
}

Provenance Provenance::from_json(const Json& j, const std::string& where) {
  Provenance p;
  p.kind = json_get<std::string>(j, "kind", where);
  p.date = json_get<std::string>(j, "date", where);
  p.software_version = json_get<std::string>(j, "software_version", where);
  if (j.contains("inputs")) {
    for (const auto& f : j.at("inputs"))
      p.inputs.push_back({json_get<std::string>(f, "path", where), json_get<std::string>(f, "sha256", where)});
  }
  p.devices = j.value("devices", Json::object());
  return p;
}

double Provenance::age_days() const {
  long long t = parse_utc_timestamp(date);
  if (t < 0) return std::numeric_limits<double>::quiet_NaN();
  return static_cast<double>(std::time(nullptr) - t) / 86400.0;
}

}  // namespace paintlab::calib
