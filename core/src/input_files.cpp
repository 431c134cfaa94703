#include "paintlab/core/input_files.h"

#include <algorithm>
#include <cctype>

#include "paintlab/core/error.h"

namespace fs = std::filesystem;

namespace paintlab {

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
