#include "paintlab/fitting/output_guard.h"

#include "paintlab/acquisition/session_reader.h"
#include "paintlab/core/error.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/paint_library.h"

namespace fs = std::filesystem;

namespace paintlab::fit {

std::optional<ProtectedDir> owned_folder_kind(const fs::path& dir) {
  if (acq::is_session_dir(dir))
    return ProtectedDir{dir, "session folder", "a measurement session is only written by `paintlab measure`"};
  std::error_code ec;
  const fs::path index = dir / kLibraryIndexFile;
  if (fs::is_regular_file(index, ec)) {
    try {
      const Json j = read_json_file(index);
      if (j.is_object() && j.value("format", std::string()) == kLibraryFormat)
        return ProtectedDir{dir, "paint library",
                            "a library is changed only by `paintlab library add` and `paintlab library remove`"};
    } catch (const Error&) {
      // Not a library's index.
    }
  }
  return std::nullopt;
}

OutputGuard& OutputGuard::input(const std::string& flag, const fs::path& path) {
  if (!path.empty()) inputs_.push_back({flag, path});
  return *this;
}

OutputGuard& OutputGuard::inputs(const std::string& flag, const std::vector<fs::path>& paths) {
  for (const auto& p : paths) input(flag, p);
  return *this;
}

OutputGuard& OutputGuard::input_tree(const std::string& flag, const fs::path& folder) {
  std::error_code ec;
  if (folder.empty() || !fs::is_directory(folder, ec)) return *this;
  for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file(ec)) input(flag, it->path());
  return *this;
}

OutputGuard& OutputGuard::output(OutputSpec out, const std::optional<fs::path>& owned) {
  if (!out.path.empty()) outputs_.emplace_back(std::move(out), owned);
  return *this;
}

void OutputGuard::check() const {
  std::vector<OutputSpec> all;
  for (const auto& [out, owned] : outputs_) {
    std::vector<ProtectedDir> dirs = protected_ancestors(out.path, owned_folder_kind);
    if (owned) {
      const fs::path mine = resolved_output_path(*owned);
      std::erase_if(dirs, [&](const ProtectedDir& d) { return resolved_output_path(d.path) == mine; });
    }
    check_output(out, inputs_, dirs);
    all.push_back(out);
  }
  check_outputs_distinct(all);
}

}  // namespace paintlab::fit
