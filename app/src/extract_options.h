#pragma once
// The extraction and binning flags of the commands that bin a session (fit, bin, export).
#include <CLI/CLI.hpp>
#include <string>

#include "paintlab/fitting/session_binning.h"

namespace paintlab::app {

// Extraction and binning flags of the commands that bin a session (fit, bin, export).
struct ExtractArgs {
  std::string calib;  // calibration folder; default: the one of the session's rig file
  double margin_px = fit::ExtractionOptions{}.margin_px;
  double blur_px = fit::ExtractionOptions{}.blur_sigma_px;
  int valid_margin_px = fit::ExtractionOptions{}.valid_margin_px;
  double max_blur_correction = fit::ExtractionOptions{}.max_blur_correction;
  std::string too_sharp = "keep";
  std::string variance = fit::to_string(fit::ExtractionOptions{}.variance);
  std::string estimator = fit::to_string(fit::BinningOptions{}.estimator);
  std::string cfa_sites = "off";  // --cfa-sites of the commands that fit (add_cfa_sites_option: auto)
  int threads = 0;
};
// Adds --calib, --margin-px, --blur-px, --valid-margin-px, --variance, --estimator and --threads (`fits`: the command fits
// too, and its threads are the fit's as well).
void add_extract_options(CLI::App* sub, ExtractArgs& a, bool fits);
// Adds --cfa-sites auto|on|off, default auto (the commands that fit a session: a fit, not a
// table, comes of the sites).
void add_cfa_sites_option(CLI::App* sub, ExtractArgs& a);
// The options the flags give (fit::bin_session checks them); DataError naming the flag.
fit::SessionBinOptions bin_options(const ExtractArgs& a);

}  // namespace paintlab::app
