// What both integrators do to merge (vcm): a light vertex kept as a Photon, and a camera
// vertex gathering the photons of its set near it through the grid, each weighed by
// kernels/bidirectional.h's merge_vertices (one camera vertex at a time, on floats).
#pragma once

#include "integrators/merge_grid.h"
#include "kernels/bidirectional.h"

namespace cierzo {
inline namespace CIERZO_ISA_NAMESPACE {

// A light vertex of set `set` as the grid keeps it.
inline Photon photon_of(const LightVertex<float>& l, uint32_t set) {
    Photon p;
    p.p[0] = l.p.x, p.p[1] = l.p.y, p.p[2] = l.p.z;
    p.wl[0] = l.wl.x, p.wl[1] = l.wl.y, p.wl[2] = l.wl.z;
    p.beta[0] = l.beta.x, p.beta[1] = l.beta.y, p.beta[2] = l.beta.z;
    p.vcm = l.mis.vcm, p.vm = l.mis.vm;
    p.length = l.length, p.set = set;
    return p;
}

// What camera vertex v of set `set` gathers from the photons of its set within its radius
// (mw: the set's merging quantities), weighted, before the camera subpath's throughput.
inline Vec3f merge_at(const PathContext& c, const MergeGrid& grid, const CameraVertex<float>& v,
                      uint32_t set, const MergeWeights<float>& mw) {
    MergeGrid::Range cells[8];
    const int n = grid.cells(v.p.x, v.p.y, v.p.z, int32_t(set), cells);
    Vec3f sum(0.0f);
    for (int r = 0; r < n; ++r)
        for (int32_t e = cells[r].begin; e < cells[r].end; ++e) {
            const Photon& ph = grid.photons()[e];
            const Vec3f p{ph.p[0], ph.p[1], ph.p[2]};
            const Vec3f to = p - v.p;
            // (a bucket also holds other cells' photons)
            if (ph.set != set || !(dot(to, to) <= mw.radius2)) continue;
            if (!length_counts<float>(c.estimator, ph.length + v.vertices - 1u)) continue;
            LightVertex<float> l{};
            l.p = p;
            l.wl = {ph.wl[0], ph.wl[1], ph.wl[2]};
            l.beta = {ph.beta[0], ph.beta[1], ph.beta[2]};
            l.mis = {ph.vcm, 0.0f, ph.vm};
            l.length = ph.length;
            sum += merge_vertices(c, v, l, mw, true);
        }
    return sum;
}

}  // namespace CIERZO_ISA_NAMESPACE
}  // namespace cierzo
