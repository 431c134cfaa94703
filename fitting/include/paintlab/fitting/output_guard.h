#pragma once
// The outputs of a paintlab command checked before it does any work (core/output_path.h):
// each command lists what it reads and what it writes; the folders only their owner writes
// are every measurement session (acquisition) and paint library (fitting) at or above an
// output, which is why this lives in fitting, the module that knows both.
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "paintlab/core/output_path.h"

namespace paintlab::fit {

// A session folder (acq::is_session_dir) or a paint library (index.json of format
// "paintlab-library"), as a folder that only its owner writes; nullopt otherwise.
std::optional<ProtectedDir> owned_folder_kind(const std::filesystem::path& dir);

class OutputGuard {
 public:
  // What the command reads (empty paths are left out).
  OutputGuard& input(const std::string& flag, const std::filesystem::path& path);
  OutputGuard& inputs(const std::string& flag, const std::vector<std::filesystem::path>& paths);
  // Every regular file below `folder` (a folder of evidence a command reads); nothing when
  // `folder` is empty or not a folder.
  OutputGuard& input_tree(const std::string& flag, const std::filesystem::path& folder);
  // What it writes (an empty path is left out). `owned`: the folder the command itself owns
  // and may write into (library add's --dir): it is not protected against this output.
  OutputGuard& output(OutputSpec out, const std::optional<std::filesystem::path>& owned = std::nullopt);
  // check_output for every output against the inputs and the protected folders above it,
  // and check_outputs_distinct; UsageError (exit 2) on the first problem.
  void check() const;

 private:
  std::vector<InputSpec> inputs_;
  std::vector<std::pair<OutputSpec, std::optional<std::filesystem::path>>> outputs_;
};

}  // namespace paintlab::fit
