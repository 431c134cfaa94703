#pragma once
// Multi-angle colourimetry: a paint's CIELAB at the fixed in-plane geometries of the industry's
// multi-angle spectrophotometers (X-Rite MA-T, BYK-mac i), the flop index, and the quality
// control verdict a paint lab signs off (docs/colour.md "Multi-angle colour").
//
// Conventions (the same in every number paintlab prints):
// - A geometry "45as15" is an illumination 45 deg from the normal and a viewing direction at
//   the aspecular angle 15 deg: the specular direction turned by that angle towards the
//   illuminator, in the plane of incidence. So 45as45 views along the normal, 45as110 views
//   65 deg from the normal on the light's side, and a negative aspecular angle (45as-15,
//   "behind the gloss") views further from the illuminator than the specular direction.
// - The reflectance factor is R = pi f(wi, wo) per channel of linear sRGB (a perfect white
//   diffuser is 1 at every geometry); XYZ is sRGB's (D65, the 2 deg observer that sRGB implies:
//   a 10 deg observer needs spectra), CIELAB against the D65 white. L* may pass 100 near the
//   specular direction, as instrument values do.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/brdf/paint.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/paint_library.h"

namespace paintlab::fit {

struct Geometry {
  std::string name;               // "45as15" (or a custom set's own name)
  double illumination_deg = 45;   // from the normal, in [0, 90)
  double aspecular_deg = 45;      // from the specular direction towards the illuminator

  // The signed viewing angle from the normal: positive on the far side of the illuminator
  // (where the specular direction is), negative on the light's side. 45as45: 0; 45as110: -65.
  double viewing_deg() const { return illumination_deg - aspecular_deg; }
  // Unit vectors in the local shading frame (normal +z, plane of incidence xz, the light on +x).
  Eigen::Vector3d towards_light() const;
  Eigen::Vector3d towards_viewer() const;
};

// "45as15", "45as-15", "15as110": illumination and aspecular angle in degrees. UsageError
// naming the text when it is not of that form or the viewing direction is not above the surface
// (|illumination - aspecular| < 90 deg).
Geometry parse_geometry(const std::string& text);

// The named sets: "astm-e2194" (45as15, 45as45, 45as110: ASTM E2194's three angles for metallic
// paints), "five-angle" (45as15, 45as25, 45as45, 45as75, 45as110: the BYK-mac i / MA-T in-plane
// set), "e2539" (interference pigments: 45as-15 and the five, plus 15 deg illumination at
// -15, 15, 25, 45 and 80; see docs/colour.md for why these), "six-angle" (45as-15 and the five).
const std::vector<std::string>& geometry_set_names();
// A named set, or a TOML file of `[[geometry]]` tables (illumination_deg, aspecular_deg, optional
// name). UsageError for an unknown name (listing the names), ConfigError naming file, line and
// key for a bad file.
std::vector<Geometry> geometry_set(const std::string& name_or_file);
inline constexpr const char* kDefaultGeometrySet = "five-angle";

struct AngleColour {
  Geometry geometry;
  colour::Rgb reflectance = colour::Rgb::Zero();  // R = pi f, linear sRGB
  colour::Lab lab;
};

// The paint's colour at each geometry (the model evaluated at the exact directions).
std::vector<AngleColour> colour_at(const brdf::Brdf& paint, const std::vector<Geometry>& geometries);

// DuPont's flop index as X-Rite's instruments report it, 2.69 (L*15 - L*110)^1.11 / (L*45)^0.86
// (illumination 45 deg; a negative lightness difference keeps its sign). nullopt when the set
// lacks 45as15, 45as45 or 45as110.
double flop_index(double L15, double L45, double L110);
std::optional<double> flop_index(const std::vector<AngleColour>& colours);

// What the measured samples nearest a geometry say (sessions and tables).
struct MeasuredColour {
  colour::Rgb reflectance = colour::Rgb::Zero();
  colour::Rgb reflectance_stderr = colour::Rgb::Zero();
  colour::Lab lab;
  std::size_t n = 0;                // samples used
  double angular_distance_deg = 0;  // the farthest sample's distance from the geometry
};

// One paint's multi-angle colour: the model at each geometry and, where measured, the samples.
struct MultiAngleColour {
  std::string paint;   // the paint's name
  std::string source;  // the file it came from
  std::vector<AngleColour> model;
  std::vector<std::optional<MeasuredColour>> measured;  // empty, or one per geometry
  std::optional<double> flop;                           // of the model
};

// The measured samples nearest each geometry in a binned table (a session's, or a MERL
// table): the bins within the smallest radius of `radii_deg` that holds `min_samples`
// samples, and the value at the geometry from a weighted local linear fit of f over them
// (so that a lobe's slope across the neighbourhood does not bias it; a plain mean below 8
// bins). Weights: the bin mean's inverse variance from `noise_variance` (a session's per-sample
// noise, BinnedTable::noise_variance; may be null), else the bin's own scatter from 5 samples,
// else its count. The radius is the angle between the geometry's light (or view) direction and
// a bin's mean one, both with the half vector at the same azimuth. nullopt where even the
// largest radius holds too few.
struct NearestSamplesOptions {
  std::uint32_t min_samples = 20;
  std::vector<double> radii_deg = {0.5, 1.0, 2.0, 3.0, 5.0};
};
std::vector<std::optional<MeasuredColour>> measured_colour(const brdf::MerlTable& table,
                                                           const std::vector<float>* noise_variance,
                                                           const std::vector<Geometry>& geometries,
                                                           const NearestSamplesOptions& options = {});

// Why a geometry has no measured samples, for people: the angle between light and camera it
// needs against the range the table covers ("45as-15 needs 105 deg between light and camera;
// the sweep covers 20..170 deg").
std::string uncovered_reason(const brdf::MerlTable& table, const Geometry& g);

// How measured data become a model and measured colours.
struct MeasuredInputOptions {
  std::filesystem::path fit_file;  // the model: a fit.json or .axf.h5 of the data; empty: fit now
  int lobes = 3;                   // Cook-Torrance lobes of a fit made now
  std::optional<std::filesystem::path> calib_dir;  // a session's calibration (default: its rig's)
  NearestSamplesOptions nearest;
};

// The colour of measured data, a session folder or a MERL .binary table: the measured samples
// nearest each geometry beside the model (options.fit_file, or a Cook-Torrance fit made now).
// DataError naming the geometries the data do not cover (and why), or data that are not
// linear sRGB.
MultiAngleColour measured_paint_colour(const std::filesystem::path& data, const std::vector<Geometry>& geometries,
                                       const MeasuredInputOptions& options = {});

// What `paintlab colour INPUT` reads: measured_paint_colour for a session folder or .binary
// table, paint_colour for the rest (UsageError when options name a fit for a paint file).
MultiAngleColour any_colour(const std::filesystem::path& input, const std::vector<Geometry>& geometries,
                            const MeasuredInputOptions& options = {});

// The colour of a paint file: a paint .toml (every model, pearlescent included), a fit.json
// or an AxF-like .axf.h5. DataError when the file's values are not linear sRGB (a measurement
// without a colour calibration has no CIELAB).
MultiAngleColour paint_colour(const std::filesystem::path& file, const std::vector<Geometry>& geometries);

// DESIGN.md's `paintlab colour --json` object: illuminant, observer, and per geometry the
// angles, the model's L*, a*, b* (with C*, h and R per channel), the measurement's (or null)
// and their CIEDE2000; the flop index.
Json colour_json(const MultiAngleColour& c);
// The same as a table for people.
std::string colour_table(const MultiAngleColour& c);

// ---- Quality control: a sample against a standard, per geometry ----

// The tolerance at one geometry: each limit given is checked (|dL*| <= dL and so on);
// dE00 is weighted by the parametric factors kL, kC, kH (DIN 6175-2-style sets loosen
// lightness near the gloss: kL > 1 there).
struct QcTolerance {
  Geometry geometry;
  std::optional<double> de00, dL, dC, dH;
  double kL = 1.0, kC = 1.0, kH = 1.0;
};

// A tolerance set from TOML (docs/colour.md "Quality control"): optional `geometries = SET`
// (a set name; then every geometry of it needs a tolerance) and one `[[tolerance]]` table per
// geometry (`geometry = "45as15"`, any of `de00`, `dL`, `dC`, `dH`, optional `kL`, `kC`, `kH`).
// ConfigError naming file, line and key, or the geometry of the set that has no tolerance.
std::vector<QcTolerance> load_tolerances(const std::filesystem::path& file);
// Without a file: dE00 <= 1.0 at each geometry of `set` (a plain default, not a standard's).
std::vector<QcTolerance> default_tolerances(const std::string& set = kDefaultGeometrySet);

struct QcAngle {
  QcTolerance tolerance;
  colour::Lab standard, sample;
  double dL = 0, dC = 0, dH = 0;  // sample - standard: CIE 1976 lightness, chroma, metric hue
  double de00 = 0;                // CIEDE2000 with the tolerance's kL, kC, kH
  bool pass = true;
  std::string failed;  // "dE00 1.42 > 1.00; dL* -1.10 beyond 1.00" or empty
};

struct QcResult {
  std::string standard, sample;  // the two paints' names
  std::vector<QcAngle> angles;
  bool pass = true;
};

// A QC side as the user names it: a file or folder that exists, else (with `library_dir`) the
// name of a paint in that library. UsageError naming the text when it is neither.
std::filesystem::path resolve_paint_input(const std::string& text, const std::filesystem::path& library_dir);

// Compares two paints (as any_colour reads them: a session or table is fitted, and its model
// compared) at the tolerances' geometries.
QcResult quality_control(const std::filesystem::path& standard, const std::filesystem::path& sample,
                         const std::vector<QcTolerance>& tolerances, const MeasuredInputOptions& measured = {});
// The same from colours already evaluated at the tolerances' geometries (in that order).
QcResult quality_control(const MultiAngleColour& standard, const MultiAngleColour& sample,
                         const std::vector<QcTolerance>& tolerances);
Json qc_json(const QcResult& r);
std::string qc_table(const QcResult& r);

// The simulator's truth beside a measurement and its fit at the same geometries (`paintlab
// demo`'s summary.json "colour"): per geometry the truth's, the measurement's and the fit's
// L*, a*, b* and the two dE00 against the truth; the worst of each.
Json colour_against_truth(const brdf::PaintSpec& truth, const MultiAngleColour& measured_and_fit);
// Its table for people.
std::string colour_against_truth_table(const Json& colour);

// ---- Colour match against a paint library ----

struct LibraryMatch {
  std::string name;            // the library paint
  double worst_de00 = 0;       // the largest CIEDE2000 over the geometries
  std::string worst_geometry;  // where it is
  double mean_de00 = 0;
};

struct LibraryMatchResult {
  std::vector<LibraryMatch> matches;  // every comparable paint, best (smallest worst_de00) first
  std::size_t from_index = 0;         // colours read from the index (no file opened)
  std::size_t from_files = 0;         // colours computed from the paint file (a version-1 entry, another set)
  std::vector<std::string> skipped;   // paints without CIELAB (camera RGB), by name
};

// `paintlab library match`: the library's paints ranked by their worst-geometry dE00 against
// `target` (evaluated at `geometries`). Colours stored in the index serve when they hold every
// geometry; otherwise the paint's file is read (checksum checked).
LibraryMatchResult library_match(const PaintLibrary& library, const MultiAngleColour& target,
                                 const std::vector<Geometry>& geometries);

}  // namespace paintlab::fit
