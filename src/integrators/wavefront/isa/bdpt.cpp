// Part of one ISA's wavefront kernels (parts.h): bidirectional jobs (bdpt, vcm, bpm, ppm).
#include "integrators/wavefront/bdpt_stage.h"
#include "integrators/wavefront/isa/stages.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template void render_bdpt_job<IsaArch>(const FlatScene&, PathPool&, const TileJob&,
                                       WavefrontCounters&);

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
