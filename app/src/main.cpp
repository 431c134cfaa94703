// paintlab: measure, calibrate, fit and export car-paint BRDFs.
// Exit codes: 0 success, 1 the job failed, 2 bad usage or bad input.
#include <cstdio>
#include <exception>

#include "cli.h"
#include "paintlab/core/error.h"
#include "paintlab/core/log.h"
#include "paintlab/core/progress.h"
#include "paintlab/core/version.h"

namespace {

// One line on stderr for a paintlab error (an option error names the flag the user typed),
// and the exit code it stands for.
int report(const paintlab::Error& e) {
  const auto* option = dynamic_cast<const paintlab::OptionError*>(&e);
  std::fprintf(stderr, "paintlab: error: %s\n",
               option ? paintlab::app::option_error_message(*option).c_str() : e.what());
  return paintlab::exit_code(e);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace paintlab;
  CLI::App app{
      "paintlab measures the reflectance of car-paint spheres on a lab rig, calibrates the rig,\n"
      "fits paint models and exports fitted paints.\n\n"
      "Exit codes: 0 success, 1 the job failed (a check failed, a fit did not converge,\n"
      "a device fault stopped the run), 2 bad usage or bad input.",
      "paintlab"};
  app.set_version_flag("--version", "paintlab " + software_version());
  int verbose = 0;
  bool quiet = false;
  CLI::Option* verbose_flag = app.add_flag("-v,--verbose", verbose, "More log output (repeat for trace)");
  app.add_flag("-q,--quiet", quiet, "Only warnings, errors and results")->excludes(verbose_flag);
  app.require_subcommand(1);
  app.fallthrough();

  app::register_rig_commands(app);
  app::register_paint_commands(app);
  app::register_sim_commands(app);
  app::register_sim_serve_command(app);
  app::register_devices_commands(app);
  app::register_fit_commands(app);
  app::register_measure_commands(app);
  app::register_calibrate_commands(app);
  app::register_hdr_commands(app);
  app::register_check_commands(app);
  app::register_export_commands(app);
  app::register_library_commands(app);
  app::register_render_commands(app);
  app::register_colour_commands(app);
  app::register_report_commands(app);
  app::register_flakes_commands(app);
  app::register_design_commands(app);
  app::register_demo_commands(app);

  try {
    app::check_command_words(app, argc, argv);
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitBadInput;
  } catch (const Error& e) {
    return report(e);
  }

  init_logging(quiet ? -1 : verbose);
  set_progress_quiet(quiet);
  const auto* run = app::chosen_command();
  if (!run) {
    std::fprintf(stderr, "paintlab: error: no command given (see paintlab --help)\n");
    return kExitBadInput;
  }
  try {
    return (*run)();
  } catch (const Error& e) {
    return report(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "paintlab: internal error: %s\n", e.what());
    return kExitFailed;
  }
}
