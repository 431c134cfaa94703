// The radiometry command line through the paintlab binary: calibrate response|dark|flat and
// hdr merge on synthetic stacks written as PNG, and bad input (exit 2, the message names
// the problem, no output file).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "paintlab/core/image_io.h"
#include "paintlab/core/json.h"
#include "test_util.h"

using namespace paintlab;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

namespace {

// Writes an 8-bit gamma-camera stack (RGB) or a 16-bit linear stack (mono) of a scene with
// radiance log-uniform over 4 decades; returns the files and "t1,t2,..." (seconds).
struct Written {
  std::vector<fs::path> files;
  std::vector<double> t;
  ImageF x;
  std::string list() const {
    std::string s;
    for (double v : t) s += (s.empty() ? "" : ",") + std::to_string(v);
    return s;
  }
  std::string images() const {
    std::string s;
    for (const auto& f : files) s += " '" + f.string() + "'";
    return s;
  }
};

Written write_stack(const fs::path& dir, int bits, int channels, int count) {
  Written w;
  const int W = 64, H = 48;
  std::mt19937_64 rng(test::seed());
  std::uniform_real_distribution<double> u(std::log(1.0), std::log(1e4));
  std::normal_distribution<double> n(0.0, 1.0);
  w.x = ImageF(W, H, channels);
  for (auto& v : w.x.values()) v = static_cast<float>(std::exp(u(rng)));
  const double m[3] = {1.0, 1.37, 1.71};
  for (int j = 0; j < count; ++j) {
    const double t = 1e-4 * std::pow(2.0, j) * m[j % 3];
    Image<std::uint16_t> img(W, H, channels);
    for (std::size_t i = 0; i < img.size(); ++i) {
      double z;
      if (bits == 8) {
        const double xt = std::min(1.0, w.x.data()[i] * t / 20.0);
        z = 255.0 * std::pow(xt, 1.0 / 2.2) + 0.5 * n(rng);
      } else {
        const double s = std::min(60000.0, w.x.data()[i] * t * 100.0);
        z = 100.0 + s + std::sqrt(s * 0.5 + 9.0) * n(rng);
      }
      img.data()[i] = static_cast<std::uint16_t>(std::clamp(std::round(z), 0.0, std::ldexp(1.0, bits) - 1.0));
    }
    w.files.push_back(dir / ("img" + std::to_string(j) + ".png"));
    write_png(w.files.back(), img, bits);
    w.t.push_back(t);
  }
  return w;
}

// OpenEXR stores channels sorted by name: compare channel sets.
std::vector<std::string> sorted(std::vector<std::string> v) {
  std::sort(v.begin(), v.end());
  return v;
}

double number_after(const std::string& text, const std::string& key) {
  const auto at = text.find(key);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(text.c_str() + at + key.size(), nullptr);
}

}  // namespace

TEST(RadiometryCli, ResponseThenMergeOnAnEightBitRgbStack) {
  test::TempDir dir;
  const Written w = write_stack(dir.path(), 8, 3, 10);
  auto r = test::run_paintlab("calibrate response --method debevec --images" + w.images() + " --exposures " + w.list() +
                              " --out '" + (dir / "response.json").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("response: debevec method, 8-bit, 3 channel(s), 256 knots, 10 images"));
  const Json j = read_json_file(dir / "response.json");
  EXPECT_EQ(j.at("provenance").at("kind"), "response");
  EXPECT_EQ(j.at("provenance").at("inputs").size(), 10u);
  EXPECT_EQ(j.at("provenance").at("inputs")[0].at("sha256").get<std::string>().size(), 64u);
  EXPECT_EQ(j.at("linear").size(), 3u);

  r = test::run_paintlab("hdr merge --images" + w.images() + " --exposures " + w.list() + " --response '" +
                         (dir / "response.json").string() + "' --out '" + (dir / "hdr.exr").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("merged 10 images 64x48x3 (8-bit)"));
  const ExrImage hdr = read_exr(dir / "hdr.exr");
  EXPECT_EQ(sorted(hdr.names), sorted({"R", "G", "B", "var.R", "var.G", "var.B", "valid"}));
  EXPECT_EQ(hdr.attributes.at("paintlab.weighting"), "inverse-variance");
  // Radiance proportional to the scene: one scale, then within a few percent per pixel.
  const ImageF& g = hdr.plane("G");
  const ImageF& ok = hdr.plane("valid");
  double s = 0.0;
  long n = 0;
  for (std::size_t p = 0; p < g.size(); ++p)
    if (ok.data()[p] == 1.0f) {
      s += std::log(g.data()[p] / w.x.data()[3 * p + 1]);
      ++n;
    }
  s /= n;
  double sq = 0.0;
  for (std::size_t p = 0; p < g.size(); ++p)
    if (ok.data()[p] == 1.0f) sq += std::pow(std::log(g.data()[p] / w.x.data()[3 * p + 1]) - s, 2);
  EXPECT_GT(n, 3000);
  EXPECT_LT(std::sqrt(sq / n), 0.03);
}

TEST(RadiometryCli, SixteenBitStackWithExposureFileDarkAndFlat) {
  test::TempDir dir;
  const Written w = write_stack(dir.path(), 16, 1, 8);
  std::string listing;
  for (std::size_t j = 0; j < w.files.size(); ++j)
    listing += w.files[j].filename().string() + " " + std::to_string(w.t[j]) + "\n";
  test::write_text(dir / "times.txt", listing);
  // Dark frames: 100 DN + read noise; flat frames: a uniform target at half scale.
  std::mt19937_64 rng(test::seed() + 9);
  std::normal_distribution<double> n(0.0, 3.0);
  std::string dark_files, flat_files;
  for (int i = 0; i < 4; ++i) {
    Image<std::uint16_t> d(64, 48, 1), f(64, 48, 1);
    for (std::size_t p = 0; p < d.size(); ++p) {
      d.data()[p] = static_cast<std::uint16_t>(std::round(100.0 + n(rng)));
      f.data()[p] = static_cast<std::uint16_t>(std::round(100.0 + 30000.0 + std::sqrt(15000.0) * n(rng) / 3.0));
    }
    write_png(dir / ("dark" + std::to_string(i) + ".png"), d, 16);
    write_png(dir / ("flat" + std::to_string(i) + ".png"), f, 16);
    dark_files += " '" + (dir / ("dark" + std::to_string(i) + ".png")).string() + "'";
    flat_files += " '" + (dir / ("flat" + std::to_string(i) + ".png")).string() + "'";
  }
  auto r = test::run_paintlab("calibrate dark --images" + dark_files + " --exposures 0.01,0.01,0.01,0.01 --out '" +
                              (dir / "dark.json").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NEAR(number_after(r.out, "black level "), 100.0, 0.2) << r.out;
  EXPECT_TRUE(fs::exists(dir / "dark.exr"));
  r = test::run_paintlab("calibrate flat --images" + flat_files + " --exposures 0.1,0.1,0.1,0.1 --dark '" +
                         (dir / "dark.json").string() + "' --out '" + (dir / "flat.json").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("darkest/brightest corner"));
  r = test::run_paintlab("hdr merge --images" + w.images() + " --exposure-file '" + (dir / "times.txt").string() +
                         "' --dark '" + (dir / "dark.json").string() + "' --flat '" + (dir / "flat.json").string() +
                         "' --read-noise 3 --gain 0.5 --out '" + (dir / "hdr.exr").string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("(16-bit)"));
  const ExrImage hdr = read_exr(dir / "hdr.exr");
  EXPECT_EQ(sorted(hdr.names), sorted({"Y", "var.Y", "valid"}));
  EXPECT_EQ(hdr.attributes.count("paintlab.dark_sha256"), 1u);
  // Linear camera: Y = 100 x scene radiance (DN/s) within the noise.
  const ImageF& y = hdr.plane("Y");
  const ImageF& v = hdr.plane("var.Y");
  // Valid where the longest exposure lifts the pixel well above the noise floor (3 x the
  // 3 DN read noise of the dark frame = 9 DN; noise there ~4.6 DN), mostly invalid well
  // below it (a single noise excursion above the floor in one of 8 exposures makes a pixel valid).
  const double t_max = *std::max_element(w.t.begin(), w.t.end());
  const ImageF& ok = hdr.plane("valid");
  double z2 = 0.0;
  long cnt = 0, bright = 0, bright_invalid = 0, faint = 0, faint_valid = 0;
  for (std::size_t p = 0; p < y.size(); ++p) {
    const double s_max = 100.0 * w.x.data()[p] * t_max;
    const bool is_valid = ok.data()[p] == 1.0f;
    if (s_max > 30.0) {
      ++bright;
      bright_invalid += !is_valid;
    }
    if (s_max < 3.0) {
      ++faint;
      faint_valid += is_valid;
    }
    if (is_valid) {
      z2 += std::pow(y.data()[p] - 100.0 * w.x.data()[p], 2) / v.data()[p];
      ++cnt;
    }
  }
  EXPECT_GT(bright, 2000);
  EXPECT_EQ(bright_invalid, 0);
  EXPECT_GT(faint, 100);
  EXPECT_LT(faint_valid, faint / 10);
  EXPECT_GT(cnt, 2000);
  EXPECT_NEAR(std::sqrt(z2 / cnt), 1.0, 0.2);
}

TEST(RadiometryCli, BadInputExitsTwoNamesTheProblemAndWritesNothing) {
  test::TempDir dir;
  const Written w = write_stack(dir.path(), 8, 1, 4);
  const std::string out = " --out '" + (dir / "out.exr").string() + "'";
  const std::string rout = " --out '" + (dir / "r.json").string() + "'";
  struct Case {
    std::string args, message;
  };
  const std::vector<Case> cases = {
      {"hdr merge --images" + w.images() + " --exposures 0.1,0.2,0.3" + out, "3 times for 4 images"},
      {"calibrate response --images" + w.images() + " --exposures 0.1,0.2,0.3" + rout, "3 times for 4 images"},
      {"hdr merge --images" + w.images() + " --exposures 0.1,abc,0.3,0.4" + out, "entry 2 'abc'"},
      {"calibrate response --images" + w.images() + " --exposures 0.1,-1,0.3,0.4" + rout, "entry 2 '-1'"},
      {"hdr merge --images" + w.images() + " '" + (dir / "missing.png").string() + "' --exposures 1,2,3,4,5" + out,
       "missing.png"},
      {"hdr merge --images" + w.images() + " --exposures 1,2,3,4 --exposure-file x.txt" + out, "not both"},
      {"hdr merge --images" + w.images() + out, "give the exposure times"},
      {"hdr merge --images" + w.images() + " --exposures 1,2,3,4 --out '" + (dir / "out.png").string() + "'",
       "not an .exr file"},
      {"hdr merge --images" + w.images() + " --exposures 1,2,3,4 --response '" + (dir / "none.json").string() + "'" +
           out,
       "none.json"},
      {"hdr merge --images" + w.images() + " --exposures 1,2,3,4 --rig '" + (dir / "norig.toml").string() + "'" + out,
       "norig.toml"},
      {"calibrate flat --images" + w.images() + " --exposures 1,2,3,4 --dark '" + (dir / "nodark.json").string() + "'" +
           rout,
       "nodark.json"},
      {"calibrate response --capture" + rout, "--capture needs --rig"},
      {"calibrate response --images" + w.images() + " --exposures 1,2,3,4", "give --out"},
      {"calibrate response --images" + w.images() + " --exposures 1,2,3,4 --method magic" + rout, "magic"},
  };
  test::write_text(dir / "junk.png", "not an image");
  for (const auto& c : cases) {
    const auto r = test::run_paintlab(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.err;
    EXPECT_THAT(r.err, HasSubstr(c.message)) << c.args;
    EXPECT_FALSE(fs::exists(dir / "out.exr")) << c.args;
    EXPECT_FALSE(fs::exists(dir / "r.json")) << c.args;
    EXPECT_FALSE(fs::exists(dir / "out.png")) << c.args;
  }
  const auto r = test::run_paintlab("hdr merge --images" + w.images() + " '" + (dir / "junk.png").string() +
                                    "' --exposures 1,2,3,4,5" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("junk.png"));
  EXPECT_FALSE(fs::exists(dir / "out.exr"));
}

TEST(RadiometryCli, ABayerStackMergesToCameraRgbWithItsVariance) {
  // A 16-bit linear mosaic (GenICam BayerGB: G B / R G) of a scene of one colour per channel
  // (DN/s): R 2000, G 5000, B 1000, three exposures.
  test::TempDir dir;
  const double rate[3] = {2000.0, 5000.0, 1000.0};
  const auto colour = [](int x, int y) { return (y & 1) ? ((x & 1) ? 1 : 0) : ((x & 1) ? 2 : 1); };
  std::string images;
  const std::vector<double> times = {0.5, 2.0, 8.0};
  for (std::size_t k = 0; k < times.size(); ++k) {
    Image<std::uint16_t> m(24, 16, 1);
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 24; ++x)
        m.at(x, y) = static_cast<std::uint16_t>(std::min(65535.0, std::round(rate[colour(x, y)] * times[k])));
    const fs::path f = dir / ("bayer" + std::to_string(k) + ".png");
    write_png(f, m, 16);
    images += " '" + f.string() + "'";
  }
  const std::string out = (dir / "rgb.exr").string();
  auto r = test::run_paintlab("hdr merge --images" + images + " --exposures 0.5,2,8 --cfa GB --out '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const ExrImage e = read_exr(out);
  std::vector<std::string> names = e.names;  // the EXR file keeps them in alphabetical order
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"B", "G", "R", "valid", "var.B", "var.G", "var.R"}));
  EXPECT_EQ(e.attributes.at("paintlab.cfa"), "GB");
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(e.plane(std::string(1, "RGB"[c])).at(11, 7), rate[c], 0.01 * rate[c]) << c;
  EXPECT_EQ(e.plane("valid").at(11, 7), 1.0f);
  r = test::run_paintlab("hdr merge --images" + images + " --exposures 0.5,2,8 --cfa XY --out '" + out + "2.exr'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--cfa: unknown colour-filter arrangement 'XY' (expected none, RG, GR, GB or BG)"));
}
