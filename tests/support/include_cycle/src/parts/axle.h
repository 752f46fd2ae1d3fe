// The other half of the cycle of wheel.h.
#pragma once

struct Axle {};
