// Part of one ISA's wavefront kernels (parts.h): the stages several parts run (stages.h).
#define CIERZO_SHARED_STAGE template
#include "integrators/wavefront/isa/stages.h"
