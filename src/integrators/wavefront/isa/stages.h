// The stages that several parts run (the camera's paths, shadow rays, compaction, the
// material sort, grouped traversal, the records of a guided render): each is instantiated
// once per ISA, by the part stages.cpp, and declared here for the others, so no part compiles
// it again. Included by a part after the stage headers it uses.
#pragma once

#include "integrators/wavefront/camera_stage.h"
#include "integrators/wavefront/compact_stage.h"
#include "integrators/wavefront/guide_stage.h"
#include "integrators/wavefront/intersect_stage.h"
#include "integrators/wavefront/isa/parts.h"
#include "integrators/wavefront/material_stage.h"
#include "integrators/wavefront/shadow_stage.h"

// `extern template` in the parts that run them; stages.cpp defines CIERZO_SHARED_STAGE as
// `template`, which instantiates them.
#ifndef CIERZO_SHARED_STAGE
#define CIERZO_SHARED_STAGE extern template
#endif

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

CIERZO_SHARED_STAGE void generate_camera_paths<true, IsaArch>(Wave<IsaArch>&, TileCursor&);
CIERZO_SHARED_STAGE void generate_camera_paths<false, IsaArch>(Wave<IsaArch>&, TileCursor&);
CIERZO_SHARED_STAGE void trace_shadow_rays<IsaArch>(Wave<IsaArch>&);
CIERZO_SHARED_STAGE void compact_paths<IsaArch>(Wave<IsaArch>&, const TileJob&, uint32_t);
CIERZO_SHARED_STAGE void settle_records<IsaArch>(Wave<IsaArch>&);
CIERZO_SHARED_STAGE void closest_hits_grouped<IsaArch>(Wave<IsaArch>&);
CIERZO_SHARED_STAGE void evaluate_sorted_materials<IsaArch>(Wave<IsaArch>&, int32_t*);
CIERZO_SHARED_STAGE Wave<IsaArch>::M occluded_by_ray<IsaArch>(const FlatScene&,
                                                              const Ray<Wave<IsaArch>::F>&,
                                                              const Wave<IsaArch>::F&,
                                                              Wave<IsaArch>::M, Wave<IsaArch>::M);
}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
