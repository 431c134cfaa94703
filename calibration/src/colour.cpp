#include "paintlab/calibration/colour.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <lcms2.h>
#include <memory>
#include <set>
#include <type_traits>

#include <Eigen/Dense>

#include "dense_solve.h"
#include "paintlab/core/enum_names.h"
#include "paintlab/core/error.h"
#include "paintlab/core/input_files.h"

namespace paintlab::calib {

namespace {

constexpr EnumNames<ColourModel, 3> kModelNames{{{ColourModel::Matrix, "matrix"},
                                                 {ColourModel::RootPolynomial2, "root-polynomial-2"},
                                                 {ColourModel::RootPolynomial3, "root-polynomial-3"}}};

// LittleCMS reports errors through a context's log handler: keep the first message.
void keep_first_error(cmsContext context, cmsUInt32Number /*code*/, const char* text) {
  auto* message = static_cast<std::string*>(cmsGetContextUserData(context));
  if (message && message->empty() && text) *message = text;
}

struct ContextDeleter {
  void operator()(cmsContext c) const { cmsDeleteContext(c); }
};
struct It8Deleter {
  void operator()(void* h) const { cmsIT8Free(static_cast<cmsHANDLE>(h)); }
};

bool parse_number(const char* text, double& value) {
  if (!text || !*text) return false;
  char* end = nullptr;
  errno = 0;
  value = std::strtod(text, &end);
  return errno == 0 && end && *end == '\0' && std::isfinite(value);
}

}  // namespace

// ---- the reference --------------------------------------------------------------------------

std::vector<colour::Xyz> ChartReference::xyz_d65() const {
  std::vector<colour::Xyz> out;
  out.reserve(lab.size());
  for (const colour::Lab& l : lab) out.push_back(colour::adapt(colour::lab_to_xyz(l, white), white, colour::d65()));
  return out;
}

std::vector<colour::Lab> ChartReference::lab_d65() const {
  std::vector<colour::Lab> out;
  for (const colour::Xyz& x : xyz_d65()) out.push_back(colour::xyz_to_lab(x, colour::d65()));
  return out;
}

std::vector<std::array<double, 3>> ChartReference::srgb_reflectances() const {
  std::vector<std::array<double, 3>> out;
  for (const colour::Xyz& x : xyz_d65()) {
    const colour::Rgb s = colour::xyz_to_srgb(x);
    out.push_back({s.x(), s.y(), s.z()});
  }
  return out;
}

int ChartReference::index_of(const std::string& patch) const {
  const auto it = std::find(patches.begin(), patches.end(), patch);
  return it == patches.end() ? -1 : static_cast<int>(it - patches.begin());
}

ChartReference ChartReference::load(const std::filesystem::path& path, const colour::Xyz& white) {
  require_readable_file(path);
  const std::string where = path.string();
  std::string message;
  std::unique_ptr<std::remove_pointer_t<cmsContext>, ContextDeleter> context(cmsCreateContext(nullptr, &message));
  if (!context) throw DataError(where + ": LittleCMS could not create a context");
  cmsSetLogErrorHandlerTHR(context.get(), keep_first_error);
  std::unique_ptr<void, It8Deleter> it8(cmsIT8LoadFromFile(context.get(), where.c_str()));
  if (!it8)
    throw DataError(where + ": not a CGATS (IT8.7) file" + (message.empty() ? std::string() : ": " + message));
  cmsHANDLE h = it8.get();

  const int id_col = cmsIT8FindDataFormat(h, "SAMPLE_ID");
  if (id_col < 0) throw DataError(where + ": no SAMPLE_ID field in BEGIN_DATA_FORMAT");
  const char* lab_fields[3] = {"LAB_L", "LAB_A", "LAB_B"};
  const char* xyz_fields[3] = {"XYZ_X", "XYZ_Y", "XYZ_Z"};
  int cols[3];
  bool is_lab = true;
  for (int c = 0; c < 3; ++c) cols[c] = cmsIT8FindDataFormat(h, lab_fields[c]);
  if (cols[0] < 0 || cols[1] < 0 || cols[2] < 0) {
    is_lab = false;
    for (int c = 0; c < 3; ++c) cols[c] = cmsIT8FindDataFormat(h, xyz_fields[c]);
    if (cols[0] < 0 || cols[1] < 0 || cols[2] < 0)
      throw DataError(where + ": the data format has neither LAB_L LAB_A LAB_B nor XYZ_X XYZ_Y XYZ_Z");
  }
  const double sets = cmsIT8GetPropertyDbl(h, "NUMBER_OF_SETS");
  if (!(sets >= 1 && sets <= 100000)) throw DataError(where + ": NUMBER_OF_SETS must be a count of patches");

  ChartReference ref;
  ref.source = where;
  ref.white = white;
  std::set<std::string> seen;
  for (int row = 0; row < static_cast<int>(sets); ++row) {
    const char* id = cmsIT8GetDataRowCol(h, row, id_col);
    if (!id || !*id) throw DataError(fmt::format("{}: data row {} has no SAMPLE_ID", where, row + 1));
    const std::string name = id;
    if (!seen.insert(name).second) throw DataError(where + ": patch '" + name + "' appears twice");
    double v[3];
    for (int c = 0; c < 3; ++c)
      if (!parse_number(cmsIT8GetDataRowCol(h, row, cols[c]), v[c]))
        throw DataError(fmt::format("{}: patch '{}': {} is not a number", where, name,
                                    is_lab ? lab_fields[c] : xyz_fields[c]));
    colour::Lab lab;
    if (is_lab) {
      if (!(v[0] >= 0.0 && v[0] <= 150.0))
        throw DataError(fmt::format("{}: patch '{}': LAB_L {} is outside 0..150", where, name, v[0]));
      lab = {v[0], v[1], v[2]};
    } else {
      if (!(v[0] >= 0.0 && v[1] >= 0.0 && v[2] >= 0.0))
        throw DataError(fmt::format("{}: patch '{}': XYZ values must not be negative", where, name));
      lab = colour::xyz_to_lab(colour::Xyz(v[0], v[1], v[2]) / 100.0, white);
    }
    ref.patches.push_back(name);
    ref.lab.push_back(lab);
  }
  return ref;
}

// ---- models -------------------------------------------------------------------------------

const char* to_string(ColourModel model) { return enum_name(kModelNames, model); }

ColourModel colour_model_from_string(const std::string& name, const std::string& where) {
  return enum_from_name(kModelNames, name, "colour model", where);
}

int colour_model_terms(ColourModel model) {
  switch (model) {
    case ColourModel::Matrix: return 3;
    case ColourModel::RootPolynomial2: return 6;
    case ColourModel::RootPolynomial3: return 13;
  }
  return 3;
}

Eigen::VectorXd colour_terms(ColourModel model, const colour::Rgb& rgb) {
  const double r = std::max(rgb.x(), 0.0), g = std::max(rgb.y(), 0.0), b = std::max(rgb.z(), 0.0);
  Eigen::VectorXd t(colour_model_terms(model));
  t.head<3>() = rgb;  // the linear terms keep their sign: noise around black stays unbiased
  if (model == ColourModel::Matrix) return t;
  t[3] = std::sqrt(r * g);
  t[4] = std::sqrt(g * b);
  t[5] = std::sqrt(r * b);
  if (model == ColourModel::RootPolynomial2) return t;
  t[6] = std::cbrt(r * g * g);
  t[7] = std::cbrt(g * b * b);
  t[8] = std::cbrt(r * b * b);
  t[9] = std::cbrt(g * r * r);
  t[10] = std::cbrt(b * g * g);
  t[11] = std::cbrt(b * r * r);
  t[12] = std::cbrt(r * g * b);
  return t;
}

void ColourFitOptions::check() const {
  if (!(min_signal_rel >= 0.0 && min_signal_rel < 1.0))
    throw OptionError("ColourFitOptions::min_signal_rel", fmt::format("{}", min_signal_rel), "[0, 1)");
}

// ---- the calibration ------------------------------------------------------------------------

colour::Xyz ColourCalibration::to_xyz(const colour::Rgb& camera) const {
  return matrix * colour_terms(model, camera);
}

std::optional<Eigen::Matrix3d> ColourCalibration::balanced_srgb_matrix() const {
  if (model != ColourModel::Matrix) return std::nullopt;
  return Eigen::Matrix3d(colour::xyz_to_srgb_matrix() * matrix.leftCols<3>() * camera_white.asDiagonal());
}

namespace {

// dE00 between the model applied to a patch's terms and the patch's reference (D65).
struct De00Residual {
  Eigen::VectorXd terms;
  colour::Lab reference;
  int k;
  bool operator()(double const* const* parameters, double* residual) const {
    const Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>> m(parameters[0], 3, k);
    const colour::Xyz xyz = m * terms;
    residual[0] = colour::delta_e_2000(colour::xyz_to_lab(xyz, colour::d65()), reference);
    return std::isfinite(residual[0]);
  }
};

// The camera value that the model maps to D65 white: Gauss-Newton from the linear terms'
// inverse (exact for the matrix model).
colour::Rgb solve_camera_white(const ColourCalibration& cal) {
  const Eigen::Matrix3d lin = cal.matrix.leftCols<3>();
  colour::Rgb c = lin.colPivHouseholderQr().solve(colour::d65());
  if (cal.model == ColourModel::Matrix) return c;
  for (int it = 0; it < 30; ++it) {
    const colour::Xyz f = cal.to_xyz(c) - colour::d65();
    if (f.norm() < 1e-12) break;
    Eigen::Matrix3d J;
    for (int j = 0; j < 3; ++j) {
      colour::Rgb d = c;
      const double h = 1e-7 * std::max(1.0, std::abs(c[j]));
      d[j] += h;
      J.col(j) = (cal.to_xyz(d) - colour::d65() - f) / h;
    }
    c -= J.colPivHouseholderQr().solve(f);
  }
  return c;
}

}  // namespace

ColourCalibration fit_colour(const ChartReference& reference, const std::vector<PatchMeasurement>& measured,
                             const ColourFitOptions& options) {
  options.check();
  if (reference.patches.empty()) throw DataError(reference.source + ": the chart reference has no patches");
  const int k = colour_model_terms(options.model);
  const std::vector<colour::Xyz> ref_xyz = reference.xyz_d65();
  const std::vector<colour::Lab> ref_lab = reference.lab_d65();

  ColourCalibration cal;
  cal.model = options.model;
  cal.reference = reference.source;
  double brightest = 0.0;
  for (const PatchMeasurement& m : measured)
    if (!m.clipped && m.rgb.allFinite()) brightest = std::max(brightest, m.rgb.maxCoeff());

  std::vector<int> measurement_of(reference.patches.size(), -1);
  for (std::size_t j = 0; j < measured.size(); ++j) {
    const int i = reference.index_of(measured[j].name);
    if (i < 0)
      throw DataError("colour: measured patch '" + measured[j].name + "' is not in the reference " + reference.source);
    measurement_of[static_cast<std::size_t>(i)] = static_cast<int>(j);
  }
  std::vector<int> used;
  int clipped = 0, dark = 0, missing = 0;
  cal.patches.resize(reference.patches.size());
  for (std::size_t i = 0; i < reference.patches.size(); ++i) {
    PatchReport& p = cal.patches[i];
    p.name = reference.patches[i];
    p.reference = ref_lab[i];
    const int j = measurement_of[i];
    if (j < 0) {
      p.why_not = "not measured";
      ++missing;
    } else if (measured[static_cast<std::size_t>(j)].clipped) {
      p.why_not = "clipped";
      ++clipped;
    } else if (!measured[static_cast<std::size_t>(j)].rgb.allFinite() ||
               measured[static_cast<std::size_t>(j)].rgb.maxCoeff() <= options.min_signal_rel * brightest) {
      p.why_not = "too dark";
      ++dark;
    } else {
      p.used = true;
      used.push_back(static_cast<int>(i));
    }
  }
  const int needed = k + 6;
  if (static_cast<int>(used.size()) < needed)
    throw CalibrationError(fmt::format(
        "colour: {} of the chart's {} patches are usable ({} clipped, {} too dark, {} not measured); the {} model "
        "needs at least {}",
        used.size(), reference.patches.size(), clipped, dark, missing, to_string(options.model), needed));

  // Linear start: weighted least squares on XYZ, each patch weighted by 1/Y.
  const int n = static_cast<int>(used.size());
  Eigen::MatrixXd A(n, k), B(n, 3);
  std::vector<Eigen::VectorXd> terms(reference.patches.size());
  for (int r = 0; r < n; ++r) {
    const auto i = static_cast<std::size_t>(used[static_cast<std::size_t>(r)]);
    terms[i] = colour_terms(options.model, measured[static_cast<std::size_t>(measurement_of[i])].rgb);
    const double w = 1.0 / std::sqrt(std::max(ref_xyz[i].y(), 0.01));
    A.row(r) = w * terms[i].transpose();
    B.row(r) = w * ref_xyz[i].transpose();
  }
  cal.matrix = A.colPivHouseholderQr().solve(B).transpose();

  const auto mean_sq_de = [&](const Eigen::MatrixXd& m) {
    double s = 0.0;
    for (int i : used) {
      const auto ui = static_cast<std::size_t>(i);
      const double d = colour::delta_e_2000(colour::xyz_to_lab(m * terms[ui], colour::d65()), ref_lab[ui]);
      s += d * d;
    }
    return s / n;
  };
  if (options.refine_de00) {
    Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> m = cal.matrix;
    ceres::Problem problem;
    for (int i : used) {
      const auto ui = static_cast<std::size_t>(i);
      auto* cost = new ceres::DynamicNumericDiffCostFunction<De00Residual, ceres::CENTRAL>(
          new De00Residual{terms[ui], ref_lab[ui], k});
      cost->AddParameterBlock(3 * k);
      cost->SetNumResiduals(1);
      problem.AddResidualBlock(cost, nullptr, m.data());
    }
    solve_dense(problem, 200, 1e-12, 1e-12);
    if (m.allFinite() && mean_sq_de(m) < mean_sq_de(cal.matrix)) cal.matrix = m;
  }

  // The report, over every measured patch (clipped ones too: their colour is shown, not used).
  std::vector<double> des;
  for (std::size_t i = 0; i < reference.patches.size(); ++i) {
    PatchReport& p = cal.patches[i];
    if (measurement_of[i] < 0) continue;
    p.fitted = colour::xyz_to_lab(cal.to_xyz(measured[static_cast<std::size_t>(measurement_of[i])].rgb), colour::d65());
    p.de00 = colour::delta_e_2000(p.fitted, p.reference);
    if (!p.used) continue;
    des.push_back(p.de00);
    if (p.de00 >= cal.max_de00) {
      cal.max_de00 = p.de00;
      cal.worst_patch = p.name;
    }
  }
  cal.patches_used = n;
  double sum = 0.0;
  for (double d : des) sum += d;
  cal.mean_de00 = sum / n;
  std::sort(des.begin(), des.end());
  cal.median_de00 = n % 2 ? des[static_cast<std::size_t>(n / 2)]
                          : 0.5 * (des[static_cast<std::size_t>(n / 2 - 1)] + des[static_cast<std::size_t>(n / 2)]);
  cal.camera_white = solve_camera_white(cal);
  return cal;
}

std::string ColourCalibration::describe() const {
  return fmt::format("colour: {} model on {} patches: CIEDE2000 mean {:.2f}, median {:.2f}, max {:.2f} ({})",
                     to_string(model), patches_used, mean_de00, median_de00, max_de00, worst_patch);
}

namespace {

Json lab_json(const colour::Lab& l) { return Json::array({l.L, l.a, l.b}); }

colour::Lab lab_from_json(const Json& j, const std::string& what) {
  const Eigen::Vector3d v = vector3_from_json(j, what);
  return {v.x(), v.y(), v.z()};
}

}  // namespace

Json ColourCalibration::to_json() const {
  Json patch_list = Json::array();
  for (const PatchReport& p : patches) {
    Json o = {{"name", p.name}, {"reference_lab", lab_json(p.reference)}, {"used", p.used}};
    if (p.why_not != "not measured") {
      o["fitted_lab"] = lab_json(p.fitted);
      o["de00"] = p.de00;
    }
    if (!p.used) o["why_not"] = p.why_not;
    patch_list.push_back(std::move(o));
  }
  return {{"model", to_string(model)},
          {"matrix", matrix_to_json(matrix)},
          {"space", "camera linear RGB -> CIE XYZ (D65, 2 deg observer, Y = 1 for the perfect white diffuser); "
                    "linear sRGB by IEC 61966-2-1"},
          {"camera_white", vector3_to_json(camera_white)},
          {"patches_used", patches_used},
          {"mean_de00", mean_de00},
          {"median_de00", median_de00},
          {"max_de00", max_de00},
          {"worst_patch", worst_patch},
          {"reference", reference},
          {"patches", patch_list},
          {"provenance", provenance.to_json()}};
}

ColourCalibration ColourCalibration::from_json(const Json& j, const std::string& where) {
  ColourCalibration c;
  c.model = colour_model_from_string(json_get<std::string>(j, "model", where), where + ": key 'model'");
  c.matrix = matrix_from_json(json_get<Json>(j, "matrix", where), where + ": key 'matrix'");
  if (c.matrix.rows() != 3 || c.matrix.cols() != colour_model_terms(c.model) || !c.matrix.allFinite())
    throw DataError(fmt::format("{}: key 'matrix' must be 3x{} finite numbers for the {} model", where,
                                colour_model_terms(c.model), to_string(c.model)));
  c.camera_white = vector3_from_json(json_get<Json>(j, "camera_white", where), where + ": key 'camera_white'");
  c.patches_used = json_get_or<int>(j, "patches_used", 0, where);
  c.mean_de00 = json_get<double>(j, "mean_de00", where);
  c.median_de00 = json_get_or<double>(j, "median_de00", 0.0, where);
  c.max_de00 = json_get<double>(j, "max_de00", where);
  c.worst_patch = json_get_or<std::string>(j, "worst_patch", "", where);
  c.reference = json_get_or<std::string>(j, "reference", "", where);
  if (j.contains("patches"))
    for (const Json& o : j.at("patches")) {
      PatchReport p;
      p.name = json_get<std::string>(o, "name", where);
      const std::string what = where + ": patch '" + p.name + "'";
      p.reference = lab_from_json(json_get<Json>(o, "reference_lab", what), what + " reference_lab");
      p.used = json_get_or<bool>(o, "used", false, what);
      if (o.contains("fitted_lab")) p.fitted = lab_from_json(o.at("fitted_lab"), what + " fitted_lab");
      p.de00 = json_get_or<double>(o, "de00", 0.0, what);
      p.why_not = json_get_or<std::string>(o, "why_not", "", what);
      c.patches.push_back(std::move(p));
    }
  if (j.contains("provenance")) c.provenance = Provenance::from_json(j.at("provenance"), where);
  return c;
}

void ColourCalibration::save(const std::filesystem::path& path) const { write_json_file(path, to_json()); }

ColourCalibration ColourCalibration::load(const std::filesystem::path& path) {
  return from_json(read_json_file(path), path.string());
}

}  // namespace paintlab::calib
