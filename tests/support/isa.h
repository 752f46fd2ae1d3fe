// Tests tied to one instruction set skip, naming what the CPU lacks, where it cannot run it.
#pragma once

#include <gtest/gtest.h>

#include "integrators/wavefront/isa.h"

// In a test body: skip unless this CPU runs `isa` (a cierzo::Isa).
#define CIERZO_REQUIRE_ISA(isa)                                                       \
    do {                                                                              \
        if (!::cierzo::isa_supported(isa))                                            \
            GTEST_SKIP() << ::cierzo::isa_name(isa)                                   \
                         << " not tested: " << ::cierzo::isa_unsupported_reason(isa); \
    } while (0)
