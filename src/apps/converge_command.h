// `cierzo converge`: error against time for every knob that trades one for the other.
#pragma once

#include <CLI/CLI.hpp>

namespace cierzo {

// Adds the subcommand to `app`; returns it so main can see whether it was chosen and run it.
CLI::App* add_converge_command(CLI::App& app);
int run_converge_command();

}  // namespace cierzo
