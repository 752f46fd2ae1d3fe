// A module that includes a module that includes it back: check_include_cycles.py must name
// the cycle (the test include_cycle_check_names_a_cycle).
#pragma once

#include "parts/axle.h"
