#pragma once
// Image files named on the command line: each argument is a file, taken as it is, or a
// folder, expanded to the regular files in it (not recursively) whose extension (case
// ignored) is one of `extensions`, sorted by name. Shell globs are the shell's business.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace paintlab {

// Raw frames of an exposure stack: PNG, TIFF, PGM (8 or 16 bit).
inline const std::vector<std::string_view> kRawImageExtensions = {".png", ".tif", ".tiff", ".pgm"};
// Images a calibration step reads: raw frames, JPEG photos and merged EXR images.
inline const std::vector<std::string_view> kCalibrationImageExtensions = {".png", ".tif",  ".tiff", ".pgm",
                                                                          ".jpg", ".jpeg", ".exr"};

// Checks that `path` names a regular file this process can read, before a parser opens it,
// so the message says what is wrong in the user's words: "no such file", "is a folder, not
// a file", "is a symbolic link to X, which does not exist", "cannot be opened (Too many
// levels of symbolic links)", "cannot be opened (Permission denied)". Throws IoError
// (IoOp::Read: exit 2) whose message starts with the path.
void require_readable_file(const std::filesystem::path& path);

// UsageError naming `option` and the argument for a path that does not exist, a folder
// without such files, and no files at all.
std::vector<std::filesystem::path> expand_input_files(const std::vector<std::string>& args, const std::string& option,
                                                      const std::vector<std::string_view>& extensions);

}  // namespace paintlab
