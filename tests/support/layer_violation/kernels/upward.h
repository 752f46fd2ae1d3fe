// A kernel header that includes the integrators' layer: check_layers.sh must refuse it
// (the test layers_check_names_an_upward_include).
#include "integrators/render.h"
