// A module outside the cycle, which includes one of its members.
#pragma once

#include "parts/wheel.h"
