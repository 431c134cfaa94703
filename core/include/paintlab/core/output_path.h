#pragma once
// The files a command writes, checked before it does any work (issue 13 "Data loss"): an
// output is never one of the command's inputs (by name, or the same file through a symlink
// or hard link), never inside a folder only its owner writes (a measurement session, a paint
// library), and its folder exists (or can be created) and is writable. Every violation is a
// UsageError (exit 2) that names the flag the user typed and both paths.
//
// The commands (app/) only list their inputs, outputs and the folders they do not own;
// protected_ancestors() finds the owned folders above an output with the caller's test of
// what a session or library is (core knows neither).
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace paintlab {

// A file or folder the command reads, with the flag (or positional name: "INPUT") it came
// from, or, for a file found elsewhere, where ("what fit.json was fitted to").
struct InputSpec {
  std::string flag;
  std::filesystem::path path;
};

// A file (or folder) the command writes.
struct OutputSpec {
  OutputSpec() = default;
  OutputSpec(std::string flag_in, std::filesystem::path path_in)
      : flag(std::move(flag_in)), path(std::move(path_in)) {}

  std::string flag;            // the flag the user typed: "--out", "--axf"
  std::filesystem::path path;  // the file written, as the user typed it
  // When `path` is written beside what the user typed (bin's coverage map beside --out,
  // dark.exr beside dark.json, check.json in the calibration folder of --rig): what the user
  // typed; empty when `path` is what the user typed.
  std::filesystem::path beside;
  bool folder = false;          // a folder the command creates and fills (measure --out, library --dir)
  bool create_parents = false;  // the command creates missing parent folders; else the parent must exist
};

// A folder that only its owner writes into.
struct ProtectedDir {
  std::filesystem::path path;
  std::string what;  // "session folder", "paint library"
  std::string why;   // "a measurement session is only written by `paintlab measure`"
};

// Throws UsageError when `out`
//  - is one of `inputs` (same path, relative or absolute, or the same file through a
//    symlink or hard link), or, for a folder output, holds one of them;
//  - is, or lies inside, one of `protected_dirs`;
//  - is a folder where a file is written (or a file where a folder is);
//  - has no folder to go in (missing, unless create_parents; not a folder), or one that is
//    not writable.
// Nothing is created or changed.
void check_output(const OutputSpec& out, std::span<const InputSpec> inputs,
                  std::span<const ProtectedDir> protected_dirs);

// Throws UsageError when two of `outputs` are the same file (bin --out X --coverage X).
void check_outputs_distinct(std::span<const OutputSpec> outputs);

// The folders among `path` (when it is a folder) and its ancestors, both as typed and with
// symlinks resolved, that `classify` says are protected, nearest first, each once.
std::vector<ProtectedDir> protected_ancestors(
    const std::filesystem::path& path,
    const std::function<std::optional<ProtectedDir>(const std::filesystem::path& dir)>& classify);

// Where writing `path` lands: its canonical form when it exists, else its parent's weakly
// canonical form joined with its name (outputs usually do not exist yet). Absolute.
std::filesystem::path resolved_output_path(const std::filesystem::path& path);

// Whether `path` is `dir` or lies inside it, both taken as resolved_output_path() leaves them.
bool path_is_within(const std::filesystem::path& path, const std::filesystem::path& dir);

}  // namespace paintlab
