#pragma once
// Atomic file replacement: write to a temporary file in the same folder, fsync it, rename
// it over the target, fsync the folder. A crash at any point leaves either the old file
// or the new one, never a torn one; a failed write leaves no partial file behind.
#include <filesystem>
#include <functional>
#include <string_view>

namespace paintlab {

// Writes `bytes` to `path` atomically. Throws IoError.
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes);

// For writers that need a path (OpenEXR, HDF5, OpenCV): calls writer(tmp_path), then
// fsyncs, renames to `path` and fsyncs the folder. When `writer` throws, the temporary
// file is removed and the exception propagates; `path` is untouched.
void write_via_temp(const std::filesystem::path& path,
                    const std::function<void(const std::filesystem::path& tmp)>& writer);

// The temporary name used for `path` (same folder, hidden, unique per process and call).
std::filesystem::path temp_path_for(const std::filesystem::path& path);

// Reads a whole file. Throws IoError.
std::string read_file(const std::filesystem::path& path);

// fsync of a file or folder by path. Throws IoError.
void fsync_path(const std::filesystem::path& path);

// Removes stale temporaries (".NAME.tmp-*") left in `dir` by a crashed writer; returns how many.
int remove_stale_temps(const std::filesystem::path& dir);

}  // namespace paintlab
