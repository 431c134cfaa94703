#pragma once
// A demo's report.html in a real browser (Debian's chromium, headless, with no network):
// every section is on the screen and not blank, every image and plot loads, no script error,
// and the page shows the numbers of the JSON files it was made from.
#include <filesystem>

namespace report_browser {

// Checks DIR/report.html of a demo folder DIR with gtest assertions.
void check_demo_report(const std::filesystem::path& demo_dir);

}  // namespace report_browser
