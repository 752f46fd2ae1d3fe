// Part of one ISA's wavefront kernels (parts.h): camera tiles of scenes whose one lobe is
// refraction.
#include "integrators/wavefront/wavefront_tile.h"
#include "integrators/wavefront/isa/stages.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template void render_tile_stages<kLobeRefract, IsaArch>(const FlatScene&, PathPool&, const TileJob&,
                                                        WavefrontCounters&);

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
