// Paint files: TOML and JSON round trips, every kind of bad file with its file:line:key
// message, the shipped paints.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/core/error.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::brdf;
using ::testing::HasSubstr;

namespace {
const char* const kGoodCt = R"(name = "example-silver"
model = "cook-torrance"
kd = [0.05, 0.06, 0.07]
[[lobes]]
ks = [0.06, 0.08, 0.09]
m = 0.38
r = 0.90
[[lobes]]
ks = [0.2, 0.2, 0.2]
m = 0.013
r = 0.04
[flakes]
density = 0.5
roughness = 0.15
)";

// docs/paint-files.md's cosine-lobes example: three lobes, a clear coat in the sharpest.
const char* const kGoodCosine = R"(name = "designed-red"
model = "cosine-lobes"
exponents = [2.1, 40, 4100]
kd = [0.2, 0.03, 0.02]
kg = [
  [0.01, 0.002, 0.001],
  [0.3, 0.1, 0.05],
  [20.0, 20.0, 20.0],
]
kdd = [
  [0.05, 0.01, 0.005],
  [0.4, 0.05, 0.02],
  [0, 0, 0],
]
)";

std::string config_error(const std::string& text, const std::string& file = "p.toml") {
  try {
    parse_paint(ConfigTable::parse_string(text, file));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

std::string data_error(const Json& j) {
  try {
    paint_from_json(j, "summary.json");
  } catch (const DataError& e) {
    return e.what();
  }
  return "no error";
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

PaintSpec example_axf_spec() {
  PaintSpec s;
  s.name = "axf-blue";
  AxfCarPaintParams p;
  p.ior = 1.52;
  p.diffuse = 0.11;
  p.lobes = {{0.05, 0.31, 0.7}, {0.02, 0.04, 0.2}};
  p.chi.theta_h_samples = 2;
  p.chi.theta_i_samples = 3;
  p.chi.scale = 1.25;
  p.chi.rgb = {Rgb(0.1, 0.2, 0.9), Rgb(0.11, 0.21, 0.91), Rgb(0.12, 0.22, 0.92),
               Rgb(0.2, 0.3, 0.8),  Rgb(0.21, 0.31, 0.81), Rgb(1.0 / 3.0, 0.1 + 0.2, 0.7)};
  s.params = p;
  s.flakes = FlakeSpec{0.25, 0.2, 7.0, {0}, 0.1, 0.3, 0.6, -5.0};  // coloured flakes
  return s;
}
}  // namespace

TEST(PaintFile, ParsesTheContractExample) {
  const PaintSpec s = parse_paint(ConfigTable::parse_string(kGoodCt, "p.toml"));
  EXPECT_EQ(s.name, "example-silver");
  EXPECT_EQ(s.model(), "cook-torrance");
  const auto* p = s.cook_torrance();
  ASSERT_NE(p, nullptr);
  EXPECT_THAT(p->kd, test::RgbNear(Rgb(0.05, 0.06, 0.07), 0));
  ASSERT_EQ(p->lobes.size(), 2u);
  EXPECT_EQ(p->lobes[1].m, 0.013);
  EXPECT_EQ(p->lobes[0].r, 0.90);
  ASSERT_TRUE(s.flakes.has_value());
  EXPECT_EQ(s.flakes->density, 0.5);
  EXPECT_EQ(s.flakes->lifetime_deg, 6.5);                // default
  EXPECT_EQ(s.flakes->lobes, (std::vector<int>{0}));  // every lobe but the narrowest
}

// The demo's truth for a monochrome camera: w . kd and w . ks in every channel, the rest
// of the paint as it was.
TEST(PaintFile, AMonochromeCameraSeesTheChannelWeightedKdAndKs) {
  const PaintSpec s = parse_paint(ConfigTable::parse_string(kGoodCt, "p.toml"));
  const Rgb w(0.25, 0.5, 0.25);
  const PaintSpec mono = seen_in_mono(s, w);
  const double kd = 0.25 * 0.05 + 0.5 * 0.06 + 0.25 * 0.07;
  EXPECT_THAT(mono.cook_torrance()->kd, test::RgbNear(Rgb::Constant(kd), 1e-15));
  for (std::size_t l = 0; l < 2; ++l) {
    const Rgb& ks = s.cook_torrance()->lobes[l].ks;
    EXPECT_THAT(mono.cook_torrance()->lobes[l].ks, test::RgbNear(Rgb::Constant((w * ks).sum()), 1e-15)) << l;
    EXPECT_EQ(mono.cook_torrance()->lobes[l].m, s.cook_torrance()->lobes[l].m);
  }
  EXPECT_EQ(mono.flakes, s.flakes);
  EXPECT_EQ(mono.name, s.name);
}

TEST(PaintFile, TomlRoundTripForEveryModel) {
  test::TempDir d;
  std::vector<PaintSpec> specs;
  specs.push_back(parse_paint(ConfigTable::parse_string(kGoodCt, "p.toml")));
  specs.push_back(example_axf_spec());
  specs.push_back(parse_paint(ConfigTable::parse_string(kGoodCosine, "c.toml")));
  for (const char* n : {"silver-metallic", "solid-blue", "pearlescent"})
    specs.push_back(load_paint_file(test::source_dir() / "paints" / (std::string(n) + ".toml")));
  PaintSpec merl;
  merl.name = "tabulated";
  std::filesystem::create_directories(d / "tables");
  write_merl(d / "tables/t.binary", MerlTable());
  merl.params = MerlParams{"tables/t.binary", d / "tables/t.binary"};
  specs.push_back(merl);
  for (const auto& s : specs) {
    const std::string text = to_toml(s);
    test::write_text(d / "rt.toml", text);
    const PaintSpec back = load_paint_file(d / "rt.toml");
    EXPECT_EQ(back, s) << text;
    EXPECT_EQ(to_toml(back), text);
    EXPECT_EQ(back.source, d / "rt.toml");
    EXPECT_NO_THROW(check_paint(s)) << s.name;
  }
  // The MERL path is relative to the paint file.
  EXPECT_EQ(load_paint_file(d / "rt.toml").merl()->resolved, d / "tables/t.binary");
}

TEST(PaintFile, JsonRoundTripAndContractShape) {
  const PaintSpec ct = parse_paint(ConfigTable::parse_string(kGoodCt, "p.toml"));
  const Json j = to_json(ct);
  EXPECT_EQ(j["model"], "cook-torrance");
  EXPECT_EQ(j["kd"], Json::parse("[0.05, 0.06, 0.07]"));
  EXPECT_EQ(j["lobes"][0]["ks"], Json::parse("[0.06, 0.08, 0.09]"));
  EXPECT_EQ(j["lobes"][1]["m"], 0.013);
  EXPECT_EQ(j["lobes"][0]["r"], 0.9);
  EXPECT_EQ(j["flakes"]["lobes"], Json::parse("[1]"));
  for (const PaintSpec& s : {ct, example_axf_spec(), parse_paint(ConfigTable::parse_string(kGoodCosine, "c.toml")),
                             load_paint_file(test::source_dir() / "paints/pearlescent.toml")}) {
    const Json js = Json::parse(to_json(s).dump());  // through text
    EXPECT_EQ(paint_from_json(js, "x.json"), s);
  }
  // A "fit" object of summary.json: no name, extra keys beside the paint's.
  const Json fit = Json::parse(R"({"model": "cook-torrance", "kd": [0.1, 0.1, 0.1],
      "lobes": [{"ks": [0.2, 0.2, 0.2], "m": 0.2, "r": 0.5}],
      "residual": {"log_rms": 0.02, "bins_used": 1000}})");
  const PaintSpec f = paint_from_json(fit, "summary.json");
  EXPECT_EQ(f.name, "unnamed");
  EXPECT_EQ(f.cook_torrance()->lobes[0].m, 0.2);
}

TEST(PaintFile, JsonErrorsNameWhereAndKey) {
  Json j = to_json(parse_paint(ConfigTable::parse_string(kGoodCt, "p.toml")));
  Json bad = j;
  bad["lobes"][1]["m"] = 1.3;
  EXPECT_THAT(data_error(bad), HasSubstr("summary.json: key 'lobes[1].m': must be in (0, 1) (got 1.3)"));
  bad = j;
  bad["lobes"][0]["sigma"] = 1;
  EXPECT_THAT(data_error(bad), HasSubstr("summary.json: key 'lobes[0].sigma': unknown key in 'lobes[0]'"));
  bad = j;
  bad["kd"] = "grey";
  EXPECT_THAT(data_error(bad), HasSubstr("key 'kd': expected an array of numbers, got a string"));
  bad = j;
  bad.erase("lobes");
  EXPECT_THAT(data_error(bad), HasSubstr("key 'lobes': required key is missing"));
  bad = j;
  bad["flakes"]["lobes"] = Json::array({3});
  EXPECT_THAT(data_error(bad), HasSubstr("key 'flakes.lobes': element 0 must be in [1, 2] (got 3)"));
  EXPECT_THAT(data_error(Json::array()), HasSubstr("summary.json: expected a paint object"));
  PaintSpec s = example_axf_spec();
  std::get<AxfCarPaintParams>(s.params).lobes[0].spread = 0;
  try {
    check_paint(s);
    ADD_FAILURE() << "no error";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("paint 'axf-blue': key 'lobes[0].spread': must be in (0, 1) (got 0)"));
  }
}

TEST(PaintFile, EveryKindOfBadFileNamesFileLineAndKey) {
  const std::string good = kGoodCt;
  // Unknown keys, at the top, in a lobe, in [flakes].
  EXPECT_THAT(config_error(good + "colour = 3\n"), HasSubstr("p.toml:15: key 'flakes.colour': unknown key in [flakes]"));
  EXPECT_THAT(config_error(replace(good, "name = \"example-silver\"\n", "name = \"example-silver\"\nkdd = 1\n")),
              HasSubstr("p.toml:2: key 'kdd': unknown key at the top level"));
  EXPECT_THAT(config_error(replace(good, "m = 0.38\n", "m = 0.38\nmm = 1\n")),
              HasSubstr("p.toml:7: key 'lobes[0].mm': unknown key in [lobes[0]]"));
  // Wrong types.
  EXPECT_THAT(config_error(replace(good, "m = 0.38", "m = \"rough\"")),
              HasSubstr("p.toml:6: key 'lobes[0].m': expected a number, got a string"));
  EXPECT_THAT(config_error(replace(good, "kd = [0.05, 0.06, 0.07]", "kd = 0.05")),
              HasSubstr("p.toml:3: key 'kd': expected an array of numbers, got a number"));
  EXPECT_THAT(config_error(replace(good, "kd = [0.05, 0.06, 0.07]", "kd = [0.05, 0.06]")),
              HasSubstr("p.toml:3: key 'kd': expected 3 values, got 2"));
  // Out of range: m and r in (0, 1), kd and ks >= 0.
  EXPECT_THAT(config_error(replace(good, "m = 0.38", "m = 1.0")),
              HasSubstr("p.toml:6: key 'lobes[0].m': must be in (0, 1) (got 1)"));
  EXPECT_THAT(config_error(replace(good, "m = 0.013", "m = 0")),
              HasSubstr("p.toml:10: key 'lobes[1].m': must be in (0, 1) (got 0)"));
  EXPECT_THAT(config_error(replace(good, "r = 0.04", "r = -0.1")),
              HasSubstr("p.toml:11: key 'lobes[1].r': must be in (0, 1) (got -0.1)"));
  EXPECT_THAT(config_error(replace(good, "kd = [0.05, 0.06, 0.07]", "kd = [0.05, -0.06, 0.07]")),
              HasSubstr("p.toml:3: key 'kd': element 1 must be in [0, 2] (got -0.06)"));
  EXPECT_THAT(config_error(replace(good, "ks = [0.2, 0.2, 0.2]", "ks = [0.2, 0.2, -1]")),
              HasSubstr("p.toml:9: key 'lobes[1].ks': element 2 must be in [0, 20] (got -1)"));
  EXPECT_THAT(config_error(replace(good, "density = 0.5", "density = 0")),
              HasSubstr("p.toml:13: key 'flakes.density': must be in (0, 100] (got 0)"));
  // Physical ranges (issue 13: kd = 1e308 rendered an image of inf, a flake density of
  // 1e300 failed later with a 600-digit number and no file or line).
  EXPECT_THAT(config_error(replace(good, "kd = [0.05, 0.06, 0.07]", "kd = [1e308, 0.06, 0.07]")),
              HasSubstr("p.toml:3: key 'kd': element 0 must be in [0, 2] (got 1e+308)"));
  EXPECT_THAT(config_error(replace(good, "kd = [0.05, 0.06, 0.07]", "kd = [0.05, 2.2, 0.07]")),
              HasSubstr("p.toml:3: key 'kd': element 1 must be in [0, 2] (got 2.2)"));
  EXPECT_THAT(config_error(replace(good, "ks = [0.2, 0.2, 0.2]", "ks = [0.2, 21, 0.2]")),
              HasSubstr("p.toml:9: key 'lobes[1].ks': element 1 must be in [0, 20] (got 21)"));
  EXPECT_THAT(config_error(replace(good, "density = 0.5", "density = 1e300")),
              HasSubstr("p.toml:13: key 'flakes.density': must be in (0, 100] (got 1e+300)"));
  EXPECT_EQ(config_error(replace(replace(good, "density = 0.5", "density = 100"), "kd = [0.05, 0.06, 0.07]",
                                 "kd = [2, 0, 1]")),
            "no error");
  // Names.
  EXPECT_THAT(config_error(replace(good, "example-silver", "Example Silver")),
              HasSubstr("p.toml:1: key 'name': \"Example Silver\" is not a valid paint name"));
  EXPECT_THAT(config_error(replace(good, "example-silver", "")), HasSubstr("p.toml:1: key 'name'"));
  // 1..3 lobes.
  EXPECT_THAT(config_error("name = \"a\"\nmodel = \"cook-torrance\"\nkd = [0, 0, 0]\n"),
              HasSubstr("p.toml:1: key 'lobes': required key is missing in the top level"));
  const std::string lobe = "[[lobes]]\nks = [0.1, 0.1, 0.1]\nm = 0.2\nr = 0.5\n";
  EXPECT_THAT(config_error("name = \"a\"\nmodel = \"cook-torrance\"\nkd = [0, 0, 0]\n" + lobe + lobe + lobe + lobe),
              HasSubstr("key 'lobes': expected 1..3 entries, got 4"));
  // Model.
  EXPECT_THAT(config_error(replace(good, "\"cook-torrance\"", "\"phong\"")),
              HasSubstr("p.toml:2: key 'model': \"phong\" is not one of \"cook-torrance\", \"axf-carpaint\", "
                        "\"layered-pearlescent\", \"merl\""));
  // Syntax.
  EXPECT_THAT(config_error(replace(good, "m = 0.38", "m = = 0.38")), HasSubstr("p.toml:6"));
  // Flake lobes.
  EXPECT_THAT(config_error(good + "lobes = [1, 1]\n"), HasSubstr("p.toml:15: key 'flakes.lobes': lobe 1 is listed twice"));
  // The flakes' colour.
  EXPECT_THAT(config_error(good + "tint_sd = 1.5\n"), HasSubstr("p.toml:15: key 'flakes.tint_sd': must be in [0, 1] (got 1.5)"));
  EXPECT_THAT(config_error(good + "interference_chroma = 0\n"),
              HasSubstr("p.toml:15: key 'flakes.interference_chroma': must be in (0, 1] (got 0)"));
  EXPECT_THAT(config_error(good + "interference_shift_deg = 100\n"),
              HasSubstr("p.toml:15: key 'flakes.interference_shift_deg': must be in [-90, 90] (got 100)"));
  EXPECT_THAT(config_error(good + "lobes = [1, 2, 1]\n"), HasSubstr("p.toml:15: key 'flakes.lobes': expected 1..2 values"));
  EXPECT_THAT(config_error(good + "lobes = [1.5]\n"),
              HasSubstr("p.toml:15: key 'flakes.lobes': lobe numbers are whole numbers (got 1.5)"));
}

TEST(PaintFile, BadFilesOfTheOtherModels) {
  const std::string axf = to_toml(example_axf_spec());
  // chi must have 3 x theta_h_samples x theta_i_samples numbers.
  EXPECT_THAT(config_error(replace(axf, "theta_i_samples = 3", "theta_i_samples = 2")),
              HasSubstr("key 'chi.rgb': expected 12 values, got 18"));
  EXPECT_THAT(config_error(replace(axf, "ior = 1.52", "ior = 0.9")),
              HasSubstr("p.toml:3: key 'ior': must be in [1, 3] (got 0.9)"));
  EXPECT_THAT(config_error(replace(axf, "spread = 0.31", "spread = 1.31")),
              HasSubstr("key 'lobes[0].spread': must be in (0, 1) (got 1.31)"));
  const std::string pearl = to_toml(load_paint_file(test::source_dir() / "paints/pearlescent.toml"));
  EXPECT_THAT(config_error(replace(pearl, "opacity = 0.15", "opacity = 1.5")),
              HasSubstr("key 'pigment.opacity': must be in [0, 1] (got 1.5)"));
  EXPECT_THAT(config_error(pearl + "lobes = [1]\n"),
              HasSubstr("key 'flakes.lobes': layered-pearlescent has no lobes"));
  EXPECT_THAT(config_error("name = \"p\"\nmodel = \"layered-pearlescent\"\nsubstrate = [0.5, 0.5, 0.5]\nior = 1.5\n"
                           "gloss_roughness = 0.1\n"),
              HasSubstr("p.toml:1: key 'pigment': required table is missing"));
  // MERL: the table must exist and have the MERL size; no [flakes].
  test::TempDir d;
  test::write_text(d / "m.toml", "name = \"m\"\nmodel = \"merl\"\ntable = \"absent.binary\"\n");
  try {
    load_paint_file(d / "m.toml");
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("m.toml:3: key 'table': no such file: " + (d / "absent.binary").string()));
  }
  test::write_text(d / "short.binary", "abc");
  test::write_text(d / "m2.toml", "name = \"m\"\nmodel = \"merl\"\ntable = \"short.binary\"\n");
  EXPECT_THROW(
      {
        try {
          load_paint_file(d / "m2.toml");
        } catch (const ConfigError& e) {
          EXPECT_THAT(e.what(), HasSubstr("m2.toml:3: key 'table': "));
          EXPECT_THAT(e.what(), HasSubstr("expected 34992012 bytes, got 3"));
          throw;
        }
      },
      ConfigError);
  write_merl(d / "ok.binary", MerlTable());
  test::write_text(d / "m3.toml", "name = \"m\"\nmodel = \"merl\"\ntable = \"ok.binary\"\n[flakes]\ndensity = 1\n");
  EXPECT_THROW(load_paint_file(d / "m3.toml"), ConfigError);
  EXPECT_THROW(load_paint_file(d / "none.toml"), IoError);
}

TEST(PaintFile, ShippedPaintsValidateAndBuildTheirModels) {
  for (const char* n : {"silver-metallic", "solid-blue", "pearlescent"}) {
    const PaintSpec s = load_paint_file(test::source_dir() / "paints" / (std::string(n) + ".toml"));
    EXPECT_EQ(s.name, n);
    const auto brdf = make_brdf(s);
    EXPECT_EQ(brdf->model(), s.model());
    EXPECT_GT(brdf->eval(Vec3(0.3, 0, 0.954).normalized(), Vec3(-0.3, 0, 0.954).normalized()).minCoeff(), 0.0);
    EXPECT_THAT(describe_paint(s), HasSubstr("paint '" + std::string(n) + "'"));
  }
  const PaintSpec silver = load_paint_file(test::source_dir() / "paints/silver-metallic.toml");
  ASSERT_EQ(silver.cook_torrance()->lobes.size(), 3u);
  ASSERT_TRUE(silver.flakes.has_value());
  EXPECT_EQ(silver.flakes->lobes, (std::vector<int>{0, 1}));
  EXPECT_EQ(load_paint_file(test::source_dir() / "paints/pearlescent.toml").model(), "layered-pearlescent");
}

TEST(PaintFile, MerlPaintLoadsItsTable) {
  test::TempDir d;
  MerlTable t;
  for (std::size_t b = 0; b < kMerlBins; ++b) t.set_value(b, Rgb(0.1, 0.2, 0.3), BinState::Measured);
  write_merl(d / "white.binary", t);
  test::write_text(d / "w.toml", "name = \"w\"\nmodel = \"merl\"\ntable = \"white.binary\"\n");
  const auto brdf = make_brdf(load_paint_file(d / "w.toml"));
  EXPECT_EQ(brdf->model(), "merl");
  EXPECT_THAT(brdf->eval(Vec3(0.5, 0, 0.866), Vec3(-0.5, 0, 0.866)), test::RgbNear(Rgb(0.1, 0.2, 0.3), 1e-12));
}

// ---- cosine-lobes ----

TEST(PaintFile, CosineLobesParseAndRoundTripThroughTomlAndJson) {
  const PaintSpec s = parse_paint(ConfigTable::parse_string(kGoodCosine, "c.toml"));
  EXPECT_EQ(s.model(), "cosine-lobes");
  const CosineLobeParams* p = s.cosine_lobes();
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->exponents, (std::vector<double>{2.1, 40, 4100}));
  EXPECT_THAT(p->kd, test::RgbNear(Rgb(0.2, 0.03, 0.02), 0));
  ASSERT_EQ(p->kg.size(), 3u);
  ASSERT_EQ(p->kdd.size(), 3u);
  EXPECT_THAT(p->kg[1], test::RgbNear(Rgb(0.3, 0.1, 0.05), 0));
  EXPECT_THAT(p->kdd[0], test::RgbNear(Rgb(0.05, 0.01, 0.005), 0));
  EXPECT_THAT(p->kdd[2], test::RgbNear(Rgb(0, 0, 0), 0));

  // Values that print with many digits come back bit for bit.
  PaintSpec odd = s;
  auto& q = std::get<CosineLobeParams>(odd.params);
  q.exponents[1] = 40.0 / 3.0;
  q.kg[1] = Rgb(0.1 + 0.2, 1.0 / 7.0, 2e-17);
  const std::string text = to_toml(odd);
  const PaintSpec back = parse_paint(ConfigTable::parse_string(text, "rt.toml"));
  EXPECT_EQ(back, odd) << text;
  EXPECT_EQ(to_toml(back), text);

  const Json j = Json::parse(to_json(odd).dump());
  EXPECT_EQ(j["model"], "cosine-lobes");
  EXPECT_EQ(j["exponents"].size(), 3u);
  EXPECT_EQ(j["kg"][1][0], 0.1 + 0.2);
  EXPECT_EQ(j["kdd"][1], Json::parse("[0.4, 0.05, 0.02]"));
  EXPECT_EQ(paint_from_json(j, "x.json"), odd);
  EXPECT_NO_THROW(check_paint(odd));

  const std::string text_of_describe = describe_paint(s);
  EXPECT_THAT(text_of_describe, HasSubstr("model cosine-lobes"));
  EXPECT_THAT(text_of_describe, HasSubstr("exponent 4100"));
}

// f(wi, wo) = kd / pi + sum_i (kg_i / (n.wi) + kdd_i) (r.wo)_+^E_i with r = 2 (n.wi) n - wi,
// computed here from the formula, not from the model's code.
TEST(PaintFile, CosineLobesPaintEvaluatesTheFormula) {
  const PaintSpec s = parse_paint(ConfigTable::parse_string(kGoodCosine, "c.toml"));
  const auto f = make_brdf(s);
  EXPECT_EQ(f->model(), "cosine-lobes");
  const Vec3 n(0, 0, 1);
  const Rgb kd(0.2, 0.03, 0.02);
  const std::vector<double> e{2.1, 40, 4100};
  const std::vector<Rgb> kg{Rgb(0.01, 0.002, 0.001), Rgb(0.3, 0.1, 0.05), Rgb(20, 20, 20)};
  const std::vector<Rgb> kdd{Rgb(0.05, 0.01, 0.005), Rgb(0.4, 0.05, 0.02), Rgb(0, 0, 0)};
  // Near the mirror direction (all three lobes count) and 50 deg away from it (the sharp ones
  // vanish); then behind the mirror direction, where only kd / pi is left.
  const std::vector<std::pair<Vec3, Vec3>> pairs = {
      {Vec3(0.3, 0.1, 0.9).normalized(), Vec3(-0.3, -0.09, 0.91).normalized()},
      {Vec3(0.5, 0.0, 0.8).normalized(), Vec3(0.2, 0.6, 0.7).normalized()},
      {Vec3(0.9, 0.0, 0.2).normalized(), Vec3(0.9, 0.1, 0.2).normalized()}};
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto& [wi, wo] = pairs[k];
    const Vec3 r = 2 * n.dot(wi) * n - wi;
    const double rv = r.dot(wo);
    Rgb expected = kd / std::numbers::pi;
    for (std::size_t i = 0; i < e.size(); ++i)
      if (rv > 0) expected += (kg[i] / n.dot(wi) + kdd[i]) * std::pow(rv, e[i]);
    if (k < 2) {
      EXPECT_GT(rv, 0.0) << k;
    } else {
      EXPECT_LT(rv, 0.0);
    }
    EXPECT_THAT(f->eval(wi, wo), test::RgbNear(expected, 1e-12)) << k;
  }
  EXPECT_GT(f->eval(pairs[0].first, pairs[0].second)[0], 1.0);  // the clear coat's lobe is in
}

TEST(PaintFile, CosineLobesSeenInMonoWeighsEveryWeight) {
  const PaintSpec s = parse_paint(ConfigTable::parse_string(kGoodCosine, "c.toml"));
  const Rgb w(0.25, 0.5, 0.25);
  const PaintSpec mono = seen_in_mono(s, w);
  const auto& a = *s.cosine_lobes();
  const auto& m = *mono.cosine_lobes();
  EXPECT_EQ(m.exponents, a.exponents);
  EXPECT_THAT(m.kd, test::RgbNear(Rgb::Constant((w * a.kd).sum()), 1e-15));
  for (std::size_t i = 0; i < a.exponents.size(); ++i) {
    EXPECT_THAT(m.kg[i], test::RgbNear(Rgb::Constant((w * a.kg[i]).sum()), 1e-15)) << i;
    EXPECT_THAT(m.kdd[i], test::RgbNear(Rgb::Constant((w * a.kdd[i]).sum()), 1e-15)) << i;
  }
}

TEST(PaintFile, BadCosineLobesFilesNameTheKey) {
  const std::string good = kGoodCosine;
  EXPECT_EQ(config_error(good), "no error");
  // One kg per exponent.
  EXPECT_THAT(config_error(replace(good, "  [0.3, 0.1, 0.05],\n", "")),
              HasSubstr("p.toml:5: key 'kg': 2 entries for 3 exponents"));
  EXPECT_THAT(config_error(replace(good, "[0.3, 0.1, 0.05]", "[0.3, 0.1]")),
              HasSubstr("p.toml:5: key 'kg': element 1: expected 3 values [R, G, B], got 2"));
  EXPECT_THAT(config_error(replace(good, "kg = [", "kg = 3\nkgx = [")),
              HasSubstr("p.toml:5: key 'kg': expected an array of [R, G, B] arrays, got an integer"));
  // Weights >= 0 and at most (E + 1) / pi.
  EXPECT_THAT(config_error(replace(good, "[0.4, 0.05, 0.02]", "[0.4, -0.05, 0.02]")),
              HasSubstr("p.toml:10: key 'kdd': element 1: [0.4, -0.05, 0.02] must be finite and >= 0 (got -0.05)"));
  EXPECT_THAT(config_error(replace(good, "[0.3, 0.1, 0.05]", "[0.3, 14, 0.05]")),
              HasSubstr("p.toml:5: key 'kg': element 1: [0.3, 14, 0.05] must be at most (E + 1) / pi = 13.05 for "
                        "exponent E = 40"));
  EXPECT_THAT(config_error(replace(good, "kd = [0.2, 0.03, 0.02]", "kd = [0.2, 0.03, 2.5]")),
              HasSubstr("p.toml:4: key 'kd': element 2 must be in [0, 2] (got 2.5)"));
  // Exponents: increasing, in [0.5, 1e6], 1 to 11 of them.
  EXPECT_THAT(config_error(replace(good, "[2.1, 40, 4100]", "[2.1, 4100, 40]")),
              HasSubstr("p.toml:3: key 'exponents': element 2: 40 not above element 1 = 4100 (exponents increase)"));
  EXPECT_THAT(config_error(replace(good, "[2.1, 40, 4100]", "[2.1, 2.1, 4100]")),
              HasSubstr("key 'exponents': element 1: 2.1 not above element 0 = 2.1"));
  EXPECT_THAT(config_error(replace(good, "[2.1, 40, 4100]", "[0.1, 40, 4100]")),
              HasSubstr("p.toml:3: key 'exponents': element 0 must be in [0.5, 1e+06] (got 0.1)"));
  EXPECT_THAT(config_error(replace(good, "[2.1, 40, 4100]", "[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]")),
              HasSubstr("key 'exponents': expected 1..11 values, got 12"));
  EXPECT_THAT(config_error(replace(good, "exponents = [2.1, 40, 4100]\n", "")),
              HasSubstr("key 'exponents': required key is missing"));
  // No sparkle: nothing in the model for flakes to carry.
  EXPECT_THAT(config_error(good + "[flakes]\ndensity = 0.5\nroughness = 0.15\n"),
              HasSubstr("p.toml:15: key 'flakes': sparkle needs lobes that flakes carry"));
  EXPECT_THAT(config_error(good + "[flakes]\ndensity = 0.5\nroughness = 0.15\n"),
              HasSubstr("not allowed with model \"cosine-lobes\""));
  // The JSON reader and check_paint apply the same rules.
  Json j = to_json(parse_paint(ConfigTable::parse_string(good, "c.toml")));
  Json bad = j;
  bad["kdd"].erase(0);
  EXPECT_THAT(data_error(bad), HasSubstr("summary.json: key 'kdd': 2 entries for 3 exponents"));
  bad = j;
  bad["exponents"] = Json::array({2.1, 4100, 40});
  EXPECT_THAT(data_error(bad), HasSubstr("summary.json: key 'exponents': element 2: 40 not above element 1 = 4100"));
  bad = j;
  bad["flakes"] = {{"density", 0.5}, {"roughness", 0.15}};
  EXPECT_THAT(data_error(bad), HasSubstr("summary.json: key 'flakes': sparkle needs lobes that flakes carry"));
  PaintSpec s = parse_paint(ConfigTable::parse_string(good, "c.toml"));
  std::get<CosineLobeParams>(s.params).kdd[1][2] = -1e-3;
  EXPECT_THAT(test::error_message<DataError>([&] { check_paint(s); }),
              HasSubstr("paint 'designed-red': key 'kdd': element 1: [0.4, 0.05, -0.001] must be finite and >= 0"));
}
