// Part of one ISA's wavefront kernels (parts.h): batches of light paths (lt).
#include "integrators/wavefront/light_stage.h"
#include "integrators/wavefront/isa/stages.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template void render_light_job<IsaArch>(const FlatScene&, PathPool&, const TileJob&,
                                        WavefrontCounters&);

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
