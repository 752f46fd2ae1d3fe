// The axle's source reads the wheel's header: axle -> wheel -> axle.
#include "parts/axle.h"
#include "parts/wheel.h"
