#pragma once
// Shared pieces of the command line: how a subcommand registers the function it runs,
// and the registration functions of every command group (one file per group).
#include <CLI/CLI.hpp>
#include <initializer_list>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

#include "paintlab/core/error.h"

namespace paintlab::app {

// Registers `run` as what happens when `sub` is chosen. It runs after the whole command
// line is parsed and logging is set up; its return value is the exit code.
void on_run(CLI::App* sub, std::function<int()> run);

// The command `name` under `parent` with its arguments: an Args that the add_option calls
// that follow bind into (it lives as long as the command line), and `run`, called with them
// when the command is chosen (its return value is the exit code).
template <class Args, class Run>
std::pair<CLI::App*, Args*> add_command(CLI::App* parent, const std::string& name, const std::string& help, Run run) {
  auto args = std::make_shared<Args>();
  CLI::App* cmd = parent->add_subcommand(name, help);
  on_run(cmd, [args, run] { return run(*args); });
  return {cmd, args.get()};
}

// `GROUP validate FILE [--json]` for the TOML files paintlab reads (rig, paint): `describe`
// loads the file (its errors name file, line and key) and returns what to print, as JSON
// with --json.
void add_validate_command(CLI::App* group, const std::string& help, const std::string& file_help,
                          const std::string& json_help, std::string (*describe)(const std::string& file, bool json));

// The function chosen by the command line, or nullptr.
const std::function<int()>* chosen_command();

// The command group `name` (e.g. "sim", "calibrate"), created on first use, so several
// files can add subcommands to one group.
CLI::App* subcommand_group(CLI::App& app, const std::string& name, const std::string& description);

// Prints result lines to stdout (not through the logger, so -q keeps them); trailing
// newlines of `text` are dropped (one ends every say).
void say(std::string_view text);

// Records that `option` (a flag such as --lobes) sets these fields of library options
// structs ("CtFitOptions::lobes"), so that an OptionError on one of them names the flag the
// user typed. Returns `option`, to be written beside the add_option that binds it.
CLI::Option* sets_fields(CLI::Option* option, std::initializer_list<const char*> fields);
// A validator for free-text flags (names, notes) that end up in JSON and HDF5 files, which
// hold UTF-8 text: "--name: not valid UTF-8 text (byte 3 is 0xff)". Paths are not checked
// (a Linux file name may be any bytes).
const CLI::Validator& utf8_text();

// "--lobes 9: allowed 1..3" for an OptionError whose field a flag sets; else what().
std::string option_error_message(const OptionError& e);

// CLI11 reports a mistyped command word ("paintlab calibrat", "paintlab rig valdate") as "A
// subcommand is required": walks the command words of argv through the command tree and
// throws UsageError naming the word and the commands that exist there. Command groups take
// no options of their own, so every word that is not an option is a command word until a
// command (a level without subcommands) is reached.
void check_command_words(const CLI::App& app, int argc, const char* const* argv);

void register_rig_commands(CLI::App& app);
void register_paint_commands(CLI::App& app);
void register_sim_commands(CLI::App& app);
void register_sim_serve_command(CLI::App& app);
void register_devices_commands(CLI::App& app);
void register_measure_commands(CLI::App& app);  // paintlab measure (cmd_measure.cpp)
void register_fit_commands(CLI::App& app);      // paintlab fit, paintlab bin (cmd_fit.cpp)
void register_calibrate_commands(CLI::App& app);  // paintlab calibrate intrinsics|dark|response|flat|sphere|light|scale|all (cmd_calibrate.cpp)
void register_hdr_commands(CLI::App& app);        // paintlab hdr merge (cmd_hdr.cpp)
void register_check_commands(CLI::App& app);      // paintlab check (cmd_check.cpp)
void register_export_commands(CLI::App& app);     // paintlab export, paintlab axf validate|show (cmd_export.cpp)
void register_library_commands(CLI::App& app);    // paintlab library add|list|show|remove|export (cmd_library.cpp)
void register_render_commands(CLI::App& app);     // paintlab render (cmd_render.cpp)
void register_colour_commands(CLI::App& app);     // paintlab colour, paintlab qc (cmd_colour.cpp)
void register_report_commands(CLI::App& app);     // paintlab report (cmd_report.cpp)
void register_flakes_commands(CLI::App& app);     // paintlab flakes (cmd_flakes.cpp)
void register_demo_commands(CLI::App& app);       // paintlab demo (cmd_demo.cpp)
void register_design_commands(CLI::App& app);     // paintlab basis, design (cmd_design.cpp)

}  // namespace paintlab::app
