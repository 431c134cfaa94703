#include "paintlab/core/input_files.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>

#include "paintlab/core/error.h"

namespace fs = std::filesystem;

namespace paintlab {

void require_readable_file(const fs::path& path) {
  const std::string shown = path.string();
  std::error_code ec;
  const fs::file_status link = fs::symlink_status(path, ec);
  if (!fs::exists(link)) throw IoError(shown, "no such file");
  const fs::file_status target = fs::status(path, ec);
  if (fs::is_symlink(link) && !fs::exists(target)) {
    if (ec && ec.value() != ENOENT) throw IoError(shown, "cannot be opened", ec.value());  // a loop: ELOOP
    fs::path to = fs::read_symlink(path, ec);
    throw IoError(shown, "is a symbolic link to " + (ec ? std::string("a missing file") : to.string()) +
                             ", which does not exist");
  }
  if (fs::is_directory(target)) throw IoError(shown, "is a folder, not a file");
  if (!fs::is_regular_file(target)) throw IoError(shown, "is not a regular file");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw IoError(shown, "cannot be opened", errno);
  ::close(fd);
}

std::vector<fs::path> expand_input_files(const std::vector<std::string>& args, const std::string& option,
                                         const std::vector<std::string_view>& extensions) {
  auto wanted = [&](const fs::path& p) {
    std::string e = p.extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return std::find(extensions.begin(), extensions.end(), e) != extensions.end();
  };
  auto listed = [&] {
    std::string s;
    for (std::string_view e : extensions) s += (s.empty() ? "" : " ") + std::string(e);
    return s;
  };
  std::vector<fs::path> out;
  for (const auto& a : args) {
    const fs::path p(a);
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      std::vector<fs::path> found;
      for (const auto& e : fs::directory_iterator(p))
        if (e.is_regular_file() && wanted(e.path())) found.push_back(e.path());
      std::sort(found.begin(), found.end());
      if (found.empty()) throw UsageError(option + " " + a + ": the folder holds no images (" + listed() + ")");
      out.insert(out.end(), found.begin(), found.end());
    } else if (fs::exists(p, ec)) {
      out.push_back(p);
    } else {
      throw UsageError(option + " " + a + ": no such file or folder");
    }
  }
  if (out.empty()) throw UsageError(option + ": no images given");
  return out;
}

}  // namespace paintlab
