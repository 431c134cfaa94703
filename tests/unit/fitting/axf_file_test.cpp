// AxF-like paint files: write/read round trip of every field, the validator on each kind
// of damage (missing group, wrong shape, out of range, wrong type, changed convention,
// truncated file), atomic writes, library files, and `paintlab axf validate`.
#include "paintlab/fitting/axf_file.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include "paintlab/brdf/paint.h"
#include "paintlab/core/atomic_file.h"
#include "paintlab/core/error.h"
#include "paintlab/core/version.h"
#include "test_util.h"

namespace fs = std::filesystem;
using namespace paintlab;
using namespace paintlab::fit;
using ::testing::HasSubstr;

namespace {

brdf::AxfCarPaintParams sample_carpaint() {
  brdf::AxfCarPaintParams c;
  c.ior = 1.52;
  c.diffuse = 0.11;
  c.lobes = {{0.05, 0.31, 0.7}, {0.02, 0.12, 0.45}, {0.3, 0.02, 0.04}};
  c.chi.theta_h_samples = 4;
  c.chi.theta_i_samples = 5;
  c.chi.scale = 1.25;
  c.chi.rgb.clear();
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 5; ++b) c.chi.rgb.emplace_back(0.1 + 0.01 * a, 0.2 + 0.02 * b, 0.9 - 0.03 * a * b / 7.0);
  return c;
}

AxfCookTorrance sample_ct(bool with_std) {
  AxfCookTorrance ct;
  ct.params.kd = brdf::Rgb(0.03, 0.032, 0.035);
  ct.params.lobes = {{brdf::Rgb(0.06, 0.062, 0.066), 0.38, 0.85},
                     {brdf::Rgb(0.045, 0.046, 0.048), 0.16, 0.55},
                     {brdf::Rgb(0.15, 0.15, 0.15), 0.015, 0.04}};
  if (with_std) {
    CookTorranceStddev sd;
    sd.kd = brdf::Rgb(1e-4, 2e-4, 3e-4);
    sd.lobes = {{brdf::Rgb(1e-3, 1.1e-3, 1.2e-3), 4e-3, 2e-2},
                {brdf::Rgb(5e-4, 6e-4, 7e-4), 1e-3, 1e-2},
                {brdf::Rgb(2e-3, 2e-3, 2e-3), 1e-4, 1.5e-3}};
    ct.stddev = sd;
  }
  return ct;
}

// Every field set to something other than its default.
AxfPaint full_paint() {
  AxfPaint p;
  p.name = "silver-fit.01";
  p.model = "axf-carpaint";
  p.carpaint = sample_carpaint();
  p.carpaint_stddev = AxfCarPaintStddev{0.01, 0.002, {{1e-3, 2e-3, 0}, {5e-4, 1e-3, 0}, {4e-3, 1e-4, 0}}};
  p.cook_torrance = sample_ct(true);
  brdf::FlakeSpec f;
  f.density = 0.7;
  f.roughness = 0.2;
  f.lifetime_deg = 5.5;
  f.lobes = {0, 2};
  f.tint_sd = 0.12;  // coloured flakes (format version 4)
  f.interference = 0.2;
  f.interference_chroma = 0.6;
  f.interference_shift_deg = -4.0;
  p.flakes = f;
  // Measured flakes (version 4): one slice with clusters, one without glints.
  FlakeStats fs;
  fs.colour_space = colour::kLinearSrgb;
  fs.images = 12;
  fs.runs = 7;
  fs.lifetime_deg = 5.25;
  fs.step_deg = 0.5;
  FlakeSlice a;
  a.theta_f = 1;
  a.theta_i = 2;
  a.pixels = 900;
  a.glints = 45;
  a.intensity_mean = 2.5;
  a.intensity_quantiles = {0.7, 1.1, 2.0, 3.1, 4.4};
  a.clusters = {{{60, -5, 3}, {70, 5, 9}, {65, 0, 6}, 0.75, 34}, {{90, 10, -20}, {95, 14, -12}, {92, 12, -16}, 0.25, 11}};
  a.inverse_cdf = {0, 0, 0, 1};
  a.runs = 7;
  a.lifetime_deg = 5.25;
  FlakeSlice b;
  b.theta_f = 0;
  b.theta_i = 0;
  b.pixels = 400;
  fs.slices = {b, a};
  fs.pixels = 1300;
  fs.glints = 45;
  fs.instrument = {{15, 50, 5, 10.0, 2.0}, {45, 0, 0, 0, 0}, {75, 0, 0, 0, 0}};
  p.flake_stats = fs;
  p.flake_btf = make_flake_btf(fs, 4);
  AxfFitQuality q;
  q.log_rms = 0.0234;
  q.bins_used = 123456;
  q.converged = false;
  q.residual = {{"log_rms", 0.0234}, {"bins_used", 123456}, {"regions", {{"peak", {{"log_rms", 0.05}}}}}};
  p.fit_quality = q;
  p.provenance.sample_name = "panel-17";
  p.provenance.measured_utc = "2026-11-20T09:15:00Z";
  p.provenance.exported_utc = "2026-11-21T10:00:00Z";
  p.provenance.rig_name = "lab-rig-2";
  p.provenance.calibration_sha256 = {{"camera.json", std::string(64, 'a')}, {"light.json", std::string(64, '0')}};
  p.provenance.session_sha256 = std::string(63, 'f') + "e";
  p.provenance.software_version = "0.1.0+gtest";
  p.provenance.source = "/data/sessions/panel-17";
  return p;
}

// Four cosine lobes (format version 5), a clear coat in the sharpest.
brdf::CosineLobeParams sample_cosine_lobes() {
  brdf::CosineLobeParams cl;
  cl.exponents = {2.1, 15.5, 120, 4100};
  cl.kd = brdf::Rgb(0.03, 0.032, 0.035);
  cl.kg = {brdf::Rgb(0.001, 0.001, 0.0012), brdf::Rgb(0.02, 0.021, 0.023), brdf::Rgb(0.3, 0.31, 0.33),
           brdf::Rgb(25, 25, 25)};
  cl.kdd = {brdf::Rgb(0.02, 0.021, 0.024), brdf::Rgb(0.1, 0.11, 1.0 / 3.0), brdf::Rgb(0.5, 0.5, 0.52),
            brdf::Rgb(0, 0, 0)};
  return cl;
}

// A paint that is only cosine-lobe weights (as paintlab design writes one).
AxfPaint cosine_lobes_paint() {
  AxfPaint p;
  p.name = "designed.02";
  p.model = "cosine-lobes";
  p.colour_space = colour::kLinearSrgb;
  p.cosine_lobes = sample_cosine_lobes();
  p.provenance.exported_utc = "2026-11-21T10:00:00Z";
  p.provenance.software_version = "0.1.0+gtest";
  p.provenance.source = "targets.toml";
  return p;
}

AxfPaint ct_only_paint() {
  AxfPaint p;
  p.name = "fit-only";
  p.model = "cook-torrance";
  p.cook_torrance = sample_ct(false);
  return p;
}

// Opens a file read-write, runs `edit`, closes it.
void damage(const fs::path& file, const std::function<void(hid_t)>& edit) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  edit(f);
  ASSERT_GE(H5Fclose(f), 0);
}

void create_doubles(hid_t f, const char* path, const std::vector<double>& v, const std::vector<hsize_t>& dims) {
  const hid_t space = dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t ds = H5Dcreate2(f, path, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  ASSERT_GE(H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
  H5Dclose(ds);
  H5Sclose(space);
}

void replace_doubles(hid_t f, const char* path, const std::vector<double>& v, const std::vector<hsize_t>& dims) {
  ASSERT_GE(H5Ldelete(f, path, H5P_DEFAULT), 0);
  create_doubles(f, path, v, dims);
}

void replace_ints(hid_t f, const char* path, const std::vector<long long>& v, const std::vector<hsize_t>& dims) {
  ASSERT_GE(H5Ldelete(f, path, H5P_DEFAULT), 0);
  const hid_t space = dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  const hid_t ds = H5Dcreate2(f, path, H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  ASSERT_GE(H5Dwrite(ds, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
  H5Dclose(ds);
  H5Sclose(space);
}

// Replaces a 1-element fixed-length string dataset.
void replace_string(hid_t f, const char* path, const std::string& text) {
  ASSERT_GE(H5Ldelete(f, path, H5P_DEFAULT), 0);
  const hsize_t one = 1;
  const hid_t space = H5Screate_simple(1, &one, nullptr);
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, text.size());
  H5Tset_cset(type, H5T_CSET_UTF8);
  const hid_t ds = H5Dcreate2(f, path, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  ASSERT_GE(H5Dwrite(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()), 0);
  H5Dclose(ds);
  H5Tclose(type);
  H5Sclose(space);
}

void overwrite_doubles(hid_t f, const char* path, const std::vector<double>& v) {
  const hid_t ds = H5Dopen2(f, path, H5P_DEFAULT);
  ASSERT_GE(ds, 0);
  ASSERT_GE(H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
  H5Dclose(ds);
}

// A fixed-length string, as files of format version 2 hold them.
void set_string_attr(hid_t f, const char* obj, const char* name, const std::string& value) {
  const hid_t o = H5Oopen(f, obj, H5P_DEFAULT);
  ASSERT_GE(o, 0);
  if (H5Aexists(o, name) > 0) H5Adelete(o, name);
  const hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, std::max<std::size_t>(value.size(), 1));
  const hid_t s = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(o, name, t, s, H5P_DEFAULT, H5P_DEFAULT);
  std::string buf = value;
  buf.resize(std::max<std::size_t>(value.size(), 1), '\0');
  ASSERT_GE(H5Awrite(a, t, buf.data()), 0);
  H5Aclose(a);
  H5Sclose(s);
  H5Tclose(t);
  H5Oclose(o);
}

void set_int_attr(hid_t f, const char* obj, const char* name, long long value) {
  const hid_t o = H5Oopen(f, obj, H5P_DEFAULT);
  ASSERT_GE(o, 0);
  if (H5Aexists(o, name) > 0) H5Adelete(o, name);
  const hid_t s = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate2(o, name, H5T_STD_I64LE, s, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(H5Awrite(a, H5T_NATIVE_LLONG, &value), 0);
  H5Aclose(a);
  H5Sclose(s);
  H5Oclose(o);
}

bool any_problem_has(const AxfValidation& v, const std::string& text) {
  for (const auto& p : v.problems)
    if (p.find(text) != std::string::npos) return true;
  return false;
}

std::string all_problems(const AxfValidation& v) {
  std::string s;
  for (const auto& p : v.problems) s += p + "\n";
  return s;
}

}  // namespace

TEST(AxfFile, RoundTripEveryField) {
  test::TempDir tmp;
  const AxfPaint p = full_paint();
  write_axf_file(tmp / "p.axf.h5", p);
  const AxfPaint back = read_axf_file(tmp / "p.axf.h5");
  EXPECT_EQ(back.name, p.name);
  EXPECT_EQ(back.model, p.model);
  ASSERT_TRUE(back.carpaint);
  EXPECT_EQ(*back.carpaint, *p.carpaint);
  ASSERT_TRUE(back.carpaint_stddev);
  EXPECT_EQ(*back.carpaint_stddev, *p.carpaint_stddev);
  ASSERT_TRUE(back.cook_torrance);
  EXPECT_EQ(*back.cook_torrance, *p.cook_torrance);
  ASSERT_TRUE(back.cook_torrance->stddev);
  ASSERT_TRUE(back.flakes);
  EXPECT_EQ(*back.flakes, *p.flakes);
  ASSERT_TRUE(back.flake_stats);
  EXPECT_EQ(*back.flake_stats, *p.flake_stats);
  ASSERT_TRUE(back.flake_btf);
  EXPECT_EQ(*back.flake_btf, *p.flake_btf);
  EXPECT_EQ(back.flake_btf->slice_lut, (std::vector<int>{0, 0, 0, 2}));  // theta_I bin 2 holds theta_F 0 and 1
  ASSERT_TRUE(back.fit_quality);
  EXPECT_EQ(*back.fit_quality, *p.fit_quality);
  EXPECT_EQ(back.provenance, p.provenance);
  EXPECT_EQ(back, p);

  const AxfValidation v = validate_axf_file(tmp / "p.axf.h5");
  EXPECT_TRUE(v.ok()) << all_problems(v);
  EXPECT_EQ(v.format, kAxfFormat);
  EXPECT_EQ(v.paints, std::vector<std::string>{"silver-fit.01"});
}

TEST(AxfFile, RoundTripGivesTheSameBrdf) {
  test::TempDir tmp;
  const AxfPaint p = full_paint();
  write_axf_file(tmp / "p.axf.h5", p);
  const AxfPaint back = read_axf_file(tmp / "p.axf.h5");
  const auto a = brdf::make_brdf(p.paint_spec());
  const auto b = brdf::make_brdf(back.paint_spec());
  EXPECT_EQ(b->model(), "axf-carpaint");
  for (double ti : {0.1, 0.6, 1.2})
    for (double to : {0.05, 0.5, 1.3}) {
      const brdf::Vec3 wi(std::sin(ti), 0, std::cos(ti)), wo(-std::sin(to) * 0.8, std::sin(to) * 0.6, std::cos(to));
      const brdf::Rgb fa = a->eval(wi, wo), fb = b->eval(wi, wo);
      EXPECT_GT(fa.maxCoeff(), 0.0);
      EXPECT_TRUE((fa == fb).all());
    }
}

TEST(AxfFile, CookTorranceOnlyPaintExportsWithoutCarpaint) {
  test::TempDir tmp;
  const AxfPaint p = ct_only_paint();
  write_axf_file(tmp / "ct.axf.h5", p);
  const AxfPaint back = read_axf_file(tmp / "ct.axf.h5");
  EXPECT_FALSE(back.carpaint);
  EXPECT_FALSE(back.flakes);
  EXPECT_FALSE(back.fit_quality);
  ASSERT_TRUE(back.cook_torrance);
  EXPECT_EQ(*back.cook_torrance, *p.cook_torrance);
  EXPECT_FALSE(back.cook_torrance->stddev);
  // The writer fills the export time and the software version.
  EXPECT_GT(parse_utc_timestamp(back.provenance.exported_utc), 0);
  EXPECT_EQ(back.provenance.software_version, software_version());
  const brdf::PaintSpec spec = back.paint_spec();
  EXPECT_EQ(spec.model(), "cook-torrance");
  EXPECT_EQ(*spec.cook_torrance(), p.cook_torrance->params);
  EXPECT_TRUE(validate_axf_file(tmp / "ct.axf.h5").ok());
}

TEST(AxfFile, TheColourSpaceOfTheValuesIsStatedAndReadBack) {
  test::TempDir tmp;
  // A paint file's values are linear sRGB; a fit's are its session's (camera RGB when unsaid).
  brdf::PaintSpec spec;
  spec.name = "blue";
  spec.params = sample_ct(false).params;
  const AxfPaint from_paint = axf_from_paint(spec);
  EXPECT_EQ(from_paint.colour_space, "linear sRGB (D65)");
  write_axf_file(tmp / "srgb.axf.h5", from_paint);
  EXPECT_EQ(read_axf_file(tmp / "srgb.axf.h5").colour_space, "linear sRGB (D65)");
  EXPECT_THAT(describe_axf(read_axf_file(tmp / "srgb.axf.h5")), HasSubstr("values in linear sRGB (D65)"));
  Json fit = brdf::to_json(from_paint.paint_spec());
  EXPECT_EQ(axf_from_fit_json(fit, "fit.json").colour_space, "linear camera RGB");
  fit["input"] = {{"kind", "session"}, {"colour_space", "linear sRGB (D65)"}};
  EXPECT_EQ(axf_from_fit_json(fit, "fit.json").colour_space, "linear sRGB (D65)");
  fit["input"]["colour_space"] = "Adobe RGB";
  EXPECT_THAT(test::error_message<DataError>([&] { axf_from_fit_json(fit, "fit.json"); }),
              HasSubstr("fit.json: input.colour_space must be"));
  // A camera-RGB paint and an sRGB one are not one measurement.
  AxfPaint camera = from_paint;
  camera.colour_space = colour::kCameraRgb;
  camera.cook_torrance.reset();
  camera.carpaint = full_paint().carpaint;
  EXPECT_THAT(test::error_message<DataError>([&] { merge_axf(from_paint, camera); }),
              HasSubstr("different colour spaces"));
}

TEST(AxfFile, ConventionsAreWrittenAndStateTheTraps) {
  const auto& c = axf_conventions();
  auto text = [&](const std::string& key) {
    for (const auto& [k, v] : c)
      if (k == key) return v;
    return std::string();
  };
  EXPECT_THAT(text("beckmann_d"), HasSubstr("WITHOUT the 1/pi"));
  EXPECT_THAT(text("values"), HasSubstr("no gamma"));
  EXPECT_THAT(text("colour_table_domain"), HasSubstr("theta_ibar <= pi/2 - theta_hbar"));
  EXPECT_THAT(text("diffuse"), HasSubstr("diffuse / pi"));
  // Version 5: the cosine lobes, whose kg terms carry no (n.i); required from version 5 on.
  EXPECT_THAT(text("cosine_lobes"), HasSubstr("sum_k kg_k (r.o)^E_k + (n.i) sum_k kdd_k (r.o)^E_k"));
  EXPECT_EQ(axf_convention_since("cosine_lobes"), 5);
  EXPECT_EQ(axf_convention_since("beckmann_d"), 1);
}

TEST(AxfFile, WriterRefusesABadPaintAndLeavesTheOldFile) {
  test::TempDir tmp;
  const fs::path file = tmp / "p.axf.h5";
  write_axf_file(file, ct_only_paint());
  const std::string before = read_file(file);

  AxfPaint bad = full_paint();
  bad.carpaint->lobes[1].spread = 1.3;
  EXPECT_THAT(test::error_message<DataError>([&] { write_axf_file(file, bad); }),
              HasSubstr("/carpaint/ct_spreads: value 1.3 at index 1 out of range (0, 1)"));
  EXPECT_EQ(read_file(file), before);
  int entries = 0;
  for (const auto& e : fs::directory_iterator(tmp.path())) entries += e.path() == file ? 0 : 1;
  EXPECT_EQ(entries, 0) << "a temporary file was left behind";

  AxfPaint bad_name = ct_only_paint();
  bad_name.name = "Bad Name";
  EXPECT_THROW(write_axf_file(tmp / "q.axf.h5", bad_name), DataError);
  EXPECT_FALSE(fs::exists(tmp / "q.axf.h5"));
}

struct Damage {
  std::string what;
  std::function<void(hid_t)> edit;
  std::string expected;  // a substring of one problem
};

TEST(AxfFile, ValidatorNamesTheFieldOfEveryDamage) {
  test::TempDir tmp;
  const fs::path good = tmp / "good.axf.h5";
  write_axf_file(good, full_paint());

  const std::vector<Damage> damages = {
      {"missing group", [](hid_t f) { H5Ldelete(f, "/carpaint", H5P_DEFAULT); }, "/carpaint: missing group"},
      {"missing provenance", [](hid_t f) { H5Ldelete(f, "/provenance", H5P_DEFAULT); }, "/provenance: missing group"},
      {"missing dataset", [](hid_t f) { H5Ldelete(f, "/cook_torrance/ks", H5P_DEFAULT); },
       "/cook_torrance/ks: missing dataset"},
      {"group is a dataset",
       [](hid_t f) {
         H5Ldelete(f, "/conventions", H5P_DEFAULT);
         create_doubles(f, "/conventions", {1.0}, {});
       },
       "/conventions: is not a group"},
      {"wrong table shape",
       [](hid_t f) { replace_doubles(f, "/carpaint/colour_table", std::vector<double>(40, 0.5), {4, 5, 2}); },
       "/carpaint/colour_table: wrong shape [4, 5, 2], expected [Nh, Ni, 3]"},
      {"wrong lobe shape", [](hid_t f) { replace_doubles(f, "/carpaint/ct_f0s", {0.5, 0.5}, {2}); },
       "/carpaint/ct_f0s: wrong shape [2], expected [3]"},
      {"scalar as array", [](hid_t f) { replace_doubles(f, "/carpaint/ior", {1.5, 1.5}, {2}); },
       "/carpaint/ior: wrong shape [2], expected a scalar"},
      {"out of range", [](hid_t f) { overwrite_doubles(f, "/carpaint/ct_spreads", {0.2, 1.3, 0.01}); },
       "/carpaint/ct_spreads: value 1.3 at index 1 out of range (0, 1)"},
      {"ior out of range", [](hid_t f) { overwrite_doubles(f, "/carpaint/ior", {0.9}); },
       "/carpaint/ior: value 0.9 out of range [1, 3]"},
      {"negative table value",
       [](hid_t f) {
         std::vector<double> t(60, 0.5);
         t[3 * 7 + 2] = -0.1;
         overwrite_doubles(f, "/carpaint/colour_table", t);
       },
       "/carpaint/colour_table: value -0.1 at index [1, 2, 2] out of range [0, inf)"},
      {"not finite", [](hid_t f) { overwrite_doubles(f, "/cook_torrance/kd", {0.1, NAN, 0.1}); },
       "/cook_torrance/kd: value nan at index 1 is not finite"},
      {"carpaint stddev shape", [](hid_t f) { replace_doubles(f, "/carpaint/ct_spreads_std", {0.1, 0.1}, {2}); },
       "/carpaint/ct_spreads_std: wrong shape [2], expected [3] (the shape of the parameter)"},
      {"missing carpaint stddev", [](hid_t f) { H5Ldelete(f, "/carpaint/ior_std", H5P_DEFAULT); },
       "/carpaint/ior_std: missing dataset"},
      {"negative stddev", [](hid_t f) { overwrite_doubles(f, "/cook_torrance/m_std", {0.1, -0.1, 0.1}); },
       "/cook_torrance/m_std: value -0.1 at index 1 out of range [0, inf)"},
      {"wrong type",
       [](hid_t f) {
         H5Ldelete(f, "/carpaint/diffuse", H5P_DEFAULT);
         const hid_t s = H5Screate(H5S_SCALAR);
         const hid_t d = H5Dcreate2(f, "/carpaint/diffuse", H5T_STD_I32LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
         int one = 1;
         H5Dwrite(d, H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, &one);
         H5Dclose(d);
         H5Sclose(s);
       },
       "/carpaint/diffuse: expected floating-point numbers"},
      {"sample positions",
       [](hid_t f) { overwrite_doubles(f, "/carpaint/colour_table_theta_h_rad", {0.0, 0.5, 0.9, 1.4}); },
       "/carpaint/colour_table_theta_h_rad: value 0 at index 0 is not the sample centre"},
      {"lobe count", [](hid_t f) { set_int_attr(f, "/carpaint", "lobe_count", 2); },
       "/carpaint attribute 'lobe_count': is 2 but /carpaint/ct_coeffs has 3 lobes"},
      {"changed convention", [](hid_t f) { set_string_attr(f, "/conventions", "beckmann_d", "normalised, with 1/pi"); },
       "/conventions attribute 'beckmann_d': states a different convention"},
      {"missing convention",
       [](hid_t f) {
         const hid_t g = H5Gopen2(f, "/conventions", H5P_DEFAULT);
         H5Adelete(g, "colour_table_domain");
         H5Gclose(g);
       },
       "/conventions attribute 'colour_table_domain': missing"},
      {"newer version", [](hid_t f) { set_int_attr(f, "/", "format_version", 6); },
       "/ attribute 'format_version': 6 is newer than this software reads (5)"},
      {"unknown colour space", [](hid_t f) { set_string_attr(f, "/conventions", "values", "linear Adobe RGB: no gamma"); },
       "/conventions attribute 'values': states a colour space the format (versions 3 to 5) does not define"},
      {"sRGB in a version-2 file",
       [](hid_t f) {
         set_int_attr(f, "/", "format_version", 2);
         set_string_attr(f, "/conventions", "values", axf_values_convention(colour::kLinearSrgb));
       },
       "/conventions attribute 'values': states a different convention than the format (versions 1 to 5) defines"},
      {"foreign format", [](hid_t f) { set_string_attr(f, "/", "format", "something-else"); },
       "/ attribute 'format': 'something-else' is not 'paintlab-axf-like'"},
      {"bad model", [](hid_t f) { set_string_attr(f, "/", "model", "phong"); }, "/ attribute 'model': 'phong'"},
      {"bad name", [](hid_t f) { set_string_attr(f, "/", "paint_name", "Silver Fit"); },
       "/ attribute 'paint_name': 'Silver Fit' is not a paint name"},
      {"flake lobe", [](hid_t f) {
         H5Ldelete(f, "/flakes/lobes", H5P_DEFAULT);
         const hsize_t n = 2;
         const hid_t s = H5Screate_simple(1, &n, nullptr);
         const hid_t d = H5Dcreate2(f, "/flakes/lobes", H5T_STD_I64LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
         const long long v[2] = {1, 4};
         H5Dwrite(d, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
         H5Dclose(d);
         H5Sclose(s);
       },
       "/flakes/lobes: value 4 at index 1 out of range [1, 3]"},
      {"flake LUT out of order",
       [](hid_t f) {
         const hid_t d = H5Dopen2(f, "/flake_btf/thetaFI_sliceLUT", H5P_DEFAULT);
         const long long v[4] = {0, 2, 1, 2};
         H5Dwrite(d, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, v);
         H5Dclose(d);
       },
       "/flake_btf: thetaFI_sliceLUT[2] = 1 after 2: theta_I bin 1 would hold -1 slices"},
      {"negative flake texel",
       [](hid_t f) {
         std::vector<double> t(2 * 4 * 4 * 3, 0.0);
         t[5] = -0.5;
         overwrite_doubles(f, "/flake_btf/BTFflakes", t);
       },
       "/flake_btf: BTFflakes value -0.5 at index 5 is not a finite value >= 0"},
      {"flake bins differ", [](hid_t f) { replace_ints(f, "/flake_btf/num_thetaF", {10}, {}); },
       "/flake_btf: 10 x 12 slice bins, but /flake_stats has 12 x 12"},
      {"flake stats not json", [](hid_t f) { replace_string(f, "/flake_stats/json", "{nope"); },
       "/flake_stats/json: not JSON"},
      {"bad checksum", [](hid_t f) { set_string_attr(f, "/provenance", "session_sha256", "abc"); },
       "/provenance attribute 'session_sha256': 'abc' is not a SHA-256"},
      {"bad date", [](hid_t f) { set_string_attr(f, "/provenance", "measured_utc", "yesterday"); },
       "/provenance attribute 'measured_utc': 'yesterday' is not an ISO 8601 UTC time"},
      {"residual json", [](hid_t f) { set_string_attr(f, "/fit_quality", "residual_json", "{not json"); },
       "/fit_quality attribute 'residual_json': is not valid JSON"},
  };

  for (const auto& d : damages) {
    SCOPED_TRACE(d.what);
    const fs::path file = tmp / "damaged.axf.h5";
    fs::copy_file(good, file, fs::copy_options::overwrite_existing);
    damage(file, d.edit);
    const AxfValidation v = validate_axf_file(file);
    EXPECT_FALSE(v.ok());
    EXPECT_TRUE(any_problem_has(v, d.expected)) << "expected \"" << d.expected << "\" in:\n" << all_problems(v);
    // Every edit also changes the content its checksum covers (a newer version's rules are unknown).
    if (d.what != "newer version") {
      EXPECT_TRUE(any_problem_has(v, "/ attribute 'content_sha256'")) << all_problems(v);
    }
    try {
      read_axf_file(file);
      ADD_FAILURE() << "read_axf_file accepted the damaged file";
    } catch (const DataError& e) {
      EXPECT_THAT(e.what(), HasSubstr(file.string() + ": /"));
    }
  }
}

TEST(AxfFile, ValidatorRejectsTruncatedAndForeignFiles) {
  test::TempDir tmp;
  const fs::path good = tmp / "good.axf.h5";
  write_axf_file(good, full_paint());
  const std::string bytes = read_file(good);
  ASSERT_GT(bytes.size(), 2000u);
  for (std::size_t keep : {bytes.size() - 1, bytes.size() / 2, std::size_t{600}, std::size_t{10}, std::size_t{0}}) {
    SCOPED_TRACE(keep);
    const fs::path file = tmp / "cut.axf.h5";
    write_file_atomic(file, std::string_view(bytes).substr(0, keep));
    const AxfValidation v = validate_axf_file(file);
    ASSERT_FALSE(v.ok());
    EXPECT_TRUE(any_problem_has(v, "truncated") || any_problem_has(v, "not an HDF5 file")) << all_problems(v);
    EXPECT_THROW(read_axf_file(file), DataError);
  }
  write_file_atomic(tmp / "text.axf.h5", "name = \"silver\"\n");
  const AxfValidation v = validate_axf_file(tmp / "text.axf.h5");
  EXPECT_TRUE(any_problem_has(v, "/: not an HDF5 file")) << all_problems(v);
  EXPECT_TRUE(any_problem_has(validate_axf_file(tmp / "absent.axf.h5"), "no such file"));
  EXPECT_THROW(read_axf_file(tmp / "absent.axf.h5"), IoError);
}

TEST(AxfFile, FromFitJsonCarriesStddevResidualAndConvergence) {
  CookTorranceFit fit;
  fit.params = sample_ct(false).params;
  fit.stddev = *sample_ct(true).stddev;
  fit.summary.converged = true;
  Json j = fit.to_json("panel-17");
  j["residual"]["log_rms"] = 0.031;
  j["residual"]["bins_used"] = 4321;
  const AxfPaint a = axf_from_fit_json(j, "fit.json");
  EXPECT_EQ(a.name, "panel-17");
  EXPECT_EQ(a.model, "cook-torrance");
  ASSERT_TRUE(a.cook_torrance);
  EXPECT_EQ(a.cook_torrance->params, fit.params);
  ASSERT_TRUE(a.cook_torrance->stddev);
  EXPECT_TRUE((a.cook_torrance->stddev->kd == fit.stddev.kd).all());
  EXPECT_EQ(a.cook_torrance->stddev->lobes, fit.stddev.lobes);
  ASSERT_TRUE(a.fit_quality);
  EXPECT_DOUBLE_EQ(a.fit_quality->log_rms, 0.031);
  EXPECT_EQ(a.fit_quality->bins_used, 4321);
  EXPECT_TRUE(a.fit_quality->converged);
  EXPECT_EQ(a.fit_quality->residual, j["residual"]);
  EXPECT_EQ(a.provenance.source, "fit.json");

  Json bad = j;
  bad["stddev"]["lobes"].erase(1);
  EXPECT_THROW(axf_from_fit_json(bad, "fit.json"), DataError);
}

TEST(AxfFile, CarPaintFitJsonAndMergeWithACookTorranceFit) {
  Json j = brdf::to_json(brdf::PaintSpec{"panel-17", sample_carpaint(), std::nullopt, {}});
  j["stddev"] = {{"ior", 0.02},
                 {"diffuse", 0.001},
                 {"lobes", Json::array({{{"coefficient", 1e-3}, {"spread", 2e-3}, {"f0", 0.0}},
                                        {{"coefficient", 2e-3}, {"spread", 3e-3}, {"f0", 0.0}},
                                        {{"coefficient", 3e-3}, {"spread", 4e-3}, {"f0", 0.0}}})}};
  j["residual"] = {{"log_rms", 0.04}, {"bins_used", 999}};
  const AxfPaint cp = axf_from_fit_json(j, "axf-fit.json");
  EXPECT_EQ(cp.model, "axf-carpaint");
  ASSERT_TRUE(cp.carpaint && cp.carpaint_stddev);
  EXPECT_EQ(*cp.carpaint, sample_carpaint());
  EXPECT_DOUBLE_EQ(cp.carpaint_stddev->ior, 0.02);
  EXPECT_DOUBLE_EQ(cp.carpaint_stddev->lobes[2].spread, 4e-3);

  const AxfPaint merged = merge_axf(cp, ct_only_paint());
  EXPECT_EQ(merged.model, "axf-carpaint");
  ASSERT_TRUE(merged.cook_torrance);
  EXPECT_EQ(*merged.cook_torrance, *ct_only_paint().cook_torrance);
  EXPECT_THROW(merge_axf(cp, cp), DataError);
  test::TempDir tmp;
  write_axf_file(tmp / "m.axf.h5", merged);
  EXPECT_EQ(read_axf_file(tmp / "m.axf.h5").carpaint_stddev, cp.carpaint_stddev);
}

TEST(AxfFile, PaintsWithoutAnAxfFormAreRefused) {
  brdf::PaintSpec pearl;
  pearl.name = "pearl";
  pearl.params = brdf::PearlescentParams{};
  EXPECT_THAT(test::error_message<DataError>([&] { axf_from_paint(pearl); }),
              HasSubstr("layered-pearlescent"));
  const brdf::PaintSpec silver = brdf::load_paint_file(test::source_dir() / "paints/silver-metallic.toml");
  const AxfPaint a = axf_from_paint(silver);
  EXPECT_EQ(a.model, "cook-torrance");
  ASSERT_TRUE(a.flakes);
  EXPECT_EQ(a.paint_spec(), silver);
}

TEST(AxfFile, LibraryFileHoldsEveryPaint) {
  test::TempDir tmp;
  AxfPaint a = full_paint();
  AxfPaint b = ct_only_paint();
  write_axf_library_file(tmp / "lib.h5", {a, b});
  const auto back = read_axf_library_file(tmp / "lib.h5");
  ASSERT_EQ(back.size(), 2u);
  // Paints come back in name order.
  EXPECT_EQ(back[0].name, "fit-only");
  EXPECT_EQ(*back[0].cook_torrance, *b.cook_torrance);
  EXPECT_EQ(back[1], a);
  const AxfValidation v = validate_axf_file(tmp / "lib.h5");
  EXPECT_TRUE(v.ok()) << all_problems(v);
  EXPECT_EQ(v.format, kAxfLibraryFormat);
  EXPECT_EQ(v.paints, (std::vector<std::string>{"fit-only", "silver-fit.01"}));
  EXPECT_THROW(read_axf_file(tmp / "lib.h5"), DataError);

  damage(tmp / "lib.h5", [](hid_t f) { overwrite_doubles(f, "/paints/silver-fit.01/carpaint/ior", {7.0}); });
  const AxfValidation bad = validate_axf_file(tmp / "lib.h5");
  EXPECT_TRUE(any_problem_has(bad, "/paints/silver-fit.01/carpaint/ior: value 7 out of range [1, 3]"))
      << all_problems(bad);
  EXPECT_THROW(write_axf_library_file(tmp / "dup.h5", {b, b}), DataError);
}

// ---- paintlab axf validate / show, paintlab export of paint files ----

TEST(AxfCli, ValidateExitCodesAndMessages) {
  test::TempDir tmp;
  const fs::path good = tmp / "good.axf.h5";
  write_axf_file(good, full_paint());
  auto r = test::run_paintlab("axf validate " + good.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("valid (AxF-like paint 'silver-fit.01', format version 5)"));

  const fs::path bad = tmp / "bad.axf.h5";
  fs::copy_file(good, bad);
  damage(bad, [](hid_t f) { overwrite_doubles(f, "/carpaint/ct_spreads", {0.2, 1.3, 0.01}); });
  r = test::run_paintlab("axf validate " + good.string() + " " + bad.string());
  EXPECT_EQ(r.exit_code, 1);
  // The edit breaks the content checksum too.
  EXPECT_THAT(r.out, HasSubstr("bad.axf.h5: invalid (2 problems)"));
  EXPECT_THAT(r.out, HasSubstr("/ attribute 'content_sha256'"));
  EXPECT_THAT(r.out, HasSubstr("/carpaint/ct_spreads: value 1.3 at index 1 out of range (0, 1)"));

  const std::string bytes = read_file(good);
  write_file_atomic(tmp / "cut.axf.h5", std::string_view(bytes).substr(0, bytes.size() / 3));
  r = test::run_paintlab("axf validate " + (tmp / "cut.axf.h5").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.out, HasSubstr("truncated or damaged HDF5 file"));

  r = test::run_paintlab("axf validate " + (tmp / "absent.axf.h5").string());
  EXPECT_EQ(r.exit_code, 2);
  r = test::run_paintlab("axf validate");
  EXPECT_EQ(r.exit_code, 2);

  r = test::run_paintlab("axf show " + good.string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("clear-coat ior 1.52"));
  EXPECT_THAT(r.out, HasSubstr("sample panel-17"));
}

TEST(AxfCli, ExportPaintAndFitFiles) {
  test::TempDir tmp;
  const std::string silver = (test::source_dir() / "paints/silver-metallic.toml").string();
  auto r = test::run_paintlab("export " + silver + " --axf " + (tmp / "s.axf.h5").string() + " --name silver-copy");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const AxfPaint s = read_axf_file(tmp / "s.axf.h5");
  EXPECT_EQ(s.name, "silver-copy");
  EXPECT_EQ(s.provenance.source, fs::absolute(silver).lexically_normal().string());

  // Two fits of one measurement (one per model) become one file.
  CookTorranceFit ct;
  ct.params = sample_ct(false).params;
  ct.stddev = *sample_ct(true).stddev;
  ct.summary.converged = true;
  Json ctj = ct.to_json("panel-17");
  ctj["residual"]["log_rms"] = 0.03;
  ctj["residual"]["bins_used"] = 1234;
  write_json_file(tmp / "ct.json", ctj);
  Json cpj = brdf::to_json(brdf::PaintSpec{"panel-17", sample_carpaint(), std::nullopt, {}});
  write_json_file(tmp / "cp.json", cpj);
  r = test::run_paintlab("export " + (tmp / "cp.json").string() + " " + (tmp / "ct.json").string() + " --axf " +
                         (tmp / "both.axf.h5").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const AxfPaint both = read_axf_file(tmp / "both.axf.h5");
  EXPECT_EQ(both.model, "axf-carpaint");
  ASSERT_TRUE(both.carpaint && both.cook_torrance && both.cook_torrance->stddev && both.fit_quality);
  EXPECT_EQ(both.fit_quality->bins_used, 1234);

  // Bad input: exit 2, nothing written.
  const std::string pearl = (test::source_dir() / "paints/pearlescent.toml").string();
  r = test::run_paintlab("export " + pearl + " --axf " + (tmp / "p.axf.h5").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("layered-pearlescent"));
  EXPECT_FALSE(fs::exists(tmp / "p.axf.h5"));
  r = test::run_paintlab("export " + silver);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--axf"));
  r = test::run_paintlab("export " + silver + " --merl " + (tmp / "m.binary").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(tmp / "m.binary"));
  r = test::run_paintlab("export " + silver + " --axf " + (tmp / "n.axf.h5").string() + " --name 'Bad Name'");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("paint_name"));
  EXPECT_FALSE(fs::exists(tmp / "n.axf.h5"));
}

// ---- /cosine_lobes (format version 5) ----

TEST(AxfFile, CosineLobesBesideACarPaintAndAsThePaintRoundTrip) {
  test::TempDir tmp;
  // Beside the car-paint and Cook-Torrance forms: a fast approximation that rides along.
  AxfPaint both = full_paint();
  both.cosine_lobes = sample_cosine_lobes();
  write_axf_file(tmp / "both.axf.h5", both);
  const AxfPaint back = read_axf_file(tmp / "both.axf.h5");
  ASSERT_TRUE(back.cosine_lobes);
  EXPECT_EQ(*back.cosine_lobes, sample_cosine_lobes());
  EXPECT_EQ(back, both);
  EXPECT_EQ(back.paint_spec().model(), "axf-carpaint");
  AxfValidation v = validate_axf_file(tmp / "both.axf.h5");
  EXPECT_TRUE(v.ok()) << all_problems(v);
  EXPECT_EQ(v.format_version, 5);
  EXPECT_THAT(describe_axf(back),
              HasSubstr("cosine lobes (an approximation of the paint): 4 exponents 2.1 .. 4100; kd [0.03, 0.032, 0.035]"));

  // The paint itself.
  const AxfPaint cl = cosine_lobes_paint();
  write_axf_file(tmp / "cl.axf.h5", cl);
  const AxfPaint cl_back = read_axf_file(tmp / "cl.axf.h5");
  EXPECT_EQ(cl_back, cl);
  EXPECT_FALSE(cl_back.carpaint || cl_back.cook_torrance || cl_back.flakes);
  v = validate_axf_file(tmp / "cl.axf.h5");
  EXPECT_TRUE(v.ok()) << all_problems(v);
  EXPECT_EQ(v.format_version, 5);
  EXPECT_EQ(v.paints, std::vector<std::string>{"designed.02"});
  const brdf::PaintSpec spec = cl_back.paint_spec();
  EXPECT_EQ(spec.model(), "cosine-lobes");
  ASSERT_NE(spec.cosine_lobes(), nullptr);
  EXPECT_EQ(*spec.cosine_lobes(), sample_cosine_lobes());
  const auto f = brdf::make_brdf(spec);
  const brdf::CosineLobes expected(sample_cosine_lobes());
  const brdf::Vec3 wi = brdf::Vec3(0.3, 0.1, 0.9).normalized(), wo = brdf::Vec3(-0.3, -0.1, 0.9).normalized();
  EXPECT_TRUE((f->eval(wi, wo) == expected.eval(wi, wo)).all());
  EXPECT_THAT(describe_axf(cl_back), HasSubstr("cosine lobes: 4 exponents 2.1 .. 4100; kd [0.03, 0.032, 0.035]"));
  EXPECT_THAT(describe_axf(cl_back), HasSubstr("exponent 4100: kg [25, 25, 25]"));

  // From a paint file's paint, and back.
  brdf::PaintSpec designed;
  designed.name = "designed.02";
  designed.params = sample_cosine_lobes();
  const AxfPaint a = axf_from_paint(designed);
  EXPECT_EQ(a.model, "cosine-lobes");
  EXPECT_EQ(a.colour_space, colour::kLinearSrgb);
  EXPECT_EQ(a.paint_spec(), designed);

  // Merged beside a fit; given twice it is refused.
  AxfPaint approx;
  approx.name = "silver-fit.01";
  approx.colour_space = full_paint().colour_space;
  approx.cosine_lobes = sample_cosine_lobes();
  const AxfPaint merged = merge_axf(full_paint(), approx);
  EXPECT_EQ(merged.model, "axf-carpaint");
  EXPECT_EQ(merged.cosine_lobes, approx.cosine_lobes);
  EXPECT_THAT(test::error_message<DataError>([&] { merge_axf(merged, approx); }),
              HasSubstr("both paints hold cosine-lobe weights"));

  // In a library file.
  write_axf_library_file(tmp / "lib.h5", {both, cl});
  const auto lib = read_axf_library_file(tmp / "lib.h5");
  ASSERT_EQ(lib.size(), 2u);
  EXPECT_EQ(lib[0], cl);
  EXPECT_EQ(lib[1], both);
}

TEST(AxfFile, ValidatorNamesTheCosineLobesFields) {
  test::TempDir tmp;
  const fs::path good = tmp / "good.axf.h5";
  write_axf_file(good, cosine_lobes_paint());
  const std::vector<Damage> damages = {
      {"exponent out of range", [](hid_t f) { overwrite_doubles(f, "/cosine_lobes/exponents", {0.1, 15.5, 120, 4100}); },
       "/cosine_lobes/exponents: value 0.1 at index 0 out of range [0.5, 1e+06]"},
      {"exponent not finite", [](hid_t f) { overwrite_doubles(f, "/cosine_lobes/exponents", {2.1, NAN, 120, 4100}); },
       "/cosine_lobes/exponents: value nan at index 1 is not finite"},
      {"exponents decrease", [](hid_t f) { overwrite_doubles(f, "/cosine_lobes/exponents", {2.1, 150, 120, 4100}); },
       "/cosine_lobes/exponents: value 120 at index 2 is not above the one before (150): exponents increase"},
      {"too many exponents",
       [](hid_t f) {
         std::vector<double> e(12);
         for (int k = 0; k < 12; ++k) e[static_cast<std::size_t>(k)] = 1.0 + k;
         replace_doubles(f, "/cosine_lobes/exponents", e, {12});
       },
       "/cosine_lobes/exponents: wrong shape [12], expected [N] with 1 to 11 lobes"},
      {"kg rows", [](hid_t f) { replace_doubles(f, "/cosine_lobes/kg", std::vector<double>(9, 0.1), {3, 3}); },
       "/cosine_lobes/kg: wrong shape [3, 3], expected [4, 3] (one row per exponent)"},
      {"negative kdd",
       [](hid_t f) {
         std::vector<double> kdd(12, 0.1);
         kdd[5] = -0.1;
         overwrite_doubles(f, "/cosine_lobes/kdd", kdd);
       },
       "/cosine_lobes/kdd: value -0.1 at index [1, 2] out of range [0, inf)"},
      {"lobe count", [](hid_t f) { set_int_attr(f, "/cosine_lobes", "lobe_count", 3); },
       "/cosine_lobes attribute 'lobe_count': is 3 but /cosine_lobes/exponents has 4 lobes"},
      {"missing group", [](hid_t f) { H5Ldelete(f, "/cosine_lobes", H5P_DEFAULT); }, "/cosine_lobes: missing group"},
      {"missing convention",
       [](hid_t f) {
         const hid_t g = H5Gopen2(f, "/conventions", H5P_DEFAULT);
         H5Adelete(g, "cosine_lobes");
         H5Gclose(g);
       },
       "/conventions attribute 'cosine_lobes': missing"},
      {"changed convention", [](hid_t f) { set_string_attr(f, "/conventions", "cosine_lobes", "f = kg (r.o)^E"); },
       "/conventions attribute 'cosine_lobes': states a different convention than the format (version 5) defines"},
      {"model of version 5 in a version-4 file", [](hid_t f) { set_int_attr(f, "/", "format_version", 4); },
       "/ attribute 'model': 'cosine-lobes' is a model of format version 5, not 4"},
  };
  for (const auto& d : damages) {
    SCOPED_TRACE(d.what);
    const fs::path file = tmp / "damaged.axf.h5";
    fs::copy_file(good, file, fs::copy_options::overwrite_existing);
    damage(file, d.edit);
    const AxfValidation v = validate_axf_file(file);
    EXPECT_FALSE(v.ok());
    EXPECT_TRUE(any_problem_has(v, d.expected)) << "expected \"" << d.expected << "\" in:\n" << all_problems(v);
    EXPECT_TRUE(any_problem_has(v, "/ attribute 'content_sha256'")) << all_problems(v);
    EXPECT_THROW(read_axf_file(file), DataError);
  }
  // The writer applies the same rules, and a cosine-lobes paint has nothing flakes could carry.
  AxfPaint bad = cosine_lobes_paint();
  bad.cosine_lobes->exponents[3] = 100;
  EXPECT_THAT(test::error_message<DataError>([&] { write_axf_file(tmp / "bad.axf.h5", bad); }),
              HasSubstr("/cosine_lobes/exponents: value 100 at index 3 is not above the one before (120)"));
  bad = cosine_lobes_paint();
  bad.flakes = brdf::FlakeSpec{};
  EXPECT_THAT(test::error_message<DataError>([&] { check_axf_paint(bad); }),
              HasSubstr("/flakes: a cosine-lobes paint has no lobes for flakes to carry"));
  bad = cosine_lobes_paint();
  bad.cosine_lobes.reset();
  EXPECT_THAT(test::error_message<DataError>([&] { check_axf_paint(bad); }), HasSubstr("/cosine_lobes: missing group"));
  EXPECT_FALSE(fs::exists(tmp / "bad.axf.h5"));
}
