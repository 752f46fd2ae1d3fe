// `cierzo trace`: the closest-hit traversal alone, on a file of rays, for measuring it
// against another ray tracer on the very same rays (bench/peers/README.md has the format).
#pragma once

#include <CLI/CLI.hpp>

namespace cierzo {

// Adds the subcommand to `app`; returns it so main can see whether it was chosen and run it.
CLI::App* add_trace_command(CLI::App& app);
int run_trace_command();

}  // namespace cierzo
