// Runs before anything else in a per-ISA benchmark program (its static initialisers too,
// which are built with that ISA's flags): on a CPU without the program's ISA it says what the
// CPU lacks and exits with status 1, instead of dying on an illegal instruction. Built
// without -m flags; CIERZO_BENCH_ISA names the program's ISA.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "integrators/wavefront/isa.h"

namespace {

[[gnu::constructor(101)]] void refuse_unless_the_cpu_runs_this_isa() {
    const cierzo::Isa isa = cierzo::parse_isa(CIERZO_BENCH_ISA);
    if (cierzo::isa_supported(isa)) return;
    std::fprintf(stderr,
                 "this benchmark program is built for %s, which this CPU cannot run: %s.\n"
                 "Run the one of an ISA it has instead (here: %s; `cierzo isas` lists them).\n",
                 CIERZO_BENCH_ISA, cierzo::isa_unsupported_reason(isa).c_str(),
                 cierzo::usable_isa_names().c_str());
    std::_Exit(1);
}

}  // namespace
