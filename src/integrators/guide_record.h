// One camera-path vertex's record for the path guide (path_guide.h), as both integrators
// hand it over when the path ends: plain floats, so that the per-ISA wavefront kernels and
// the guide share the type.
#pragma once

#include <cstdint>

namespace cierzo {

struct GuideRecord {
    float p[3];           // the vertex
    float dir[3];         // the direction the path left it in
    float density;        // that direction's density (the lobe's, or the guided mixture's)
    float throughput[3];  // the path's throughput after the vertex
    // The light the path gathered after the vertex (the wavefront keeps here, until the
    // path ends, what it had gathered when the vertex's own shadow rays had landed)
    float gathered[3];
    // A diffuse vertex with a guide to sample (selection != 0): f·cos θ, and what the cell's
    // share α learns from (PathGuide::SelectionSample)
    float f_cos[3];
    float guide_pdf, lobe_pdf, fraction;
    int32_t selection;
    int32_t previous;  // the wavefront: the path's record before this one, or -1
    int32_t ordinal;   // the wavefront: the path's records before this one
};

}  // namespace cierzo
