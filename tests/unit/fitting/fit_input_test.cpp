// What a fit reads (fit::load_fit_input): a MERL table with or without the coverage map
// `paintlab bin` writes beside it, and the errors for what is neither a table nor a session.
// Sessions go through bin_session (FitCli.BinsAndFitsASessionFolder runs that path).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include "paintlab/brdf/cook_torrance.h"
#include "paintlab/brdf/merl.h"
#include "paintlab/core/error.h"
#include "paintlab/fitting/coverage.h"
#include "paintlab/fitting/hole_fill.h"
#include "paintlab/fitting/session_binning.h"
#include "synthetic.h"
#include "test_util.h"

using namespace paintlab;
using namespace paintlab::fit;
using ::testing::HasSubstr;

TEST(FitInput, AFilledTableLeavesItsFilledBinsOutWithItsMapAndIsWarnedAboutWithout) {
  test::TempDir dir;
  const brdf::CookTorrance paint(brdf::Rgb(0.03, 0.06, 0.3), {{brdf::Rgb(0.15, 0.15, 0.15), 0.05, 0.04}});
  brdf::MerlTable t = test_support::tabulate_sparse(paint, 8);
  const std::size_t measured = t.count_in_state(brdf::BinState::Measured);
  const HoleFillReport r = fill_holes(t);
  const std::size_t filled = r.filled_mirror + r.filled_pyramid;
  ASSERT_GT(filled, 0u);
  brdf::write_merl(dir / "blue.binary", t);
  write_coverage_exr(coverage_map_path_for(dir / "blue.binary"), t);

  const FitInput in = load_fit_input(dir / "blue.binary", SessionBinOptions{});
  EXPECT_EQ(in.table.count_in_state(brdf::BinState::Measured), measured);  // the filled ones marked, not fitted
  EXPECT_EQ(in.input["kind"], "merl");
  EXPECT_EQ(in.input["filled_bins_left_out"].get<std::size_t>(), filled);
  EXPECT_EQ(in.sample, "blue");
  EXPECT_TRUE(in.noise_variance.empty());
  EXPECT_FALSE(in.stats);
  ASSERT_EQ(in.warnings.size(), 1u);
  EXPECT_THAT(in.warnings[0], HasSubstr("filled bins are not measurements, so the fit uses the " +
                                        std::to_string(measured) + " measured ones"));

  // Without its map the same table reads as measured everywhere, and says why that is suspect.
  std::filesystem::remove(coverage_map_path_for(dir / "blue.binary"));
  const FitInput bare = load_fit_input(dir / "blue.binary", SessionBinOptions{});
  EXPECT_EQ(bare.table.count_in_state(brdf::BinState::Measured), measured + filled);
  ASSERT_EQ(bare.warnings.size(), 1u);
  EXPECT_THAT(bare.warnings[0], HasSubstr("no coverage map (blue.coverage.exr) says which were measured"));
}

TEST(FitInput, NeitherATableNorASessionIsAnErrorNamingThePath) {
  test::TempDir dir;
  EXPECT_THAT(test::error_message<DataError>([&] { load_fit_input(dir.path(), SessionBinOptions{}); }),
              HasSubstr("a folder without session.json"));
  EXPECT_THROW(load_fit_input(dir / "missing.binary", SessionBinOptions{}), IoError);
}

// `export --merl` bins a fitted session again as the fit's input records (docs/fitting.md):
// the extraction rules it names, and none of the newer ones for a fit.json written before
// them; a damaged record is an error naming the key.
TEST(FitInput, TheBinningOptionsAFitRecordsAreReadBackAndOldFitsKeepTheirs) {
  const Json recorded = {{"margin_px", 4.0},          {"blur_sigma_px", 0.6},   {"valid_margin_px", 3},
                         {"max_blur_correction", 0.2}, {"too_sharp", "skip"},    {"variance", "local"},
                         {"estimator", "median-of-means"}};
  const SessionBinOptions o = bin_options_of_input(recorded, {}, "fit.json");
  EXPECT_EQ(o.extraction.margin_px, 4.0);
  EXPECT_EQ(o.extraction.blur_sigma_px, 0.6);
  EXPECT_EQ(o.extraction.valid_margin_px, 3);
  EXPECT_EQ(o.extraction.max_blur_correction, 0.2);
  EXPECT_TRUE(o.extraction.skip_too_sharp);
  EXPECT_EQ(o.extraction.variance, VarianceModel::Local);
  EXPECT_EQ(o.binning.estimator, BinEstimator::MedianOfMeans);
  // A fit.json from before the blur and margin rules: binned without them.
  const SessionBinOptions old = bin_options_of_input(Json{{"margin_px", 3.0}}, {}, "old/fit.json");
  EXPECT_EQ(old.extraction.blur_sigma_px, 0.0);
  EXPECT_EQ(old.extraction.valid_margin_px, 0);
  EXPECT_FALSE(old.extraction.skip_too_sharp);
  for (const auto& [key, bad] : std::vector<std::pair<std::string, Json>>{
           {"blur_sigma_px", "wide"}, {"valid_margin_px", 2.5}, {"valid_margin_px", 1000000000000LL},
           {"too_sharp", "sometimes"}, {"max_blur_correction", Json::array()}}) {
    SCOPED_TRACE(key);
    try {
      bin_options_of_input(Json{{key, bad}}, {}, "fit.json");
      ADD_FAILURE() << "accepted " << bad.dump();
    } catch (const DataError& e) {
      EXPECT_THAT(e.what(), HasSubstr("fit.json input." + key));
    }
  }
}
