// Part of one ISA's wavefront kernels (parts.h): the traversal alone (`cierzo trace`).
#include "integrators/wavefront/intersect_stage.h"
#include "integrators/wavefront/isa/stages.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

template void trace_rays_isa<IsaArch>(const FlatScene&, const float*, size_t, const TraceOptions&,
                                      TraceTotals&);

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
