#include "report_browser.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cstdlib>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "paintlab/core/atomic_file.h"
#include "paintlab/core/json.h"
#include "paintlab/core/process.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace report_browser {
namespace {

// Injected into a copy of the page: records script and resource errors from the start, and
// after the load event writes what the page looks like into <pre id="probe"> (JSON): the
// page height, every image (loaded or broken) and every section's box with its images.
constexpr const char* kErrorProbe =
    "<script>window.__errors=[];window.addEventListener('error',function(e){window.__errors.push("
    "String(e.message||(e.target&&e.target.src?'failed to load '+String(e.target.src).slice(0,40):'error')))},true);"
    "</script>";
constexpr const char* kLayoutProbe = R"js(<script>
window.addEventListener('load', function () {
  var r = {errors: window.__errors, height: document.documentElement.scrollHeight, images: 0, broken: 0, sections: []};
  var ok = function (i) { return i.complete && i.naturalWidth > 0; };
  document.querySelectorAll('img').forEach(function (i) { r.images++; if (!ok(i)) r.broken++; });
  document.querySelectorAll('section').forEach(function (s) {
    var b = s.getBoundingClientRect(), imgs = [];
    s.querySelectorAll('img').forEach(function (i) {
      var c = i.getBoundingClientRect();
      imgs.push({x: c.left + scrollX, y: c.top + scrollY, w: c.width, h: c.height, ok: ok(i), svg: i.src.indexOf('svg') > 0});
    });
    r.sections.push({id: s.id, x: b.left + scrollX, y: b.top + scrollY, w: b.width, h: b.height, imgs: imgs});
  });
  var p = document.createElement('pre'); p.id = 'probe'; p.textContent = JSON.stringify(r); document.body.appendChild(p);
});
</script>)js";

std::string unescape(std::string s) {
  for (auto [from, to] : {std::pair{"&quot;", "\""}, {"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}}) {
    for (auto at = s.find(from); at != std::string::npos; at = s.find(from, at + 1)) s.replace(at, std::string(from).size(), to);
  }
  return s;
}

// chromium headless with no network: in a new network namespace of its own (unshare -rn:
// only a loopback that is down), and told to resolve no host and use a closed proxy besides.
ProcessOutput chromium(const fs::path& profile, std::vector<std::string> args) {
  std::vector<std::string> argv = {"-rn", "chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                                   "--no-first-run", "--disable-background-networking", "--disable-component-update",
                                   "--disable-sync", "--host-resolver-rules=MAP * ~NOTFOUND",
                                   "--proxy-server=http://127.0.0.1:9", "--user-data-dir=" + profile.string()};
  argv.insert(argv.end(), args.begin(), args.end());
  return run_process_capture("unshare", argv, "", 120.0);
}

// The DOM value of the element with this id (tags inside dropped).
std::string element_text(const std::string& dom, const std::string& id) {
  const auto at = dom.find("id=\"" + id + "\"");
  if (at == std::string::npos) return "(no element " + id + ")";
  const auto start = dom.find('>', at) + 1;
  std::string text;
  bool in_tag = false;
  for (auto i = start; i < dom.size() && dom.compare(i, 5, "</td>") != 0 && dom.compare(i, 4, "</p>") != 0; ++i) {
    if (dom[i] == '<') in_tag = true;
    if (!in_tag) text += dom[i];
    if (dom[i] == '>') in_tag = false;
  }
  return text;
}

// The first number in `text`.
double first_number(const std::string& text) {
  const auto at = text.find_first_of("-0123456789");
  return at == std::string::npos ? std::nan("") : std::strtod(text.c_str() + at, nullptr);
}

}  // namespace

void check_demo_report(const fs::path& demo) {
  const fs::path page = demo / "report.html";
  ASSERT_TRUE(fs::exists(page));
  const std::string html = [&] {
    std::ifstream in(page, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }();
  // The performance goal's size (docs/reports.md): at most 10 MB.
  EXPECT_LT(html.size(), 10u << 20);
  test::TempDir tmp;
  std::string probed = html;
  probed.insert(probed.find("<head>") + 6, kErrorProbe);
  probed.insert(probed.rfind("</body>"), kLayoutProbe);
  const fs::path copy = tmp / "report-probe.html";
  write_file_atomic(copy, probed);
  const std::string url = "file://" + copy.string();

  // The same width for the layout probe as for the screenshot below (the page's layout depends
  // on the width only), so that the boxes the probe reports are where the screenshot has them.
  constexpr int kWidth = 1200;
  const ProcessOutput dom = chromium(
      tmp / "profile1", {fmt::format("--window-size={},1000", kWidth), "--virtual-time-budget=10000", "--dump-dom", url});
  ASSERT_EQ(dom.exit_code, 0) << dom.err.substr(0, 2000);
  const auto p0 = dom.out.find("<pre id=\"probe\">");
  ASSERT_NE(p0, std::string::npos) << "the page's load event did not run";
  const auto p1 = dom.out.find("</pre>", p0);
  const Json probe = Json::parse(unescape(dom.out.substr(p0 + 16, p1 - p0 - 16)));
  EXPECT_TRUE(probe["errors"].empty()) << probe["errors"].dump();
  EXPECT_EQ(probe["broken"], 0) << "broken images";
  EXPECT_GT(probe["images"].get<int>(), 10);

  // The numbers of the files it was made from.
  const Json fit = read_json_file(demo / "fit.json");
  const Json check = read_json_file(demo / "calib" / "check.json");
  const Json camera = read_json_file(demo / "calib" / "camera.json");
  const auto near = [](double shown, double truth, const char* what) {
    EXPECT_NEAR(shown, truth, 1e-3 * std::abs(truth) + 1e-12) << what;
  };
  near(first_number(element_text(dom.out, "fit-log-rms")), fit["residual"]["log_rms"], "fit log-RMS");
  near(first_number(element_text(dom.out, "fit-lobe1-m")), fit["lobes"][0]["m"], "lobe 1 m");
  near(first_number(element_text(dom.out, "fit-lobe3-r")), fit["lobes"][2]["r"], "lobe 3 r");
  near(first_number(element_text(dom.out, "fit-kd")), fit["kd"][0], "kd R");
  near(first_number(element_text(dom.out, "camera-rms-px")), camera["rms_px"], "reprojection RMS");
  near(first_number(element_text(dom.out, "camera-fx")), camera["K"][0][0], "fx");
  EXPECT_THAT(element_text(dom.out, "check-verdict"),
              HasSubstr(fmt::format("{} of {} checks failed", check["failures"].get<int>(), check["checks"].size())));
  for (const Json& c : check["checks"])
    if (c["value"].is_number())
      near(first_number(element_text(dom.out, "check-" + c["id"].get<std::string>())), c["value"], "check value");
  EXPECT_THAT(element_text(dom.out, "software-version"), HasSubstr("0."));

  // A screenshot of the whole page: each section is not blank, and each of its plots and
  // pictures shows something (not a uniform box).
  const int height = std::min(probe["height"].get<int>() + 10, 30000);
  const fs::path shot = tmp / "page.png";
  const ProcessOutput ss = chromium(tmp / "profile2", {"--hide-scrollbars", fmt::format("--window-size={},{}", kWidth, height),
                                                       "--screenshot=" + shot.string(), url});
  ASSERT_EQ(ss.exit_code, 0) << ss.err.substr(0, 2000);
  const cv::Mat image = cv::imread(shot.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(image.empty());
  std::vector<std::string> ids;
  for (const Json& s : probe["sections"]) {
    const std::string id = s["id"];
    ids.push_back(id);
    SCOPED_TRACE("section " + id);
    const cv::Rect box = cv::Rect(s["x"].get<int>(), s["y"].get<int>(), s["w"].get<int>(), s["h"].get<int>()) &
                         cv::Rect(0, 0, image.cols, image.rows);
    ASSERT_GT(box.area(), 0) << "not on the screen";
    cv::Mat ink;
    cv::compare(image(box), 200, ink, cv::CMP_LT);
    EXPECT_GT(cv::countNonZero(ink), box.area() / 200) << "blank";
    for (const Json& i : s["imgs"]) {
      EXPECT_TRUE(i["ok"].get<bool>());
      const cv::Rect r = cv::Rect(i["x"].get<int>(), i["y"].get<int>(), i["w"].get<int>(), i["h"].get<int>()) &
                         cv::Rect(0, 0, image.cols, image.rows);
      if (r.area() < 400) continue;  // colour swatches are spans; tiny images are icons
      cv::Scalar mean, sd;
      cv::meanStdDev(image(r), mean, sd);
      EXPECT_GT(sd[0], 5.0) << (i["svg"].get<bool>() ? "plot" : "picture") << " at y " << r.y << " looks uniform";
    }
  }
  for (const char* want : {"status", "summary", "calibration", "check", "measurement", "fit", "colour", "provenance"})
    EXPECT_THAT(ids, ::testing::Contains(std::string(want)));
  // Plots in the sections that have them.
  for (const Json& s : probe["sections"]) {
    const std::string id = s["id"];
    if (id != "calibration" && id != "measurement" && id != "fit") continue;
    int plots = 0;
    for (const Json& i : s["imgs"]) plots += i["svg"].get<bool>();
    EXPECT_GE(plots, 1) << id;
  }
}

}  // namespace report_browser
