#pragma once
// Paint files (DESIGN.md "Contracts", docs/paint-files.md): the parameters of every model,
// read from TOML with errors that name file:line:key, written back to TOML, and converted
// to and from the JSON objects of summary.json ("truth", "fit") and fit.json.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/carpaint.h"
#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/cosine_lobes.h"
#include "paintlab/brdf/pearlescent.h"
#include "paintlab/core/config.h"
#include "paintlab/core/json.h"

namespace paintlab::brdf {

// Sparkle of the simulated flakes (models.md "Sparkle"). Only the simulator uses it; the
// BRDF of the paint is its average.
// Above this many flakes per pixel footprint the glints average into the BRDF (and the
// simulator would keep more flakes than it can): the paint validator's bound.
inline constexpr double kMaxFlakeDensity = 100.0;

struct FlakeSpec {
  double density = 0.5;       // flakes per pixel footprint at the reference distance, (0, 100]
  double roughness = 0.15;    // Beckmann m of the flake normals, (0, 1)
  double lifetime_deg = 6.5;  // a flake lights up while angle(flake normal, h) < lifetime, (0, 45]
  // Which lobes the flakes carry (their energy becomes sparkle), as 0-based indices into
  // the paint's lobes; files write them 1-based ("lobes = [1, 2]"). Default: every lobe
  // except the narrowest (the clear coat), or the only lobe. Empty for layered-pearlescent,
  // whose glitter term is what the flakes carry.
  std::vector<int> lobes;
  // The flakes' own colour (docs/paint-files.md "Flake colour"): a flake's glint is the carried
  // part times its tint t = 1 + c (cos(psi) u + sin(psi) v), u and v the unit vectors of the
  // RGB plane orthogonal to grey, so that the tints average to grey and the sparkle still
  // averages to the BRDF. Ordinary flakes: (c cos psi, c sin psi) normal with this standard
  // deviation per axis (c at most 1), [0, 1]; 0: grey flakes.
  double tint_sd = 0.0;
  // The fraction of interference flakes, [0, 1]: chroma interference_chroma, (0, 1], and a
  // hue psi that turns by interference_shift_deg per degree of the angle between the light
  // and the flake normal, [-90, 90] (a random start per flake).
  double interference = 0.0;
  double interference_chroma = 0.5;
  double interference_shift_deg = 6.0;
  bool coloured() const { return tint_sd > 0 || interference > 0; }
  bool operator==(const FlakeSpec&) const = default;
};

struct CookTorranceParams {
  Rgb kd = Rgb::Zero();  // f_diffuse = kd / pi, so kd is the diffuse albedo
  std::vector<CtLobe> lobes;  // 1..3
  bool operator==(const CookTorranceParams& o) const { return (kd == o.kd).all() && lobes == o.lobes; }
};

struct MerlParams {
  std::string table;               // as written in the file (relative to the paint file)
  std::filesystem::path resolved;  // the path to open
  bool operator==(const MerlParams& o) const { return table == o.table; }
};

using PaintParams =
    std::variant<CookTorranceParams, AxfCarPaintParams, PearlescentParams, MerlParams, CosineLobeParams>;

struct PaintSpec {
  std::string name;  // [a-z0-9._-]+
  PaintParams params;
  std::optional<FlakeSpec> flakes;
  std::filesystem::path source;  // the file it came from (empty otherwise); not compared

  // "cook-torrance", "axf-carpaint", "layered-pearlescent", "merl" or "cosine-lobes".
  std::string model() const;
  const CookTorranceParams* cook_torrance() const { return std::get_if<CookTorranceParams>(&params); }
  const AxfCarPaintParams* axf_carpaint() const { return std::get_if<AxfCarPaintParams>(&params); }
  const PearlescentParams* pearlescent() const { return std::get_if<PearlescentParams>(&params); }
  const MerlParams* merl() const { return std::get_if<MerlParams>(&params); }
  const CosineLobeParams* cosine_lobes() const { return std::get_if<CosineLobeParams>(&params); }
  bool operator==(const PaintSpec& o) const { return name == o.name && params == o.params && flakes == o.flakes; }
};

// The paint as a monochrome camera with channel weights `w` (linear RGB to its one channel)
// sees it: Cook-Torrance is linear in kd and ks (F, D, G do not depend on the channel), the
// cosine lobes in kd, kg and kdd, so each weight becomes w . rgb in all three channels. Other
// models are returned unchanged.
PaintSpec seen_in_mono(PaintSpec p, const Rgb& w);

// The model names a paint file may use.
const std::vector<std::string>& paint_models();

// Reads and validates a paint file. Throws IoError (cannot read) or ConfigError
// ("FILE:LINE: key 'KEY': RULE") for syntax errors, unknown keys, wrong types, values out
// of range, a bad name, 0 or more than 3 lobes, a missing MERL table, cosine-lobe exponents
// that do not increase or weights that do not match them one for one, [flakes] on a paint
// without lobes the flakes could carry (merl, cosine-lobes).
PaintSpec load_paint_file(const std::filesystem::path& path);
// The same on an already parsed table (relative MERL paths resolve against the folder
// of t.file()). Calls finish() on every table it reads.
PaintSpec parse_paint(const ConfigTable& t);

// TOML text that parse_paint() reads back into an equal PaintSpec (numbers printed
// with round-trip precision).
std::string to_toml(const PaintSpec& spec);

// JSON object {"name", "model", ...the model's keys as in TOML...}; for cook-torrance
// exactly the "truth"/"fit" shape {"model", "kd", "lobes": [{"ks", "m", "r"}]} plus "name"
// and "flakes" when present.
Json to_json(const PaintSpec& spec);
// Reads that object with the rules of the TOML reader. Errors are DataErrors naming
// `where` and the key ("summary.json: key 'fit.lobes[1].m': must be in (0, 1) (got 1.3)").
// Keys of the top-level object that are not paint keys ("residual", standard deviations)
// are ignored, so a fit object reads as a paint; nested objects are strict. "name" may
// be absent (then "unnamed"). Relative MERL paths resolve against base_dir.
PaintSpec paint_from_json(const Json& j, const std::string& where, const std::filesystem::path& base_dir = {});

// Checks a PaintSpec built in code against the same rules (DataError naming the key).
void check_paint(const PaintSpec& spec);

// The model behind the spec (a MERL table is read from disk: IoError/DataError).
std::unique_ptr<Brdf> make_brdf(const PaintSpec& spec);

// Several lines a technician reads: the model and every parameter.
std::string describe_paint(const PaintSpec& spec);

// The default lobes the flakes carry for `lobe_roughness` (every lobe but the narrowest).
std::vector<int> default_flake_lobes(const std::vector<double>& lobe_roughness);

}  // namespace paintlab::brdf
