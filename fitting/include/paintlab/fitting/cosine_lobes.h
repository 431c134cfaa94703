#pragma once
// The cosine-lobe basis for paint design (docs/design.md "Cosine-lobe basis"; the 2005 source
// on interactive colour-appearance design of automotive paints). A library's paints share one
// set of exponents E_i (brdf/cosine_lobes.h); each paint is then a handful of non-negative
// weights per channel, found by a linear programme, and a new paint is the weights whose colour
// at a few multi-angle geometries matches target CIELAB values.
//
// Errors are relative: |model - paint| / (paint + kCosineErrorFloor) per channel, so the gloss
// peak (hundreds of 1/sr) and the flop (hundredths) count alike; the floor (a reflectance factor
// of 0.01) keeps near-black values from dominating where no eye sees the difference.
//
// Solvers: the L1 fits and the design are linear programmes solved by GLPK's simplex through
// LEMON's LP interface (liblemon-dev is built with GLPK; the source used an LP as well); the
// exponent search's inner loop uses non-negative least squares (Lawson-Hanson), a hundred times
// faster, and the table reports the L1 fits at the exponents it found.
#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "paintlab/brdf/brdf.h"
#include "paintlab/brdf/cosine_lobes.h"
#include "paintlab/core/colour.h"
#include "paintlab/core/json.h"
#include "paintlab/fitting/multiangle.h"

namespace paintlab::fit {

inline constexpr double kCosineErrorFloor = 0.01 / 3.14159265358979323846;  // 1/sr: R = 0.01
inline constexpr const char* kCosineBasisFormat = "paintlab-cosine-basis";
inline constexpr int kCosineBasisVersion = 1;

struct DirectionPair {
  brdf::Vec3 wi, wo;  // towards the light, towards the viewer (local frame, n = +z)
};

// Where a paint and its cosine-lobe form are compared: illumination at 15..65 deg in 10 deg
// steps, each with the mirror direction, the plane of incidence every 2.5 deg of viewing angle
// and views around the mirror direction at 16 distances from 0.5 to 80 deg (dense near the
// gloss, where a clear coat's lobe is a few degrees wide) at 5 azimuths over half a turn (the
// paints are symmetric about the plane of incidence); views more than 70 deg from the normal
// are left out.
const std::vector<DirectionPair>& cosine_fit_geometries();

// The model's columns at `at`: one row per direction pair, columns [kd, kg_1..kg_n,
// kdd_1..kdd_n], each the BRDF (1/sr) of a unit weight.
Eigen::MatrixXd cosine_lobe_columns(const std::vector<DirectionPair>& at, const std::vector<double>& exponents);

// Non-negative least squares (Lawson and Hanson 1974): argmin |A x - b| over x >= 0.
Eigen::VectorXd nnls(const Eigen::MatrixXd& A, const Eigen::VectorXd& b);

// Minimises sum_r |A x - b|_r over x >= 0 by the simplex (GLPK through LEMON) plus
// `l1_weights . x` (a tie-break among equally good solutions; may be empty), subject to
// C x <= d (may be empty). DataError when the solver fails.
Eigen::VectorXd nonnegative_l1(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& l1_weights = {},
                               const Eigen::MatrixXd& C = {}, const Eigen::VectorXd& d = {});

// The paint's directional albedo at normal incidence per unit weight of each column [kd, kg_i,
// kdd_i]: 1 and 2 pi / (E_i + 2) (the lobe about the normal, integral of cos^E times cos).
// What `design` keeps at most 1 per channel (energy conservation at normal incidence).
Eigen::VectorXd cosine_lobe_albedo(const std::vector<double>& exponents);

enum class LobeNorm {
  L1,  // the linear programme (the source's)
  L2,  // non-negative least squares of the relative errors (the exponent search's)
};

struct CosineLobeFit {
  brdf::CosineLobeParams params;
  double mean_error = 0;  // the mean relative error over the geometries and channels
  double max_error = 0;   // the largest
};

// The paint's cosine-lobe weights for `exponents` (increasing, 1..11 of them).
CosineLobeFit fit_cosine_lobes(const brdf::Brdf& paint, const std::vector<double>& exponents,
                               LobeNorm norm = LobeNorm::L1);

// ---- The basis of a library: `paintlab basis fit` ----

struct CosineBasisRow {
  int lobes = 0;
  std::vector<double> exponents;
  double mean_error = 0;    // the library's mean of its paints' mean relative errors (L1 fits)
  double max_error = 0;     // the worst paint's mean relative error
  std::string worst_paint;  // which
  int evaluations = 0;      // exponent sets tried
  double criterion() const { return mean_error + max_error; }  // the source's average plus maximum
};

struct CosineBasis {
  std::vector<double> exponents;       // the chosen set
  int lobes = 0;                       // its size
  std::vector<CosineBasisRow> table;   // one row per lobe count tried
  std::vector<std::string> paints;     // the paints it was chosen over
  std::string library;                 // their library folder (as given)
  Json to_json() const;
  static CosineBasis from_json(const Json& j, const std::string& where);
};

struct CosineBasisOptions {
  int min_lobes = 1;
  int max_lobes = brdf::kMaxCosineLobes;
  // The count kept: the smallest whose criterion is within `keep_within` of the best row's
  // (the criterion falls ever more slowly with more lobes), unless `lobes` says.
  double keep_within = 0.10;
  std::optional<int> lobes;
  int max_evaluations = 600;  // per lobe count (Nelder-Mead over log exponents)
  std::function<void(const CosineBasisRow&)> progress;
};

// Chooses the exponents for `paints` (name, model): for each lobe count the set minimising the
// criterion (average plus maximum over the paints of their mean relative error), by Nelder-Mead
// over the exponents' logarithms from evenly spaced ones. UsageError without paints or for
// counts outside 1..11.
CosineBasis fit_cosine_basis(const std::vector<std::pair<std::string, std::shared_ptr<const brdf::Brdf>>>& paints,
                             const CosineBasisOptions& options = {});

// basis.json (atomic write). read: DataError naming the file and key.
void write_cosine_basis(const std::filesystem::path& path, const CosineBasis& basis);
CosineBasis read_cosine_basis(const std::filesystem::path& path);
// The table for people: lobes, mean and worst error (%), criterion, exponents; the kept row marked.
std::string cosine_basis_table(const CosineBasis& basis);

// ---- Design: `paintlab design --targets targets.toml` ----

inline constexpr double kDesignToleranceDe00 = 0.5;  // a target counts as reached within this

struct DesignTarget {
  Geometry geometry;
  colour::Lab lab;
};

struct DesignTargets {
  std::string name;                            // the new paint's name (optional in the file)
  std::optional<std::filesystem::path> basis;  // basis.json named by the file (relative to it)
  std::vector<DesignTarget> targets;
};

// targets.toml: optional `name`, optional `basis = "basis.json"`, and one `[[target]]` table per
// geometry (`geometry = "45as15"`, `lab = [L, a, b]`), 1 to 32 of them, each geometry once.
// ConfigError naming file, line and key.
DesignTargets load_design_targets(const std::filesystem::path& file);

struct DesignAngle {
  DesignTarget target;
  colour::Lab achieved;
  double de00 = 0;
  bool reached = false;
  std::string why;  // for a target not reached: why it is out of reach
};

struct DesignResult {
  brdf::CosineLobeParams params;
  std::vector<DesignAngle> angles;
  double solve_ms = 0;  // the three linear programmes
  // The lobes no target sees (at most kUnseenLobe of their peak at every target geometry), and
  // where their weights came from (`like`, or 0), one line each.
  std::vector<std::string> notes;
  bool all_reached() const;
};

inline constexpr double kUnseenLobe = 1e-3;

// The basis weights (per channel, >= 0) whose CIELAB at the targets' geometries is closest to
// the targets: the L1 linear programme over the relative error of each target's linear sRGB
// reflectance factor (a target hit exactly in every channel has dE00 0), with the albedo at
// normal incidence at most 1 per channel (else a narrow lobe's far tail could hit a target with
// an absurd weight whose gloss no paint has) and a tie-break towards the least albedo. Targets outside the sRGB gamut (a negative linear channel) are
// aimed at their gamut's edge and reported.
// Lobes no target sees (a clear coat's, for targets away from the gloss) take the weights of
// `like` (a paint's cosine-lobe form for the same exponents: `design --like PAINT` keeps a measured
// paint's gloss), else 0; the programme fits the rest with the unseen lobes' small contribution at
// the targets subtracted and their albedo counted. UsageError when `like` has other exponents.
DesignResult design_paint(const std::vector<double>& exponents, const std::vector<DesignTarget>& targets,
                          const brdf::CosineLobeParams* like = nullptr);

// The result as a table for people (target, achieved, dE00, reached or why not) and as JSON.
std::string design_table(const DesignResult& r);
Json design_json(const DesignResult& r);

}  // namespace paintlab::fit
